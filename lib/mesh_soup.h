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
  std::vector<long> face_lines;                 // each face's line in a text file (empty for binary files)
};

// STL, binary or ASCII (mesh_stl.cpp): from a file, or from its bytes (`name` in errors).
Soup read_stl(const std::string& path);
Soup parse_stl(const std::string& name, const std::string& bytes);

// PLY, ASCII or binary (mesh_ply.cpp): from a file, or from its bytes (`name` in errors).
Soup read_ply(const std::string& path);
Soup parse_ply(const std::string& name, std::string bytes);

}  // namespace rayproof::mesh_detail
