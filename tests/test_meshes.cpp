// Meshes in scenes (docs/spec/audit.md): the four formats read to the same doubles, placement in
// double, fans, degenerate triangles, and every bad file named with its line.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>

#include <algorithm>
#include <bit>
#include <cstdlib>
#include <fstream>

#include "rayproof/core/mesh.h"
#include "rayproof/core/scene.h"
#include "test_dir.h"

namespace rayproof {
namespace {

using testing_support::test_dir;

std::string write(const std::string& name, const std::string& text) {
  const std::string path = test_dir() + "/" + name;
  std::ofstream(path, std::ios::binary) << text;
  return path;
}

// Numbers a float-storing loader would change: 0.1, a subnormal, 0.30000000000000004, and a value
// needing all 53 bits.
const char* kX = "0.1";
const char* kY = "4.9406564584124654e-320";
const char* kZ = "0.30000000000000004";
const char* kW = "123456789.12345679";

std::string tetra_vertices(const char* prefix) {
  std::string p(prefix);
  return p + kX + " " + kY + " " + kZ + "\n" + p + "1 0 0\n" + p + "0 1 0\n" + p + kW + " 2 3\n";
}

void expect_tetra(const Mesh& m, const std::string& format) {
  ASSERT_EQ(m.triangles.size(), 4u) << format;
  const Vec3 first(std::strtod(kX, nullptr), std::strtod(kY, nullptr), std::strtod(kZ, nullptr));
  bool found_first = false, found_w = false;
  for (const Triangle& t : m.triangles)
    for (const Vec3& v : t.v) {
      found_first |= v == first;
      found_w |= v.x() == std::strtod(kW, nullptr);
    }
  EXPECT_TRUE(found_first) << format << ": the vertex with 0.1, a subnormal and 0.30000000000000004 changed";
  EXPECT_TRUE(found_w) << format << ": 123456789.12345679 lost bits";
}

TEST(Meshes, FourFormatsReadToTheSameDoubles) {
  expect_tetra(load_mesh(write("t.off", "OFF\n4 4 0\n" + tetra_vertices("") + "3 0 1 2\n3 0 1 3\n3 0 2 3\n3 1 2 3\n")),
               "OFF");
  expect_tetra(
      load_mesh(write("t.obj", tetra_vertices("v ") + "f 1 2 3\nf 1/1 2/2 4/4\nf 1//1 3//3 4//4\nf -3 -2 -1\n")),
      "OBJ");
  expect_tetra(load_mesh(write("t.ply",
                               "ply\nformat ascii 1.0\nelement vertex 4\nproperty double x\nproperty double y\n"
                               "property double z\nelement face 4\nproperty list uchar int vertex_indices\n"
                               "end_header\n" +
                                   tetra_vertices("") + "3 0 1 2\n3 0 1 3\n3 0 2 3\n3 1 2 3\n")),
               "PLY");
  std::string stl = "solid t\n";
  const std::string v[4] = {std::string(kX) + " " + kY + " " + kZ, "1 0 0", "0 1 0", std::string(kW) + " 2 3"};
  for (auto f : {std::array{0, 1, 2}, {0, 1, 3}, {0, 2, 3}, {1, 2, 3}}) {
    stl += "facet normal 0 0 0\nouter loop\n";
    for (int i : f) stl += "vertex " + v[i] + "\n";
    stl += "endloop\nendfacet\n";
  }
  expect_tetra(load_mesh(write("t.stl", stl + "endsolid t\n")), "STL");
}

// Binary PLY in both byte orders: doubles as written, floats widened exactly; a list count in
// a binary face that claims 4·10⁹ indices is refused from the bytes that remain.
std::string ply_bytes(bool big_endian, bool doubles, std::uint32_t list_length) {
  std::string out = std::string("ply\nformat ") + (big_endian ? "binary_big_endian" : "binary_little_endian") +
                    " 1.0\ncomment written by test_meshes\nelement vertex 3\nproperty " +
                    (doubles ? "double" : "float") + " x\nproperty " + (doubles ? "double" : "float") +
                    " y\nproperty " + (doubles ? "double" : "float") +
                    " z\nproperty uchar red\nelement face 1\nproperty list uint uint vertex_indices\nend_header\n";
  auto put = [&](const void* p, std::size_t n) {
    std::string b(static_cast<const char*>(p), n);
    if (big_endian) std::reverse(b.begin(), b.end());  // this test runs on little-endian machines
    out += b;
  };
  const double coords[9] = {0.1, 0, 0, 1, 0, 0, 0, 1, 4.9406564584124654e-320};
  for (int v = 0; v < 3; ++v) {
    for (int k = 0; k < 3; ++k) {
      if (doubles)
        put(&coords[3 * v + k], 8);
      else {
        const float f = static_cast<float>(coords[3 * v + k]);
        put(&f, 4);
      }
    }
    out += '\x07';  // red
  }
  put(&list_length, 4);
  for (std::uint32_t i = 0; i < 3; ++i) put(&i, 4);
  return out;
}

TEST(Meshes, BinaryPlyInBothByteOrders) {
  static_assert(std::endian::native == std::endian::little);
  for (bool big : {false, true}) {
    const Mesh d = load_mesh(write("d.ply", ply_bytes(big, true, 3)));
    ASSERT_EQ(d.triangles.size(), 1u);
    EXPECT_EQ(d.triangles[0].v[0].x(), 0.1) << "big endian " << big;
    EXPECT_EQ(d.triangles[0].v[2].z(), 4.9406564584124654e-320) << "big endian " << big;
    const Mesh f = load_mesh(write("f.ply", ply_bytes(big, false, 3)));
    EXPECT_EQ(f.triangles[0].v[0].x(), static_cast<double>(0.1f)) << "big endian " << big;
    try {
      load_mesh(write("l.ply", ply_bytes(big, true, 4000000000u)));
      ADD_FAILURE() << "a list of 4e9 indices read";
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find(
                    "l.ply: face 0: a list of 4000000000 values is longer than the rest of the file (12 bytes)"),
                std::string::npos)
          << e.what();
    }
  }
}

// Which vertices make each face (issue 23): a reader that mixed up indices but kept the vertex
// set would pass FourFormatsReadToTheSameDoubles. OBJ's negative indices count back from the last
// vertex read *so far* (vertices interleaved with faces); OFF variants (COFF's colours, counts on
// the header line, comments); binary STL, whose float corners widen exactly and whose shared
// corners are one vertex.
void expect_faces(const Mesh& m, const std::vector<std::array<std::uint32_t, 3>>& corners,
                  const std::vector<Vec3>& points, const std::string& format) {
  ASSERT_EQ(m.corners, corners) << format;
  ASSERT_EQ(m.triangles.size(), corners.size()) << format;
  for (std::size_t f = 0; f < corners.size(); ++f)
    for (int k = 0; k < 3; ++k)
      EXPECT_EQ(m.triangles[f].v[k], points[corners[f][k]]) << format << " face " << f << " corner " << k;
}

TEST(Meshes, FaceConnectivityIsTheFilesInEveryFormat) {
  const std::vector<Vec3> p = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(0, 0, 1)};
  expect_faces(
      load_mesh(write("c.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -3 -2 -1\nv 0 0 1\nf 1 -3 -1\nf -1/1/1 -4//2 3\n")),
      {{0, 1, 2}, {0, 1, 3}, {3, 0, 2}}, p, "OBJ");
  expect_faces(load_mesh(write("c.off",
                               "# a comment\nCOFF\n4 3 0\n0 0 0 255 0 0 255\n1 0 0 255 0 0 255\n\n"
                               "0 1 0 255 0 0 255\n0 0 1 255 0 0 255\n3 0 1 2 255 0 0\n3 0 3 1\n3 3 0 2\n")),
               {{0, 1, 2}, {0, 3, 1}, {3, 0, 2}}, p, "COFF");
  expect_faces(load_mesh(write("h.off", "OFF 4 1 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n4 0 1 2 3\n")), {{0, 1, 2}, {0, 2, 3}},
               p, "OFF with counts on the header line, a quad fanned");
  // Binary STL: 80-byte header, a count, 50-byte facets (normal, three corners, attribute).
  std::string stl(80, ' ');
  stl.replace(0, 12, "binary test.");
  auto put = [&](const auto& x) { stl.append(reinterpret_cast<const char*>(&x), sizeof x); };
  put(std::uint32_t{2});
  const float corner[2][3][3] = {{{0, 0, 0}, {1, 0, 0}, {0, 1, 0.1f}}, {{1, 0, 0}, {0, 0, 0}, {0, 0, 1}}};
  for (const auto& facet : corner) {
    for (int k = 0; k < 3; ++k) put(0.0f);
    for (const auto& v : facet)
      for (float x : v) put(x);
    put(std::uint16_t{0});
  }
  const Mesh m = load_mesh(write("b.stl", stl));
  ASSERT_EQ(m.triangles.size(), 2u);
  EXPECT_EQ(m.triangles[0].v[2], Vec3(0, 1, static_cast<double>(0.1f))) << "a float corner widened exactly";
  EXPECT_EQ(m.triangles[1].v[2], Vec3(0, 0, 1));
  EXPECT_EQ(m.corners[0][0], m.corners[1][1]) << "the corner the two facets share is one vertex";
  EXPECT_EQ(m.corners[0][1], m.corners[1][0]);
  EXPECT_EQ(m.vertex_count, 4u);
}

TEST(Meshes, QuadsAreFannedAndPlacementIsInDouble) {
  const Mesh m = load_mesh(write("q.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n"), 0.1, Vec3(3, 0, 0));
  ASSERT_EQ(m.triangles.size(), 2u);
  EXPECT_EQ(m.triangles[0].v[1].x(), 1 * 0.1 + 3.0);
  EXPECT_EQ(m.triangles[1].v[2].y(), 0.1);
  EXPECT_EQ(m.corners[1], (std::array<std::uint32_t, 3>{0, 2, 3}));
}

TEST(Meshes, DegenerateTrianglesAreSkippedAndCountedWithAWarning) {
  write("d.off", "OFF\n4 2 0\n0 0 0\n1 1 1\n2 2 2\n0 1 0\n3 0 1 2\n3 0 1 3\n");
  const Mesh m = load_mesh(test_dir() + "/d.off");
  EXPECT_EQ(m.triangles.size(), 1u);
  EXPECT_EQ(m.degenerate_skipped, 1u);
  const Scene s = parse_scene(R"({"camera": {"eye": [0,0,-1], "look_at": [0,0,0], "up": [0,1,0], "fov_deg": 40,
      "width": 4, "height": 4}, "objects": [{"type": "mesh", "file": "d.off"}]})",
                              test_dir() + "/scene.json");
  ASSERT_EQ(s.warnings.size(), 1u);
  EXPECT_NE(s.warnings[0].find("d.off"), std::string::npos) << s.warnings[0];
}

// Each bad file: the error names the file and (text formats) the line.
// Loading `text` saved as `name` fails with a message holding `expected` (file and line included).
void expect_load_error(const std::string& name, const std::string& text, const std::string& expected) {
  const std::string path = write(name, text);
  try {
    load_mesh(path);
    ADD_FAILURE() << name << ": no error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(expected), std::string::npos) << name << ": " << e.what();
  }
}

struct BadMesh {
  const char* name;
  const char* text;
  const char* expected;  // substring of the message, file and line included
};

TEST(Meshes, BadFilesAreErrorsNamingFileAndLine) {
  const BadMesh cases[] = {
      {"range.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n", "range.off:6: vertex index 7 out of range"},
      {"nan.off", "OFF\n3 1 0\n0 0 0\nnan 0 0\n0 1 0\n3 0 1 2\n", "nan.off:4: coordinate 'nan' is not finite"},
      {"inf.obj", "v 0 0 0\nv 1e999 0 0\nv 0 1 0\nf 1 2 3\n",
       "inf.obj:2: coordinate '1e999' is beyond the double range"},
      {"word.obj", "v 0 0 0\nv 1 zero 0\n", "word.obj:2: expected a number, got 'zero'"},
      {"zero.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n", "zero.obj:4: vertex index 0 out of range"},
      {"short.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n", "short.off:4: file ends after 2 of 3 vertices"},
      {"header.off", "FOO\n", "header.off:1: expected the OFF header"},
      {"empty.obj", "", "empty.obj: the mesh has no non-degenerate triangles"},
      {"mesh.xyz", "1 2 3\n", "mesh.xyz: unknown mesh format 'xyz'"},
      {"bad.ply",
       "ply\nformat ascii 1.0\nelement vertex 1\nproperty double x\nproperty double y\nproperty double z\n"
       "element face 0\nproperty list uchar int vertex_indices\nend_header\nnot-a-number 0 0\n",
       "bad.ply:10: vertex 0 x: expected a number, got 'not-a-number'"},
      // A list count before its data: refused before anything is allocated for it (issue 26).
      {"list.ply",
       "ply\nformat ascii 1.0\nelement vertex 3\nproperty double x\nproperty double y\nproperty double z\n"
       "element face 1\nproperty list uint int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n250000000 0 1 2\n",
       "list.ply:13: face 0: a list of 250000000 values is longer than the rest of the file"},
      {"count.ply",
       "ply\nformat binary_little_endian 1.0\nelement vertex 2000000000\nproperty float x\nproperty float y\n"
       "property float z\nend_header\n",
       "count.ply: the header's element counts need at least 24000000000 bytes"},
      {"two.ply",
       "ply\nformat ascii 1.0\nelement vertex 3\nproperty double x\nproperty double y\nproperty double z\n"
       "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n2 0 1\n",
       "two.ply:13: face 0 has 2 vertices (a face needs at least 3)"},
      {"noz.ply",
       "ply\nformat ascii 1.0\nelement vertex 3\nproperty double x\nproperty double y\n"
       "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0\n1 0\n0 1\n3 0 1 2\n",
       "noz.ply: the vertex element has no 'z' property"},
      {"env.off", "SECRET=hunter2\n", "env.off:1: expected the OFF header (not an OFF file"},
      {"range.ply",
       "ply\nformat ascii 1.0\nelement vertex 3\nproperty double x\nproperty double y\nproperty double z\n"
       "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 9\n",
       "range.ply:13: face 0: vertex index 9 out of range (3 vertices)"},
  };
  for (const BadMesh& c : cases) expect_load_error(c.name, c.text, c.expected);
  try {
    load_mesh("/dev/zero");
    ADD_FAILURE() << "/dev/zero: no error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("/dev/zero: not a regular file"), std::string::npos) << e.what();
  }
  try {
    load_mesh(test_dir() + "/missing.off");
    ADD_FAILURE() << "missing file: no error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("missing.off: cannot open mesh file"), std::string::npos) << e.what();
  }
}

// Issue 42: what CGAL's STL reader and a float-to-integer cast let through, and messages that
// said the wrong thing.
TEST(Meshes, HostileFilesRoundFour) {
  const std::string ply_head =
      "ply\nformat ascii 1.0\nelement vertex 3\nproperty double x\nproperty double y\nproperty double z\n"
      "element face 1\nproperty list uchar float vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n";
  auto binary_stl = [](std::uint32_t header_count, int triangles, float poison) {
    std::string b(80, ' ');
    b.append(reinterpret_cast<const char*>(&header_count), 4);
    for (int t = 0; t < triangles; ++t) {
      const float f[12] = {0, 0, 1, 0, 0, 0, poison, 0, float(t), 0, 1, float(t)};
      b.append(reinterpret_cast<const char*>(f), sizeof f);
      b.append(2, '\0');
    }
    return b;
  };
  struct Bad {
    std::string name, text, expected;
  };
  const Bad cases[] = {
      {"inf.ply", ply_head + "3 0 1 inf\n", "inf.ply:13: face 0: vertex index inf is not an index"},
      {"big.ply", ply_head + "3 0 1 1e20\n", "big.ply:13: face 0: vertex index 1.0000000200408773e+20 is not an index"},
      {"tiny.obj", "v 0 0 0\nv 1e-400 0 0\n", "tiny.obj:2: coordinate '1e-400' underflows to zero in double"},
      {"nan.stl",
       "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex nan 0 0\nvertex 0 1 0\n"
       "endloop\nendfacet\nendsolid t\n",
       "nan.stl:5: coordinate 'nan' is not finite"},
      {"nanb.stl", binary_stl(1, 1, NAN), "nanb.stl: triangle 0, corner 1: coordinate 0 is not finite"},
      {"count.stl", binary_stl(1, 2, 1),
       "count.stl: binary STL header says 1 triangles (134 bytes), but the file has 184"},
      {"zero.stl", binary_stl(0, 0, 1), "zero.stl: binary STL with 0 triangles"},
      {"empty.stl", "", "empty.stl: empty file"},
      {"short.stl", std::string(40, 'x'), "short.stl: truncated binary STL: 40 bytes"},
      {"open.stl", "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\n",
       "open.stl:6: truncated: a facet with 2 of 3 vertices"},
      {"noend.stl", "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\n",
       "noend.stl:7: truncated ASCII STL: no endsolid"},
  };
  for (const Bad& c : cases) expect_load_error(c.name, c.text, c.expected);
  // A binary file whose header starts with "solid" is still binary (its size decides), and two
  // triangles with a shared corner share a vertex.
  std::string solid_header = binary_stl(2, 2, 1);
  solid_header.replace(0, 5, "solid");
  const Mesh m = load_mesh(write("solid-binary.stl", solid_header));
  EXPECT_EQ(m.triangles.size(), 2u);
  EXPECT_EQ(m.corners[0][0], m.corners[1][0]);
}

TEST(Meshes, SceneMeshObjectsResolvePathsAndRejectUnknownKeys) {
  write("m.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
  const std::string camera =
      R"("camera": {"eye": [0,0,-1], "look_at": [0,0,0], "up": [0,1,0], "fov_deg": 40, "width": 4, "height": 4})";
  const Scene s = parse_scene(
      "{" + camera + R"(, "objects": [{"type": "mesh", "file": "m.obj", "scale": 2, "translate": [0, 0, 0.5]}]})",
      test_dir() + "/s.json");
  ASSERT_TRUE(s.objects[0].mesh);
  EXPECT_EQ(s.objects[0].mesh->triangles[0].v[1], Vec3(2, 0, 0.5));
  try {
    parse_scene("{" + camera + R"(, "objects": [{"type": "mesh", "file": "m.obj", "colour": [1, 0, 0]}]})",
                test_dir() + "/s.json");
    ADD_FAILURE() << "unknown key accepted";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("colour"), std::string::npos) << e.what();
  }
  try {
    parse_scene("{" + camera + R"(, "objects": [{"type": "mesh", "file": "nope.off"}]})", test_dir() + "/s.json");
    ADD_FAILURE() << "missing mesh accepted";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("nope.off: cannot open mesh file (objects[0].file)"), std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace rayproof
