#include "rayproof/core/json_fields.h"

#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

namespace rayproof {

DecimalNumber parse_decimal(std::string_view text) {
  DecimalNumber out;
  double x = 0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), x);
  if (end != text.data() + text.size() || (ec != std::errc() && ec != std::errc::result_out_of_range)) return out;
  if (ec == std::errc()) {
    out.status = DecimalNumber::Status::ok, out.value = x;
    return out;
  }
  // Out of range: strtod (correctly rounded in glibc) tells an overflow (±HUGE_VAL) from a
  // subnormal result (kept) and from an underflow to zero.
  const std::string copy(text);
  const double y = std::strtod(copy.c_str(), nullptr);
  if (std::isinf(y))
    out.status = DecimalNumber::Status::overflow;
  else if (y == 0)
    out.status = DecimalNumber::Status::underflow;
  else
    out.status = DecimalNumber::Status::ok, out.value = y;
  return out;
}

std::string_view decimal_problem(DecimalNumber::Status status) {
  switch (status) {
    case DecimalNumber::Status::overflow: return "is beyond the double range";
    case DecimalNumber::Status::underflow: return "underflows to zero in double";
    default: return "is not a number";
  }
}

std::optional<double> parse_hex_double(std::string_view text) {
  // Grammar: [+-] 0x|0X hexdigits [. hexdigits] p|P [+-] digits — strictly, no spaces.
  size_t i = 0;
  if (i < text.size() && (text[i] == '+' || text[i] == '-')) ++i;
  if (i + 1 >= text.size() || text[i] != '0' || (text[i + 1] != 'x' && text[i + 1] != 'X')) return std::nullopt;
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
      if (x == std::floor(x) && std::abs(x) < 9007199254740992.0) return static_cast<std::int64_t>(x);
      return x;
    }
  }
  return hex_double(x);
}

namespace {

// Builds the DOM from nlohmann's SAX events (iteratively: no recursion a hostile file could
// exhaust), enforcing what json::parse would not: a nesting limit, unique keys, and numbers
// beyond the double range kept (as a binary value, which JSON text cannot produce) so that
// read_number reports them under their own field.
class DomBuilder {
 public:
  json root;

  bool null() { return add(nullptr); }
  bool boolean(bool v) { return add(v); }
  bool number_integer(json::number_integer_t v) { return add(v); }
  bool number_unsigned(json::number_unsigned_t v) { return add(v); }
  // Numbers beyond the double range reach the builder as strings the parser's first attempt
  // planted (see parse_json_text), marked by a prefix that does not occur in the input.
  explicit DomBuilder(std::string overflow_marker) : marker_(std::move(overflow_marker)) {}
  bool number_float(json::number_float_t v, const std::string&) { return add(v); }
  bool string(std::string& v) {
    if (!v.starts_with(marker_)) return add(std::move(v));
    return add(json::binary(json::binary_t::container_type(v.begin() + marker_.size(), v.end())));
  }
  bool binary(json::binary_t& v) { return add(std::move(v)); }
  bool start_object(std::size_t) { return open(json::object()); }
  bool start_array(std::size_t) { return open(json::array()); }
  bool end_object() { return close(); }
  bool end_array() { return close(); }
  bool key(std::string& k) {
    json& object = *stack_.back().value;
    if (object.contains(k)) throw FieldError(path(k), "duplicate key \"" + k + "\"");
    element_ = &object[k];
    key_ = k;
    return true;
  }
  // A number beyond the double range stops nlohmann's parser (out_of_range 406) at the byte
  // after it: parse_json_text replaces exactly that token and parses again.
  struct Overflow {
    std::size_t end;
    std::string token;
  };
  bool parse_error(std::size_t position, const std::string& token, const nlohmann::detail::exception& e) {
    if (const auto* p = dynamic_cast<const json::parse_error*>(&e)) throw *p;
    if (e.id == 406) throw Overflow{position, token};
    throw FieldError("", std::string("malformed JSON: ") + e.what());
  }

 private:
  struct Open {
    json* value;
    std::string field;  // its path, e.g. "shape.vertices[1]"
  };
  std::string path(const std::string& key) const {
    const std::string base = stack_.empty() ? std::string() : stack_.back().field;
    return base.empty() ? key : base + "." + key;
  }
  std::string child_field() const {
    if (stack_.empty()) return "";
    const Open& parent = stack_.back();
    if (parent.value->is_array()) return parent.field + "[" + std::to_string(parent.value->size()) + "]";
    return path(key_);
  }
  template <class V>
  json* place(V&& v) {
    if (stack_.empty()) {
      root = json(std::forward<V>(v));
      return &root;
    }
    json& parent = *stack_.back().value;
    if (parent.is_array()) {
      parent.push_back(json(std::forward<V>(v)));
      return &parent.back();
    }
    *element_ = json(std::forward<V>(v));
    return element_;
  }
  template <class V>
  bool add(V&& v) {
    place(std::forward<V>(v));
    return true;
  }
  bool open(json container) {
    const std::string field = child_field();
    if (stack_.size() >= kMaxJsonDepth)
      throw FieldError(field, "nested deeper than " + std::to_string(kMaxJsonDepth) + " levels");
    json* j = place(std::move(container));
    stack_.push_back({j, field});
    return true;
  }
  bool close() {
    stack_.pop_back();
    return true;
  }
  std::vector<Open> stack_;
  json* element_ = nullptr;
  std::string key_;
  std::string marker_;
};

}  // namespace

json parse_json_text(const std::string& text) {
  // A marker no string of this input contains (a counter until one is absent).
  std::string marker = "rayproof-overflow:";
  for (unsigned n = 0; text.find(marker) != std::string::npos; ++n)
    marker = "rayproof-overflow-" + std::to_string(n) + ":";
  std::string patched = text;
  for (;;) {
    DomBuilder builder(marker);
    try {
      json::sax_parse(patched, &builder);
      return std::move(builder.root);
    } catch (const DomBuilder::Overflow& o) {
      const size_t start = o.end - o.token.size();
      if (o.end > patched.size() || o.token.empty() || patched.compare(start, o.token.size(), o.token) != 0)
        throw FieldError("", "malformed JSON: number overflow parsing '" + o.token + "'");
      patched.replace(start, o.token.size(), "\"" + marker + o.token + "\"");
    }
  }
}

namespace {
// The length of the well-formed UTF-8 sequence starting at text[i] (RFC 3629: no overlongs, no
// surrogates, nothing beyond U+10FFFF), or 0.
std::size_t utf8_sequence(std::string_view text, std::size_t i) {
  const auto byte = [&](std::size_t k) { return static_cast<unsigned char>(text[k]); };
  const unsigned char c = byte(i);
  std::size_t n = 0;
  unsigned char lo = 0x80, hi = 0xbf;  // the range of the second byte
  if (c >= 0xc2 && c <= 0xdf)
    n = 2;
  else if (c == 0xe0)
    n = 3, lo = 0xa0;
  else if (c >= 0xe1 && c <= 0xef)
    n = 3, hi = c == 0xed ? 0x9f : 0xbf;
  else if (c == 0xf0)
    n = 4, lo = 0x90;
  else if (c >= 0xf1 && c <= 0xf3)
    n = 4;
  else if (c == 0xf4)
    n = 4, hi = 0x8f;
  else
    return 0;
  if (i + n > text.size() || byte(i + 1) < lo || byte(i + 1) > hi) return 0;
  for (std::size_t k = 2; k < n; ++k)
    if (byte(i + k) < 0x80 || byte(i + k) > 0xbf) return 0;
  return n;
}
}  // namespace

namespace {
// text with every byte that is not part of well-formed UTF-8 as \xNN and, unless
// keep_controls, every control character too (ESC sequences among them).
std::string escaped_bytes(std::string_view text, bool keep_controls) {
  std::string out;
  for (std::size_t i = 0; i < text.size();) {
    const unsigned char c = static_cast<unsigned char>(text[i]);
    const bool plain = c < 0x80 && (keep_controls || (c >= 0x20 && c < 0x7f));
    if (const std::size_t n = plain ? 1 : c >= 0x80 ? utf8_sequence(text, i) : 0) {
      out.append(text.substr(i, n)), i += n;
      continue;
    }
    char buf[8];
    std::snprintf(buf, sizeof buf, "\\x%02x", c);
    out += buf, ++i;
  }
  return out;
}
}  // namespace

// Safe on a terminal and valid in JSON output (nlohmann refuses invalid UTF-8 when dumping).
std::string printable(std::string_view text) { return escaped_bytes(text, false); }

std::string shell_quoted(std::string_view text) {
  constexpr std::string_view kSafe = "abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789-_./=:,@+%";
  if (!text.empty() && text.find_first_not_of(kSafe) == std::string_view::npos) return std::string(text);
  std::string q = "'";
  for (char c : text) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

std::string printable_prefix(std::string_view text, std::size_t max_bytes) {
  if (text.size() <= max_bytes) return printable(text);
  std::size_t cut = max_bytes;
  while (cut > 0 && (static_cast<unsigned char>(text[cut]) & 0xc0) == 0x80) --cut;  // not inside a character
  return printable(text.substr(0, cut)) + "… (" + std::to_string(text.size()) + " bytes)";
}

namespace {
// Control characters stay in JSON strings: the JSON writer escapes them.
std::string valid_utf8(std::string_view text) { return escaped_bytes(text, true); }

template <class Json>
Json with_valid_utf8(const Json& j) {
  if (j.is_string()) return valid_utf8(j.template get_ref<const std::string&>());
  if (j.is_array()) {
    Json out = Json::array();
    for (const Json& e : j) out.push_back(with_valid_utf8(e));
    return out;
  }
  if (j.is_object()) {
    Json out = Json::object();
    for (const auto& [key, value] : j.items()) out[valid_utf8(key)] = with_valid_utf8(value);
    return out;
  }
  return j;
}

template <class Json>
std::string json_text_of(const Json& j, int indent) {
  try {
    return j.dump(indent);
  } catch (const json::type_error&) {  // 316: invalid UTF-8 somewhere; the rare path walks and escapes
    return with_valid_utf8(j).dump(indent);
  }
}
}  // namespace

std::string json_text(const json& j, int indent) { return json_text_of(j, indent); }
std::string json_text(const nlohmann::ordered_json& j, int indent) { return json_text_of(j, indent); }

std::uint64_t read_count(const json& j, const std::string& field) {
  if (j.is_number_unsigned()) return j.get<std::uint64_t>();
  if (j.is_number_integer()) throw FieldError(field, "a count cannot be negative (" + j.dump() + ")");
  if (j.is_null()) throw FieldError(field, "missing");
  throw FieldError(field, "expected a whole number >= 0, got " + printable_prefix(j.dump(), 40));
}

double read_number(const json& j, const std::string& field) {
  double x;
  if (j.is_binary())  // DomBuilder's mark for a number beyond the double range
    throw FieldError(
        field, "value " + std::string(j.get_binary().begin(), j.get_binary().end()) + " overflows the double range");
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
  if (j.size() != 3) throw FieldError(field, "expected 3 components, got " + std::to_string(j.size()));
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

Shape read_shape(const json& j, const std::string& field, std::initializer_list<std::string_view> extra_keys) {
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
    if (!v.is_array() || v.size() != 3) throw FieldError(prefix + "vertices", "expected an array of 3 vertices");
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
  double x[kMaxShapeNumbers];
  shape_numbers(shape, x);
  json j = {{"type", std::string(to_string(kind_of(shape)))}};
  const double* next = x;
  auto vec = [&] {
    const json v = vec_json(Vec3(next[0], next[1], next[2]));
    next += 3;
    return v;
  };
  for (const ShapeField& f : shape_fields(kind_of(shape))) {
    json& field = j[std::string(f.name)];
    if (f.vectors == 0) {
      field = exact_json_number(*next++);
    } else if (!f.nested()) {
      field = vec();
    } else {
      field = json::array();
      for (int i = 0; i < f.vectors; ++i) field.push_back(vec());
    }
  }
  return j;
}

}  // namespace rayproof
