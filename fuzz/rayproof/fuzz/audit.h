// Judging your own intersection function from your own tests (the installed C++ API):
//
//   Hit my_sphere(const rayproof::Ray&, const rayproof::Sphere&);
//   EXPECT_THAT(rayproof::audit(my_sphere, {.families = "tangent,grazing", .count = 100000}),
//               rayproof::HasNoWrongClass());          // matchers: rayproof/fuzz/testing.h
//
// The function runs in this process on generated cases (fuzz/generators.h) or a case file, each
// answer judged by the exact oracle as `check` judges a variant; disagreements are shrunk.
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <string>
#include <type_traits>
#include <vector>

#include "rayproof/core/casefile.h"
#include "rayproof/core/variants.h"
#include "rayproof/verify/tally.h"

namespace rayproof {

struct AuditOptions {
  std::string families = "all";  // comma separated: random, tangent, grazing, near-origin, exit-entry, extremes
  std::uint64_t count = 10000;   // cases per family
  std::uint64_t seed = 1;
  HitRule rule = HitRule::nearest_contact;  // the contact your function reports
  Precision precision = Precision::f64;     // f32: your function is given float-rounded cases
  std::size_t keep = 5;                     // disagreements kept (shrunk) in the report
  std::string name = "yours";               // how the report names your function
  std::string shape;                        // for a function of `const Shape&`: which shape to generate
};

struct AuditReport {
  std::string name;
  ShapeKind shape = ShapeKind::sphere;
  Tally total;
  std::map<std::string, Tally> by_family;  // by family, or by file name for a case file
  std::vector<Case> findings;              // the first `keep` disagreements, shrunk, `expect` the exact verdict
  // A table of the tallies and the findings as case lines: what a failing test prints.
  std::string summary() const;
};

using UserIntersector = std::function<Hit(const Ray&, const Shape&)>;
AuditReport audit_function(const UserIntersector& fn, ShapeKind shape, const AuditOptions& options = {});
AuditReport audit_case_file(const UserIntersector& fn, ShapeKind shape, const std::string& path,
                            const AuditOptions& options = {});

namespace detail {
template <class F, class S>
constexpr bool takes = std::is_invocable_r_v<Hit, F, const Ray&, const S&>;

// The shape a callable's second parameter names, and the callable erased to UserIntersector.
template <class F>
std::pair<ShapeKind, UserIntersector> erase(F fn, const std::string& shape_option) {
  if constexpr (takes<F, Shape>) {
    const auto k = shape_kind_from_string(shape_option);
    if (!k)
      throw std::invalid_argument(
          "rayproof::audit: a function of const Shape& needs options.shape (sphere, plane, triangle or box)");
    return {*k, [fn](const Ray& r, const Shape& s) { return fn(r, s); }};
  } else if constexpr (takes<F, Sphere>) {
    return {ShapeKind::sphere, [fn](const Ray& r, const Shape& s) { return fn(r, std::get<Sphere>(s)); }};
  } else if constexpr (takes<F, Plane>) {
    return {ShapeKind::plane, [fn](const Ray& r, const Shape& s) { return fn(r, std::get<Plane>(s)); }};
  } else if constexpr (takes<F, Triangle>) {
    return {ShapeKind::triangle, [fn](const Ray& r, const Shape& s) { return fn(r, std::get<Triangle>(s)); }};
  } else {
    static_assert(takes<F, Box>,
                  "rayproof::audit takes a callable Hit(const Ray&, const Sphere|Plane|Triangle|Box|Shape&)");
    return {ShapeKind::box, [fn](const Ray& r, const Shape& s) { return fn(r, std::get<Box>(s)); }};
  }
}
}  // namespace detail

// Your function on generated cases of the families asked for.
template <class F>
AuditReport audit(F fn, const AuditOptions& options = {}) {
  const auto [shape, erased] = detail::erase(fn, options.shape);
  return audit_function(erased, shape, options);
}
// Your function on the cases of a case file (docs/spec/cases.md) of its shape.
template <class F>
AuditReport audit_file(F fn, const std::string& case_file, const AuditOptions& options = {}) {
  const auto [shape, erased] = detail::erase(fn, options.shape);
  return audit_case_file(erased, shape, case_file, options);
}

}  // namespace rayproof
