#include "rayproof/core/casefile.h"
#include "rayproof/core/mesh_case.h"

#include <cmath>
#include <fstream>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <functional>
#include <iostream>
#include <string_view>
#include <vector>

namespace rayproof {

std::string CaseError::to_string() const {
  std::string s = printable(file) + (line > 0 ? ":" + std::to_string(line) : "") + ": ";
  if (!field.empty()) s += "field '" + printable(field) + "': ";
  return s + printable(message);
}

namespace {
double read_expected_t(const json& j) {
  if (j.is_string() && j.get_ref<const std::string&>() == "inf") return std::numeric_limits<double>::infinity();
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
              {"direction", json::array({exact_json_number(c.ray.direction.x()), exact_json_number(c.ray.direction.y()),
                                         exact_json_number(c.ray.direction.z())})}};
  j["shape"] = shape_to_json(c.shape);
  if (c.expect) {
    j["expect"] = {{"class", std::string(to_string(c.expect->cls))}};
    if (c.expect->t) j["expect"]["t"] = hex_double(*c.expect->t);
  }
  if (!c.found.is_null()) j["found"] = c.found;
  return j;
}

namespace {

// Ids seen so far, as 64-bit fingerprints in an open-addressing table that grows by half when
// 85% full (about 10–15 bytes per id at its peak, while the old table is copied, whatever the
// ids' length). Two different ids collide with probability about n²/2^65 (3·10^-6 for ten
// million ids): then a unique id would be reported as a duplicate.
class IdFingerprints {
 public:
  // False when the id (or, with that tiny probability, another with its fingerprint) was seen.
  bool insert(std::string_view id) {
    std::uint64_t h = std::hash<std::string_view>{}(id)*0x9E3779B97F4A7C15ull;
    if (h == 0) h = 1;  // 0 marks an empty slot
    if (20 * (count_ + 1) > 17 * slots_.size()) grow(slots_.empty() ? 1024 : slots_.size() + slots_.size() / 2);
    return place(h);
  }
  // Sizes the table for about `ids` ids at once (no growth, so no moment with two tables).
  void expect(std::uint64_t ids) {
    const size_t slots = static_cast<size_t>(ids * 20 / 17) + 1024;
    if (slots > slots_.size()) grow(slots);
  }

 private:
  bool place(std::uint64_t h) {
    // The slot from the fingerprint's high bits, scaled to any table size (Lemire's fast range).
    size_t i = static_cast<size_t>((static_cast<unsigned __int128>(h) * slots_.size()) >> 64);
    for (;; i = i + 1 == slots_.size() ? 0 : i + 1) {
      if (slots_[i] == h) return false;
      if (slots_[i] == 0) {
        slots_[i] = h;
        ++count_;
        return true;
      }
    }
  }
  void grow(size_t slots) {
    std::vector<std::uint64_t> old = std::move(slots_);
    slots_.assign(slots, 0);
    count_ = 0;
    for (std::uint64_t h : old)
      if (h) place(h);
  }
  std::vector<std::uint64_t> slots_;
  size_t count_ = 0;
};

}  // namespace

bool read_case_file(const std::string& path, const std::function<void(const Case&, long line)>& on_case,
                    const std::function<void(const CaseError&)>& on_error,
                    const std::function<void(const MeshCase&, long line)>& on_mesh_case) {
  std::ifstream file;
  if (path != "-") {
    std::error_code ec;
    if (std::filesystem::is_directory(path, ec)) {
      on_error({path, 0, "", "is a directory, not a case file"});
      return false;
    }
    file.open(path, std::ios::binary);
    if (!file) {
      on_error({path, 0, "", std::string("cannot open: ") + std::strerror(errno)});
      return false;
    }
  }
  std::istream& in = path == "-" ? std::cin : file;
  IdFingerprints ids;
  std::string text;
  long line = 0;
  std::uint64_t bytes = 0;
  std::error_code size_error;
  const std::uintmax_t file_size = path == "-" ? 0 : std::filesystem::file_size(path, size_error);
  while (std::getline(in, text)) {
    ++line;
    bytes += text.size() + 1;
    // A large file's line count, estimated from its first thousand lines, sizes the id table once.
    if (line == 1000 && file_size > bytes && !size_error) ids.expect(file_size / (bytes / 1000) * 11 / 10);
    if (text.find_first_not_of(" \t\r") == std::string::npos) continue;
    try {
      if (text.find("\"mesh\"") != std::string::npos) {  // perhaps a mesh case: read it as one if it is
        json j;
        try {
          j = parse_json_text(text);
        } catch (const json::parse_error& e) {
          throw FieldError("", std::string("malformed JSON: ") + e.what());
        }
        if (is_mesh_case(j)) {
          if (!on_mesh_case)
            throw FieldError("mesh", "a mesh case (docs/spec/tracer.md): `rayproof check` judges tracers on it");
          MeshCase c = read_mesh_case(j);
          if (!ids.insert(c.id)) throw FieldError("id", "duplicate id \"" + c.id + "\"");
          on_mesh_case(c, line);
          continue;
        }
      }
      Case c = parse_case(text);
      if (!ids.insert(c.id)) throw FieldError("id", "duplicate id \"" + c.id + "\"");
      on_case(c, line);
    } catch (const FieldError& e) {
      on_error({path, line, e.field, e.what()});
    }
  }
  if (in.bad()) on_error({path, line + 1, "", std::string("read error: ") + std::strerror(errno)});
  return true;
}

}  // namespace rayproof
