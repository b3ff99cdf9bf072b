#include "rayproof/core/casefile.h"

#include <cmath>
#include <fstream>
#include <unordered_set>

namespace rayproof {

std::string CaseError::to_string() const {
  std::string s = file + ":" + std::to_string(line) + ": ";
  if (!field.empty()) s += "field '" + field + "': ";
  return s + message;
}

namespace {
double read_expected_t(const json& j) {
  if (j.is_string() && j.get_ref<const std::string&>() == "inf")
    return std::numeric_limits<double>::infinity();
  const double t = read_number(j, "expect.t");
  if (t < 0) throw FieldError("expect.t", "t must be >= 0");
  return t;
}
}  // namespace

Case parse_case(const std::string& text) {
  json j;
  try {
    j = parse_json_text(text);
  } catch (const json::parse_error& e) {
    throw FieldError("", std::string("malformed JSON: ") + e.what());
  }
  check_keys(j, "", {"id", "ray", "shape", "expect", "found"}, {"id", "ray", "shape"});
  Case c;
  if (!j["id"].is_string()) throw FieldError("id", "expected a string");
  c.id = j["id"];
  const json& ray = j["ray"];
  check_keys(ray, "ray", {"origin", "direction"}, {"origin", "direction"});
  c.ray.origin = read_vec3(ray["origin"], "ray.origin");
  c.ray.direction = read_vec3(ray["direction"], "ray.direction");
  if (c.ray.direction.x() == 0 && c.ray.direction.y() == 0 && c.ray.direction.z() == 0)
    throw FieldError("ray.direction", "zero direction");
  c.shape = read_shape(j["shape"], "shape");
  if (j.contains("expect")) {
    const json& e = j["expect"];
    check_keys(e, "expect", {"class", "t"}, {"class"});
    if (!e["class"].is_string()) throw FieldError("expect.class", "expected a string");
    auto cls = hit_class_from_string(e["class"].get<std::string>());
    if (!cls) throw FieldError("expect.class", "unknown class \"" + e["class"].get<std::string>() + "\"");
    Expectation ex{*cls, std::nullopt};
    if (e.contains("t") && !e["t"].is_null()) ex.t = read_expected_t(e["t"]);
    c.expect = ex;
  }
  if (j.contains("found")) {
    if (!j["found"].is_object()) throw FieldError("found", "expected an object");
    c.found = j["found"];
  }
  return c;
}

json case_to_json(const Case& c) {
  json j;
  j["id"] = c.id;
  j["ray"] = {{"origin", json::array({exact_json_number(c.ray.origin.x()), exact_json_number(c.ray.origin.y()),
                                      exact_json_number(c.ray.origin.z())})},
              {"direction", json::array({exact_json_number(c.ray.direction.x()),
                                         exact_json_number(c.ray.direction.y()),
                                         exact_json_number(c.ray.direction.z())})}};
  j["shape"] = shape_to_json(c.shape);
  if (c.expect) {
    j["expect"] = {{"class", std::string(to_string(c.expect->cls))}};
    if (c.expect->t) j["expect"]["t"] = hex_double(*c.expect->t);
  }
  if (!c.found.is_null()) j["found"] = c.found;
  return j;
}

bool read_case_file(const std::string& path,
                    const std::function<void(const Case&, long line)>& on_case,
                    const std::function<void(const CaseError&)>& on_error) {
  std::ifstream in(path);
  if (!in) {
    on_error({path, 0, "", "cannot open file"});
    return false;
  }
  std::unordered_set<std::string> ids;
  std::string text;
  long line = 0;
  while (std::getline(in, text)) {
    ++line;
    if (text.find_first_not_of(" \t\r") == std::string::npos) continue;
    try {
      Case c = parse_case(text);
      if (!ids.insert(c.id).second) throw FieldError("id", "duplicate id \"" + c.id + "\"");
      on_case(c, line);
    } catch (const FieldError& e) {
      on_error({path, line, e.field, e.what()});
    }
  }
  return true;
}

}  // namespace rayproof
