// Moving a secondary ray's origin off the surface it leaves, so that the ray does not meet that
// surface again (self-intersection, "shadow acne"). Used by the renderer's shadow rays and
// measured, with the naive alternatives, by the spawn study (studies/spawn.h).
#pragma once

#include "rayproof/core/geometry.h"
#include "rayproof/core/variants.h"

namespace rayproof {

// pbrt-v4's OffsetRayOrigin: p = primary.at(t) pushed along the unit normal n (on the side the new
// ray leaves by) by the projection of p's rounding-error bound, then each coordinate rounded one
// more double away. The bound for p = o + t·d assumes t itself within γ(7)·t, which holds for the
// stable formulas and not for a cancelling one.
Vec3 offset_by_error_bound(const Ray& primary, double t, const Vec3& p, const Vec3& n);

// Ray Tracing Gems ch. 6 (Wächter & Binder, "A Fast and Robust Method for Avoiding
// Self-Intersection"): each coordinate moved int_scale ulps along n, or by a tiny fixed amount
// near zero where ulps vanish. The chapter's constants, its float scale moved from float's 24-bit
// to double's 53-bit significand.
Vec3 offset_by_ulps(const Vec3& p, const Vec3& n);

// The same chapter as written, in float: p and n rounded to float, each coordinate moved
// int_scale = 256 float ulps along n, or by n/65536 within 1/32 of zero (the chapter's
// constants). What a float renderer (a GPU's, Embree's) spawns with.
Vec3 offset_by_ulps_f32(const Vec3& p, const Vec3& n);

// Where a renderer computing in `precision` starts a secondary ray from the hit at t of
// `primary` (p = primary.at(t) in double, n facing the side the new ray leaves by): double code
// by pbrt's error bound, float code from the hit point computed in float (o + t·d, every number
// rounded to float) moved by Wächter & Binder's float offset. The renderer's shadow rays, the
// audit's and the spawn study's ulp-offset-f32 strategy all start here.
Vec3 spawn_origin(const Ray& primary, double t, const Vec3& p, const Vec3& n, Precision precision);

}  // namespace rayproof
