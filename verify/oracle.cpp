// The exact oracle. See rayproof/oracle.h for the contract; this file is the only place that
// includes CGAL's number types.
#include "rayproof/oracle.h"

#include <CGAL/Exact_rational.h>
#include <CGAL/Interval_nt.h>
#include <mpfr.h>

#include <cfloat>
#include <cmath>
#include <limits>
#include <type_traits>

namespace rayproof {
namespace {

using Interval = CGAL::Interval_nt_advanced;  // needs Protect_FPU_rounding around its use
using Exact = CGAL::Exact_rational;
static_assert(std::is_same_v<Exact, mpq_class>, "build with CGAL_USE_GMPXX: Exact_rational is mpq_class");

// ---------------------------------------------------------------------------------------------
// Vectors over a number type: the same expressions are evaluated in intervals and in rationals.
template <class NT>
struct V {
  NT x, y, z;
  NT operator[](int i) const { return i == 0 ? x : i == 1 ? y : z; }
};
template <class NT>
V<NT> lift(const Vec3& v) {
  return {NT(v.x()), NT(v.y()), NT(v.z())};
}
template <class NT>
V<NT> operator-(const V<NT>& a, const V<NT>& b) {
  return {NT(a.x - b.x), NT(a.y - b.y), NT(a.z - b.z)};
}
template <class NT>
NT dot(const V<NT>& a, const V<NT>& b) {
  return NT(a.x * b.x + a.y * b.y + a.z * b.z);
}
template <class NT>
V<NT> cross(const V<NT>& a, const V<NT>& b) {
  return {NT(a.y * b.z - a.z * b.y), NT(a.z * b.x - a.x * b.z), NT(a.x * b.y - a.y * b.x)};
}

// The sign of x, or nullopt when an interval straddles zero.
std::optional<int> sign_of(const Interval& x) {
  const auto s = CGAL::sign(x);
  if (!CGAL::is_certain(s)) return std::nullopt;
  return static_cast<int>(CGAL::get_certain(s));
}
std::optional<int> sign_of(const Exact& x) { return sgn(x); }

// What a classification decided, before the rule and before t is rounded. `t_source` names
// which exact expression is the contact parameter; it is built from exact terms only.
struct Decision {
  HitClass cls = HitClass::miss;
  bool front = false;
  int t_source = -1;  // shape-specific; −1: no t
};

// ---------------------------------------------------------------------------------------------
// Sphere: with f = o − m, a = d·d, b′ = −f·d, c = f·f − r², D′ = b′² − a·c, the roots are
// t = (b′ ∓ √D′)/a. Their signs follow from the signs of D′, b′ and c alone:
// both roots positive ⇔ c > 0 ∧ b′ > 0; one positive ⇔ c < 0; a zero root ⇔ c = 0.
template <class NT>
struct SphereTerms {
  NT a, b, c, disc;  // b = b′
};
template <class NT>
SphereTerms<NT> sphere_terms(const Ray& ray, const Sphere& s) {
  const V<NT> f = lift<NT>(ray.origin) - lift<NT>(s.center);
  const V<NT> d = lift<NT>(ray.direction);
  SphereTerms<NT> t;
  t.a = dot(d, d);
  t.b = -dot(f, d);
  t.c = NT(dot(f, f) - NT(s.radius) * NT(s.radius));
  t.disc = NT(t.b * t.b - t.a * t.c);
  return t;
}
enum SphereT { kTangentRoot, kNearRoot, kFarRoot, kSecondRootAtOrigin };

template <class NT>
std::optional<Decision> decide_sphere(const SphereTerms<NT>& t) {
  const auto sd = sign_of(t.disc);
  if (!sd) return std::nullopt;
  if (*sd < 0) return Decision{};
  const auto sb = sign_of(t.b);
  if (!sb) return std::nullopt;
  if (*sd == 0) {  // discriminant exactly zero: one double root b′/a
    if (*sb > 0) return Decision{HitClass::tangent, false, kTangentRoot};
    return Decision{};
  }
  const auto sc = sign_of(t.c);
  if (!sc) return std::nullopt;
  if (*sc > 0) return *sb > 0 ? Decision{HitClass::enter, true, kNearRoot} : Decision{};
  if (*sc == 0) return *sb > 0 ? Decision{HitClass::exit, false, kSecondRootAtOrigin} : Decision{};
  return Decision{HitClass::exit, false, kFarRoot};
}

ExactParameter sphere_parameter(const SphereTerms<Exact>& t, int source) {
  switch (source) {
    case kTangentRoot: return {t.b, 0, t.a, 0};
    case kNearRoot: return {t.b, t.disc, t.a, -1};
    case kFarRoot: return {t.b, t.disc, t.a, +1};
    default: return {Exact(2 * t.b), 0, t.a, 0};  // roots 0 and 2b′/a
  }
}

// ---------------------------------------------------------------------------------------------
// Plane n·x = k: t = (k − n·o)/(n·d).
template <class NT>
struct PlaneTerms {
  NT num, den;
};
template <class NT>
PlaneTerms<NT> plane_terms(const Ray& ray, const Plane& p) {
  const V<NT> n = lift<NT>(p.normal);
  return {NT(NT(p.offset) - dot(n, lift<NT>(ray.origin))), dot(n, lift<NT>(ray.direction))};
}
template <class NT>
std::optional<Decision> decide_plane(const PlaneTerms<NT>& t) {
  const auto sd = sign_of(t.den), sn = sign_of(t.num);
  if (!sd || !sn) return std::nullopt;
  if (*sd == 0) return *sn == 0 ? Decision{HitClass::tangent, false, -1} : Decision{};
  if (*sn != *sd) return Decision{};  // t ≤ 0
  const bool front = *sd < 0;         // arrives against the normal: from the front side
  return Decision{front ? HitClass::enter : HitClass::exit, front, 0};
}

// ---------------------------------------------------------------------------------------------
// Triangle: n = (v1−v0)×(v2−v0), t = n·(v0−o)/(n·d). The line meets the closed triangle iff the
// three triple products e_i = d·((v_i−o)×(v_{i+1}−o)) all have the sign of n·d or are zero
// (their sum is n·d); a zero one puts the hit on an edge, two on a vertex.
template <class NT>
struct TriangleTerms {
  NT num, den;
  NT edge[3];
};
template <class NT>
TriangleTerms<NT> triangle_terms(const Ray& ray, const Triangle& tri) {
  const V<NT> o = lift<NT>(ray.origin), d = lift<NT>(ray.direction);
  const V<NT> v[3] = {lift<NT>(tri.v[0]), lift<NT>(tri.v[1]), lift<NT>(tri.v[2])};
  const V<NT> n = cross(v[1] - v[0], v[2] - v[0]);
  TriangleTerms<NT> t;
  t.den = dot(n, d);
  t.num = dot(n, v[0] - o);
  const V<NT> rel[3] = {v[0] - o, v[1] - o, v[2] - o};
  for (int i = 0; i < 3; ++i) t.edge[i] = dot(d, cross(rel[i], rel[(i + 1) % 3]));
  return t;
}
constexpr int kCoplanar = 1;  // Decision::t_source flag: the ray lies in the triangle's plane

template <class NT>
std::optional<Decision> decide_triangle(const TriangleTerms<NT>& t) {
  const auto sd = sign_of(t.den), sn = sign_of(t.num);
  if (!sd || !sn) return std::nullopt;
  if (*sd == 0) return *sn == 0 ? Decision{HitClass::tangent, false, kCoplanar} : Decision{};
  if (*sn != *sd) return Decision{};  // plane met at t ≤ 0
  bool on_edge = false;
  for (const NT& e : t.edge) {
    const auto se = sign_of(e);
    if (!se) return std::nullopt;
    if (*se == -*sd) return Decision{};
    on_edge = on_edge || *se == 0;
  }
  const bool front = *sd < 0;
  return Decision{on_edge ? HitClass::boundary : front ? HitClass::enter : HitClass::exit, front, 0};
}

// A ray in the triangle's plane, in exact rationals: tangent without t when it runs into the
// closed triangle from an origin on it; tangent at the first edge crossing when it comes from
// outside; otherwise a miss. Worked in the 2D projection that drops n's largest axis.
Verdict coplanar_triangle(const Ray& ray, const Triangle& tri, RoundingStats& rounding) {
  const V<Exact> o = lift<Exact>(ray.origin), d = lift<Exact>(ray.direction);
  const V<Exact> v[3] = {lift<Exact>(tri.v[0]), lift<Exact>(tri.v[1]), lift<Exact>(tri.v[2])};
  const V<Exact> n = cross(v[1] - v[0], v[2] - v[0]);
  int drop = 0;
  for (int i = 1; i < 3; ++i)
    if (abs(n[i]) > abs(n[drop])) drop = i;
  const int ax = (drop + 1) % 3, ay = (drop + 2) % 3;
  auto cross2 = [&](const V<Exact>& a, const V<Exact>& b) { return Exact(a[ax] * b[ay] - a[ay] * b[ax]); };
  const int orient = sgn(n[drop]) * (drop == 1 ? -1 : 1) > 0 ? 1 : -1;  // sign of cross2(e1, e2)
  bool inside_closed = true, moves_inside = true;
  for (int i = 0; i < 3; ++i) {
    const V<Exact> e = v[(i + 1) % 3] - v[i];
    const int side = orient * sgn(cross2(e, o - v[i]));
    if (side < 0) inside_closed = false;
    if (side == 0 && orient * sgn(cross2(e, d)) < 0) moves_inside = false;
  }
  Verdict verdict;
  if (inside_closed) {
    if (moves_inside) verdict.cls = HitClass::tangent;  // meets it for every small t > 0: no t
    return verdict;
  }
  std::optional<Exact> first;
  for (int i = 0; i < 3; ++i) {
    const V<Exact> e = v[(i + 1) % 3] - v[i];
    const Exact den = cross2(d, e);
    if (den == 0) continue;  // parallel edge: its endpoints are found on the two other edges
    const Exact t = cross2(v[i] - o, e) / den;
    const Exact u = cross2(v[i] - o, d) / den;
    if (t > 0 && u >= 0 && u <= 1 && (!first || t < *first)) first = t;
  }
  if (!first) return verdict;
  verdict.cls = HitClass::tangent;
  verdict.exact_t = ExactParameter{*first, 0, 1, 0};
  verdict.t = round_to_nearest(*verdict.exact_t, rounding);
  return verdict;
}

// ---------------------------------------------------------------------------------------------
// Box: the line's parameter interval [t_min, t_max] inside the closed box (slabs of the axes
// where d ≠ 0; an axis with d = 0 keeps the line or loses it). The open interior is met iff
// t_min < t_max and every d = 0 axis has its origin strictly between the planes.
template <class NT>
struct BoxTerms {
  int axes = 0;
  int axis[3];
  NT near[3], far[3];
  bool outside = false;     // some d = 0 axis has the origin outside its slab
  bool on_a_face = false;   // some d = 0 axis has the origin on one of its planes
};
template <class NT>
BoxTerms<NT> box_terms(const Ray& ray, const Box& b) {
  BoxTerms<NT> t;
  for (int i = 0; i < 3; ++i) {
    const double o = ray.origin[i], d = ray.direction[i];
    if (d == 0) {  // exact comparisons of input doubles
      t.outside = t.outside || o < b.min[i] || o > b.max[i];
      t.on_a_face = t.on_a_face || o == b.min[i] || o == b.max[i];
      continue;
    }
    const NT lo = NT(NT(b.min[i]) - NT(o)) / NT(d), hi = NT(NT(b.max[i]) - NT(o)) / NT(d);
    t.axis[t.axes] = i;
    t.near[t.axes] = d > 0 ? lo : hi;
    t.far[t.axes] = d > 0 ? hi : lo;
    ++t.axes;
  }
  return t;
}
// t_source encodes which slab plane gives t: 0..2 the near plane of slab k, 3..5 the far one.
template <class NT>
std::optional<Decision> decide_box(const BoxTerms<NT>& t) {
  if (t.outside) return Decision{};
  int enter_k = 0, leave_k = 0;  // slabs giving t_min (largest near) and t_max (smallest far)
  for (int k = 1; k < t.axes; ++k) {
    const auto sn = sign_of(NT(t.near[k] - t.near[enter_k]));
    const auto sf = sign_of(NT(t.far[k] - t.far[leave_k]));
    if (!sn || !sf) return std::nullopt;
    if (*sn > 0) enter_k = k;
    if (*sf < 0) leave_k = k;
  }
  const NT& t_min = t.near[enter_k];
  const NT& t_max = t.far[leave_k];
  const auto order = sign_of(NT(t_min - t_max)), s_max = sign_of(t_max), s_min = sign_of(t_min);
  if (!order || !s_max || !s_min) return std::nullopt;
  if (*order > 0 || *s_max <= 0) return Decision{};
  if (*order < 0 && !t.on_a_face) {  // the open interior is crossed
    if (*s_min > 0) return Decision{HitClass::enter, true, enter_k};
    return Decision{HitClass::exit, false, 3 + leave_k};  // origin inside or on the boundary
  }
  // Only the boundary is met: at t_min, or for every small t > 0 when t_min ≤ 0.
  return Decision{HitClass::tangent, false, *s_min > 0 ? enter_k : -1};
}

ExactParameter box_parameter(const BoxTerms<Exact>& t, int source) {
  return {source < 3 ? t.near[source] : t.far[source - 3], 0, 1, 0};
}

// ---------------------------------------------------------------------------------------------
// Filtered, then exact: decide with the interval terms when every sign is certain, otherwise
// with exact terms; exact terms are computed at most once, and only when needed.
template <template <class> class Terms, class MakeTerms, class DecideI, class DecideE>
std::pair<Decision, std::optional<Terms<Exact>>> filtered(bool filter, OracleStats& stats, MakeTerms make,
                                                          DecideI decide_interval, DecideE decide_exact) {
  if (filter) {
    std::optional<Decision> d;
    {
      CGAL::Protect_FPU_rounding<true> upward;
      d = decide_interval(make(Interval{}));
    }
    if (d) return {*d, std::nullopt};
  }
  ++stats.class_exact;
  Terms<Exact> exact = make(Exact{});
  return {*decide_exact(exact), std::move(exact)};
}

}  // namespace

// ---------------------------------------------------------------------------------------------
int compare(const ExactParameter& t, const mpq_class& m) {
  // sign((p + s√D)/q − m) = sign(R + s√D) with R = p − m·q, as q > 0.
  const mpq_class r = t.p - m * t.q;
  const int sr = sgn(r);
  if (t.s == 0 || sgn(t.radicand) == 0) return sr;
  if (sr == 0 || sr == t.s) return t.s;  // R and s√D do not oppose each other
  // Opposite signs: |R| against √D, i.e. R² against D.
  const int c = cmp(r * r, t.radicand);
  return c == 0 ? 0 : (c > 0 ? sr : t.s);
}

namespace {

// Lower and upper MPFR bounds of a non-negative quantity (only non-negative terms are ever
// combined, so every operation is monotone and each bound rounds in its own direction).
constexpr mpfr_prec_t kEnclosureBits = 128;
struct Enclosure {
  mpfr_t lo, hi;
  Enclosure() { mpfr_inits2(kEnclosureBits, lo, hi, static_cast<mpfr_ptr>(nullptr)); }
  ~Enclosure() { mpfr_clears(lo, hi, static_cast<mpfr_ptr>(nullptr)); }
  Enclosure(const Enclosure&) = delete;
  void set(const mpq_class& x) {  // x ≥ 0
    mpfr_set_q(lo, x.get_mpq_t(), MPFR_RNDD);
    mpfr_set_q(hi, x.get_mpq_t(), MPFR_RNDU);
  }
};

mpq_class rational_of(double x) { return mpq_class(x); }

// (a + b)/2 as a rational, where b = +inf stands for 2^1024, the next "double" after DBL_MAX.
mpq_class midpoint(double a, double b) {
  mpq_class sum = rational_of(a);
  if (std::isinf(b)) {
    mpz_class two_1024 = 1;
    two_1024 <<= 1024;
    sum += mpq_class(two_1024);
  } else {
    sum += rational_of(b);
  }
  return sum / 2;
}

double even_of(double a, double b) {
  std::uint64_t bits;
  std::memcpy(&bits, &a, sizeof bits);
  return (bits & 1) == 0 ? a : b;
}

}  // namespace

double round_to_nearest(const ExactParameter& t, RoundingStats& stats) {
  ++stats.rounded;
  // 1. A rigorous 128-bit enclosure of |t|, written so that no subtraction cancels:
  //    (|p| + √D)/q when p and s√D have the same sign, else |p² − D| / (q·(|p| + √D)).
  Enclosure mag, root, q;
  int sign;
  q.set(t.q);
  if (t.s == 0) {
    mag.set(abs(t.p));
    sign = sgn(t.p);
    mpfr_div(mag.lo, mag.lo, q.hi, MPFR_RNDD);
    mpfr_div(mag.hi, mag.hi, q.lo, MPFR_RNDU);
  } else {
    root.set(t.radicand);
    mpfr_sqrt(root.lo, root.lo, MPFR_RNDD);
    mpfr_sqrt(root.hi, root.hi, MPFR_RNDU);
    Enclosure abs_p;
    abs_p.set(abs(t.p));
    mpfr_add(root.lo, root.lo, abs_p.lo, MPFR_RNDD);  // |p| + √D
    mpfr_add(root.hi, root.hi, abs_p.hi, MPFR_RNDU);
    if (sgn(t.p) == 0 || sgn(t.p) == t.s) {
      sign = t.s;
      mpfr_div(mag.lo, root.lo, q.hi, MPFR_RNDD);
      mpfr_div(mag.hi, root.hi, q.lo, MPFR_RNDU);
    } else {
      const mpq_class num = t.p * t.p - t.radicand;
      sign = sgn(num) * sgn(t.p);
      mag.set(abs(num));
      mpfr_mul(root.lo, root.lo, q.lo, MPFR_RNDD);
      mpfr_mul(root.hi, root.hi, q.hi, MPFR_RNDU);
      mpfr_div(mag.lo, mag.lo, root.hi, MPFR_RNDD);
      mpfr_div(mag.hi, mag.hi, root.lo, MPFR_RNDU);
    }
  }
  // mpfr_get_d rounds correctly over the whole double range (subnormals, overflow to inf).
  double lo = mpfr_get_d(mag.lo, MPFR_RNDN), hi = mpfr_get_d(mag.hi, MPFR_RNDN);
  if (sign < 0) std::swap(lo, hi), lo = -lo, hi = -hi;
  if (lo == hi && sign != 0) return lo;  // every value in the enclosure rounds to it
  if (sign == 0) return 0.0;

  // 2. The enclosure straddles a rounding boundary: walk to the double whose rounding interval
  //    holds t, deciding each midpoint exactly (ties to even).
  ++stats.exact_fallbacks;
  double x = lo;
  for (int guard = 0; guard < 64; ++guard) {
    if (std::isinf(x)) {
      const double edge = std::copysign(DBL_MAX, x);
      const int c = compare(t, x > 0 ? midpoint(DBL_MAX, x) : -midpoint(DBL_MAX, -x));
      if ((x > 0 && c >= 0) || (x < 0 && c <= 0)) return x;
      x = edge;
      continue;
    }
    const double below = std::nextafter(x, -INFINITY), above = std::nextafter(x, INFINITY);
    const int c_low = compare(t, std::isinf(below) ? -midpoint(DBL_MAX, INFINITY) : midpoint(below, x));
    if (c_low < 0) { x = below; continue; }
    if (c_low == 0) return even_of(below, x);
    const int c_high = compare(t, midpoint(x, above));
    if (c_high > 0) { x = above; continue; }
    if (c_high == 0) return even_of(x, above);
    return x;
  }
  return x;  // unreachable: the enclosure is within a few ulps
}

// ---------------------------------------------------------------------------------------------
namespace {
Verdict apply_rule(Verdict v, HitRule rule) {
  // Enter-only keeps a contact only where the ray enters: an entry, or an edge hit from the front.
  if (rule == HitRule::enter_only &&
      !(v.cls == HitClass::enter || (v.cls == HitClass::boundary && v.front)))
    return Verdict{};
  return v;
}
}  // namespace

Verdict Oracle::judge(const Ray& ray, const Shape& shape, HitRule rule) {
  OracleStats& st = stats_[shape.index()];
  ++st.queries;
  Verdict v;
  auto finish = [&](const Decision& d, auto&& exact_parameter) {
    v.cls = d.cls;
    v.front = d.front;
    if (d.t_source >= 0) {
      v.exact_t = exact_parameter();
      v.t = round_to_nearest(*v.exact_t, st.rounding);
    }
  };
  if (const auto* s = std::get_if<Sphere>(&shape)) {
    auto [d, exact] = filtered<SphereTerms>(
        options_.filter, st, [&](auto nt) { return sphere_terms<decltype(nt)>(ray, *s); },
        [](const auto& t) { return decide_sphere(t); }, [](const auto& t) { return decide_sphere(t); });
    finish(d, [&] { return sphere_parameter(exact ? *exact : sphere_terms<Exact>(ray, *s), d.t_source); });
  } else if (const auto* p = std::get_if<Plane>(&shape)) {
    auto [d, exact] = filtered<PlaneTerms>(
        options_.filter, st, [&](auto nt) { return plane_terms<decltype(nt)>(ray, *p); },
        [](const auto& t) { return decide_plane(t); }, [](const auto& t) { return decide_plane(t); });
    finish(d, [&] {
      const PlaneTerms<Exact> t = exact ? *exact : plane_terms<Exact>(ray, *p);
      return ExactParameter{Exact(t.num / t.den), 0, 1, 0};
    });
  } else if (const auto* tri = std::get_if<Triangle>(&shape)) {
    auto [d, exact] = filtered<TriangleTerms>(
        options_.filter, st, [&](auto nt) { return triangle_terms<decltype(nt)>(ray, *tri); },
        [](const auto& t) { return decide_triangle(t); }, [](const auto& t) { return decide_triangle(t); });
    if (d.cls == HitClass::tangent) {
      v = coplanar_triangle(ray, *tri, st.rounding);
    } else {
      finish(d, [&] {
        const TriangleTerms<Exact> t = exact ? *exact : triangle_terms<Exact>(ray, *tri);
        return ExactParameter{Exact(t.num / t.den), 0, 1, 0};
      });
    }
  } else {
    const Box& b = std::get<Box>(shape);
    auto [d, exact] = filtered<BoxTerms>(
        options_.filter, st, [&](auto nt) { return box_terms<decltype(nt)>(ray, b); },
        [](const auto& t) { return decide_box(t); }, [](const auto& t) { return decide_box(t); });
    finish(d, [&] { return box_parameter(exact ? *exact : box_terms<Exact>(ray, b), d.t_source); });
  }
  return apply_rule(std::move(v), rule);
}

void Oracle::merge_stats(const Oracle& other) {
  for (size_t i = 0; i < stats_.size(); ++i) {
    stats_[i].queries += other.stats_[i].queries;
    stats_[i].class_exact += other.stats_[i].class_exact;
    stats_[i].rounding.rounded += other.stats_[i].rounding.rounded;
    stats_[i].rounding.exact_fallbacks += other.stats_[i].rounding.exact_fallbacks;
  }
}

}  // namespace rayproof
