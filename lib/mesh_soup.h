// Internal to lib/: a polygon soup as a reader returns it, before placement and triangulation.
#pragma once

#include <array>
#include <string>
#include <string_view>
#include <vector>

namespace rayproof::mesh_detail {

struct Soup {
  std::vector<std::array<double, 3>> points;
  std::vector<std::vector<std::size_t>> faces;  // vertex indices, 0-based
  std::vector<long> face_lines;                 // each face's line in a text file (empty for PLY, STL)
};

// PLY or STL ("ply", "stl") through CGAL (mesh_cgal.cpp).
Soup read_cgal_soup(const std::string& path, std::string_view format);

}  // namespace rayproof::mesh_detail
