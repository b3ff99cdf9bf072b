// Mesh cases (docs/spec/tracer.md, "Mesh findings"): one line holding a mesh, a ray with tmin
// and tmax, optionally "all": true (an any-hit case), what the oracle expects and how it was
// found. `fuzz --tracer` writes them, `check` replays them. Errors name the field.
#pragma once

#include <memory>
#include <optional>
#include <string>

#include "rayproof/core/json_fields.h"
#include "rayproof/core/tracer.h"

namespace rayproof {

struct MeshCase {
  std::string id;
  std::shared_ptr<const TriangleMesh> mesh;
  TracerRay ray;
  bool all = false;  // any-hit
  json expect;       // null when absent: {"touched", "nearest", "t"}
  json found;        // kept verbatim; null when absent
};

// Whether a case line's object is a mesh case (it has a "mesh" key).
inline bool is_mesh_case(const json& j) { return j.is_object() && j.contains("mesh"); }
// Throws FieldError naming the field: a bad vertex (NaN, infinite, wrong arity), an index out of
// range, no triangles, a ray that cannot be traced, unknown keys.
MeshCase read_mesh_case(const json& j);
json mesh_case_to_json(const MeshCase& c);
json mesh_to_json(const TriangleMesh& mesh);
// json_text(mesh_case_to_json(c)), the same bytes, with the mesh's part given as
// json_text(mesh_to_json(*c.mesh)): the findings on one mesh (other rays, tracers, modes) format
// its thousands of exact numbers once.
std::string mesh_case_text(const MeshCase& c, const std::string& mesh_text);
json tracer_ray_to_json(const TracerRay& ray);

}  // namespace rayproof
