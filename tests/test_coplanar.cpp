// Rays lying in the plane of a triangle of any orientation, built exactly (integer spanning
// vectors, origins as exact dyadic combinations: inside, on edges, at vertices, outside), judged
// by the oracle and by a second classifier that shares none of its code: the barycentric
// coordinates λ_i(t) of o + t·d, each linear in t, computed with 3D cross products in rationals.
// RAYPROOF_COPLANAR_CASES sets the count (default 40,000; the README's figure is 10^6).
#include <gtest/gtest.h>
#include <gmpxx.h>

#include <array>
#include <cmath>
#include <cstdlib>
#include <optional>
#include <random>

#include "rayproof/verify/oracle.h"

namespace rayproof {
namespace {

using Q = mpq_class;
using QV = std::array<Q, 3>;

QV qv(const Vec3& v) { return {Q(v.x()), Q(v.y()), Q(v.z())}; }
QV sub(const QV& a, const QV& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
QV qcross(const QV& a, const QV& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
Q qdot(const QV& a, const QV& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

// The spec's answer for a ray in the triangle's plane: the set {t : all λ_i(o + t·d) ≥ 0} is an
// interval [lo, hi]; contact for every small t > 0 when lo ≤ 0 < hi (tangent, no t); a first
// contact at lo when lo > 0 (tangent at lo); otherwise (empty, or only t ≤ 0) a miss.
struct Truth {
  HitClass cls = HitClass::miss;
  std::optional<Q> t;
};
Truth second_classifier(const Ray& ray, const Triangle& tri) {
  const QV o = qv(ray.origin), d = qv(ray.direction);
  const QV v[3] = {qv(tri.v[0]), qv(tri.v[1]), qv(tri.v[2])};
  const QV n = qcross(sub(v[1], v[0]), sub(v[2], v[0]));
  std::optional<Q> lo, hi;  // unbounded when absent
  for (int i = 0; i < 3; ++i) {
    // λ_i(p) ∝ n·((v_{i+1} − p) × (v_{i+2} − p)), linear in p = o + t·d: a + b·t.
    const QV a1 = sub(v[(i + 1) % 3], o), a2 = sub(v[(i + 2) % 3], o);
    const Q a = qdot(n, qcross(a1, a2));
    const QV minus_d = {-d[0], -d[1], -d[2]};
    const Q b = qdot(n, qcross(minus_d, a2)) + qdot(n, qcross(a1, minus_d));  // the t² term is d × d = 0
    if (b == 0) {
      if (a < 0) return {};
      continue;
    }
    const Q root = -a / b;
    if (b > 0 && (!lo || root > *lo)) lo = root;
    if (b < 0 && (!hi || root < *hi)) hi = root;
  }
  if (lo && hi && *lo > *hi) return {};
  if (hi && *hi <= 0) return {};
  if (!lo || *lo <= 0) return {HitClass::tangent, std::nullopt};
  return {HitClass::tangent, *lo};
}

// Whether x is the double nearest to t (ties: either neighbour's midpoint counts as inside).
bool correctly_rounded(double x, const Q& t) {
  const Q below = (Q(std::nextafter(x, -INFINITY)) + Q(x)) / 2, above = (Q(x) + Q(std::nextafter(x, INFINITY))) / 2;
  return below <= t && t <= above;
}

struct CoplanarCase {
  Ray ray;
  Triangle tri;
  const char* kind;
};

// Triangle P + a_i·s1 + b_i·s2 with integer spanning vectors s1, s2 in a random orientation; the
// origin P + α·s1 + β·s2 with α, β multiples of 1/8 (interior, edge, vertex or outside); the
// direction an integer combination of s1 and s2. Every coordinate is an integer or a multiple of
// 1/8 below 2^40: exact in double, so the ray lies exactly in the plane.
CoplanarCase make_case(std::mt19937_64& rng) {
  std::uniform_int_distribution<int> small(-9, 9), big(-1000, 1000), kind(0, 3);
  Vec3 s1, s2;
  do {
    s1 = Vec3(small(rng), small(rng), small(rng));
    s2 = Vec3(small(rng), small(rng), small(rng));
  } while (cross(s1, s2) == Vec3::Zero());
  const Vec3 p(big(rng), big(rng), big(rng));
  int a1, b1, a2, b2;
  do a1 = small(rng), b1 = small(rng), a2 = small(rng), b2 = small(rng);
  while (a1 * b2 - a2 * b1 == 0);
  const Triangle tri{{p, p + a1 * s1 + b1 * s2, p + a2 * s1 + b2 * s2}};
  // Barycentric (w0, w1, w2) in eighths: the origin's place relative to the triangle.
  std::uniform_int_distribution<int> eighth(0, 8);
  int w1 = eighth(rng), w2 = eighth(rng);
  const int k = kind(rng);
  const char* what = "inside";
  if (k == 0) {  // interior or edge, by chance
    while (w1 + w2 > 8) w1 = eighth(rng), w2 = eighth(rng);
  } else if (k == 1) {  // on an edge
    w2 = 8 - w1;
    what = "edge";
  } else if (k == 2) {  // at a vertex
    const int v = eighth(rng) % 3;
    w1 = v == 1 ? 8 : 0, w2 = v == 2 ? 8 : 0;
    what = "vertex";
  } else {  // outside, up to a triangle's width away
    w1 = small(rng) + 4, w2 = 12 - w1 + small(rng) % 3;
    what = "outside";
  }
  const double alpha = (w1 * a1 + w2 * a2) / 8.0, beta = (w1 * b1 + w2 * b2) / 8.0;
  const Vec3 origin = p + alpha * s1 + beta * s2;
  Vec3 d = Vec3::Zero();
  if (k == 3 && rng() % 2 == 0) {  // from outside toward a point of the triangle (in eighths)
    int t1 = eighth(rng), t2 = eighth(rng);
    while (t1 + t2 > 8) t1 = eighth(rng), t2 = eighth(rng);
    const double c1 = (t1 - w1) * a1 + (t2 - w2) * a2, c2 = (t1 - w1) * b1 + (t2 - w2) * b2;  // 8·(target − origin)
    d = c1 * s1 + c2 * s2;
  }
  while (d == Vec3::Zero()) d = small(rng) * s1 + small(rng) * s2;
  return {Ray{origin, d}, tri, what};
}

TEST(OracleCoplanar, AgreesWithAnIndependentClassifierInEveryOrientation) {
  const char* env = std::getenv("RAYPROOF_COPLANAR_CASES");
  const long count = env ? std::atol(env) : 40000;
  std::mt19937_64 rng(20261129);
  Oracle oracle;
  long disagreements = 0, tangent_without_t = 0, tangent_with_t = 0, misses = 0;
  long by_axis[3] = {};
  for (long i = 0; i < count; ++i) {
    const CoplanarCase c = make_case(rng);
    const Vec3 n = cross(c.tri.v[1] - c.tri.v[0], c.tri.v[2] - c.tri.v[0]);  // small integers: exact
    int drop = 0;
    for (int a = 1; a < 3; ++a)
      if (std::abs(n[a]) > std::abs(n[drop])) drop = a;
    ++by_axis[drop];
    const Truth truth = second_classifier(c.ray, c.tri);
    const Verdict v = oracle.judge(c.ray, c.tri);
    const bool same =
        v.cls == truth.cls && v.t.has_value() == truth.t.has_value() && (!v.t || correctly_rounded(*v.t, *truth.t));
    if (!same && ++disagreements <= 5)
      ADD_FAILURE() << "case " << i << " (" << c.kind << ", normal's largest axis " << drop << "): oracle "
                    << to_string(v.cls) << (v.t ? " with t" : " without t") << ", second classifier "
                    << to_string(truth.cls) << (truth.t ? " with t" : " without t");
    if (truth.cls == HitClass::miss)
      ++misses;
    else if (truth.t)
      ++tangent_with_t;
    else
      ++tangent_without_t;
  }
  EXPECT_EQ(disagreements, 0);
  // The generator reaches every answer and every projection axis.
  EXPECT_GT(tangent_without_t, count / 10);
  EXPECT_GT(tangent_with_t, count / 20);
  EXPECT_GT(misses, count / 20);
  for (long n : by_axis) EXPECT_GT(n, count / 10);
  std::printf("coplanar: %ld cases, %ld disagreements (tangent without t %ld, with t %ld, miss %ld)\n", count,
              disagreements, tangent_without_t, tangent_with_t, misses);
}

}  // namespace
}  // namespace rayproof
