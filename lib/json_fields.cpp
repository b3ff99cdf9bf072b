#include "rayproof/core/json_fields.h"

#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>

namespace rayproof {

std::optional<double> parse_hex_double(std::string_view text) {
  // Grammar: [+-] 0x|0X hexdigits [. hexdigits] p|P [+-] digits — strictly, no spaces.
  size_t i = 0;
  if (i < text.size() && (text[i] == '+' || text[i] == '-')) ++i;
  if (i + 1 >= text.size() || text[i] != '0' || (text[i + 1] != 'x' && text[i + 1] != 'X'))
    return std::nullopt;
  i += 2;
  size_t digits = 0;
  while (i < text.size() && std::isxdigit(static_cast<unsigned char>(text[i]))) ++i, ++digits;
  if (i < text.size() && text[i] == '.') {
    ++i;
    while (i < text.size() && std::isxdigit(static_cast<unsigned char>(text[i]))) ++i, ++digits;
  }
  if (digits == 0 || i >= text.size() || (text[i] != 'p' && text[i] != 'P')) return std::nullopt;
  ++i;
  if (i < text.size() && (text[i] == '+' || text[i] == '-')) ++i;
  size_t exp_digits = 0;
  while (i < text.size() && std::isdigit(static_cast<unsigned char>(text[i]))) ++i, ++exp_digits;
  if (exp_digits == 0 || i != text.size()) return std::nullopt;
  // glibc's strtod rounds hex input correctly (round-to-nearest-even), including subnormals.
  const std::string copy(text);
  return std::strtod(copy.c_str(), nullptr);
}

std::string hex_double(double x) {
  if (std::isinf(x)) return x > 0 ? "inf" : "-inf";
  if (std::isnan(x)) return "nan";
  char buf[64];
  std::snprintf(buf, sizeof buf, "%a", x);
  return buf;
}

json exact_json_number(double x) {
  if (std::isfinite(x) && !(x == 0 && std::signbit(x))) {
    char buf[32];
    auto [end, ec] = std::to_chars(buf, buf + sizeof buf, x);  // shortest round-trip decimal
    if (ec == std::errc() && end - buf <= 12) {
      if (x == std::floor(x) && std::abs(x) < 9007199254740992.0)
        return static_cast<std::int64_t>(x);
      return x;
    }
  }
  return hex_double(x);
}

namespace {
constexpr std::string_view kOverflowMarker = "\x01overflow:";
}

json parse_json_text(const std::string& text) {
  std::string patched = text;
  for (int attempt = 0; attempt < 64; ++attempt) {
    try {
      return json::parse(patched);
    } catch (const json::out_of_range& e) {
      // "number overflow parsing '1e999'": quote that token as a marker string and retry.
      const std::string what = e.what();
      const size_t open = what.find('\''), close = what.rfind('\'');
      if (e.id != 406 || open == std::string::npos || close <= open) throw;
      const std::string token = what.substr(open + 1, close - open - 1);
      const size_t at = patched.find(token);
      if (at == std::string::npos) throw;
      patched.replace(at, token.size(), "\"\\u0001overflow:" + token + "\"");  // JSON escape of the marker
    }
  }
  return json::parse(patched);
}

double read_number(const json& j, const std::string& field) {
  double x;
  if (j.is_string() && j.get_ref<const std::string&>().starts_with(kOverflowMarker))
    throw FieldError(field, "value " + j.get<std::string>().substr(kOverflowMarker.size()) +
                                " overflows the double range");
  if (j.is_number()) {
    x = j.get<double>();
  } else if (j.is_string()) {
    const auto& s = j.get_ref<const std::string&>();
    auto parsed = parse_hex_double(s);
    if (!parsed) throw FieldError(field, "\"" + s + "\" is not a number or a C99 hex float such as \"0x1.8p+1\"");
    x = *parsed;
  } else {
    throw FieldError(field, "expected a number, got " + std::string(j.type_name()));
  }
  if (std::isnan(x)) throw FieldError(field, "NaN is not allowed");
  if (std::isinf(x)) throw FieldError(field, "value is infinite or overflows the double range");
  return x;
}

Vec3 read_vec3(const json& j, const std::string& field) {
  if (!j.is_array()) throw FieldError(field, "expected an array of 3 numbers, got " + std::string(j.type_name()));
  if (j.size() != 3)
    throw FieldError(field, "expected 3 components, got " + std::to_string(j.size()));
  Vec3 v;
  for (int i = 0; i < 3; ++i) v[i] = read_number(j[i], field + "[" + std::to_string(i) + "]");
  return v;
}

const json& require_object(const json& j, const std::string& field) {
  if (!j.is_object()) throw FieldError(field, "expected an object, got " + std::string(j.type_name()));
  return j;
}

void check_keys(const json& obj, const std::string& field, std::initializer_list<std::string_view> allowed,
                std::initializer_list<std::string_view> required) {
  require_object(obj, field);
  const std::string prefix = field.empty() ? "" : field + ".";
  for (auto it = obj.begin(); it != obj.end(); ++it) {
    bool ok = false;
    for (auto a : allowed) ok = ok || a == it.key();
    if (!ok) throw FieldError(prefix + it.key(), "unknown key \"" + it.key() + "\"");
  }
  for (auto r : required)
    if (!obj.contains(r)) throw FieldError(prefix + std::string(r), "missing");
}

Shape read_shape(const json& j, const std::string& field,
                 std::initializer_list<std::string_view> extra_keys) {
  require_object(j, field);
  const std::string prefix = field + ".";
  if (!j.contains("type")) throw FieldError(prefix + "type", "missing");
  if (!j["type"].is_string()) throw FieldError(prefix + "type", "expected a string");
  const std::string type = j["type"];
  auto keys = [&](std::initializer_list<std::string_view> own) {
    std::vector<std::string_view> allowed(own);
    allowed.push_back("type");
    allowed.insert(allowed.end(), extra_keys.begin(), extra_keys.end());
    for (auto it = j.begin(); it != j.end(); ++it) {
      bool ok = false;
      for (auto a : allowed) ok = ok || a == it.key();
      if (!ok) throw FieldError(prefix + it.key(), "unknown key \"" + it.key() + "\" for a " + type);
    }
    for (auto r : own)
      if (!j.contains(r)) throw FieldError(prefix + std::string(r), "missing");
  };
  Shape shape;
  if (type == "sphere") {
    keys({"center", "radius"});
    shape = Sphere{read_vec3(j["center"], prefix + "center"), read_number(j["radius"], prefix + "radius")};
    if (!(std::get<Sphere>(shape).radius > 0)) throw FieldError(prefix + "radius", "radius must be > 0");
  } else if (type == "plane") {
    keys({"normal", "offset"});
    shape = Plane{read_vec3(j["normal"], prefix + "normal"), read_number(j["offset"], prefix + "offset")};
    if (degenerate_reason(shape)) throw FieldError(prefix + "normal", "zero plane normal");
  } else if (type == "triangle") {
    keys({"vertices"});
    const json& v = j["vertices"];
    if (!v.is_array() || v.size() != 3)
      throw FieldError(prefix + "vertices", "expected an array of 3 vertices");
    Triangle t;
    for (int i = 0; i < 3; ++i) t.v[i] = read_vec3(v[i], prefix + "vertices[" + std::to_string(i) + "]");
    shape = t;
    if (degenerate_reason(shape)) throw FieldError(prefix + "vertices", "triangle vertices are collinear");
  } else if (type == "box") {
    keys({"min", "max"});
    shape = Box{read_vec3(j["min"], prefix + "min"), read_vec3(j["max"], prefix + "max")};
    if (degenerate_reason(shape)) throw FieldError(prefix + "max", "box min must be < max on every axis");
  } else {
    throw FieldError(prefix + "type", "unknown shape type \"" + type + "\" (sphere, plane, triangle, box)");
  }
  return shape;
}

namespace {
json vec_json(const Vec3& v) {
  return json::array({exact_json_number(v.x()), exact_json_number(v.y()), exact_json_number(v.z())});
}
}  // namespace

json shape_to_json(const Shape& shape) {
  struct ToJson {
    json operator()(const Sphere& s) const {
      return {{"type", "sphere"}, {"center", vec_json(s.center)}, {"radius", exact_json_number(s.radius)}};
    }
    json operator()(const Plane& p) const {
      return {{"type", "plane"}, {"normal", vec_json(p.normal)}, {"offset", exact_json_number(p.offset)}};
    }
    json operator()(const Triangle& t) const {
      return {{"type", "triangle"},
              {"vertices", json::array({vec_json(t.v[0]), vec_json(t.v[1]), vec_json(t.v[2])})}};
    }
    json operator()(const Box& b) const {
      return {{"type", "box"}, {"min", vec_json(b.min)}, {"max", vec_json(b.max)}};
    }
  };
  return std::visit(ToJson{}, shape);
}

}  // namespace rayproof
