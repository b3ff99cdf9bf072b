// PLY and STL meshes through CGAL's polygon-soup readers (header-only; the only CGAL in lib/):
// they keep coordinates as doubles (a binary file's floats convert exactly), unlike readers that
// store float and would silently move the geometry being judged.
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/IO/PLY.h>
#include <CGAL/IO/STL.h>

#include <fstream>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "mesh_soup.h"
#include "rayproof/core/json_fields.h"

namespace rayproof::mesh_detail {

Soup read_cgal_soup(const std::string& path, std::string_view format) {
  using Point = CGAL::Exact_predicates_inexact_constructions_kernel::Point_3;
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error(printable(path) + ": cannot open mesh file");
  std::vector<Point> points;
  std::vector<std::vector<std::size_t>> faces;
  const bool ok = format == "ply" ? CGAL::IO::read_PLY(in, points, faces)
                                  : CGAL::IO::read_STL(in, points, faces, CGAL::parameters::verbose(false));
  if (!ok)
    throw std::runtime_error(printable(path) + ": CGAL's " + std::string(format == "ply" ? "PLY" : "STL") +
                             " reader could not read this file (malformed, truncated or not " +
                             std::string(format == "ply" ? "PLY" : "STL") + ")");
  Soup soup;
  soup.points.reserve(points.size());
  for (const Point& p : points) soup.points.push_back({p.x(), p.y(), p.z()});
  soup.faces = std::move(faces);
  return soup;
}

}  // namespace rayproof::mesh_detail
