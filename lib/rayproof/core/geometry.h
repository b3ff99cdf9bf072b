// Vectors and rays of the double kernel.
//
// Storage is Eigen's Vector3d, but every product a variant depends on is written out here in
// a fixed order: Eigen may vectorise or fuse (pmadd → FMA) dot and cross products, which would
// make a variant's answer depend on the compiler flags of the machine that built it.
#pragma once

#include <Eigen/Core>
#include <cmath>

namespace rayproof {

using Vec3 = Eigen::Vector3d;

// Three coordinates over another number type: float in the variants' float twins
// (lib/variants.cpp), intervals and rationals in the oracle's stages (verify/oracle.cpp). One
// template; the arithmetic on it is written beside each use, in the fixed order that use's
// results depend on (the float twins mirror the double formulas operation by operation; the
// oracle evaluates one expression in several number types). Eigen is not used for these: its
// expression templates reorder and vectorise.
template <class T>
struct Vec3Of {
  T x, y, z;
  const T& operator[](int i) const { return i == 0 ? x : i == 1 ? y : z; }
};

// a·b summed left to right: x, then y, then z.
inline double dot(const Vec3& a, const Vec3& b) { return a.x() * b.x() + a.y() * b.y() + a.z() * b.z(); }

inline Vec3 cross(const Vec3& a, const Vec3& b) {
  return Vec3(a.y() * b.z() - a.z() * b.y(), a.z() * b.x() - a.x() * b.z(), a.x() * b.y() - a.y() * b.x());
}

inline double length(const Vec3& a) { return std::sqrt(dot(a, a)); }
inline Vec3 normalized(const Vec3& a) { return a / length(a); }
inline bool all_finite(const Vec3& a) { return std::isfinite(a.x()) && std::isfinite(a.y()) && std::isfinite(a.z()); }
// (Two-argument max, not the initializer-list form, which GCC keeps as an out-of-line loop: the
// oracle's static filters call this on every query. The same comparisons in the same order.)
inline double max_abs(const Vec3& a) { return std::max(std::max(std::abs(a.x()), std::abs(a.y())), std::abs(a.z())); }

// The ray o + t·d for t > 0. The direction is kept exactly as given: t is measured in units of
// the user's direction, never of a renormalised one.
struct Ray {
  Vec3 origin;
  Vec3 direction;
  Vec3 at(double t) const {
    return Vec3(origin.x() + t * direction.x(), origin.y() + t * direction.y(), origin.z() + t * direction.z());
  }
};

}  // namespace rayproof
