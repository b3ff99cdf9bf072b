// The certified variants: the oracle's filtered front end offered as an intersector, one per
// shape (certified-sphere, …). The semi-static filter answers; where it cannot decide, the exact
// stages do; the class is always the oracle's and t the correctly rounded one. Users who need
// certainty see its price on the trade plot beside the formulas they know.
#pragma once

#include "rayproof/core/variants.h"

namespace rayproof {

// The oracle's answer as a Hit (a tangent without t has t = NaN). One oracle per thread.
Hit certified_intersect(const Ray& ray, const Shape& shape, HitRule rule);

// Registers certified-sphere, certified-plane, certified-triangle and certified-box (once).
void register_certified_variants();

}  // namespace rayproof
