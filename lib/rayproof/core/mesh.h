// Triangle meshes of scenes (docs/spec/audit.md, "Meshes in scenes"): read from OFF, OBJ, PLY or
// STL keeping every coordinate as the double it reads as, then placed as v·scale + translate in
// double. Those rounded triangles *are* the scene the oracle judges.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "rayproof/core/geometry.h"
#include "rayproof/core/shapes.h"

namespace rayproof {

struct Mesh {
  std::vector<Triangle> triangles;                    // placed, degenerate ones left out
  std::vector<std::array<std::uint32_t, 3>> corners;  // each triangle's vertex indices in the file
  std::size_t vertex_count = 0;
  std::size_t degenerate_skipped = 0;  // exactly collinear triangles (after placement)
};

// Reads the mesh at `path` by its extension (.off, .obj, .ply, .stl, any case). OFF and OBJ are
// read line by line, numbers by std::from_chars (correctly rounded); PLY and STL (ASCII or
// binary) by rayproof's own readers (mesh_ply.cpp, mesh_stl.cpp), which store doubles and trust
// no count before the bytes that back it. Faces with more than three
// vertices are fanned from their first vertex. Throws std::runtime_error naming the file and,
// for text formats, the line: missing or unreadable file, unknown format, a face index out of
// range, a NaN or infinite coordinate, a file with no triangles.
Mesh load_mesh(const std::string& path, double scale = 1, const Vec3& translate = Vec3::Zero());
// A PLY or STL file's bytes as load_mesh reads them (`name` names it in errors): the parser
// harness's doors.
Mesh parse_ply_mesh(const std::string& bytes, const std::string& name);
Mesh parse_stl_mesh(const std::string& bytes, const std::string& name);

// Whether two triangles of a mesh share a vertex (the acne test's "adjacent").
inline bool share_a_vertex(const std::array<std::uint32_t, 3>& a, const std::array<std::uint32_t, 3>& b) {
  for (std::uint32_t i : a)
    for (std::uint32_t j : b)
      if (i == j) return true;
  return false;
}

}  // namespace rayproof
