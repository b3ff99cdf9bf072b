// A generated case is a pure function of (seed, family, shape, index) — on every compiler. C++
// leaves the order of the operands of one expression to the compiler, so a generator that draws
// two random numbers inside one expression (`Vec3(u(), u(), u())`, `a() * e1 + b() * e2`) builds
// other cases under clang than under GCC, and shards of one campaign built by two compilers would
// disagree. These digests were taken from the GCC build; the clang sanitizer build must give the
// same. A change to a generator that changes its cases changes a digest here, on purpose.
#include <gtest/gtest.h>

#include <cstdint>
#include <cstdio>
#include <string>

#include "rayproof/core/casefile.h"
#include "rayproof/core/mesh_case.h"
#include "rayproof/fuzz/generators.h"
#include "rayproof/fuzz/tracer_families.h"
#include "rayproof/studies/stability.h"
#include "rayproof/verify/certified.h"

namespace rayproof::fuzz {
namespace {

// FNV-1a, 64 bits: enough to tell two case streams apart.
struct Digest {
  std::uint64_t h = 0xcbf29ce484222325ull;
  void add(const std::string& s) {
    for (unsigned char ch : s) h = (h ^ ch) * 0x100000001b3ull;
    h = (h ^ '\n') * 0x100000001b3ull;
  }
  std::string hex() const {
    char buf[17];
    std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(h));
    return buf;
  }
};

// Every number of the case is printed round-trip exactly by the case writer (17 digits).
std::string case_text(const GeneratedCase& g) {
  Case c;
  static_cast<Query&>(c) = g;
  c.id = g.detail;
  return case_to_json(c).dump();
}

std::string family_digest(Family family, Construction construction) {
  Digest d;
  for (ShapeKind shape : {ShapeKind::sphere, ShapeKind::plane, ShapeKind::triangle, ShapeKind::box})
    for (std::uint64_t i = 0; i < 300; ++i) d.add(case_text(generate(family, shape, 20261202, i, construction)));
  return d.hex();
}

std::string tracer_family_digest(TracerFamily family) {
  Digest d;
  for (std::uint64_t m = 0; m < 6; ++m) {
    const MeshWork work = generate_mesh_work(family, 20261202, m, kRaysPerMesh);
    d.add(mesh_to_json(*work.mesh).dump());
    for (std::size_t r = 0; r < work.rays.size(); ++r) d.add(tracer_ray_to_json(work.rays[r]).dump() + work.details[r]);
    d.add(std::to_string(work.log2_translate));
  }
  return d.hex();
}

TEST(Generators, EveryFamilyBuildsTheSameCasesOnEveryCompiler) {
  const struct {
    Family family;
    Construction construction;
    const char* digest;
  } pinned[] = {
      {Family::random, Construction::exact, "d991f8e268d05a5c"},
      {Family::tangent, Construction::exact, "455929ed5b82e114"},
      {Family::tangent, Construction::full, "0aebd73bb42f59f8"},
      {Family::grazing, Construction::exact, "b4a80bb8d29f4b1c"},
      {Family::grazing, Construction::full, "67eaa693c0929dce"},
      {Family::near_origin, Construction::exact, "bd8dca6e054f405c"},
      {Family::exit_entry, Construction::exact, "8772e5b678e672a5"},
      {Family::exit_entry, Construction::full, "66da17f49e8d1a91"},
      {Family::extremes, Construction::exact, "1980992c1180b2ff"},
      {Family::extremes, Construction::full, "6ba45ffff5fae472"},
  };
  for (const auto& p : pinned)
    EXPECT_EQ(family_digest(p.family, p.construction), p.digest) << family_label(p.family, p.construction);
}

// The CLI registers the oracle's certified variants before any command (cmd/main.cpp) and users
// register their own; neither may change a case (issue 41: near-origin spawned from the live
// registry, so `rayproof fuzz` and the installed library wrote different cases under one id). The
// registering runs in a child process, so the rest of this binary sees the built-ins alone.
TEST(GeneratorsDeathTest, RegisteringVariantsChangesNoFamilysCases) {
  std::vector<std::string> before;
  for (Family f : kAllFamilies)
    for (Construction c : {Construction::exact, Construction::full}) before.push_back(family_digest(f, c));
  EXPECT_EXIT(
      {
        register_certified_variants();
        for (ShapeKind shape : {ShapeKind::sphere, ShapeKind::plane, ShapeKind::triangle, ShapeKind::box}) {
          const Variant& builtin = default_variant(shape);
          Variant extra = builtin;
          static std::string names[4];
          names[static_cast<int>(shape)] = "registered-first-" + std::string(to_string(shape));
          extra.name = names[static_cast<int>(shape)];
          register_variant(extra);
        }
        std::size_t k = 0;
        for (Family f : kAllFamilies)
          for (Construction c : {Construction::exact, Construction::full})
            if (family_digest(f, c) != before[k++]) std::exit(1);
        std::exit(0);
      },
      ::testing::ExitedWithCode(0), "");
}

TEST(Generators, EveryTracerFamilyBuildsTheSameMeshesOnEveryCompiler) {
  const struct {
    TracerFamily family;
    const char* digest;
  } pinned[] = {
      {TracerFamily::shared_edges, "f5d0e20b12541ef1"}, {TracerFamily::fans, "b872b33a29a83d28"},
      {TracerFamily::axis_planes, "f50d2511b819bcfc"},  {TracerFamily::needles, "41667beab085d3c9"},
      {TracerFamily::spawned, "a7d7959a355ba502"},      {TracerFamily::shells, "da3d8012241ea675"},
      {TracerFamily::far, "2d5ff8861fdd6066"},          {TracerFamily::random, "a901ee6b81978bea"},
  };
  for (const auto& p : pinned) EXPECT_EQ(tracer_family_digest(p.family), p.digest) << to_string(p.family);
}

TEST(Generators, StabilityCellsAreTheSameOnEveryCompiler) {
  const char* pinned[] = {"3ec7f11d1b11efa7", "a692b75ef1c52347", "ce918b4791d14bad", "8cef5629b0b69685"};
  for (ShapeKind shape : {ShapeKind::sphere, ShapeKind::plane, ShapeKind::triangle, ShapeKind::box}) {
    Digest d;
    for (int a : {-200, 0, 180})
      for (int b : {-100, 0, 200})
        for (std::uint64_t i = 0; i < 50; ++i) {
          const Query q = studies::stability_query(shape, a, b, 1, i);
          d.add(case_text(GeneratedCase{q.ray, q.shape, "cell"}));
        }
    EXPECT_EQ(d.hex(), pinned[static_cast<int>(shape)]) << to_string(shape);
  }
}

}  // namespace
}  // namespace rayproof::fuzz
