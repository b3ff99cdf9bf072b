// Moving a secondary ray's origin off the surface it leaves, so that the ray does not meet that
// surface again (self-intersection, "shadow acne"). Used by the renderer's shadow rays and
// measured, with the naive alternatives, by the spawn study (studies/spawn.h).
#pragma once

#include "rayproof/core/geometry.h"

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

}  // namespace rayproof
