// β of a variant's answer (verdicts.md §3): moves of one ray and one shape, each made exact and
// decided by exact_verdict (oracle.h). backward_error.h says how; README ("Bug or rounding?") why.
#include <algorithm>
#include <functional>
#include <cmath>
#include <vector>

#include "rayproof/verify/backward_error.h"
#include "rayproof/verify/compare.h"

namespace rayproof {
namespace {
using Q = mpq_class;
// Moves are computed in long double: only their size matters (each is made exact and decided
// exactly), and 64 bits put a target within 2^-11 of a double ulp, far inside the overshoot.
using LD = long double;
struct L3 {
  LD v[3] = {0, 0, 0};
  LD& operator[](int i) { return v[i]; }
  const LD& operator[](int i) const { return v[i]; }
};
L3 operator+(const L3& a, const L3& b) { return {{a[0] + b[0], a[1] + b[1], a[2] + b[2]}}; }
L3 operator-(const L3& a, const L3& b) { return {{a[0] - b[0], a[1] - b[1], a[2] - b[2]}}; }
L3 operator*(const L3& a, LD s) { return {{a[0] * s, a[1] * s, a[2] * s}}; }
LD dot(const L3& a, const L3& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
LD norm(const L3& a) { return std::sqrt(dot(a, a)); }
L3 cross(const L3& a, const L3& b) {
  return {{a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]}};
}
L3 unit(const L3& a) {
  const LD n = norm(a);
  return n > 0 ? a * (1 / n) : L3{};
}
L3 any_perpendicular(const L3& d) {
  const int k = std::abs(d[0]) <= std::abs(d[1]) && std::abs(d[0]) <= std::abs(d[2]) ? 0
                : std::abs(d[1]) <= std::abs(d[2])                                   ? 1
                                                                                     : 2;
  L3 e;
  e[k] = 1;
  return unit(cross(d, e));
}

// A long double, exactly: its 64-bit significand splits into two doubles (hi + lo exactly). A
// move that came out NaN or infinite (a degenerate direction, an overflow) is no move: 0, so the
// candidate is the query itself, which the exact judge then refuses.
Q exact_ld(LD x) {
  if (!std::isfinite(x)) return 0;
  const double hi = static_cast<double>(x);
  if (!std::isfinite(hi)) return 0;
  return exact_of(hi) + exact_of(static_cast<double>(x - hi));
}
// A double that may have come out NaN or infinite: 0 then (the same reasoning).
Q exact_or_zero(double x) { return std::isfinite(x) ? exact_of(x) : Q(0); }

// The query as the variant saw it, in long double (L3, numbers) and exactly (q0), with S and u.
struct Setting {
  ShapeKind kind = ShapeKind::sphere;
  L3 o, d;
  LD x[kMaxShapeNumbers] = {};
  int count = 0;
  double scale = 0, dn = 0, u = 0;
  // The query exactly, made on first use (most tally verdicts never need a rational).
  const ExactQuery& q0() const {
    if (!exact_) {
      ExactQuery q;
      q.kind = kind;
      for (int k = 0; k < 3; ++k)
        q.origin[k] = exact_of(static_cast<double>(o[k])), q.direction[k] = exact_of(static_cast<double>(d[k]));
      for (int i = 0; i < count; ++i) q.numbers[i] = exact_of(static_cast<double>(x[i]));
      exact_ = std::move(q);
    }
    return *exact_;
  }

 private:
  mutable std::optional<ExactQuery> exact_;
};
Setting setting_of(const Query& seen, Precision p) {
  Setting s;
  double x[kMaxShapeNumbers];
  s.count = shape_numbers(seen.shape, x);
  s.kind = kind_of(seen.shape);
  double scale = max_abs(seen.ray.origin);
  for (int i = 0; i < s.count; ++i) {
    s.x[i] = x[i];
    scale = std::max(scale, std::abs(x[i]));
  }
  for (int k = 0; k < 3; ++k) s.o[k] = seen.ray.origin[k], s.d[k] = seen.ray.direction[k];
  s.scale = scale > 0 ? scale : 0x1p-1022, s.dn = max_abs(seen.ray.direction), s.u = unit_roundoff(p);
  return s;
}

// A moved query in long double, before it is made exact.
struct Moved {
  L3 o, d;
  LD x[kMaxShapeNumbers];
};
Moved unmoved(const Setting& s) {
  Moved m{s.o, s.d, {}};
  std::copy(s.x, s.x + kMaxShapeNumbers, m.x);
  return m;
}
ExactQuery exact_query(const Setting& s, const Moved& m) {
  ExactQuery q;
  q.kind = s.kind;
  for (int k = 0; k < 3; ++k) q.origin[k] = exact_ld(m.o[k]), q.direction[k] = exact_ld(m.d[k]);
  for (int i = 0; i < s.count; ++i) q.numbers[i] = exact_ld(m.x[i]);
  return q;
}

// ε of a moved query: its largest move over what that number may move, exactly, rounded up.
double exact_ulps(const Setting& s, const ExactQuery& q) {
  const Q uS = exact_of(s.u) * exact_of(s.scale), ud = exact_of(s.u) * exact_of(s.dn);
  Q most = 0;
  for (int k = 0; k < 3; ++k) {
    most = std::max(most, Q(abs(q.origin[k] - s.q0().origin[k]) / uS));
    most = std::max(most, Q(abs(q.direction[k] - s.q0().direction[k]) / ud));
  }
  for (int i = 0; i < s.count; ++i) most = std::max(most, Q(abs(q.numbers[i] - s.q0().numbers[i]) / uS));
  return round_up(most);
}

// A candidate move: the whole moved query, and whether the boundary is searched along it (a
// reported edge hit or tangent needs the exact point the move was built for: no search).
// A candidate move: the whole moved query, in long double (made exact only for the witness a
// verdict keeps) or, for the few moves that must be exact (a reported touch), in rationals; and
// whether the boundary is searched along it (a touch needs the exact point it was built for).
struct Candidate {
  Moved m;  // the move, or for an exact one the long double move it stands for (its size)
  // An exact move, made only when tried (rationals cost tens of microseconds; most are never tried).
  std::function<std::optional<ExactQuery>()> make_exact;
  bool search = true;
  double ulps = 0;  // ε of m, rounded up (an exact move's own is computed when it is made)
};

// ε of a long double move, rounded up past its own rounding (a relative 2^-60 covers the
// division and the differences, each within 2^-63).
double ulps_of(const Setting& s, const Moved& m) {
  const LD uS = static_cast<LD>(s.u) * s.scale, ud = static_cast<LD>(s.u) * s.dn;
  LD most = 0;
  for (int k = 0; k < 3; ++k) most = std::max({most, std::abs(m.o[k] - s.o[k]) / uS, std::abs(m.d[k] - s.d[k]) / ud});
  for (int i = 0; i < s.count; ++i) most = std::max(most, std::abs(m.x[i] - s.x[i]) / uS);
  if (!std::isfinite(most)) return std::numeric_limits<double>::infinity();
  return static_cast<double>(most * (1 + 0x1p-60L)) * (1 + 0x1p-52);
}

// q0 + λ·(m − q0) in long double (the witness is whatever this gives, made exact).
Moved along(const Setting& s, const Moved& m, LD lambda) {
  Moved r = m;
  for (int k = 0; k < 3; ++k) {
    r.o[k] = s.o[k] + lambda * (m.o[k] - s.o[k]);
    r.d[k] = s.d[k] + lambda * (m.d[k] - s.d[k]);
  }
  for (int i = 0; i < s.count; ++i) r.x[i] = s.x[i] + lambda * (m.x[i] - s.x[i]);
  return r;
}

// The moved query's numbers as double-doubles (exactly its value), for filtered_class.
SplitQuery split_of(const Setting& s, const Moved& m) {
  SplitQuery q;
  q.kind = s.kind;
  auto put = [&](int i, LD x) {
    q.hi[i] = static_cast<double>(x);
    q.lo[i] = std::isfinite(q.hi[i]) ? static_cast<double>(x - q.hi[i]) : 0;
  };
  for (int k = 0; k < 3; ++k) put(k, m.o[k]), put(3 + k, m.d[k]);
  for (int i = 0; i < kMaxShapeNumbers; ++i) put(6 + i, i < s.count ? m.x[i] : 0);
  return q;
}

// The ray moved so that at parameter tp it passes through T: the move w = T − (o + tp·d) split
// as Δd = w·‖d‖∞/(S + tp·‖d‖∞) and Δo = w − tp·Δd, each using the same share of what it may move
// (backward_error.cpp's move_ray_through, for one shape).
Moved ray_through(const Setting& s, const L3& target, LD tp) {
  tp = std::max<LD>(tp, 0);
  Moved m = unmoved(s);
  const L3 w = target - (s.o + s.d * tp);
  const L3 dd = w * (s.dn / (s.scale + tp * s.dn));
  m.d = s.d + dd;
  m.o = s.o + (w - dd * tp);
  return m;
}
// The same exactly: the moved ray passes through the exact point T at the double tp.
ExactQuery ray_through_exactly(const Setting& s, const ExactVec& target, double tp) {
  ExactQuery q = s.q0();
  const Q tq = exact_or_zero(tp);
  const double share = s.dn / (s.scale + tp * s.dn);
  for (int k = 0; k < 3; ++k) {
    const Q w = target[k] - (s.q0().origin[k] + tq * s.q0().direction[k]);
    const Q dd = exact_or_zero(w.get_d() * share);
    q.direction[k] = s.q0().direction[k] + dd;
    q.origin[k] = s.q0().origin[k] + w - tq * dd;
  }
  return q;
}

struct Candidates {
  const Setting& s;
  std::vector<Candidate> list;
  LD tiny() const { return 0x1p-8L * s.u * s.scale; }  // an overshoot far below any β that matters
  LD tiny_d() const { return 0x1p-8L * s.u * s.dn; }
  void add(const Moved& m) { list.push_back({m, nullptr, true, 0}); }
  // An exact move, and the long double move `about` of about its size (the order of tries).
  void add_exactly(const Moved& about, std::function<std::optional<ExactQuery>()> make) {
    list.push_back({about, std::move(make), false, 0});
  }
  // The line mirrored through the point e (where it passes the line at tp): it passes as far
  // on the other side, plus a little; where it passes through e, a little either way along
  // `fallback`.
  void mirror_through(const L3& e, LD tp, const L3& fallback) {
    tp = std::max<LD>(tp, 0);
    const L3 x = s.o + s.d * tp, away = e - x;
    if (norm(away) > tiny()) {
      add(ray_through(s, e + away + unit(away) * tiny(), tp));
    } else {
      add(ray_through(s, e + fallback * tiny(), tp));
      add(ray_through(s, e - fallback * tiny(), tp));
    }
  }
  LD parameter_nearest(const L3& p) const { return dot(p - s.o, s.d) / dot(s.d, s.d); }
  // The point of segment [a, b] nearest the ray's line, and the line's parameter there.
  std::pair<L3, LD> nearest_on_segment(const L3& a, const L3& b) const {
    const L3 e = b - a, w = a - s.o;
    const LD dd = dot(s.d, s.d), ee = dot(e, e), de = dot(s.d, e), dw = dot(s.d, w), ew = dot(e, w);
    const LD den = dd * ee - de * de;
    LD t = den > 0 ? (de * dw - dd * ew) / den : 0;  // along the segment, then clamped
    t = std::clamp<LD>(t, 0, 1);
    const L3 p = a + e * t;
    return {p, parameter_nearest(p)};
  }
  // Segment [a, b] of a shape whose inside lies towards `inside`: the mirror through its
  // nearest point; for a reported edge hit also the ray through that point exactly.
  void edge(const L3& a, const L3& b, const L3& inside, bool exact_point) {
    // (Not a structured binding: clang cannot capture one in the lambda below.)
    const std::pair<L3, LD> nearest = nearest_on_segment(a, b);
    const L3 p = nearest.first, e = b - a;
    const LD tp = nearest.second;
    L3 out = (p - inside) - e * (dot(p - inside, e) / dot(e, e));
    mirror_through(p, tp, unit(out));
    if (!exact_point) return;
    const Setting& setting = s;
    add_exactly(ray_through(s, p, tp), [&setting, a, b, p, e, tp] {
      const ExactVec ea = exact_vec_ld(a), eb = exact_vec_ld(b);
      const double w = static_cast<double>(dot(p - a, e) / dot(e, e));
      const Q sq = w >= 0 && w <= 1 ? exact_of(w) : Q(w > 1 ? 1 : 0);
      ExactVec point;
      for (int k = 0; k < 3; ++k) point[k] = ea[k] + sq * (eb[k] - ea[k]);
      return std::optional<ExactQuery>(ray_through_exactly(setting, point, static_cast<double>(std::max<LD>(tp, 0))));
    });
  }
  static ExactVec exact_vec_ld(const L3& v) { return {exact_ld(v[0]), exact_ld(v[1]), exact_ld(v[2])}; }
};

L3 vec_at(const LD* x, int at) { return {{x[at], x[at + 1], x[at + 2]}}; }

// x·2^k exactly.
Q times_two_to(const Q& x, long k) {
  Q r = x;
  if (k >= 0)
    mpq_mul_2exp(r.get_mpq_t(), x.get_mpq_t(), static_cast<mp_bitcnt_t>(k));
  else
    mpq_div_2exp(r.get_mpq_t(), x.get_mpq_t(), static_cast<mp_bitcnt_t>(-k));
  return r;
}
// log2 of a dyadic's denominator.
long denominator_bits(const Q& x) { return static_cast<long>(mpz_sizeinbase(x.get_den().get_mpz_t(), 2)) - 1; }

// A dyadic point x with a·x = c exactly (a, c dyadic), near `target` (which nearly satisfies it):
// a touch of a plane or a ray parallel to one, made exact. One coordinate keeps its target;
// the two others solve a_j·X + a_k·Y = C in integers over 2^-F (extended Euclid), Y within
// 2^-F·|a_j|/g of its target, so F grows until both lie within 2^-58 of the largest target (the
// long double target's own error is 2^-64 of it).
// (A line in a plane is what a tangent needs; no single coordinate's division is dyadic.)
std::optional<ExactVec> on_plane(const ExactVec& a, const Q& c, const L3& target) {
  const LD size = std::max({std::abs(target[0]), std::abs(target[1]), std::abs(target[2]), LD(0x1p-1000L)});
  // First one coordinate alone, the others at their targets: dyadic where a_j divides exactly
  // (a power of two, as an axis-aligned normal's).
  for (int j = 0; j < 3; ++j) {
    if (a[j] == 0) continue;
    ExactVec x;
    Q rest = c;
    for (int i = 0; i < 3; ++i)
      if (i != j) x[i] = exact_ld(target[i]), rest -= a[i] * x[i];
    x[j] = rest / a[j];
    if (mpz_popcount(x[j].get_den().get_mpz_t()) == 1 &&
        std::abs(static_cast<LD>(Q(x[j] - exact_ld(target[j])).get_d())) <= size * 0x1p-58L)
      return x;
  }
  for (int keep = 0; keep < 3; ++keep) {
    const int j = (keep + 1) % 3, k = (keep + 2) % 3;
    if (a[j] == 0 || a[k] == 0) continue;
    ExactVec x;
    x[keep] = exact_ld(target[keep]);
    const Q rest = c - a[keep] * x[keep];
    // Integers A·X + B·Y = C with A, B = a_j, a_k times 2^E (E clearing their denominators) and
    // C = rest·2^(F + E), an integer once F + E reaches rest's denominator.
    const long E = std::max(denominator_bits(a[j]), denominator_bits(a[k]));
    const mpz_class A = times_two_to(a[j], E).get_num(), B = times_two_to(a[k], E).get_num();
    const long first_F = std::max(64L, denominator_bits(rest) - E);
    for (long F = first_F; F <= first_F + 2400; F += 128) {
      const mpz_class C = times_two_to(rest, F + E).get_num();
      mpz_class g, s, t;
      mpz_gcdext(g.get_mpz_t(), s.get_mpz_t(), t.get_mpz_t(), A.get_mpz_t(), B.get_mpz_t());
      if (!mpz_divisible_p(C.get_mpz_t(), g.get_mpz_t())) break;  // no dyadic solution for this pair
      const mpz_class X0 = s * (C / g), Y0 = t * (C / g), step = A / g;
      // Y (coordinate k) to its target: Y = Y0 − (A/g)·τ.
      const Q want = times_two_to(exact_ld(target[k]), F);
      mpz_class tau;
      const Q ratio = (Q(Y0) - want) / Q(step);
      mpz_fdiv_q(tau.get_mpz_t(), ratio.get_num().get_mpz_t(), ratio.get_den().get_mpz_t());
      const mpz_class X = X0 + (B / g) * tau, Y = Y0 - step * tau;
      x[j] = times_two_to(Q(X), -F), x[k] = times_two_to(Q(Y), -F);
      const LD off = std::max(std::abs(static_cast<LD>(Q(x[j] - exact_ld(target[j])).get_d())),
                              std::abs(static_cast<LD>(Q(x[k] - exact_ld(target[k])).get_d())));
      if (off <= size * 0x1p-58L) return x;  // the target's own error (64 bits) and the grid's
    }
  }
  return std::nullopt;
}
LD sign_of(LD x) { return x < 0 ? -1 : 1; }

// A ray exactly tangent to a moved sphere (a reported touch). No dyadic point lies at a given
// distance along a given unit direction, so the frame is made rational: a dyadic quaternion q
// (N = |q|²) whose rotation takes x̂ to d̂ and ŷ towards the centre; the columns of N·R(q) are
// orthogonal with norm N exactly. The direction becomes L·(first column), p the ray's point at
// the parameter nearest the centre, the centre p + m·(second column), the radius m·N: then
// |c′ − p| = r′ and (c′ − p) ⊥ d′ exactly, and the ray touches at p.
std::optional<ExactQuery> tangent_sphere(const Setting& s, LD tp, const L3& dn, const L3& wn);
void sphere_tangent(Candidates& c) {
  const Setting& s = c.s;
  const L3 centre = vec_at(s.x, 0);
  const LD tp = c.parameter_nearest(centre);
  if (!(tp > 0)) return;
  const L3 dn = unit(s.d), w = centre - (s.o + s.d * tp);
  L3 wn = unit(w - dn * dot(dn, w));
  if (norm(wn) == 0) wn = any_perpendicular(s.d);
  Moved about = unmoved(s);  // the centre moved to the distance r from the line
  const L3 x = s.o + s.d * tp;
  for (int k = 0; k < 3; ++k) about.x[k] = x[k] + wn[k] * std::abs(s.x[3]);
  c.add_exactly(about, [&s, tp, dn, wn] { return tangent_sphere(s, tp, dn, wn); });
}
std::optional<ExactQuery> tangent_sphere(const Setting& s, LD tp, const L3& dn, const L3& wn) {
  const L3 third = cross(dn, wn);
  // Rotation (columns dn, wn, third) to a quaternion (w, x, y, z), Shepperd's method.
  const LD m00 = dn[0], m11 = wn[1], m22 = third[2], trace = m00 + m11 + m22;
  LD q[4];
  if (trace > 0) {
    const LD r = std::sqrt(1 + trace) * 2;
    q[0] = r / 4, q[1] = (wn[2] - third[1]) / r, q[2] = (third[0] - dn[2]) / r, q[3] = (dn[1] - wn[0]) / r;
  } else if (m00 > m11 && m00 > m22) {
    const LD r = std::sqrt(1 + m00 - m11 - m22) * 2;
    q[0] = (wn[2] - third[1]) / r, q[1] = r / 4, q[2] = (wn[0] + dn[1]) / r, q[3] = (third[0] + dn[2]) / r;
  } else if (m11 > m22) {
    const LD r = std::sqrt(1 + m11 - m00 - m22) * 2;
    q[0] = (third[0] - dn[2]) / r, q[1] = (wn[0] + dn[1]) / r, q[2] = r / 4, q[3] = (third[1] + wn[2]) / r;
  } else {
    const LD r = std::sqrt(1 + m22 - m00 - m11) * 2;
    q[0] = (dn[1] - wn[0]) / r, q[1] = (third[0] + dn[2]) / r, q[2] = (third[1] + wn[2]) / r, q[3] = r / 4;
  }
  Q a = exact_ld(q[0]), b = exact_ld(q[1]), cq = exact_ld(q[2]), e = exact_ld(q[3]);
  const Q N = a * a + b * b + cq * cq + e * e;
  if (N == 0) return std::nullopt;
  const ExactVec first{a * a + b * b - cq * cq - e * e, 2 * (b * cq + e * a), 2 * (b * e - cq * a)};
  const ExactVec second{2 * (b * cq - e * a), a * a - b * b + cq * cq - e * e, 2 * (cq * e + b * a)};
  const LD n_ld = static_cast<LD>(N.get_d());
  const Q L = exact_ld(norm(s.d) / n_ld), m = exact_ld(std::abs(s.x[3]) / n_ld), t = exact_ld(tp);
  ExactQuery moved = s.q0();
  for (int k = 0; k < 3; ++k) {
    moved.direction[k] = L * first[k];
    const Q p = s.q0().origin[k] + t * moved.direction[k];
    moved.numbers[k] = p + m * second[k];
  }
  moved.numbers[3] = s.x[3] < 0 ? Q(-m * N) : Q(m * N);
  return moved;
}

void sphere_moves(Candidates& c) {
  const Setting& s = c.s;
  const L3 centre = vec_at(s.x, 0);
  const LD r = std::abs(s.x[3]);
  const LD tp = std::max<LD>(c.parameter_nearest(centre), 0);
  const L3 x = s.o + s.d * tp;
  const LD h = norm(x - centre);
  const L3 radial = h > 0 ? unit(x - centre) : any_perpendicular(s.d);
  // The line through the silhouette's nearest point, mirrored (passes in where it passed out).
  c.mirror_through(centre + radial * r, tp, radial);
  // The radius through the line's distance, and through the origin's.
  const L3 f = s.o - centre;
  const LD fo = norm(f);
  for (LD target : {h, fo}) {
    Moved m = unmoved(s);
    m.x[3] = sign_of(s.x[3]) * (2 * target - r + sign_of(target - r) * c.tiny());
    if (m.x[3] != 0) c.add(m);
  }
  // The origin across the surface along its radius, as far as it was (at most the radius).
  const L3 out = fo > 0 ? unit(f) : any_perpendicular(s.d);
  Moved m = unmoved(s);
  m.o = centre + out * (r + sign_of(r - fo) * (std::min(std::abs(fo - r), r) + c.tiny()));
  c.add(m);
}

// A ray lying exactly in the plane n·x = k (n, k exact): the direction made parallel and the
// origin put on it (on_plane), or for a plane its offset through the origin.
// (`plane_normal` gives n and k exactly, when a move is made.)
void in_plane(Candidates& c, const L3& nl, LD k, bool move_offset,
              std::function<std::pair<ExactVec, Q>()> plane_normal) {
  const Setting& s = c.s;
  const LD nn = dot(nl, nl);
  const L3 d_target = s.d - nl * (dot(nl, s.d) / nn), o_target = s.o + nl * ((k - dot(nl, s.o)) / nn);
  Moved about = unmoved(s);
  about.d = d_target;
  if (move_offset) {
    Moved offset = about;
    offset.x[3] = dot(nl, s.o);
    c.add_exactly(offset, [&s, d_target, plane_normal]() -> std::optional<ExactQuery> {
      const auto [n, k_exact] = plane_normal();
      const auto d = on_plane(n, 0, d_target);
      if (!d) return std::nullopt;
      ExactQuery q = s.q0();
      q.direction = *d;
      q.numbers[3] = n[0] * q.origin[0] + n[1] * q.origin[1] + n[2] * q.origin[2];
      return q;
    });
  }
  about.o = o_target;
  c.add_exactly(about, [&s, d_target, o_target, plane_normal]() -> std::optional<ExactQuery> {
    const auto [n, k_exact] = plane_normal();
    const auto d = on_plane(n, 0, d_target);
    const auto o = on_plane(n, k_exact, o_target);
    if (!d || !o) return std::nullopt;
    ExactQuery q = s.q0();
    q.direction = *d, q.origin = *o;
    return q;
  });
}

// A plane n·x = k (or a triangle's): the origin mirrored through it, the direction through its
// parallel; for a plane also the offset through the origin.
void plane_moves(Candidates& c, const L3& n, LD k, bool move_offset) {
  const Setting& s = c.s;
  const LD nn = dot(n, n), side = k - dot(n, s.o), along = dot(n, s.d);
  const L3 nu = unit(n);
  Moved m = unmoved(s);
  m.o = s.o + n * (2 * side / nn) + nu * (sign_of(side) * c.tiny());
  c.add(m);
  m = unmoved(s);
  m.d = s.d - n * (2 * along / nn) - nu * (sign_of(along) * c.tiny_d());
  c.add(m);
  if (move_offset) {
    m = unmoved(s);
    m.x[3] = 2 * dot(n, s.o) - k - sign_of(side) * c.tiny();
    c.add(m);
  }
}

void triangle_moves(Candidates& c, bool exact_point) {
  const Setting& s = c.s;
  const L3 v[3] = {vec_at(s.x, 0), vec_at(s.x, 3), vec_at(s.x, 6)};
  const L3 centroid = (v[0] + v[1] + v[2]) * (1.0L / 3);
  for (int i = 0; i < 3; ++i) c.edge(v[i], v[(i + 1) % 3], centroid, exact_point);
  for (int i = 0; i < 3; ++i) {
    c.mirror_through(v[i], c.parameter_nearest(v[i]), unit(v[i] - centroid));
    if (exact_point) {
      const double tp = static_cast<double>(std::max<LD>(c.parameter_nearest(v[i]), 0));
      c.add_exactly(ray_through(s, v[i], tp), [&s, i, tp] {
        const auto& x = s.q0().numbers;
        return std::optional<ExactQuery>(ray_through_exactly(s, {x[3 * i], x[3 * i + 1], x[3 * i + 2]}, tp));
      });
    }
  }
  const L3 n = cross(v[1] - v[0], v[2] - v[0]);
  plane_moves(c, n, dot(n, v[0]), false);
  // The ray through the triangle's inside: the middle of the stretch where the line passes over
  // it (edge k's inward normal n × e_k is ⊥ n, so passing over is a sign per edge, linear in t),
  // dropped onto the plane (a ray nearly in the plane, above the triangle, is made to cross it).
  LD lo = 0, hi = std::numeric_limits<LD>::infinity();
  for (int i = 0; i < 3; ++i) {
    const L3 inward = cross(n, v[(i + 1) % 3] - v[i]);
    const LD at0 = dot(inward, s.o - v[i]), rate = dot(inward, s.d);
    if (rate == 0) {
      if (at0 < 0) lo = hi;  // never over the triangle
    } else if (rate > 0) {
      lo = std::max(lo, -at0 / rate);
    } else {
      hi = std::min(hi, -at0 / rate);
    }
  }
  if (lo < hi) {
    const LD tp = std::isfinite(hi) ? (lo + hi) / 2 : lo + 1;
    const L3 x = s.o + s.d * tp, nu = unit(n);
    const L3 p = x - nu * dot(nu, x - v[0]);  // (mid-stretch: inside, not on an edge)
    c.add(ray_through(s, p, tp));
    // ... and through p from either side: the direction tilted so the ray arrives from the front
    // (an entry) or the back (an exit), as steeply as the origin's height asks, the origin on the line.
    const LD height = std::max(std::abs(dot(nu, s.o - v[0])), c.tiny());
    for (const LD side : {LD(1), LD(-1)}) {
      Moved m = unmoved(s);
      m.d = s.d - nu * dot(nu, s.d) - nu * (side * height / tp);
      m.o = p - m.d * tp;
      c.add(m);
    }
  }
  if (exact_point)  // the ray in the triangle's plane (a touch: tangent)
    in_plane(c, n, dot(n, v[0]), false, [&s] {
      const auto& x = s.q0().numbers;
      const ExactVec e1{x[3] - x[0], x[4] - x[1], x[5] - x[2]}, e2{x[6] - x[0], x[7] - x[1], x[8] - x[2]};
      const ExactVec ne{e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]};
      return std::pair<ExactVec, Q>{ne, ne[0] * x[0] + ne[1] * x[1] + ne[2] * x[2]};
    });
}

void box_moves(Candidates& c, bool exact_point) {
  const Setting& s = c.s;
  const L3 lo = vec_at(s.x, 0), hi = vec_at(s.x, 3), centre = (lo + hi) * 0.5L;
  {  // the origin to the nearest point just inside (an origin on an edge or corner moves on each axis)
    Moved m = unmoved(s);
    for (int axis = 0; axis < 3; ++axis) {
      const LD margin = std::min(c.tiny(), (hi[axis] - lo[axis]) / 4);
      m.o[axis] = std::clamp(s.o[axis], lo[axis] + margin, hi[axis] - margin);
    }
    c.add(m);
  }
  for (int axis = 0; axis < 3; ++axis) {  // the 12 edges: along `axis`, at each corner of the other two
    const int j = (axis + 1) % 3, k = (axis + 2) % 3;
    for (int corner = 0; corner < 4; ++corner) {
      L3 a = lo;
      a[j] = corner & 1 ? hi[j] : lo[j], a[k] = corner & 2 ? hi[k] : lo[k];
      L3 b = a;
      b[axis] = hi[axis];
      c.edge(a, b, centre, false);
    }
  }
  for (int axis = 0; axis < 3; ++axis) {
    for (const LD plane : {lo[axis], hi[axis]}) {  // the origin to either side of each face's
      const LD side = plane - s.o[axis];           // plane, as far as it was (at most half the width)
      for (const LD way : {LD(-1), LD(1)}) {
        Moved m = unmoved(s);
        m.o[axis] = plane + way * (std::min(std::abs(side), (hi[axis] - lo[axis]) / 2) + c.tiny());
        c.add(m);
      }
      if (exact_point) {  // the ray in the face's plane: a touch, exactly
        Moved about = unmoved(s);
        about.o[axis] = plane, about.d[axis] = 0;
        c.add_exactly(about, [&s, axis, plane] {
          ExactQuery q = s.q0();
          q.origin[axis] = exact_ld(plane), q.direction[axis] = 0;
          return std::optional<ExactQuery>(q);
        });
      }
    }
    Moved m = unmoved(s);  // the direction through the slab's parallel
    m.d[axis] = s.d[axis] != 0 ? -s.d[axis] - sign_of(s.d[axis]) * c.tiny_d() : c.tiny_d();
    c.add(m);
    if (s.d[axis] == 0) {
      m.d[axis] = -c.tiny_d();
      c.add(m);
    }
  }
}

bool class_right(const ExactQuery& q, HitRule rule, HitClass reported) {
  const auto v = exact_verdict(q, rule);
  return v && agreement_of(v->cls, reported) == Agreement::agrees;
}

// Whether the exact parameter rounds to t in precision p (strictly inside t's rounding interval).
bool rounds_to(const ExactParameter& exact, double t, Precision p) {
  double below, above;
  if (p == Precision::f32) {
    const float f = static_cast<float>(t);
    below = std::nextafter(f, -INFINITY), above = std::nextafter(f, INFINITY);
  } else {
    below = std::nextafter(t, -INFINITY), above = std::nextafter(t, INFINITY);
  }
  if (!std::isfinite(below) || !std::isfinite(above)) return false;
  const Q x = exact_of(t);
  return compare(exact, Q((exact_of(below) + x) / 2)) > 0 && compare(exact, Q((x + exact_of(above)) / 2)) < 0;
}

bool t_right(const ExactQuery& q, HitRule rule, HitClass reported, double t, Precision p) {
  const auto v = exact_verdict(q, rule);
  return v && agreement_of(v->cls, reported) == Agreement::agrees && v->t && rounds_to(*v->t, t, p);
}

Witness witness_of(const Setting& s, const ExactQuery& q, double ulps) {
  Witness w;
  w.ulps = ulps, w.scale = s.scale;
  w.origin = q.origin, w.direction = q.direction;
  w.shape = q.kind, w.shape_numbers = q.numbers;
  return w;
}

// t* − t for an exact parameter t* = (p + s·√r)/q, to about 300 bits (GMP floats: no overflow,
// and the difference is formed before it is rounded: it may be a fraction of t's ulp).
LD distance_to(const ExactParameter& t, double t_reported) {
  constexpr mp_bitcnt_t kBits = 300;
  const mpq_class a = t.p - exact_of(t_reported) * t.q;
  mpf_class x(a, kBits);
  if (t.s) x += t.s * sqrt(mpf_class(t.radicand, kBits));
  x /= mpf_class(t.q, kBits);
  long exponent = 0;
  const double mantissa = mpf_get_d_2exp(&exponent, x.get_mpf_t());
  return std::ldexp(static_cast<LD>(mantissa), static_cast<int>(std::clamp<long>(exponent, -20000, 20000)));
}
}  // namespace

BackwardError class_backward_error(const Query& seen, HitRule rule, HitClass reported, Precision p, double check_up_to,
                                   bool keep_witness) {
  const Setting s = setting_of(seen, p);
  Candidates c{s, {}};
  c.list.reserve(64);
  const bool exact_point = reported == HitClass::boundary || reported == HitClass::tangent;
  switch (s.kind) {
    case ShapeKind::sphere:
      sphere_moves(c);
      if (exact_point) sphere_tangent(c);
      break;
    case ShapeKind::plane:
      plane_moves(c, vec_at(s.x, 0), s.x[3], true);
      if (exact_point)
        in_plane(c, vec_at(s.x, 0), s.x[3], true, [&s] {
          const auto& x = s.q0().numbers;
          return std::pair<ExactVec, Q>{{x[0], x[1], x[2]}, x[3]};
        });
      break;
    case ShapeKind::triangle: triangle_moves(c, exact_point); break;
    case ShapeKind::box: box_moves(c, exact_point); break;
  }
  for (Candidate& k : c.list) k.ulps = ulps_of(s, k.m);
  // A searched move crosses about half-way (it is a mirror); none is trusted below an eighth.
  auto least_possible = [](const Candidate& k) { return k.search ? k.ulps / 8 : k.ulps; };
  std::sort(c.list.begin(), c.list.end(),
            [&](const Candidate& a, const Candidate& b) { return least_possible(a) < least_possible(b); });
  // The exact judge of a long double move: intervals over its exact value first, rationals where
  // they cannot tell (near the boundary the search is looking for).
  auto right = [&](const Moved& m) {
    if (const auto cls = filtered_class(split_of(s, m), rule)) return agreement_of(*cls, reported) == Agreement::agrees;
    return class_right(exact_query(s, m), rule, reported);
  };
  BackwardError out;
  // The smallest few moves are tried (as backward_error's tries for tracers): 8 for a tally's
  // verdict, 16 where the witness is kept (a box has some forty), of them 3 or 6 exact ones.
  int tries = keep_witness ? 16 : 8, exact_tries = keep_witness ? 6 : 3;  // (an exact one costs ~50 µs)
  for (const Candidate& k : c.list) {
    if (out.checked && least_possible(k) >= *out.beta) break;
    if (!out.checked && least_possible(k) > check_up_to) break;
    if (tries-- == 0) break;
    std::optional<ExactQuery> made;
    if (k.make_exact) {
      if (exact_tries-- == 0) continue;
      made = k.make_exact();
      if (!made || !class_right(*made, rule, reported)) continue;
    } else if (!right(k.m)) {
      continue;
    }
    LD hi = 1;
    if (k.search && keep_witness) {  // halve while it stays right, then three bisections: within 1/8
      LD lo = 0;
      // (Not below 2^-20 ulps: the histogram's lowest bucket holds all below, and no tolerance is that fine.)
      for (int halvings = 0; halvings < 40 && k.ulps * hi > 0x1p-20; ++halvings) {
        if (!right(along(s, k.m, hi / 2))) {
          lo = hi / 2;
          break;
        }
        hi /= 2;
      }
      for (int step = 0; step < 3 && lo > 0; ++step) {
        const LD mid = (lo + hi) / 2;
        (right(along(s, k.m, mid)) ? hi : lo) = mid;
      }
    } else if (k.search) {  // a tally's verdict: halve once, and on while above K (β within 2×)
      for (int halvings = 0; halvings < 40 && (halvings == 0 || k.ulps * hi > check_up_to); ++halvings) {
        if (!right(along(s, k.m, hi / 2))) break;
        hi /= 2;
      }
    }
    std::optional<ExactQuery> q = made;
    double ulps = made ? exact_ulps(s, *made) : k.ulps;
    if (!made) {
      const Moved w = along(s, k.m, hi);
      ulps = ulps_of(s, w);
      if (keep_witness) q = exact_query(s, w), ulps = exact_ulps(s, *q);
    }
    if (out.checked && ulps >= *out.beta) continue;
    out.beta = ulps, out.checked = true;
    out.witness.reset();
    if (q && keep_witness) out.witness = std::make_shared<const Witness>(witness_of(s, *q, ulps));
    if (!keep_witness && ulps <= check_up_to) break;  // a tally's verdict: the first witness will do
  }
  if (out.checked) return out;
  if (c.list.empty()) return out.refused = true, out;
  out.beta = least_possible(c.list.front());  // the estimate where nothing was checked
  if (out.beta > check_up_to)
    out.estimated = true;
  else
    out.refused = true;
  return out;
}

BackwardError t_backward_error(const Query& seen, HitRule rule, HitClass reported, double t, Precision p) {
  const Setting s = setting_of(seen, p);
  BackwardError out;
  const auto v = exact_verdict(s.q0(), rule);
  if (!v || !v->t || !std::isfinite(t)) return out.refused = true, out;
  const LD shift = distance_to(*v->t, t);
  // The origin along d, exactly (a move across d, however small, is amplified near a tangent,
  // where the root moves as the square root of the distance): the contact comes to t.
  std::vector<ExactQuery> tries;
  ExactQuery along_d = s.q0();
  const Q exact_shift = exact_ld(shift);
  for (int k = 0; k < 3; ++k) along_d.origin[k] += exact_shift * s.q0().direction[k];
  tries.push_back(along_d);
  Moved m;
  ExactVec point;  // o + t·d, exactly: the reported contact
  for (int k = 0; k < 3; ++k) point[k] = s.q0().origin[k] + exact_of(t) * s.q0().direction[k];
  const L3 pl{
      {static_cast<LD>(point[0].get_d()), static_cast<LD>(point[1].get_d()), static_cast<LD>(point[2].get_d())}};
  ExactQuery q = s.q0();
  switch (s.kind) {
    case ShapeKind::sphere: {  // the radius through the reported contact, to 300 bits (a tangent amplifies)
      Q squared = 0;
      for (int k = 0; k < 3; ++k) squared += (point[k] - s.q0().numbers[k]) * (point[k] - s.q0().numbers[k]);
      const mpf_class radius = sqrt(mpf_class(squared, 300));
      q.numbers[3] = s.x[3] < 0 ? Q(-mpq_class(radius)) : mpq_class(radius);
      tries.push_back(q);
      break;
    }
    case ShapeKind::plane:  // the offset through it, exactly
      q.numbers[3] = q.numbers[0] * point[0] + q.numbers[1] * point[1] + q.numbers[2] * point[2];
      tries.push_back(q);
      break;
    case ShapeKind::triangle: {  // the triangle along its normal through it
      const L3 v0 = vec_at(s.x, 0), n = cross(vec_at(s.x, 3) - v0, vec_at(s.x, 6) - v0);
      const L3 move = n * (dot(n, pl - v0) / dot(n, n));
      m = unmoved(s);
      for (int i = 0; i < 9; ++i) m.x[i] += move[i % 3];
      tries.push_back(exact_query(s, m));
      break;
    }
    case ShapeKind::box: {  // each face plane through it, and every near (far) face at once: a corner
      ExactQuery near = s.q0(), far = s.q0();
      for (int i = 0; i < 6; ++i)
        if (s.d[i % 3] != 0) {
          q = s.q0(), q.numbers[i] = point[i % 3];
          tries.push_back(q);
          ((i < 3) == (s.d[i % 3] > 0) ? near : far).numbers[i] = point[i % 3];
        }
      tries.push_back(near), tries.push_back(far);
      break;
    }
  }
  for (const ExactQuery& x : tries) {
    if (!t_right(x, rule, reported, t, p)) continue;
    const double ulps = exact_ulps(s, x);
    if (out.witness && ulps >= *out.beta) continue;
    out.beta = ulps, out.witness = std::make_shared<const Witness>(witness_of(s, x, ulps)), out.checked = true;
  }
  if (!out.witness) out.refused = true;
  return out;
}

bool origin_on_shape(const Query& q) {
  const Setting s = setting_of(q, Precision::f64);
  const ExactVec& o = s.q0().origin;
  const auto& x = s.q0().numbers;
  auto at = [&](int i) { return ExactVec{x[i], x[i + 1], x[i + 2]}; };
  auto minus = [](const ExactVec& a, const ExactVec& b) { return ExactVec{a[0] - b[0], a[1] - b[1], a[2] - b[2]}; };
  auto dot3 = [](const ExactVec& a, const ExactVec& b) { return Q(a[0] * b[0] + a[1] * b[1] + a[2] * b[2]); };
  auto cross3 = [](const ExactVec& a, const ExactVec& b) {
    return ExactVec{a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
  };
  switch (s.kind) {
    case ShapeKind::sphere: {
      const ExactVec f = minus(o, at(0));
      return dot3(f, f) == x[3] * x[3];
    }
    case ShapeKind::plane: return dot3(at(0), o) == x[3];
    case ShapeKind::triangle: {
      const ExactVec v[3] = {at(0), at(3), at(6)};
      const ExactVec n = cross3(minus(v[1], v[0]), minus(v[2], v[0]));
      if (dot3(n, minus(o, v[0])) != 0) return false;
      for (int i = 0; i < 3; ++i)  // on the inner side of (or on) each edge, in the plane
        if (sgn(dot3(n, cross3(minus(v[(i + 1) % 3], v[i]), minus(o, v[i])))) < 0) return false;
      return true;
    }
    case ShapeKind::box: {
      bool on_a_face = false;
      for (int i = 0; i < 3; ++i) {
        if (o[i] < x[i] || o[i] > x[3 + i]) return false;
        on_a_face = on_a_face || o[i] == x[i] || o[i] == x[3 + i];
      }
      return on_a_face;
    }
  }
  return false;
}

bool shape_witness_holds(const Query& seen, const Witness& w, HitRule rule, HitClass reported, std::optional<double> t,
                         Precision p) {
  const Setting s = setting_of(seen, p);
  if (!w.shape || *w.shape != s.kind || !(w.scale == s.scale) || !(w.ulps >= 0)) return false;
  ExactQuery q = s.q0();
  q.origin = w.origin, q.direction = w.direction, q.numbers = w.shape_numbers;
  if (exact_ulps(s, q) > w.ulps) return false;  // moves more than it claims
  return t ? t_right(q, rule, reported, *t, p) : class_right(q, rule, reported);
}

}  // namespace rayproof

namespace rayproof {

std::optional<OutcomeVerdict> outcome_verdict(const Query& q, const VariantOutcome& o, HitRule rule,
                                              double tolerance_ulps, bool with_t, double check_up_to,
                                              bool keep_witness) {
  if (o.answer.failed()) return std::nullopt;
  const Precision p = o.variant ? o.variant->precision : Precision::f64;
  const HitRule own_rule = o.variant ? o.variant->rule_for(rule) : rule;
  std::optional<Query> seen = p == Precision::f32 ? rounded_to_float(q) : std::optional<Query>(q);
  if (!seen) return std::nullopt;
  OutcomeVerdict v;
  const RangeRule range = o.variant ? o.variant->range : RangeRule::open;
  if (o.agreement != Agreement::agrees && range == RangeRule::closed && o.answer.cls != HitClass::miss &&
      o.answer.t == 0 && origin_on_shape(*seen)) {
    v.at_range_end = true, v.level = Level::rounding;
    return v;
  }
  if (o.agreement != Agreement::agrees) {
    v.beta = class_backward_error(*seen, own_rule, o.answer.cls, p, check_up_to, keep_witness);
  } else {
    const std::optional<std::uint64_t> off = p == Precision::f32 ? o.ulp_own : o.ulp;
    if (!with_t || !off || *off == 0 || !o.answer.has_t()) return std::nullopt;
    v.of_t = true;
    v.beta = t_backward_error(*seen, own_rule, o.answer.cls, o.answer.t, p);
  }
  v.level = level_of(v.beta, tolerance_ulps);
  return v;
}

namespace {
template <class Json>
void add_fields(Json& entry, const OutcomeVerdict& v, std::string_view range) {
  const std::string suffix = v.of_t ? "_t" : "";
  entry["level" + suffix] = std::string(to_string(v.level));
  // (json converts to ordered_json only through text; a finding's entry is json: no copy.)
  auto as = [](const json& j) {
    if constexpr (std::is_same_v<Json, json>)
      return j;
    else
      return Json::parse(j.dump());
  };
  entry["beta" + suffix] = as(beta_json(v.beta));
  if (!v.of_t) entry["range"] = std::string(range);
  if (v.level == Level::rounding && v.beta.witness) entry["witness" + suffix] = as(v.beta.witness->to_json());
}
}  // namespace

void add_verdict_fields(nlohmann::ordered_json& entry, const OutcomeVerdict& v, std::string_view range) {
  add_fields(entry, v, range);
}
void add_verdict_fields(json& entry, const OutcomeVerdict& v, std::string_view range) { add_fields(entry, v, range); }

}  // namespace rayproof
