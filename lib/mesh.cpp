#include "rayproof/core/mesh.h"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string_view>

#include "mesh_soup.h"
#include "rayproof/core/json_fields.h"

namespace rayproof {

namespace {

using mesh_detail::Soup;

[[noreturn]] void fail(const std::string& path, long line, const std::string& message) {
  throw std::runtime_error(printable(path) + (line > 0 ? ":" + std::to_string(line) : "") + ": " + message);
}

// Splits a line into whitespace-separated tokens, stopping at a '#' comment.
std::vector<std::string_view> tokens_of(std::string_view line) {
  std::vector<std::string_view> out;
  size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && std::isspace(static_cast<unsigned char>(line[i]))) ++i;
    if (i >= line.size() || line[i] == '#') break;
    size_t j = i;
    while (j < line.size() && !std::isspace(static_cast<unsigned char>(line[j]))) ++j;
    out.push_back(line.substr(i, j - i));
    i = j;
  }
  return out;
}

// A finite double, correctly rounded from decimal text (from_chars); errors name file and line.
double coordinate(std::string_view text, const std::string& path, long line) {
  const DecimalNumber n = parse_decimal(text);
  if (n.status == DecimalNumber::Status::not_a_number)
    fail(path, line, "expected a number, got '" + printable(text) + "'");
  if (n.status != DecimalNumber::Status::ok)
    fail(path, line, "coordinate '" + printable(text) + "' " + std::string(decimal_problem(n.status)));
  if (!std::isfinite(n.value)) fail(path, line, "coordinate '" + printable(text) + "' is not finite");
  return n.value;
}

long long integer(std::string_view text, const std::string& path, long line, const char* what) {
  long long x = 0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), x);
  if (ec != std::errc() || end != text.data() + text.size())
    fail(path, line, std::string("expected ") + what + ", got '" + printable(text) + "'");
  return x;
}

// Lines of a text file with their 1-based numbers, blank and comment-only lines skipped.
class LineReader {
 public:
  explicit LineReader(const std::string& path) : path_(path), in_(path, std::ios::binary) {
    if (!in_) fail(path, 0, "cannot open mesh file");
  }
  bool next(std::vector<std::string_view>& tokens) {
    while (std::getline(in_, text_)) {
      ++line_;
      tokens = tokens_of(text_);
      if (!tokens.empty()) return true;
    }
    return false;
  }
  long line() const { return line_; }

 private:
  std::string path_;
  std::ifstream in_;
  std::string text_;
  long line_ = 0;
};

// OFF (Geomview): "OFF" (or COFF, NOFF, CNOFF, STOFF...: extra per-vertex numbers are ignored),
// then "V F E", V lines "x y z ...", F lines "n i_1 ... i_n [colour]".
Soup read_off(const std::string& path) {
  LineReader in(path);
  std::vector<std::string_view> tok;
  if (!in.next(tok)) fail(path, in.line(), "empty OFF file");
  const std::string_view header = tok[0];
  if (header.size() < 3 || header.substr(header.size() - 3) != "OFF")
    fail(path, in.line(), "expected the OFF header (not an OFF file; nothing of it is shown)");
  if (header.find('4') != std::string_view::npos || header.find('n') != std::string_view::npos)
    fail(path, in.line(), "only 3-dimensional OFF is supported");
  std::vector<std::string_view> counts(tok.begin() + 1, tok.end());
  if (counts.empty()) {
    if (!in.next(tok)) fail(path, in.line(), "missing the vertex and face counts");
    counts = tok;
  }
  if (counts.size() < 2) fail(path, in.line(), "expected 'vertices faces edges'");
  const long long nv = integer(counts[0], path, in.line(), "a vertex count");
  const long long nf = integer(counts[1], path, in.line(), "a face count");
  if (nv < 0 || nf < 0 || nv > (1LL << 31) || nf > (1LL << 31))
    fail(path, in.line(), "vertex or face count out of range");
  Soup soup;
  soup.points.reserve(static_cast<size_t>(std::min(nv, 1LL << 24)));
  for (long long i = 0; i < nv; ++i) {
    if (!in.next(tok))
      fail(path, in.line(), "file ends after " + std::to_string(i) + " of " + std::to_string(nv) + " vertices");
    if (tok.size() < 3) fail(path, in.line(), "a vertex needs 3 coordinates");
    soup.points.push_back({coordinate(tok[0], path, in.line()), coordinate(tok[1], path, in.line()),
                           coordinate(tok[2], path, in.line())});
  }
  for (long long f = 0; f < nf; ++f) {
    if (!in.next(tok))
      fail(path, in.line(), "file ends after " + std::to_string(f) + " of " + std::to_string(nf) + " faces");
    const long long n = integer(tok[0], path, in.line(), "the face's vertex count");
    if (n < 3 || static_cast<size_t>(n) + 1 > tok.size()) fail(path, in.line(), "a face needs n >= 3 and n indices");
    std::vector<size_t> face;
    for (long long k = 1; k <= n; ++k) {
      const long long idx = integer(tok[k], path, in.line(), "a vertex index");
      if (idx < 0 || idx >= nv)
        fail(path, in.line(),
             "vertex index " + std::to_string(idx) + " out of range (" + std::to_string(nv) + " vertices)");
      face.push_back(static_cast<size_t>(idx));
    }
    soup.faces.push_back(std::move(face));
    soup.face_lines.push_back(in.line());
  }
  return soup;
}

// Wavefront OBJ: "v x y z [w]" and "f a b c ..." whose entries are "i", "i/t", "i//n" or "i/t/n",
// 1-based, negative counting back from the last vertex so far. Other statements are ignored.
Soup read_obj(const std::string& path) {
  LineReader in(path);
  std::vector<std::string_view> tok;
  Soup soup;
  while (in.next(tok)) {
    if (tok[0] == "v") {
      if (tok.size() < 4) fail(path, in.line(), "a vertex needs 3 coordinates");
      soup.points.push_back({coordinate(tok[1], path, in.line()), coordinate(tok[2], path, in.line()),
                             coordinate(tok[3], path, in.line())});
    } else if (tok[0] == "f") {
      if (tok.size() < 4) fail(path, in.line(), "a face needs at least 3 vertices");
      std::vector<size_t> face;
      const long long n = static_cast<long long>(soup.points.size());
      for (size_t k = 1; k < tok.size(); ++k) {
        const long long raw = integer(tok[k].substr(0, tok[k].find('/')), path, in.line(), "a vertex index");
        const long long idx = raw < 0 ? n + raw : raw - 1;
        if (raw == 0 || idx < 0 || idx >= n)
          fail(path, in.line(),
               "vertex index " + std::to_string(raw) + " out of range (" + std::to_string(n) + " vertices so far)");
        face.push_back(static_cast<size_t>(idx));
      }
      soup.faces.push_back(std::move(face));
      soup.face_lines.push_back(in.line());
    }
  }
  return soup;
}

std::string lower_extension(const std::string& path) {
  const size_t dot = path.find_last_of('.');
  const size_t slash = path.find_last_of('/');
  if (dot == std::string::npos || (slash != std::string::npos && dot < slash)) return "";
  std::string ext = path.substr(dot + 1);
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return ext;
}

// Placement and triangulation of what a reader returned.
Mesh mesh_of_soup(const std::string& path, const Soup& soup, double scale, const Vec3& translate) {
  Mesh mesh;
  mesh.vertex_count = soup.points.size();
  // Placement v·scale + translate, two roundings per coordinate (this file is built without
  // FMA contraction, so the result is the same on every machine).
  std::vector<Vec3> placed(soup.points.size());
  for (size_t i = 0; i < soup.points.size(); ++i) {
    for (int k = 0; k < 3; ++k) {
      const double x = soup.points[i][k];
      if (!std::isfinite(x)) fail(path, 0, "vertex " + std::to_string(i) + " has a coordinate that is not finite");
      placed[i][k] = x * scale + translate[k];
      if (!std::isfinite(placed[i][k]))
        fail(path, 0, "vertex " + std::to_string(i) + " overflows once scaled and translated");
    }
  }
  for (size_t f = 0; f < soup.faces.size(); ++f) {
    const std::vector<size_t>& face = soup.faces[f];
    const long line = soup.face_lines.empty() ? 0 : soup.face_lines[f];
    for (size_t idx : face)
      if (idx >= placed.size())
        fail(path, line,
             "face " + std::to_string(f) + ": vertex index " + std::to_string(idx) + " out of range (" +
                 std::to_string(placed.size()) + " vertices)");
    for (size_t k = 1; k + 1 < face.size(); ++k) {  // the fan from the face's first vertex
      const std::array<std::uint32_t, 3> c = {static_cast<std::uint32_t>(face[0]), static_cast<std::uint32_t>(face[k]),
                                              static_cast<std::uint32_t>(face[k + 1])};
      const Triangle tri{{placed[c[0]], placed[c[1]], placed[c[2]]}};
      if (degenerate_reason(tri)) {
        ++mesh.degenerate_skipped;
        continue;
      }
      mesh.triangles.push_back(tri);
      mesh.corners.push_back(c);
    }
  }
  if (mesh.triangles.empty()) fail(path, 0, "the mesh has no non-degenerate triangles");
  return mesh;
}

}  // namespace

Mesh load_mesh(const std::string& path, double scale, const Vec3& translate) {
  // A scene names its mesh files: a device or FIFO (/dev/zero, /dev/stdin) would be read
  // forever, so only regular files are meshes.
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) fail(path, 0, "cannot open mesh file");
  if (!std::filesystem::is_regular_file(path, ec)) fail(path, 0, "not a regular file");
  const std::string ext = lower_extension(path);
  Soup soup;
  if (ext == "off")
    soup = read_off(path);
  else if (ext == "obj")
    soup = read_obj(path);
  else if (ext == "ply")
    soup = mesh_detail::read_ply(path);
  else if (ext == "stl")
    soup = mesh_detail::read_stl(path);
  else
    fail(path, 0, "unknown mesh format '" + printable(ext) + "' (OFF, OBJ, PLY or STL)");

  return mesh_of_soup(path, soup, scale, translate);
}

Mesh parse_ply_mesh(const std::string& bytes, const std::string& name) {
  return mesh_of_soup(name, mesh_detail::parse_ply(name, bytes), 1, Vec3::Zero());
}

Mesh parse_stl_mesh(const std::string& bytes, const std::string& name) {
  return mesh_of_soup(name, mesh_detail::parse_stl(name, bytes), 1, Vec3::Zero());
}

}  // namespace rayproof
