// Reading the numbers, vectors and shapes shared by case files and scene files
// (docs/spec/cases.md, "Every number is ..."). Errors name the field by its JSON path.
#pragma once

#include <cstdint>
#include <initializer_list>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <string>
#include <string_view>

#include "rayproof/core/shapes.h"

namespace rayproof {

// rayproof's JSON type (a case's `found`, every record's to_json): an alias in rayproof's own
// namespace, so including a rayproof header brings no name into the user's scope.
using json = nlohmann::json;

// A malformed field: `field` is its path, e.g. "shape.center[2]".
struct FieldError : std::runtime_error {
  FieldError(std::string field, const std::string& message) : std::runtime_error(message), field(std::move(field)) {}
  std::string field;
};

// Parses a C99 hexadecimal float exactly ("0x1.8p+1"); nullopt when the text is not one.
std::optional<double> parse_hex_double(std::string_view text);
// A decimal number of a text file (meshes), correctly rounded (from_chars). `value` is set for
// `ok`, which includes subnormal results; `overflow` is beyond ±DBL_MAX; `underflow` is a
// non-zero number below the smallest subnormal (it would round to zero, silently moving the
// geometry); `not_a_number` is anything else, trailing characters included.
struct DecimalNumber {
  enum class Status { ok, not_a_number, overflow, underflow } status = Status::not_a_number;
  double value = 0;
};
DecimalNumber parse_decimal(std::string_view text);
// "is beyond the double range", "underflows to zero in double", "is not a number".
std::string_view decimal_problem(DecimalNumber::Status status);

// The hex form of a double as printf's %a writes it ("0x1p+1", "-0x0p+0", "inf").
std::string hex_double(double x);
// A JSON value for x: a plain number when a short decimal names it exactly, else a hex string.
json exact_json_number(double x);

// Every JSON input (cases, scenes, checkpoints, summaries) is parsed here: json::parse, except
// that nesting deeper than kMaxJsonDepth and a key repeated in one object are FieldErrors naming
// the field, and a number beyond the double range (1e999) does not abort the document: it is
// kept so that read_number reports it under the field's own name. Throws json::parse_error for
// malformed JSON.
inline constexpr size_t kMaxJsonDepth = 64;
json parse_json_text(const std::string& text);

// Text safe to print on a terminal: control characters (ESC sequences among them) as \xNN.
std::string printable(std::string_view text);
// printable() of at most max_bytes of text, cut at a character boundary, with "… (N bytes)"
// when cut: for strings from outside (answer lines, plugin names) that end up in messages.
std::string printable_prefix(std::string_view text, std::size_t max_bytes);

// A word a POSIX shell reads back as `text`: as it is when it holds only safe characters, else
// in single quotes (a ' inside as '\''). For the commands rayproof prints for users to run.
std::string shell_quoted(std::string_view text);

// Every JSON that rayproof writes goes through here: j.dump(indent), except that a string (or
// key) that is not valid UTF-8 (a file name, a plugin's message) has its bad bytes written as
// \xNN instead of making the dump throw and the file go unwritten.
std::string json_text(const json& j, int indent = -1);
std::string json_text(const nlohmann::ordered_json& j, int indent = -1);  // keys kept in insertion order

// A count from a summary or checkpoint: a JSON integer >= 0, never a float (1e308), a negative
// number (-5 would wrap to 18446744073709551611) or text.
std::uint64_t read_count(const json& j, const std::string& field);

// A finite double from a JSON number or a hex-float string.
double read_number(const json& j, const std::string& field);
Vec3 read_vec3(const json& j, const std::string& field);
// Rejects any key of `obj` not in `allowed`, and any missing key of `required`.
void check_keys(const json& obj, const std::string& field, std::initializer_list<std::string_view> allowed,
                std::initializer_list<std::string_view> required);
const json& require_object(const json& j, const std::string& field);
// A shape object of the case format. `extra_keys` are allowed besides the shape's own
// (scene objects add "color" and "id"). Degenerate shapes are errors.
Shape read_shape(const json& j, const std::string& field, std::initializer_list<std::string_view> extra_keys = {});
json shape_to_json(const Shape& s);

}  // namespace rayproof
