// Intersection variants: each is one small named function (sources in variants.cpp) and all
// are reachable by name through one registry, which the command line, the tests and the
// benchmarks enumerate. Adding a variant = one function + one registry row.
#pragma once

#include <span>
#include <string_view>
#include <vector>

#include "rayproof/core/geometry.h"
#include "rayproof/core/hit.h"
#include "rayproof/core/shapes.h"

namespace rayproof {

// Sphere: roots of a t² + b t + c = 0, a = d·d, b = 2 d·(o−m), c = |o−m|² − r².
Hit sphere_textbook(const Ray& ray, const Sphere& s, HitRule rule);
Hit sphere_stable(const Ray& ray, const Sphere& s, HitRule rule);
Hit sphere_stable_fma(const Ray& ray, const Sphere& s, HitRule rule);
Hit sphere_hearn_baker(const Ray& ray, const Sphere& s, HitRule rule);
Hit plane_direct(const Ray& ray, const Plane& p, HitRule rule);
Hit triangle_moller_trumbore(const Ray& ray, const Triangle& tri, HitRule rule);
Hit triangle_watertight(const Ray& ray, const Triangle& tri, HitRule rule);
Hit box_slab(const Ray& ray, const Box& b, HitRule rule);
Hit box_robust_slab(const Ray& ray, const Box& b, HitRule rule);

struct Variant {
  std::string_view name;    // unique over all shapes, e.g. "stable"
  ShapeKind shape;
  std::string_view source;  // paper or formula it follows
  Hit (*intersect)(const Ray&, const Shape&, HitRule);  // type-erased entry point
  bool is_oracle = false;  // the exact oracle's own answer (certified-*): campaigns skip it unless named
};

// Every variant: the built-ins above, then those registered at run time.
std::span<const Variant> all_variants();
// Adds a variant from a higher layer (the oracle's certified front ends, plugins) before any
// command starts; `name`, `source` must outlive the process. Throws on a duplicate name.
const Variant& register_variant(const Variant& v);
const Variant* find_variant(std::string_view name);
std::vector<const Variant*> variants_for(ShapeKind shape);
// The variant the renderer uses for a shape unless told otherwise.
const Variant& default_variant(ShapeKind shape);

}  // namespace rayproof
