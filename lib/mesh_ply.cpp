// PLY meshes (Greg Turk's format, as Paul Bourke documents it): a text header of elements and
// their properties, then the elements in that order, as ASCII or binary of either byte order.
//
// Written here rather than taken from CGAL (which reads STL for us) because a reader of hostile
// files must not trust a count before the data: CGAL's reader resizes a face's index list to the
// count the file claims, so a 198-byte file can ask for 16 GB. Here every count is checked
// against the bytes that remain before anything is allocated, faces with fewer than 3 vertices
// and vertices without x, y or z are refused, and every error names the vertex or face (and, in
// ASCII, the line). Coordinates keep the type the header declares: a "float" property is read as
// that float, exactly widened to double, a "double" one as written.
#include <algorithm>
#include <bit>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <iterator>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "mesh_soup.h"
#include "rayproof/core/fp.h"
#include "rayproof/core/json_fields.h"

namespace rayproof::mesh_detail {

namespace {

enum class PlyType { i8, u8, i16, u16, i32, u32, f32, f64 };

std::optional<PlyType> ply_type(std::string_view name) {
  if (name == "char" || name == "int8") return PlyType::i8;
  if (name == "uchar" || name == "uint8") return PlyType::u8;
  if (name == "short" || name == "int16") return PlyType::i16;
  if (name == "ushort" || name == "uint16") return PlyType::u16;
  if (name == "int" || name == "int32") return PlyType::i32;
  if (name == "uint" || name == "uint32") return PlyType::u32;
  if (name == "float" || name == "float32") return PlyType::f32;
  if (name == "double" || name == "float64") return PlyType::f64;
  return std::nullopt;
}

std::size_t size_of(PlyType t) {
  switch (t) {
    case PlyType::i8:
    case PlyType::u8: return 1;
    case PlyType::i16:
    case PlyType::u16: return 2;
    case PlyType::i32:
    case PlyType::u32:
    case PlyType::f32: return 4;
    case PlyType::f64: return 8;
  }
  return 8;
}

struct Property {
  std::string name;
  bool is_list = false;
  PlyType count_type = PlyType::u8, value_type = PlyType::f32;
};

struct Element {
  std::string name;
  std::uint64_t count = 0;
  std::vector<Property> properties;
};

enum class Encoding { ascii, little, big };

class PlyReader {
 public:
  PlyReader(const std::string& path, std::string bytes) : path_(path), bytes_(std::move(bytes)) {}

  Soup read() {
    read_header();
    Soup soup;
    bool seen_vertices = false, seen_faces = false;
    for (const Element& e : elements_) {
      if (e.name == "vertex") {
        if (seen_vertices) fail("two 'vertex' elements");
        seen_vertices = true;
        read_vertices(e, soup);
      } else if (e.name == "face") {
        if (seen_faces) fail("two 'face' elements");
        seen_faces = true;
        read_faces(e, soup);
      } else {
        for (std::uint64_t i = 0; i < e.count; ++i)
          for (const Property& p : e.properties) skip(p, e.name + " " + std::to_string(i));
      }
    }
    if (!seen_vertices) fail("no 'vertex' element", false);
    if (!seen_faces) fail("no 'face' element", false);
    return soup;
  }

 private:
  // An error at the current line (header or ASCII body) or, for what the header as a whole
  // lacks, at none.
  [[noreturn]] void fail(const std::string& message, bool at_line = true) const {
    const bool with_line = at_line && (in_header_ || encoding_ == Encoding::ascii) && line_ > 0;
    throw std::runtime_error(printable(path_) + (with_line ? ":" + std::to_string(line_) : "") + ": " + message);
  }

  std::size_t remaining() const { return bytes_.size() - pos_; }

  // The header's next line without its line ending; fails at the end of the file.
  std::string_view header_line() {
    if (pos_ >= bytes_.size()) fail("the header has no 'end_header'");
    const std::size_t end = bytes_.find('\n', pos_);
    std::string_view line(bytes_.data() + pos_, (end == std::string::npos ? bytes_.size() : end) - pos_);
    pos_ = end == std::string::npos ? bytes_.size() : end + 1;
    ++line_;
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    return line;
  }

  static std::vector<std::string_view> words(std::string_view line) {
    std::vector<std::string_view> out;
    std::size_t i = 0;
    while (i < line.size()) {
      while (i < line.size() && (line[i] == ' ' || line[i] == '\t')) ++i;
      std::size_t j = i;
      while (j < line.size() && line[j] != ' ' && line[j] != '\t') ++j;
      if (j > i) out.push_back(line.substr(i, j - i));
      i = j;
    }
    return out;
  }

  PlyType type_named(std::string_view name) {
    const auto t = ply_type(name);
    if (!t) fail("unknown property type '" + printable(name) + "'");
    return *t;
  }

  void read_header() {
    if (header_line() != "ply") {
      line_ = 1;
      fail("expected 'ply' on the first line");
    }
    bool have_format = false;
    for (;;) {
      const std::vector<std::string_view> w = words(header_line());
      if (w.empty() || w[0] == "comment" || w[0] == "obj_info") continue;
      if (w[0] == "end_header") break;
      if (w[0] == "format") {
        if (w.size() != 3) fail("expected 'format ascii|binary_little_endian|binary_big_endian 1.0'");
        if (w[1] == "ascii")
          encoding_ = Encoding::ascii;
        else if (w[1] == "binary_little_endian")
          encoding_ = Encoding::little;
        else if (w[1] == "binary_big_endian")
          encoding_ = Encoding::big;
        else
          fail("unknown format '" + printable(w[1]) + "'");
        have_format = true;
      } else if (w[0] == "element") {
        std::uint64_t count = 0;
        if (w.size() != 3 ||
            std::from_chars(w[2].data(), w[2].data() + w[2].size(), count).ptr != w[2].data() + w[2].size())
          fail("expected 'element NAME COUNT' with a count >= 0");
        if (count > (std::uint64_t{1} << 31))
          fail("element '" + printable(w[1]) + "' count " + std::string(w[2]) + " is out of range");
        elements_.push_back({std::string(w[1]), count, {}});
      } else if (w[0] == "property") {
        if (elements_.empty()) fail("a property before any element");
        Property p;
        if (w.size() == 5 && w[1] == "list") {
          p = {std::string(w[4]), true, type_named(w[2]), type_named(w[3])};
          if (p.count_type == PlyType::f32 || p.count_type == PlyType::f64)
            fail("a list count must have an integer type");
        } else if (w.size() == 3) {
          p = {std::string(w[2]), false, PlyType::u8, type_named(w[1])};
        } else {
          fail("expected 'property TYPE NAME' or 'property list COUNT_TYPE TYPE NAME'");
        }
        elements_.back().properties.push_back(std::move(p));
      } else {
        fail("unexpected header line starting '" + printable(w[0]) + "'");
      }
    }
    if (!have_format) fail("the header has no 'format' line");
    in_header_ = false;
    ++line_;  // ASCII elements start on the line after end_header
    // Each element takes at least one byte per property (binary) or one character and a
    // separator (ASCII): a header that claims more than the file can hold is refused here,
    // before anything is reserved.
    std::uint64_t least = 0;
    for (const Element& e : elements_) {
      std::uint64_t per_element = 0;
      for (const Property& p : e.properties)
        per_element += encoding_ == Encoding::ascii ? 2 : p.is_list ? size_of(p.count_type) : size_of(p.value_type);
      least += e.count * per_element;
    }
    if (least > remaining() + 1)
      fail("the header's element counts need at least " + std::to_string(least) + " bytes, the file has " +
           std::to_string(remaining()) + " after the header");
  }

  // The next ASCII token, skipping spaces and counting lines.
  std::string_view token(const std::string& what) {
    while (pos_ < bytes_.size() && std::isspace(static_cast<unsigned char>(bytes_[pos_]))) {
      if (bytes_[pos_] == '\n') ++line_;
      ++pos_;
    }
    if (pos_ >= bytes_.size()) fail("the file ends inside " + what);
    const std::size_t start = pos_;
    while (pos_ < bytes_.size() && !std::isspace(static_cast<unsigned char>(bytes_[pos_]))) ++pos_;
    return std::string_view(bytes_).substr(start, pos_ - start);
  }

  template <class T>
  T binary_value(const std::string& what) {
    if (remaining() < sizeof(T)) fail("the file ends inside " + what);
    unsigned char raw[sizeof(T)];
    std::memcpy(raw, bytes_.data() + pos_, sizeof(T));
    pos_ += sizeof(T);
    const bool file_little = encoding_ == Encoding::little;
    if (file_little != (std::endian::native == std::endian::little)) std::reverse(std::begin(raw), std::end(raw));
    T value;
    std::memcpy(&value, raw, sizeof(T));
    return value;
  }

  // One value of type t as a double, exactly (every PLY type fits a double).
  double value(PlyType t, const std::string& what) {
    if (encoding_ == Encoding::ascii) {
      const std::string_view text = token(what);
      const bool integral = t != PlyType::f32 && t != PlyType::f64;
      if (integral) {
        long long x = 0;
        const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), x);
        if (ec != std::errc() || end != text.data() + text.size())
          fail(what + ": expected an integer, got '" + printable(text) + "'");
        const bool is_unsigned = t == PlyType::u8 || t == PlyType::u16 || t == PlyType::u32;
        const long long lo = is_unsigned ? 0 : -(1LL << (8 * size_of(t) - 1));
        const long long hi = is_unsigned ? (1LL << (8 * size_of(t))) - 1 : (1LL << (8 * size_of(t) - 1)) - 1;
        if (x < lo || x > hi) fail(what + ": " + std::string(text) + " does not fit the declared type");
        return static_cast<double>(x);
      }
      const DecimalNumber n = parse_decimal(text);
      if (n.status == DecimalNumber::Status::not_a_number)
        fail(what + ": expected a number, got '" + printable(text) + "'");
      if (n.status != DecimalNumber::Status::ok)
        fail(what + ": '" + printable(text) + "' " + std::string(decimal_problem(n.status)));
      // A property declared float holds a float: its decimal text names the nearest float.
      return t == PlyType::f32 ? static_cast<double>(to_nearest_float(n.value)) : n.value;
    }
    switch (t) {
      case PlyType::i8: return binary_value<std::int8_t>(what);
      case PlyType::u8: return binary_value<std::uint8_t>(what);
      case PlyType::i16: return binary_value<std::int16_t>(what);
      case PlyType::u16: return binary_value<std::uint16_t>(what);
      case PlyType::i32: return binary_value<std::int32_t>(what);
      case PlyType::u32: return binary_value<std::uint32_t>(what);
      case PlyType::f32: return binary_value<float>(what);
      case PlyType::f64: return binary_value<double>(what);
    }
    return 0;
  }

  // A list's length, checked against what remains before anyone allocates for it.
  std::uint64_t list_length(const Property& p, const std::string& what) {
    const double n = value(p.count_type, what + " list length");
    if (n < 0) fail(what + ": negative list length");
    const auto length = static_cast<std::uint64_t>(n);
    const std::uint64_t least = encoding_ == Encoding::ascii ? length : length * size_of(p.value_type);
    if (least > remaining())
      fail(what + ": a list of " + std::to_string(length) + " values is longer than the rest of the file (" +
           std::to_string(remaining()) + " bytes)");
    return length;
  }

  void skip(const Property& p, const std::string& what) {
    const std::uint64_t n = p.is_list ? list_length(p, what) : 1;
    for (std::uint64_t k = 0; k < n; ++k) value(p.value_type, what);
  }

  void read_vertices(const Element& e, Soup& soup) {
    int axis_of[3] = {-1, -1, -1};
    for (std::size_t k = 0; k < e.properties.size(); ++k) {
      const Property& p = e.properties[k];
      const int axis = p.name == "x" ? 0 : p.name == "y" ? 1 : p.name == "z" ? 2 : -1;
      if (axis < 0) continue;
      if (p.is_list) fail("vertex property '" + p.name + "' is a list");
      axis_of[axis] = static_cast<int>(k);
    }
    for (int axis = 0; axis < 3; ++axis)
      if (axis_of[axis] < 0) fail(std::string("the vertex element has no '") + "xyz"[axis] + "' property", false);
    soup.points.reserve(e.count);  // bounded by the file's size in read_header
    for (std::uint64_t i = 0; i < e.count; ++i) {
      const std::string what = "vertex " + std::to_string(i);
      std::array<double, 3> point{};
      for (std::size_t k = 0; k < e.properties.size(); ++k) {
        const Property& p = e.properties[k];
        const int axis = k == static_cast<std::size_t>(axis_of[0])   ? 0
                         : k == static_cast<std::size_t>(axis_of[1]) ? 1
                         : k == static_cast<std::size_t>(axis_of[2]) ? 2
                                                                     : -1;
        if (axis < 0)
          skip(p, what);
        else
          point[axis] = value(p.value_type, what + " " + p.name);
      }
      soup.points.push_back(point);
    }
  }

  void read_faces(const Element& e, Soup& soup) {
    std::size_t indices = e.properties.size();
    for (std::size_t k = 0; k < e.properties.size(); ++k)
      if (e.properties[k].name == "vertex_indices" || e.properties[k].name == "vertex_index") indices = k;
    if (indices == e.properties.size() || !e.properties[indices].is_list)
      fail("the face element has no 'vertex_indices' list", false);
    soup.faces.reserve(e.count);  // bounded by the file's size in read_header
    for (std::uint64_t f = 0; f < e.count; ++f) {
      const std::string what = "face " + std::to_string(f);
      for (std::size_t k = 0; k < e.properties.size(); ++k) {
        const Property& p = e.properties[k];
        if (k != indices) {
          skip(p, what);
          continue;
        }
        const std::uint64_t n = list_length(p, what);
        if (n < 3) fail(what + " has " + std::to_string(n) + " vertices (a face needs at least 3)");
        std::vector<std::size_t> face;
        face.reserve(n);
        for (std::uint64_t j = 0; j < n; ++j) {
          const double idx = value(p.value_type, what + " vertex index");
          // A float- or double-typed list may hold inf or 1e20: casting those to an integer is
          // undefined, so anything but a whole number below 2^32 is refused first.
          if (!(idx >= 0 && idx < 0x1p32) || idx != std::floor(idx)) {
            char text[32];
            std::snprintf(text, sizeof text, "%.17g", idx);
            fail(what + ": vertex index " + text + " is not an index");
          }
          face.push_back(static_cast<std::size_t>(idx));
        }
        soup.faces.push_back(std::move(face));
        if (encoding_ == Encoding::ascii) soup.face_lines.push_back(line_);
      }
    }
  }

  std::string path_;
  std::string bytes_;
  std::size_t pos_ = 0;
  long line_ = 0;
  bool in_header_ = true;
  Encoding encoding_ = Encoding::ascii;
  std::vector<Element> elements_;
};

}  // namespace

Soup read_ply(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error(printable(path) + ": cannot open mesh file");
  std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  return parse_ply(path, std::move(bytes));
}

Soup parse_ply(const std::string& name, std::string bytes) {
  if (bytes.empty()) throw std::runtime_error(printable(name) + ": empty PLY file");
  return PlyReader(name, std::move(bytes)).read();
}

}  // namespace rayproof::mesh_detail
