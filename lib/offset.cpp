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
    if (n[i] > 0) out[i] = std::nextafter(out[i], INFINITY);
    if (n[i] < 0) out[i] = std::nextafter(out[i], -INFINITY);
  }
  return out;
}

Vec3 offset_by_ulps(const Vec3& p, const Vec3& n) {
  constexpr double kOrigin = 1.0 / 32, kFloatScale = 0x1p-16 * 0x1p-29;
  constexpr std::int64_t kIntScale = 256;
  Vec3 out;
  for (int i = 0; i < 3; ++i) {
    const std::int64_t of = static_cast<std::int64_t>(kIntScale * n[i]);
    std::int64_t bits;
    std::memcpy(&bits, &p[i], sizeof bits);
    bits += (p[i] < 0) ? -of : of;
    double moved;
    std::memcpy(&moved, &bits, sizeof moved);
    out[i] = std::abs(p[i]) < kOrigin ? p[i] + kFloatScale * n[i] : moved;
  }
  return out;
}

}  // namespace rayproof
