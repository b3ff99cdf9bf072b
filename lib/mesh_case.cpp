#include "rayproof/core/mesh_case.h"

#include <cmath>
#include <stdexcept>
#include <string>

namespace rayproof {

namespace {
std::uint32_t read_index(const json& j, const std::string& field) {
  if (!j.is_number_unsigned()) throw FieldError(field, "must be a vertex index (a whole number >= 0)");
  const std::uint64_t i = j.get<std::uint64_t>();
  if (i >= 0xffffffffull) throw FieldError(field, "index beyond 2^32 - 2");
  return static_cast<std::uint32_t>(i);
}
}  // namespace

MeshCase read_mesh_case(const json& j) {
  if (!j.is_object()) throw FieldError("", "a case line is a JSON object");
  check_keys(j, "", {"id", "mesh", "ray", "all", "expect", "found"}, {"id", "mesh", "ray"});
  MeshCase c;
  if (!j.at("id").is_string()) throw FieldError("id", "must be a string");
  c.id = j.at("id").get<std::string>();
  const json& m = require_object(j.at("mesh"), "mesh");
  check_keys(m, "mesh", {"vertices", "triangles"}, {"vertices", "triangles"});
  if (!m.at("vertices").is_array()) throw FieldError("mesh.vertices", "must be an array of [x, y, z]");
  if (!m.at("triangles").is_array()) throw FieldError("mesh.triangles", "must be an array of [i, j, k]");
  auto mesh = std::make_shared<TriangleMesh>();
  const json& vs = m.at("vertices");
  for (std::size_t i = 0; i < vs.size(); ++i) {
    const Vec3 v = read_vec3(vs[i], "mesh.vertices[" + std::to_string(i) + "]");
    mesh->vertices.insert(mesh->vertices.end(), {v.x(), v.y(), v.z()});
  }
  const json& ts = m.at("triangles");
  if (ts.empty()) throw FieldError("mesh.triangles", "no triangles");
  for (std::size_t i = 0; i < ts.size(); ++i) {
    const std::string field = "mesh.triangles[" + std::to_string(i) + "]";
    if (!ts[i].is_array() || ts[i].size() != 3) throw FieldError(field, "must be [i, j, k]");
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t index = read_index(ts[i][k], field + "[" + std::to_string(k) + "]");
      if (index >= mesh->vertex_count())
        throw FieldError(field + "[" + std::to_string(k) + "]", "vertex " + std::to_string(index) + " out of range (" +
                                                                    std::to_string(mesh->vertex_count()) +
                                                                    " vertices)");
      mesh->indices.push_back(index);
    }
  }
  if (const auto why = invalid_mesh_reason(*mesh)) throw FieldError("mesh", *why);
  c.mesh = mesh;
  const json& r = require_object(j.at("ray"), "ray");
  check_keys(r, "ray", {"origin", "direction", "tmin", "tmax"}, {"origin", "direction"});
  c.ray.ray.origin = read_vec3(r.at("origin"), "ray.origin");
  c.ray.ray.direction = read_vec3(r.at("direction"), "ray.direction");
  if (r.contains("tmin")) c.ray.tmin = read_number(r.at("tmin"), "ray.tmin");
  if (r.contains("tmax")) {
    const json& t = r.at("tmax");
    c.ray.tmax = t.is_string() && t.get<std::string>() == "inf" ? std::numeric_limits<double>::infinity()
                                                                : read_number(t, "ray.tmax");
  }
  if (const auto why = invalid_ray_reason(c.ray)) throw FieldError("ray", *why);
  if (j.contains("all")) {
    if (!j.at("all").is_boolean()) throw FieldError("all", "must be true or false");
    c.all = j.at("all").get<bool>();
  }
  if (j.contains("expect")) c.expect = require_object(j.at("expect"), "expect");
  if (j.contains("found")) c.found = j.at("found");
  return c;
}

json mesh_to_json(const TriangleMesh& mesh) {
  json vs = json::array(), ts = json::array();
  for (std::size_t i = 0; i < mesh.vertex_count(); ++i)
    vs.push_back({exact_json_number(mesh.vertices[3 * i]), exact_json_number(mesh.vertices[3 * i + 1]),
                  exact_json_number(mesh.vertices[3 * i + 2])});
  for (std::size_t i = 0; i < mesh.triangle_count(); ++i) ts.push_back(mesh.corners(i));
  return {{"vertices", vs}, {"triangles", ts}};
}

json tracer_ray_to_json(const TracerRay& r) {
  auto vec = [](const Vec3& v) {
    return json{exact_json_number(v.x()), exact_json_number(v.y()), exact_json_number(v.z())};
  };
  return {{"origin", vec(r.ray.origin)},
          {"direction", vec(r.ray.direction)},
          {"tmin", exact_json_number(r.tmin)},
          {"tmax", std::isinf(r.tmax) ? json("inf") : exact_json_number(r.tmax)}};
}

namespace {
json case_fields(const MeshCase& c, json mesh) {
  json out = {{"id", c.id}, {"mesh", std::move(mesh)}, {"ray", tracer_ray_to_json(c.ray)}};
  if (c.all) out["all"] = true;
  if (!c.expect.is_null()) out["expect"] = c.expect;
  if (!c.found.is_null()) out["found"] = c.found;
  return out;
}
}  // namespace

json mesh_case_to_json(const MeshCase& c) { return case_fields(c, mesh_to_json(*c.mesh)); }

std::string mesh_case_text(const MeshCase& c, const std::string& mesh_text) {
  // The mesh's place held by a mark. Keys are written sorted (all, expect, found, id, mesh, ray):
  // only the ray, numbers and "inf", follows the top level's "mesh", so the last "mesh" key with
  // the mark's value is that one (expect or found may hold the same pair: the test writes them).
  const std::string mark = "\x01rayproof-mesh\x01";
  std::string text = json_text(case_fields(c, mark));
  const std::string written = "\"mesh\":" + json(mark).dump();
  const std::size_t at = text.rfind(written);
  if (at == std::string::npos) throw std::logic_error("mesh_case_text: the mesh's place is not in the text");
  return text.replace(at, written.size(), "\"mesh\":" + mesh_text);
}

}  // namespace rayproof
