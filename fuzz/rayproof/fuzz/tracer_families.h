// Adversarial meshes and rays for whole tracers (docs/spec/tracer.md, issue 20). Each family
// builds meshes from small integers and dyadic fractions so that the feature a ray is aimed at
// (a shared edge, a fan's centre, a box-face plane, a point on a triangle) is exact, then lets
// the ray pass exactly through it. Mesh m of a family and its rays are a pure function of
// (seed, family, m): any shard, thread count or machine produces the same case.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "rayproof/core/tracer.h"

namespace rayproof::fuzz {

enum class TracerFamily { shared_edges, fans, axis_planes, needles, spawned, shells, far, random };
inline constexpr TracerFamily kAllTracerFamilies[] = {
    TracerFamily::shared_edges, TracerFamily::fans,   TracerFamily::axis_planes, TracerFamily::needles,
    TracerFamily::spawned,      TracerFamily::shells, TracerFamily::far,         TracerFamily::random};
std::string_view to_string(TracerFamily f);
std::optional<TracerFamily> tracer_family_from_string(std::string_view s);

// Rays aimed at one mesh: case index i of a family is ray i % kRaysPerMesh of mesh i / kRaysPerMesh.
inline constexpr std::uint64_t kRaysPerMesh = 64;

struct MeshWork {
  std::shared_ptr<const TriangleMesh> mesh;
  std::vector<TracerRay> rays;
  std::vector<std::string> details;  // per ray: how it was aimed ("edge 1/4", "fan centre", ...)
  int log2_translate = 0;            // the far family: the mesh and origins were moved by 2^k
};

// Mesh `mesh_index` of the family and its first `rays` rays (at most kRaysPerMesh).
MeshWork generate_mesh_work(TracerFamily family, std::uint64_t seed, std::uint64_t mesh_index, std::uint64_t rays);

// The far family moves float tracers' meshes only up to 2^40 (tracer.md): beyond that a float
// mesh has collapsed, and the case is not_representable for them.
inline constexpr int kFarFloatLimit = 40;

}  // namespace rayproof::fuzz
