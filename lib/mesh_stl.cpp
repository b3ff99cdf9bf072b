// STL meshes, binary and ASCII, read here rather than by CGAL's reader (issue 42): CGAL merges
// points through an ordered map where a NaN compares "equal" to anything (its triangle vanished
// without a word) and trusts a binary header's triangle count (a file holding two triangles
// under a header saying one lost one). Here every coordinate must be finite, a binary file's
// size must be exactly 84 + 50 × its header's count, and points merge only when equal in value
// (so that triangles sharing a corner share a vertex, as in the file's own intent). A binary
// file's floats convert to double exactly.
#include <bit>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <array>
#include <vector>
#include <fstream>
#include <iterator>
#include <map>
#include <stdexcept>
#include <string>
#include <string_view>

#include "mesh_soup.h"
#include "rayproof/core/json_fields.h"

namespace rayproof::mesh_detail {

namespace {

[[noreturn]] void fail(const std::string& name, long line, const std::string& message) {
  throw std::runtime_error(printable(name) + (line > 0 ? ":" + std::to_string(line) : std::string()) + ": " + message);
}

// Points equal in value share one index (a NaN never reaches here).
struct PointIndex {
  Soup& soup;
  std::map<std::array<double, 3>, std::size_t> seen;
  std::size_t operator()(const std::array<double, 3>& p) {
    const auto [it, added] = seen.emplace(p, soup.points.size());
    if (added) soup.points.push_back(p);
    return it->second;
  }
};

bool looks_ascii(const std::string& bytes) {
  std::size_t i = 0;
  while (i < bytes.size() && std::isspace(static_cast<unsigned char>(bytes[i]))) ++i;
  return bytes.compare(i, 5, "solid") == 0;
}

Soup parse_binary(const std::string& name, const std::string& bytes) {
  if (bytes.size() < 84)
    fail(name, 0, "truncated binary STL: " + std::to_string(bytes.size()) + " bytes, where the header alone takes 84");
  std::uint32_t count;
  std::memcpy(&count, bytes.data() + 80, 4);
  if constexpr (std::endian::native == std::endian::big) count = __builtin_bswap32(count);
  const std::uint64_t expected = 84 + 50 * std::uint64_t(count);
  if (bytes.size() != expected)
    fail(name, 0,
         "binary STL header says " + std::to_string(count) + " triangles (" + std::to_string(expected) +
             " bytes), but the file has " + std::to_string(bytes.size()) + " bytes");
  if (count == 0) fail(name, 0, "binary STL with 0 triangles");
  Soup soup;
  PointIndex index{soup, {}};
  for (std::uint32_t t = 0; t < count; ++t) {
    std::vector<std::size_t> face;
    for (int corner = 0; corner < 3; ++corner) {
      std::array<double, 3> p;
      for (int k = 0; k < 3; ++k) {
        std::uint32_t bits;
        // 50 bytes a triangle: its normal (12), three corners (36), an attribute count (2).
        std::memcpy(&bits, bytes.data() + 84 + 50 * std::size_t(t) + 12 + 12 * corner + 4 * k, 4);
        if constexpr (std::endian::native == std::endian::big) bits = __builtin_bswap32(bits);
        p[k] = double(std::bit_cast<float>(bits));
        if (!std::isfinite(p[k]))
          fail(name, 0,
               "triangle " + std::to_string(t) + ", corner " + std::to_string(corner) + ": coordinate " +
                   std::to_string(k) + " is not finite");
      }
      face.push_back(index(p));
    }
    soup.faces.push_back(std::move(face));
  }
  return soup;
}

// ASCII: `solid`, then per facet `facet normal … outer loop`, three `vertex x y z`, `endloop`,
// `endfacet`; then `endsolid`. Only the vertices matter; every one must be complete and finite,
// in threes, and the file must end its last facet.
Soup parse_ascii(const std::string& name, const std::string& bytes) {
  Soup soup;
  PointIndex index{soup, {}};
  std::vector<std::size_t> face;
  long line = 1, face_line = 0;
  bool ended = false;
  std::size_t pos = 0;
  auto next_word = [&]() -> std::string_view {
    while (pos < bytes.size() && std::isspace(static_cast<unsigned char>(bytes[pos]))) line += bytes[pos++] == '\n';
    const std::size_t start = pos;
    while (pos < bytes.size() && !std::isspace(static_cast<unsigned char>(bytes[pos]))) ++pos;
    return std::string_view(bytes).substr(start, pos - start);
  };
  for (std::string_view w = next_word(); !w.empty(); w = next_word()) {
    if (w == "endsolid") {
      ended = true;
      break;
    }
    if (w != "vertex") continue;
    std::array<double, 3> p;
    for (int k = 0; k < 3; ++k) {
      const std::string_view text = next_word();
      const DecimalNumber n = parse_decimal(text);
      if (text.empty()) fail(name, line, "truncated: a vertex with " + std::to_string(k) + " of 3 coordinates");
      if (n.status != DecimalNumber::Status::ok)
        fail(name, line, "coordinate '" + printable(text) + "' " + std::string(decimal_problem(n.status)));
      if (!std::isfinite(n.value)) fail(name, line, "coordinate '" + printable(text) + "' is not finite");
      p[k] = n.value;
    }
    if (face.empty()) face_line = line;
    face.push_back(index(p));
    if (face.size() == 3) {
      soup.faces.push_back(std::move(face));
      soup.face_lines.push_back(face_line);
      face.clear();
    }
  }
  if (!face.empty()) fail(name, line, "truncated: a facet with " + std::to_string(face.size()) + " of 3 vertices");
  if (!ended) fail(name, line, "truncated ASCII STL: no endsolid");
  if (soup.faces.empty()) fail(name, line, "ASCII STL with no facets");
  return soup;
}

}  // namespace

Soup parse_stl(const std::string& name, const std::string& bytes) {
  if (bytes.empty()) fail(name, 0, "empty file (an STL file starts with an 80-byte header or 'solid')");
  // A binary file's 80-byte header may begin with "solid" too: its exact size decides.
  if (looks_ascii(bytes)) {
    std::uint32_t count = 0;
    if (bytes.size() >= 84) std::memcpy(&count, bytes.data() + 80, 4);
    if (!(bytes.size() >= 84 && bytes.size() == 84 + 50 * std::uint64_t(count))) return parse_ascii(name, bytes);
  }
  return parse_binary(name, bytes);
}

Soup read_stl(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) fail(path, 0, "cannot open mesh file");
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  return parse_stl(path, bytes);
}

}  // namespace rayproof::mesh_detail
