// STL meshes through CGAL's polygon-soup reader (header-only; the only CGAL in lib/): it keeps
// coordinates as doubles (a binary file's floats convert exactly), unlike readers that store
// float and would silently move the geometry being judged. PLY is read in mesh_ply.cpp.
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/IO/STL.h>

#include <fstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "mesh_soup.h"
#include "rayproof/core/json_fields.h"

namespace rayproof::mesh_detail {

Soup read_stl(const std::string& path) {
  using Point = CGAL::Exact_predicates_inexact_constructions_kernel::Point_3;
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error(printable(path) + ": cannot open mesh file");
  std::vector<Point> points;
  std::vector<std::vector<std::size_t>> faces;
  if (!CGAL::IO::read_STL(in, points, faces, CGAL::parameters::verbose(false)))
    throw std::runtime_error(printable(path) +
                             ": CGAL's STL reader could not read this file (malformed, truncated or not STL)");
  Soup soup;
  soup.points.reserve(points.size());
  for (const Point& p : points) soup.points.push_back({p.x(), p.y(), p.z()});
  soup.faces = std::move(faces);
  return soup;
}

}  // namespace rayproof::mesh_detail
