#include "rayproof/core/offset.h"

#include <cmath>
#include <cstdint>
#include <cstring>

#include "rayproof/core/fp.h"

namespace rayproof {

Vec3 offset_by_error_bound(const Ray& r, double t, const Vec3& p, const Vec3& n) {
  Vec3 error;
  for (int i = 0; i < 3; ++i)
    error[i] = gamma(2) * std::abs(p[i]) + gamma(1) * std::abs(r.origin[i]) + gamma(8) * std::abs(t * r.direction[i]);
  const double d = std::abs(n.x()) * error.x() + std::abs(n.y()) * error.y() + std::abs(n.z()) * error.z();
  Vec3 out = p + d * n;
  for (int i = 0; i < 3; ++i) {
    if (n[i] > 0) out[i] = next_up(out[i]);
    if (n[i] < 0) out[i] = next_down(out[i]);
  }
  return out;
}

Vec3 offset_by_ulps(const Vec3& p, const Vec3& n) {
  constexpr double kOrigin = 1.0 / 32, kFloatScale = 0x1p-16 * 0x1p-29;
  constexpr std::int64_t kIntScale = 256;
  Vec3 out;
  for (int i = 0; i < 3; ++i) {
    if (std::abs(p[i]) < kOrigin) {  // near zero ulps vanish: a fixed step (the bits of ±0 must not be moved)
      out[i] = p[i] + kFloatScale * n[i];
      continue;
    }
    const std::int64_t of = static_cast<std::int64_t>(kIntScale * n[i]);
    std::int64_t bits;
    std::memcpy(&bits, &p[i], sizeof bits);
    bits += (p[i] < 0) ? -of : of;
    std::memcpy(&out[i], &bits, sizeof bits);
  }
  return out;
}

Vec3 offset_by_ulps_f32(const Vec3& p, const Vec3& n) {
  constexpr float kOrigin = 1.0f / 32, kFloatScale = 1.0f / 65536, kIntScale = 256;
  Vec3 out;
  for (int i = 0; i < 3; ++i) {
    const float pf = to_nearest_float(p[i]), nf = to_nearest_float(n[i]);
    if (std::abs(pf) < kOrigin) {  // near zero ulps vanish: a fixed step (the bits of ±0 must not be moved)
      out[i] = pf + kFloatScale * nf;
      continue;
    }
    const std::int32_t of = static_cast<std::int32_t>(kIntScale * nf);  // |n| <= 1: within range
    std::int32_t bits;
    std::memcpy(&bits, &pf, sizeof bits);
    bits += (pf < 0) ? -of : of;
    float moved;
    std::memcpy(&moved, &bits, sizeof moved);
    out[i] = moved;
  }
  return out;
}

Vec3 spawn_origin(const Ray& primary, double t, const Vec3& p, const Vec3& n, Precision precision) {
  if (precision == Precision::f64) return offset_by_error_bound(primary, t, p, n);
  Vec3 pf;
  const float tf = to_nearest_float(t);
  for (int k = 0; k < 3; ++k) pf[k] = to_nearest_float(primary.origin[k]) + tf * to_nearest_float(primary.direction[k]);
  return offset_by_ulps_f32(pf, n);
}

}  // namespace rayproof
