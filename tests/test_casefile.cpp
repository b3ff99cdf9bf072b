// Case files: exact number round trips, and clear per-line errors for bad input.
#include <gtest/gtest.h>
#include <unistd.h>

#include "test_dir.h"

#include <cfloat>
#include <cmath>
#include <cstring>
#include <fstream>
#include <random>

#include "rayproof/core/casefile.h"
#include "rayproof/core/mesh_case.h"

namespace rayproof {
namespace {

std::uint64_t bits(double x) {
  std::uint64_t b;
  std::memcpy(&b, &x, sizeof b);
  return b;
}

std::vector<double> interesting_doubles() {
  std::vector<double> v = {0.0,
                           -0.0,
                           1.0,
                           -1.0,
                           0.1,
                           1e-300,
                           DBL_MAX,
                           -DBL_MAX,
                           DBL_MIN,
                           -DBL_MIN,
                           DBL_TRUE_MIN,
                           -DBL_TRUE_MIN,
                           std::nextafter(DBL_MIN, 0.0),
                           9007199254740993.0,
                           9007199254740992.0,
                           123456789.0,
                           0.5,
                           1e22,
                           1e23};
  std::mt19937_64 rng(42);
  for (int i = 0; i < 20000; ++i) {
    double x;
    const std::uint64_t b = rng();
    std::memcpy(&x, &b, sizeof x);
    if (std::isfinite(x)) v.push_back(x);
  }
  std::uniform_real_distribution<double> u(-100, 100);
  for (int i = 0; i < 2000; ++i) v.push_back(u(rng));
  return v;
}

TEST(HexFloat, EveryFiniteDoubleRoundTripsBitForBit) {
  for (double x : interesting_doubles()) {
    const std::string hex = hex_double(x);
    const auto back = parse_hex_double(hex);
    ASSERT_TRUE(back.has_value()) << hex;
    EXPECT_EQ(bits(*back), bits(x)) << hex;
    // And through the JSON writer, which may choose a short decimal instead.
    const json j = exact_json_number(x);
    EXPECT_EQ(bits(read_number(json::parse(j.dump()), "x")), bits(x)) << j.dump();
  }
}

TEST(HexFloat, GrammarIsStrict) {
  EXPECT_EQ(*parse_hex_double("0x1.8p+1"), 3.0);
  EXPECT_EQ(*parse_hex_double("-0X1P-2"), -0.25);
  EXPECT_EQ(*parse_hex_double("0x.8p0"), 0.5);
  EXPECT_TRUE(std::signbit(*parse_hex_double("-0x0p+0")));
  for (const char* bad :
       {"0x1.8", "1.5", " 0x1p1", "0x1p1 ", "0xp1", "0x1p", "0x1.8e+1", "nan", "inf", "0x1p+1x", "", "++0x1p1"})
    EXPECT_FALSE(parse_hex_double(bad).has_value()) << bad;
  EXPECT_TRUE(std::isinf(*parse_hex_double("0x1p+1024")));  // parses, then read_number rejects it
  EXPECT_THROW(read_number(json("0x1p+1024"), "f"), FieldError);
}

TEST(CaseFile, ParsesTheSpecExampleAndRoundTrips) {
  const Case c = parse_case(
      R"({"id": "tangent-unit", "ray": {"origin": [-2, 1, 0], "direction": [1, 0, 0]},
          "shape": {"type": "sphere", "center": [0, 0, 0], "radius": 1},
          "expect": {"class": "tangent", "t": 2}, "found": {"family": "hand"}})");
  EXPECT_EQ(c.id, "tangent-unit");
  EXPECT_EQ(c.ray.origin, Vec3(-2, 1, 0));
  ASSERT_TRUE(c.expect);
  EXPECT_EQ(c.expect->cls, HitClass::tangent);
  EXPECT_EQ(*c.expect->t, 2.0);
  EXPECT_EQ(c.found["family"], "hand");
  const Case back = parse_case(case_to_json(c).dump());
  EXPECT_EQ(back.ray.origin, c.ray.origin);
  EXPECT_EQ(std::get<Sphere>(back.shape).radius, 1.0);
  EXPECT_EQ(*back.expect->t, 2.0);
}

TEST(CaseFile, RandomCasesRoundTripExactly) {
  std::mt19937_64 rng(7);
  auto rnd = [&] {
    double x;
    do {
      const std::uint64_t b = rng();
      std::memcpy(&x, &b, sizeof x);
    } while (!std::isfinite(x));
    return x;
  };
  for (int i = 0; i < 2000; ++i) {
    Case c;
    c.id = "c" + std::to_string(i);
    c.ray = Ray{Vec3(rnd(), rnd(), rnd()), Vec3(rnd(), rnd(), 1.0)};
    c.shape = Box{Vec3(-1, -2, -0.0), Vec3(rnd() < 0 ? 1 : 2, 3, DBL_TRUE_MIN)};
    const Case back = parse_case(case_to_json(c).dump());
    for (int k = 0; k < 3; ++k) {
      EXPECT_EQ(bits(back.ray.origin[k]), bits(c.ray.origin[k]));
      EXPECT_EQ(bits(back.ray.direction[k]), bits(c.ray.direction[k]));
      EXPECT_EQ(bits(std::get<Box>(back.shape).min[k]), bits(std::get<Box>(c.shape).min[k]));
      EXPECT_EQ(bits(std::get<Box>(back.shape).max[k]), bits(std::get<Box>(c.shape).max[k]));
    }
  }
}

// A finding's line with its mesh formatted once is the line formatted whole, byte for byte, also
// where the case's other fields hold a "mesh" key, the mark's own text or invalid UTF-8.
TEST(CaseFile, MeshCaseTextWithTheMeshGivenIsTheWholeCasesText) {
  MeshCase c;
  auto mesh = std::make_shared<TriangleMesh>();
  mesh->vertices = {0, 0, 0, 1, -0.0, 0x1.23456789abcdep-1000, 0, 1e300, DBL_TRUE_MIN};
  mesh->indices = {0, 1, 2};
  c.mesh = mesh;
  c.id = "x/\x01rayproof-mesh\x01/\xff";
  c.ray = {Ray{Vec3(0.25, 0.25, -1), Vec3(0, 0, 1)}, 0, INFINITY};
  c.all = true;
  c.expect = {{"touched", {0}}, {"mesh", "\x01rayproof-mesh\x01"}};
  c.found = {{"mesh", {{"mesh", nullptr}}}, {"detail", "\"mesh\":\"\\u0001rayproof-mesh\\u0001\""}};
  const std::string whole = json_text(mesh_case_to_json(c));
  EXPECT_EQ(mesh_case_text(c, json_text(mesh_to_json(*c.mesh))), whole);
  EXPECT_EQ(read_mesh_case(parse_json_text(whole)).mesh->vertices, mesh->vertices);
}

// Each bad line must fail with the named field.
struct BadLine {
  const char* text;
  const char* field;
};

TEST(CaseFile, BadInputNamesTheField) {
  const std::string ray = R"("ray": {"origin": [0, 0, 0], "direction": [1, 0, 0]})";
  const std::string sphere = R"("shape": {"type": "sphere", "center": [5, 0, 0], "radius": 1})";
  const std::vector<std::pair<std::string, std::string>> bad = {
      {R"({"id": "a", "ray": {"origin": [0, 0, "nan"], "direction": [1, 0, 0]}, )" + sphere + "}", "ray.origin[2]"},
      {R"({"id": "a", "ray": {"origin": [0, 0, 1e999], "direction": [1, 0, 0]}, )" + sphere + "}", "ray.origin[2]"},
      {R"({"id": "a", "ray": {"origin": [0, 0], "direction": [1, 0, 0]}, )" + sphere + "}", "ray.origin"},
      {R"({"id": "a", "ray": {"origin": [0, 0, 0], "direction": [0, 0, 0]}, )" + sphere + "}", "ray.direction"},
      {R"({"id": "a", "ray": {"origin": [0, 0, 0], "direction": [1, 0, "0x1p+1024"]}, )" + sphere + "}",
       "ray.direction[2]"},
      {R"({"id": "a", )" + ray + R"(, "shape": {"type": "sphere", "center": [5, 0, 0], "radius": -1}})",
       "shape.radius"},
      {R"({"id": "a", )" + ray + R"(, "shape": {"type": "sphere", "center": [5, 0, 0], "radius": 0}})", "shape.radius"},
      {R"({"id": "a", )" + ray + R"(, "shape": {"type": "torus"}})", "shape.type"},
      {R"({"id": "a", )" + ray + R"(, "shape": {"type": "plane", "normal": [0, 0, 0], "offset": 1}})", "shape.normal"},
      {R"({"id": "a", )" + ray + R"(, "shape": {"type": "triangle", "vertices": [[0,0,0],[1,1,1],[3,3,3]]}})",
       "shape.vertices"},
      {R"({"id": "a", )" + ray + R"(, "shape": {"type": "box", "min": [0,0,0], "max": [1,0,1]}})", "shape.max"},
      {R"({"id": "a", )" + ray + ", " + sphere + R"(, "colour": 1})", "colour"},
      {R"({"id": "a", )" + ray + R"(, "shape": {"type": "sphere", "center": [5, 0, 0], "radius": 1, "r": 2}})",
       "shape.r"},
      {R"({"id": "a", )" + ray + ", " + sphere + R"(, "expect": {"class": "hit"}})", "expect.class"},
      {R"({"id": 5, )" + ray + ", " + sphere + "}", "id"},
      {R"({"id": "a", )" + ray + "}", "shape"},
      {R"({"id": "a", )" + ray + ", " + sphere, ""},
      {"[1, 2, 3]", ""},
  };
  for (const auto& [text, field] : bad) {
    try {
      parse_case(text);
      ADD_FAILURE() << "accepted: " << text;
    } catch (const FieldError& e) {
      EXPECT_EQ(e.field, field) << text << " → " << e.what();
      EXPECT_GT(std::strlen(e.what()), 3u);
    }
  }
}

TEST(CaseFile, ErrorsNameFileAndLineAndTheRestIsStillRead) {
  const std::string path = rayproof::testing_support::test_dir() + "/mixed.jsonl";
  {
    std::ofstream out(path);
    out << R"({"id": "good1", "ray": {"origin": [0,0,0], "direction": [1,0,0]}, )"
           R"("shape": {"type": "sphere", "center": [5,0,0], "radius": 1}})"
           "\n";
    out << "not json at all\n\n";
    out << R"({"id": "good1", "ray": {"origin": [0,0,0], "direction": [1,0,0]}, )"
           R"("shape": {"type": "sphere", "center": [5,0,0], "radius": 1}})"
           "\n";
    out << R"({"id": "good2", "ray": {"origin": [0,0,0], "direction": [1,0,0]}, )"
           R"("shape": {"type": "plane", "normal": [1,0,0], "offset": 3}})"
           "\n";
  }
  std::vector<std::string> ids;
  std::vector<CaseError> errors;
  read_case_file(
      path, [&](const Case& c, long) { ids.push_back(c.id); }, [&](const CaseError& e) { errors.push_back(e); });
  EXPECT_EQ(ids, (std::vector<std::string>{"good1", "good2"}));
  ASSERT_EQ(errors.size(), 2u);
  EXPECT_EQ(errors[0].line, 2);
  EXPECT_EQ(errors[1].line, 4);
  EXPECT_EQ(errors[1].field, "id");  // duplicate id
  EXPECT_NE(errors[0].to_string().find("mixed.jsonl:2:"), std::string::npos);
}

}  // namespace
}  // namespace rayproof
