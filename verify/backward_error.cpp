#include "rayproof/verify/backward_error.h"

#include "rayproof/core/fp.h"
#include "rayproof/verify/expansion.h"

#include <mpfr.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <optional>
#include <utility>
#include <set>

namespace rayproof {

// ------------------------------------------------------------------------------ exact numbers
ExactVec exact_vec(const Vec3& v) { return {exact_of(v.x()), exact_of(v.y()), exact_of(v.z())}; }
json exact_vec_json(const ExactVec& v) { return json::array({hex_exact(v[0]), hex_exact(v[1]), hex_exact(v[2])}); }

mpq_class exact_of(double x) {
  mpq_class q(x);  // GMP converts a finite double exactly
  return q;
}

double round_up(const mpq_class& x) {
  double d = x.get_d();  // truncated toward zero
  if (mpq_class(d) < x) d = std::nextafter(d, std::numeric_limits<double>::infinity());
  return d;
}

std::string hex_exact(const mpq_class& x) {
  if (x == 0) return "0x0p+0";
  const mpz_class& den = x.get_den();
  if (mpz_popcount(den.get_mpz_t()) != 1) throw std::runtime_error("hex_exact: not a dyadic rational");
  const long k = static_cast<long>(mpz_sizeinbase(den.get_mpz_t(), 2)) - 1;  // den = 2^k
  mpz_class m = abs(x.get_num());
  const long bits = static_cast<long>(mpz_sizeinbase(m.get_mpz_t(), 2));
  const long exponent = bits - 1 - k;
  // m = 1.fff… · 2^(bits−1): the bits after the leading one, padded to whole hex digits.
  mpz_class frac = m - (mpz_class(1) << (bits - 1));
  long frac_bits = bits - 1;
  const long pad = (4 - frac_bits % 4) % 4;
  frac <<= pad, frac_bits += pad;
  std::string digits = frac_bits ? frac.get_str(16) : "";
  digits.insert(0, static_cast<std::size_t>(frac_bits / 4) - digits.size(), '0');
  while (!digits.empty() && digits.back() == '0') digits.pop_back();
  std::string out = x < 0 ? "-0x1" : "0x1";
  if (!digits.empty()) out += "." + digits;
  out += (exponent < 0 ? "p" : "p+") + std::to_string(exponent);
  return out;
}

std::optional<mpq_class> parse_hex_exact(std::string_view text) {
  std::string_view s = text;
  bool negative = false;
  if (!s.empty() && (s[0] == '-' || s[0] == '+')) negative = s[0] == '-', s.remove_prefix(1);
  if (s.size() < 3 || s[0] != '0' || (s[1] != 'x' && s[1] != 'X')) return std::nullopt;
  s.remove_prefix(2);
  mpz_class m = 0;
  long frac_digits = 0, digits = 0;
  bool point = false;
  std::size_t i = 0;
  for (; i < s.size() && s[i] != 'p' && s[i] != 'P'; ++i) {
    const char c = s[i];
    if (c == '.') {
      if (point) return std::nullopt;
      point = true;
      continue;
    }
    int v;
    if (c >= '0' && c <= '9')
      v = c - '0';
    else if (c >= 'a' && c <= 'f')
      v = c - 'a' + 10;
    else if (c >= 'A' && c <= 'F')
      v = c - 'A' + 10;
    else
      return std::nullopt;
    if (++digits > 4000) return std::nullopt;  // a bound on what a reader allocates
    m = m * 16 + v;
    frac_digits += point;
  }
  if (digits == 0 || i + 1 >= s.size()) return std::nullopt;
  std::string_view e = s.substr(i + 1);
  bool eneg = false;
  if (e[0] == '-' || e[0] == '+') eneg = e[0] == '-', e.remove_prefix(1);
  if (e.empty() || e.size() > 6) return std::nullopt;
  long exponent = 0;
  for (char c : e) {
    if (c < '0' || c > '9') return std::nullopt;
    exponent = exponent * 10 + (c - '0');
  }
  exponent = (eneg ? -exponent : exponent) - 4 * frac_digits;
  mpq_class q(m);
  if (exponent >= 0)
    q *= mpq_class(mpz_class(1) << exponent);
  else
    q /= mpq_class(mpz_class(1) << -exponent);
  q.canonicalize();
  return negative ? mpq_class(-q) : q;
}

double unit_roundoff(Precision p) { return p == Precision::f32 ? 0x1p-24 : 0x1p-53; }

std::string_view to_string(Level l) { return l == Level::rounding ? "rounding" : "bug"; }

json beta_json(const BackwardError& b) {
  // unproved: nothing to try, or every witness within the checked range refused (README's extensions)
  if (!b.beta || (b.refused && !b.checked)) return b.refused ? "unproved" : "none";
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.2g", *b.beta);
  return std::stod(buf);
}

std::string beta_bucket(const BackwardError& b) {
  if (!b.beta) return "none";
  if (!b.checked && !b.estimated) return "unproved";  // the exact judge refused every witness tried
  if (*b.beta <= 0x1p-20) return "2^-20";
  int k = -20;
  while (k < 60 && std::ldexp(1.0, k) < *b.beta) ++k;
  return "2^" + std::to_string(k);
}

namespace {
using Q = mpq_class;

// An exact dyadic number m·2^e in integers. A witness's numbers are all dyadic (doubles, their
// sums and products), and a rational pays a gcd on every operation: sums, differences and
// products here pay shifts, and the rational is made once, reduced by the shared powers of two.
struct Dyadic {
  mpz_class m;
  long e = 0;
  static Dyadic of(double x) {  // x finite: m·2^e with m an integer below 2^53
    int ex;
    Dyadic d;
    mpz_set_d(d.m.get_mpz_t(), std::ldexp(std::frexp(x, &ex), 53));
    d.e = long(ex) - 53;
    return d;
  }
  static std::optional<Dyadic> of(const Q& x) {
    if (mpz_popcount(x.get_den_mpz_t()) != 1) return std::nullopt;
    return Dyadic{x.get_num(), -(long(mpz_sizeinbase(x.get_den_mpz_t(), 2)) - 1)};
  }
  Q rational() const {
    Q out;
    if (m == 0) return out;
    if (e >= 0) {
      mpz_mul_2exp(out.get_num_mpz_t(), m.get_mpz_t(), mp_bitcnt_t(e));
      return out;
    }
    const mp_bitcnt_t shared = std::min<mp_bitcnt_t>(mpz_scan1(m.get_mpz_t(), 0), mp_bitcnt_t(-e));
    mpz_tdiv_q_2exp(out.get_num_mpz_t(), m.get_mpz_t(), shared);
    mpz_set_ui(out.get_den_mpz_t(), 1);
    mpz_mul_2exp(out.get_den_mpz_t(), out.get_den_mpz_t(), mp_bitcnt_t(-e) - shared);
    return out;
  }
  // Truncated toward zero, as mpq_class::get_d (which decides where the value is no normal double).
  double truncated() const {
    long ex;
    const double f = mpz_get_d_2exp(&ex, m.get_mpz_t());
    const long x = ex + e;
    if (f == 0) return 0;
    if (x < -1020 || x > 1020) return rational().get_d();
    return std::ldexp(f, int(x));
  }
  int sign() const { return sgn(m); }
  friend Dyadic operator+(const Dyadic& a, const Dyadic& b) { return sum(a, b, false); }
  friend Dyadic operator-(const Dyadic& a, const Dyadic& b) { return sum(a, b, true); }
  friend Dyadic operator*(const Dyadic& a, const Dyadic& b) { return {a.m * b.m, a.e + b.e}; }
  // sign(|a| − |b|)
  friend int compare_magnitudes(const Dyadic& a, const Dyadic& b) {
    Dyadic x{abs(a.m), a.e}, y{abs(b.m), b.e};
    return (x - y).sign();
  }

 private:
  static Dyadic sum(const Dyadic& a, const Dyadic& b, bool negate_b) {
    Dyadic r;
    if (a.e <= b.e) {
      mpz_mul_2exp(r.m.get_mpz_t(), b.m.get_mpz_t(), mp_bitcnt_t(b.e - a.e));
      if (negate_b)
        r.m = a.m - r.m;
      else
        r.m += a.m;
      r.e = a.e;
    } else {
      mpz_mul_2exp(r.m.get_mpz_t(), a.m.get_mpz_t(), mp_bitcnt_t(a.e - b.e));
      if (negate_b)
        r.m -= b.m;
      else
        r.m += b.m;
      r.e = b.e;
    }
    return r;
  }
};

// Vector terms in one exact number type T: rationals (ExactVec), or floating-point expansions.
template <class T>
using TVec = std::array<T, 3>;
template <class T>
TVec<T> sub(const TVec<T>& a, const TVec<T>& b) {
  return {a[0] - b[0], a[1] - b[1], a[2] - b[2]};
}
template <class T>
TVec<T> cross(const TVec<T>& a, const TVec<T>& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
template <class T>
T dot(const TVec<T>& a, const TVec<T>& b) {
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

ExactVec read_exact_vec(const json& j, const std::string& field) {
  if (!j.is_array() || j.size() != 3) throw FieldError(field, "expected [x, y, z]");
  ExactVec v;
  for (int k = 0; k < 3; ++k) {
    const json& x = j[k];
    std::optional<mpq_class> q;
    if (x.is_number() && std::isfinite(x.get<double>()))
      q = exact_of(x.get<double>());
    else if (x.is_string())
      q = parse_hex_exact(x.get<std::string>());
    if (!q) throw FieldError(field + "[" + std::to_string(k) + "]", "expected an exact hex float");
    v[k] = *q;
  }
  return v;
}

// The line o + t·d against one triangle, exactly: TrianglePolicy's terms (oracle.cpp) over the
// rationals — n = (v₁ − v₀) × (v₂ − v₀), t = n·(v₀ − o) / n·d, edge k of sign d·((v_k − o) ×
// (v_k+1 − o)); the line meets the closed triangle where no edge has the sign opposite to n·d.
// The edge is computed in Plücker form, d·(v_k × v_k+1) + (v_k − v_k+1)·(d × o) (the same number:
// (v_k − o) × (v_k+1 − o) = v_k × v_k+1 + o × (v_k − v_k+1)), the line's moment d × o made once:
// a moved ray's coordinates are sums of several doubles, and products of its differences grew.
struct LineContact {
  enum Kind { miss, crossing, in_plane, degenerate } kind = miss;
  Q t;
  bool front = false, boundary = false;
  std::array<bool, 3> zero_edge{};
};
// The contact's terms in either exact type (expansions are exact while valid: nullopt where one
// left fp.h's safe range or its capacity, and the caller falls back to rationals).
bool exact_ok(const Q&) { return true; }
bool exact_ok(const Expansion& e) { return e.valid(); }
// `inside`: the filter below has proved the line crosses the interior (the edge signs are
// skipped). A crossing's t is num / den.
template <class T>
std::optional<LineContact> contact_terms(const TVec<T>& o, const TVec<T>& d, const TVec<T>& moment,
                                         const std::array<TVec<T>, 3>& v, bool inside, T& num, T& den) {
  LineContact c;
  const TVec<T> n = cross(sub(v[1], v[0]), sub(v[2], v[0]));
  if (!exact_ok(n[0]) || !exact_ok(n[1]) || !exact_ok(n[2])) return std::nullopt;
  if (sgn(n[0]) == 0 && sgn(n[1]) == 0 && sgn(n[2]) == 0) return c.kind = LineContact::degenerate, c;
  den = dot(n, d), num = dot(n, sub(v[0], o));
  if (!exact_ok(den) || !exact_ok(num)) return std::nullopt;
  if (sgn(den) == 0) {
    if (sgn(num) == 0) c.kind = LineContact::in_plane;
    return c;
  }
  const int sd = sgn(den);
  for (int k = 0; k < 3 && !inside; ++k) {
    const T edge = dot(d, cross(v[k], v[(k + 1) % 3])) + dot(sub(v[k], v[(k + 1) % 3]), moment);
    if (!exact_ok(edge)) return std::nullopt;
    const int se = sgn(edge);
    if (se == -sd) return c;
    c.zero_edge[k] = se == 0;
    c.boundary = c.boundary || se == 0;
  }
  c.kind = LineContact::crossing;
  c.front = sd < 0;
  return c;
}
LineContact line_contact(const ExactVec& o, const ExactVec& d, const std::array<ExactVec, 3>& v, bool inside = false) {
  Q num, den;
  LineContact c = *contact_terms<Q>(o, d, cross(d, o), v, inside, num, den);
  if (c.kind == LineContact::crossing) c.t = num / den;
  return c;
}

// The same in expansions: a dyadic rational as the exact sum of at most 6 doubles, none below
// fp.h's safe range (else false: the rationals decide).
using EVec = TVec<Expansion>;
// Each part is the rest truncated to 53 bits (the rest keeps x's sign, smaller each time). x is
// num / 2^k: the parts are num's top 53 bits at a time, in integers (no gcd, unlike mpq's
// subtraction); a part whose exponent is beyond ±1100 could not be safe or finite anyway.
bool expansion_of(const Q& x, Expansion& out) {
  out = Expansion();
  const mpz_srcptr den = x.get_den_mpz_t();
  if (mpz_popcount(den) != 1) return false;  // not dyadic: no finite sum of doubles
  const long k = long(mpz_sizeinbase(den, 2)) - 1;
  if (mpz_sizeinbase(x.get_num_mpz_t(), 2) <= 53) {  // one double (the judged ray's own numbers)
    if (k > 1100) return false;
    const double part = std::ldexp(mpz_get_d(x.get_num_mpz_t()), int(-k));
    if (part == 0) return true;
    if (!(std::abs(part) >= kSafeMagnitudeMin) || !std::isfinite(part)) return false;
    out = Expansion(part);
    return true;
  }
  mpz_class rest = x.get_num();
  for (int i = 0; i < 6 && rest != 0; ++i) {
    const long bits = long(mpz_sizeinbase(rest.get_mpz_t(), 2)), low = std::max(0L, bits - 53);
    if (low - k < -1100 || low - k > 1100) return false;
    mpz_class top;
    mpz_tdiv_q_2exp(top.get_mpz_t(), rest.get_mpz_t(), low);  // truncated toward zero
    const double part = std::ldexp(top.get_d(), int(low - k));
    if (!(std::abs(part) >= kSafeMagnitudeMin) || !std::isfinite(part)) return false;
    out = out + Expansion(part);
    mpz_tdiv_r_2exp(rest.get_mpz_t(), rest.get_mpz_t(), low);
  }
  return rest == 0 && out.valid();
}
bool expansion_of(const ExactVec& v, EVec& out) {
  return expansion_of(v[0], out[0]) && expansion_of(v[1], out[1]) && expansion_of(v[2], out[2]);
}
EVec expansion_of(const Vec3& v) { return {Expansion(v.x()), Expansion(v.y()), Expansion(v.z())}; }
// The components summed exactly (Dyadic: no rational additions).
Q rational_of(const Expansion& e) {
  Dyadic sum = Dyadic::of(0.0);
  for (int i = 0; i < e.size(); ++i) sum = sum + Dyadic::of(e.component(i));
  return sum.rational();
}
std::optional<LineContact> line_contact(const EVec& o, const EVec& d, const EVec& moment, const std::array<EVec, 3>& v,
                                        bool inside) {
  Expansion num, den;
  std::optional<LineContact> c = contact_terms<Expansion>(o, d, moment, v, inside, num, den);
  if (c && c->kind == LineContact::crossing) c->t = rational_of(num) / rational_of(den);
  return c;
}

// x itself where it is a double (num / 2^k with a numerator of at most 53 bits, k ≤ 1022 so the
// value is no subnormal): a witness's unmoved numbers, read without rational arithmetic.
std::optional<double> exact_double(const Q& x) {
  const mpz_srcptr num = x.get_num_mpz_t(), den = x.get_den_mpz_t();
  if (mpz_sizeinbase(num, 2) > 53 || mpz_popcount(den) != 1) return std::nullopt;
  const std::size_t k = mpz_sizeinbase(den, 2) - 1;
  if (k > 1022) return std::nullopt;
  return std::ldexp(mpz_get_d(num), -int(k));
}

// A filter in front of line_contact: interval arithmetic in double, each operation's result
// widened outward by one ulp (round to nearest errs by at most half an ulp, so the exact value
// stays inside), each rational input enclosed by the doubles on either side of its truncation
// (an input that is a double by itself).
// It answers only "certainly a miss": an edge function whose whole interval has the sign
// opposite to n·d's whole interval (line_contact's own miss condition, proved).
struct Interval {
  double lo, hi;
  static Interval of(const Q& x) {
    if (const auto d = exact_double(x)) return {*d, *d};
    const double d = x.get_d();  // truncated toward zero: x lies within one ulp of it
    return {next_down(d), next_up(d)};
  }
  friend Interval operator-(Interval a, Interval b) { return {next_down(a.lo - b.hi), next_up(a.hi - b.lo)}; }
  friend Interval operator+(Interval a, Interval b) { return {next_down(a.lo + b.lo), next_up(a.hi + b.hi)}; }
  friend Interval operator*(Interval a, Interval b) {
    const double p[] = {a.lo * b.lo, a.lo * b.hi, a.hi * b.lo, a.hi * b.hi};
    return {next_down(std::min({p[0], p[1], p[2], p[3]})), next_up(std::max({p[0], p[1], p[2], p[3]}))};
  }
  int sign() const { return lo > 0 ? 1 : hi < 0 ? -1 : 0; }  // 0: not certain (or NaN)
};
using IVec = std::array<Interval, 3>;
IVec interval_vec(const ExactVec& v) { return {Interval::of(v[0]), Interval::of(v[1]), Interval::of(v[2])}; }
IVec point_interval(const Vec3& v) { return {Interval{v.x(), v.x()}, Interval{v.y(), v.y()}, Interval{v.z(), v.z()}}; }
// What the intervals decide of line_contact's kind: a miss, a crossing (n·d and every edge
// certainly of one sign: inside, off every edge), or nothing (0).
enum class Certain { nothing, miss, crossing };
Certain certain_contact(const IVec& o, const IVec& d, const std::array<IVec, 3>& v) {
  const int sd = dot(cross(sub(v[1], v[0]), sub(v[2], v[0])), d).sign();
  if (sd == 0) return Certain::nothing;
  const IVec rel[3] = {sub(v[0], o), sub(v[1], o), sub(v[2], o)};
  bool inside = true;
  for (int k = 0; k < 3; ++k) {
    const int se = dot(d, cross(rel[k], rel[(k + 1) % 3])).sign();
    if (se == -sd) return Certain::miss;
    inside = inside && se == sd;
  }
  return inside ? Certain::crossing : Certain::nothing;
}

// A point p lying in the triangle's plane: inside the closed triangle?
bool in_plane_point_inside(const ExactVec& p, const std::array<ExactVec, 3>& v) {
  const ExactVec n = cross(sub(v[1], v[0]), sub(v[2], v[0]));
  for (int k = 0; k < 3; ++k)
    if (sgn(dot(n, cross(sub(v[(k + 1) % 3], v[k]), sub(p, v[k])))) < 0) return false;
  return true;
}

bool in_range(const Q& t, const TracerRay& r, RangeRule range) {
  const Q lo = exact_of(r.tmin);
  if (range == RangeRule::closed ? t < lo : t <= lo) return false;
  if (std::isinf(r.tmax)) return true;
  const Q hi = exact_of(r.tmax);
  return range == RangeRule::closed ? t <= hi : t < hi;
}

// The moved input: the witness's ray, and each vertex moved or as it was.
struct MovedInput {
  const TriangleMesh& mesh;
  const Witness& w;
  ExactVec vertex(std::uint32_t i) const {
    if (const auto it = w.vertices.find(i); it != w.vertices.end()) return it->second;
    return exact_vec(mesh.vertex(i));
  }
  std::array<ExactVec, 3> triangle(std::uint32_t t) const {
    const auto c = mesh.corners(t);
    return {vertex(c[0]), vertex(c[1]), vertex(c[2])};
  }
  // line_contact of the witness's ray with triangle t, the intervals first.
  LineContact contact(std::uint32_t t) const { return contact(interval_vec(w.origin), interval_vec(w.direction), t); }
  LineContact contact(const IVec& io, const IVec& id, std::uint32_t t) const {
    const Certain filtered = certain_contact(io, id, triangle_intervals(t));
    if (filtered == Certain::miss) return {};
    return exact_contact(t, filtered == Certain::crossing);
  }
  // line_contact without the filter (`inside`: it proved the interior crossed), expansions first
  // (no allocation), rationals where they cannot say.
  LineContact exact_contact(std::uint32_t t, bool inside) const {
    if (!ray_expansions) {
      ray_expansions.emplace();
      ray_converts =
          expansion_of(w.origin, ray_expansions->origin) && expansion_of(w.direction, ray_expansions->direction);
      if (ray_converts) ray_expansions->moment = cross(ray_expansions->direction, ray_expansions->origin);
    }
    if (ray_converts) {
      std::array<EVec, 3> corners;
      const auto c = mesh.corners(t);
      bool converts = true;
      for (int k = 0; k < 3 && converts; ++k) {
        if (const auto it = w.vertices.find(c[k]); it != w.vertices.end()) {
          const std::optional<EVec>& moved = moved_expansion(c[k], it->second);
          converts = moved.has_value();
          if (converts) corners[k] = *moved;
        } else {
          corners[k] = expansion_of(mesh.vertex(c[k]));
        }
      }
      if (converts)
        if (auto fast = line_contact(ray_expansions->origin, ray_expansions->direction, ray_expansions->moment, corners,
                                     inside))
          return *fast;
    }
    return line_contact(w.origin, w.direction, triangle(t), inside);
  }
  struct RayExpansions {
    EVec origin, direction, moment;
  };
  mutable std::optional<RayExpansions> ray_expansions;  // the witness's ray, converted once
  mutable bool ray_converts = false;
  // A moved vertex converted once (nullopt: beyond the expansions), as expansions and as intervals:
  // it is a corner of several of the triangles a truth looks at.
  mutable std::vector<std::pair<std::uint32_t, std::optional<EVec>>> moved_expansions;
  mutable std::vector<std::pair<std::uint32_t, IVec>> moved_intervals;
  const std::optional<EVec>& moved_expansion(std::uint32_t i, const ExactVec& v) const {
    for (const auto& [index, e] : moved_expansions)
      if (index == i) return e;
    EVec e;
    moved_expansions.emplace_back(i, expansion_of(v, e) ? std::optional<EVec>(e) : std::nullopt);
    return moved_expansions.back().second;
  }
  const IVec& moved_interval(std::uint32_t i, const ExactVec& v) const {
    for (const auto& [index, iv] : moved_intervals)
      if (index == i) return iv;
    moved_intervals.emplace_back(i, interval_vec(v));
    return moved_intervals.back().second;
  }
  // Whether the witness's ray crosses triangle t (no t computed where the intervals decide).
  bool crosses(std::uint32_t t) const {
    const Certain filtered = certain_contact(interval_vec(w.origin), interval_vec(w.direction), triangle_intervals(t));
    if (filtered != Certain::nothing) return filtered == Certain::crossing;
    return exact_contact(t, false).kind == LineContact::crossing;
  }
  // The same corners as intervals for the filter: a point interval where the vertex is a double.
  std::array<IVec, 3> triangle_intervals(std::uint32_t t) const {
    const auto c = mesh.corners(t);
    std::array<IVec, 3> out;
    for (int k = 0; k < 3; ++k) {
      if (const auto it = w.vertices.find(c[k]); it != w.vertices.end()) {
        out[k] = moved_interval(c[k], it->second);
      } else {
        out[k] = point_interval(mesh.vertex(c[k]));
      }
    }
    return out;
  }
};

// The exact truth over the moved input, as MeshTruth is over the given one.
struct ExactContact {
  std::uint32_t triangle;
  Q t;
  bool optional;  // at a closed range's end
  MeshOracle::PointContact at;
};
struct ExactTruth {
  std::vector<ExactContact> contacts;            // by t
  std::vector<std::vector<std::size_t>> points;  // crossings (not optional) grouped by equal t
  std::vector<bool> required;                    // per point
  std::set<std::uint32_t> unknown;               // in-plane or degenerate candidates: optional, t unknown
  const ExactContact* of(std::uint32_t t) const {
    for (const ExactContact& c : contacts)
      if (c.triangle == t) return &c;
    return nullptr;
  }
  std::optional<std::size_t> first_required() const {
    for (std::size_t i = 0; i < points.size(); ++i)
      if (required[i]) return i;
    return std::nullopt;
  }
};

// Contacts of the input a truth is computed for, already known to its caller (in.contact's).
using KnownContacts = std::vector<std::pair<std::uint32_t, LineContact>>;

// Triangle t's contact with the moved input, added to the truth: a crossing in range, or an
// unknown (collinear as given and not moved, in the line's plane, or degenerate after the move).
void add_exact_contact(ExactTruth& truth, const MeshOracle& oracle, const TracerRay& r, const MovedInput& in,
                       const IVec& io, const IVec& id, std::uint32_t t, RangeRule range, const KnownContacts& known) {
  const TriangleMesh& mesh = oracle.mesh();
  if (t >= mesh.triangle_count()) return;
  const auto c0 = mesh.corners(t);
  if (oracle.degenerate(t) && !in.w.vertices.contains(c0[0]) && !in.w.vertices.contains(c0[1]) &&
      !in.w.vertices.contains(c0[2])) {  // collinear as given and not moved: optional, t unknown
    truth.unknown.insert(t);
    return;
  }
  const auto k = std::ranges::find(known, t, &KnownContacts::value_type::first);
  const LineContact c = k != known.end() ? k->second : in.contact(io, id, t);
  if (c.kind == LineContact::in_plane || c.kind == LineContact::degenerate) {
    truth.unknown.insert(t);
    return;
  }
  if (c.kind != LineContact::crossing || !in_range(c.t, r, range)) return;
  const bool at_end =
      range == RangeRule::closed && (c.t == exact_of(r.tmin) || (!std::isinf(r.tmax) && c.t == exact_of(r.tmax)));
  truth.contacts.push_back({t, c.t, at_end, {t, c.boundary, c.front, c.zero_edge}});
}

// The contacts sorted by t, the crossings (not optional) grouped by equal t, each group's
// requirement (an interior crossing, or the one-hit rule at a shared edge or fan centre).
void group_by_t(ExactTruth& truth, const MeshOracle& oracle) {
  std::sort(truth.contacts.begin(), truth.contacts.end(), [](const ExactContact& a, const ExactContact& b) {
    return a.t != b.t ? a.t < b.t : a.triangle < b.triangle;
  });
  for (std::size_t i = 0; i < truth.contacts.size(); ++i) {
    const ExactContact& c = truth.contacts[i];
    if (c.optional) continue;
    if (truth.points.empty() || truth.contacts[truth.points.back().front()].t != c.t) truth.points.push_back({});
    truth.points.back().push_back(i);
  }
  for (const auto& p : truth.points) {
    std::vector<MeshOracle::PointContact> at;
    bool interior = false;
    for (std::size_t i : p) at.push_back(truth.contacts[i].at), interior = interior || !truth.contacts[i].at.boundary;
    truth.required.push_back(interior || oracle.one_hit_rule_applies(at));
  }
}

ExactTruth exact_truth(const MeshOracle& oracle, const TracerRay& r, const Witness& w, RangeRule range,
                       const std::vector<std::uint32_t>& also, const KnownContacts& known = {}) {
  const TriangleMesh& mesh = oracle.mesh();
  const MovedInput in{mesh, w};
  // The candidates: triangles whose box, grown by the margin below, the double ray nearest the
  // witness's ray meets (Bvh::traverse is conservative for that double ray). A point p = o' + t·d'
  // of the witness's ray inside a moved triangle's box lies within dv (the largest vertex move)
  // of the original box, and |p| ≤ M + dv; the axis k of the largest |d| then bounds
  // t ≤ T = (M + dv + |o'_k|) / |d'_k|, and the double ray r0 at that t lies within
  // dev_o + T·dev_d of p. Margin: twice dv + dev_o + T·dev_d (each computed upward to within a few
  // roundings, which the factor 2 covers). Only contacts at t ≤ tmax are in range: r0 at the same
  // t lies in the grown box, so the traversal stops at tmax.
  // The moves are bounded from above by intervals (the truth's filter encloses the moved numbers
  // anyway): a bound a few roundings loose only adds candidates.
  const Ray& r0 = r.ray;  // the ray as judged: the witness lies within its move of it
  const IVec io = interval_vec(w.origin), id = interval_vec(w.direction);
  auto most_moved = [](const IVec& moved, const Vec3& given) {
    double most = 0;
    for (int k = 0; k < 3; ++k) {
      const Interval m = moved[k] - Interval{given[k], given[k]};
      most = std::max({most, -m.lo, m.hi});
    }
    return most;
  };
  const double dev_o = most_moved(io, r0.origin), dev_d = most_moved(id, r0.direction);
  double dv = 0;
  for (const auto& [i, v] : w.vertices) dv = std::max(dv, most_moved(in.moved_interval(i, v), mesh.vertex(i)));
  const double dmax = max_abs(r0.direction) - dev_d;
  const double far = dmax > 0 ? (oracle.magnitude() + dv + max_abs(r0.origin) + dev_o) / dmax
                              : std::numeric_limits<double>::infinity();
  const double margin = 2 * (dv + dev_o + far * dev_d) + 0x1p-1000;
  std::vector<std::uint32_t> candidates(also.begin(), also.end());  // sorted and unique below
  for (const auto& [i, v] : w.vertices)
    if (i < mesh.vertex_count())
      for (std::uint32_t t : oracle.triangles_around(i)) candidates.push_back(t);
  if (std::isfinite(margin) && std::isfinite(far))
    oracle.triangles_near(
        r0, margin, [&](std::uint32_t t) { candidates.push_back(t); }, r.tmax);
  else
    for (std::uint32_t t = 0; t < mesh.triangle_count(); ++t) candidates.push_back(t);
  std::sort(candidates.begin(), candidates.end());
  candidates.erase(std::unique(candidates.begin(), candidates.end()), candidates.end());

  ExactTruth truth;
  for (std::uint32_t t : candidates) add_exact_contact(truth, oracle, r, in, io, id, t, range, known);
  group_by_t(truth, oracle);
  return truth;
}

// The truth of w after the vertices `moved` moved (w holds their new places; `truth` was w's
// before): only the triangles around them changed, and each is judged again; every other
// triangle's contact is the same, and the candidates that found it stay complete for it (its
// box did not move, the ray did not either). The candidates still include every triangle the
// first truth was given (`also`): those around the moved vertices are judged again, the others
// keep their place. `known`: contacts after the move known to the caller.
void update_after_move(ExactTruth& truth, const MeshOracle& oracle, const TracerRay& r, const Witness& w,
                       RangeRule range, const std::set<std::uint32_t>& moved, const KnownContacts& known) {
  std::vector<std::uint32_t> changed;
  for (std::uint32_t v : moved)
    for (std::uint32_t t : oracle.triangles_around(v)) changed.push_back(t);
  std::sort(changed.begin(), changed.end());
  changed.erase(std::unique(changed.begin(), changed.end()), changed.end());
  auto is_changed = [&](std::uint32_t t) { return std::binary_search(changed.begin(), changed.end(), t); };
  std::erase_if(truth.contacts, [&](const ExactContact& c) { return is_changed(c.triangle); });
  std::erase_if(truth.unknown, is_changed);
  const MovedInput in{oracle.mesh(), w};
  const IVec io = interval_vec(w.origin), id = interval_vec(w.direction);
  for (std::uint32_t t : changed) add_exact_contact(truth, oracle, r, in, io, id, t, range, known);
  truth.points.clear(), truth.required.clear();
  group_by_t(truth, oracle);
}

// The answer judged on the exact truth, as MeshOracle judges it (no ties): nullopt where a
// reported triangle's contact is unknown (in-plane or degenerate after the move).
std::optional<bool> exact_answer_right(const ExactTruth& truth, const MeshAnswer& a) {
  const auto req = truth.first_required();
  if (!a.all) {
    if (a.triangle == kNoTriangle) return !req;
    if (truth.unknown.contains(a.triangle)) return std::nullopt;
    const ExactContact* c = truth.of(a.triangle);
    if (!c) return false;
    if (!req) return true;
    return c->t <= truth.contacts[truth.points[*req].front()].t;
  }
  const std::set<std::uint32_t> reported(a.triangles.begin(), a.triangles.end());
  for (std::uint32_t t : reported) {
    if (truth.unknown.contains(t)) return std::nullopt;
    if (!truth.of(t)) return false;
  }
  for (std::size_t i = 0; i < truth.points.size(); ++i) {
    std::size_t n = 0;
    for (std::size_t k : truth.points[i]) {
      const ExactContact& c = truth.contacts[k];
      const bool in = reported.contains(c.triangle);
      n += in;
      if (!in && !c.at.boundary) return false;  // an interior crossing left out
    }
    if (truth.required[i] && !truth.points[i].empty()) {
      bool rule = true;
      for (std::size_t k : truth.points[i]) rule = rule && truth.contacts[k].at.boundary;
      if (rule && n != 1) return false;  // the one-hit rule: exactly one
    }
  }
  return true;
}

std::vector<std::uint32_t> reported_of(const MeshAnswer& a, std::size_t triangles) {
  std::vector<std::uint32_t> out;
  if (!a.all && a.triangle != kNoTriangle && a.triangle < triangles) out.push_back(a.triangle);
  if (a.all)
    for (std::uint32_t t : a.triangles)
      if (t < triangles) out.push_back(t);
  return out;
}

// The judged ray in rationals, made once for all of a β's tries.
struct ExactRay {
  ExactVec o, d;
  explicit ExactRay(const Ray& r) : o(exact_vec(r.origin)), d(exact_vec(r.direction)) {}
};

// ε of a witness: the largest move over what it may move, exactly, rounded up.
// The largest of |moved − given| over the pairs, exactly: in dyadic numbers (a rational where a
// witness read from a file is not dyadic), unmoved numbers skipped.
class LargestMove {
 public:
  void add(const Q& moved, double given) {
    if (exact_double(moved) == given) return;
    if (const auto d = Dyadic::of(moved)) {
      add_move(*d - Dyadic::of(given));
    } else {
      other_ = std::max(other_, Q(abs(moved - exact_of(given))));
    }
  }
  void add_move(Dyadic move) {
    if (!most_ || compare_magnitudes(move, *most_) > 0) most_ = std::move(move);
  }
  Q exact() const { return most_ ? std::max(other_, Q(abs(most_->rational()))) : other_; }
  // The largest move over u·by, rounded up to a double: one division in MPFR, correctly rounded
  // upwards from exact operands (u a power of two), where the moves are dyadic.
  double over_rounded_up(double by, double u) const {
    if (other_ != 0) return round_up(Q(exact() / (exact_of(u) * exact_of(by))));
    if (!most_ || most_->sign() == 0) return 0;
    const mpz_class magnitude = abs(most_->m);
    mpfr_t x, y;
    mpfr_init2(x, std::max<mpfr_prec_t>(MPFR_PREC_MIN, mpfr_prec_t(mpz_sizeinbase(magnitude.get_mpz_t(), 2))));
    mpfr_init2(y, 53);
    mpfr_set_z_2exp(x, magnitude.get_mpz_t(), most_->e, MPFR_RNDN);  // exact: x has the bits
    mpfr_div_d(y, x, by, MPFR_RNDU);
    mpfr_mul_2si(y, y, -std::ilogb(u), MPFR_RNDU);  // exact: a power of two
    const double out = mpfr_get_d(y, MPFR_RNDU);    // a double is a 53-bit number: no second rounding
    mpfr_clear(x), mpfr_clear(y);
    return out;
  }

 private:
  std::optional<Dyadic> most_;
  Q other_ = 0;
};

// ε of the moves: the largest coordinate move over u·S, the largest direction move over u·‖d‖∞,
// exactly, rounded up.
double ulps_of_moves(const LargestMove& points, const LargestMove& directions, double scale, const Ray& ray, double u) {
  // Rounding up commutes with the maximum.
  return std::max(points.over_rounded_up(scale, u), directions.over_rounded_up(max_abs(ray.direction), u));
}

double witness_ulps(const MeshOracle& oracle, const TracerRay& r, const Witness& w, double u) {
  LargestMove points, directions;
  for (int k = 0; k < 3; ++k) {
    points.add(w.origin[k], r.ray.origin[k]);
    directions.add(w.direction[k], r.ray.direction[k]);
  }
  for (const auto& [i, v] : w.vertices)
    for (int k = 0; k < 3; ++k) points.add(v[k], oracle.mesh().vertex(i)[k]);
  return ulps_of_moves(points, directions, w.scale, r.ray, u);
}

Witness unmoved(const ExactRay& given, double scale) {
  Witness w;
  w.scale = scale;
  w.origin = given.o, w.direction = given.d;
  return w;
}

// The ray moved so that at parameter tp it passes exactly through q: the move w = q − (o + tp·d)
// is split as Δd = w·‖d‖∞ / (S + tp·‖d‖∞) (rounded: any double will do) and Δo = w − tp·Δd
// (exact), so both use the same share of what they may move. Its ε (witness_ulps' number) from
// the moves themselves.
void move_ray_through(Witness& w, const TracerRay& r, const std::array<Dyadic, 3>& q, double tp, double u) {
  const Vec3 &o = r.ray.origin, &d = r.ray.direction;
  const Dyadic tq = Dyadic::of(tp);
  const double dn = max_abs(r.ray.direction), share = dn / (w.scale + tp * dn);
  LargestMove points, directions;
  for (int k = 0; k < 3; ++k) {
    const Dyadic ok = Dyadic::of(o[k]), move = q[k] - (ok + tq * Dyadic::of(d[k]));
    Dyadic dd = Dyadic::of(move.truncated() * share), shift = move - tq * dd;
    w.direction[k] = (Dyadic::of(d[k]) + dd).rational();
    w.origin[k] = (ok + shift).rational();
    points.add_move(std::move(shift)), directions.add_move(std::move(dd));
  }
  w.ulps = ulps_of_moves(points, directions, w.scale, r.ray, u);
}

// The point of segment [a, b] nearest the ray's line (Euclidean, in double: only its size
// matters) as a + s·(b − a) with s in [0, 1], and the ray's parameter there.
std::pair<double, double> nearest_on_edge(const Ray& ray, const Vec3& a, const Vec3& b) {
  const Vec3 e = b - a, w0 = a - ray.origin, d = ray.direction;
  const double A = e.dot(e), B = e.dot(d), C = d.dot(d), D = e.dot(w0), E = d.dot(w0);
  const double den = A * C - B * B;
  double s = den > 0 ? (B * E - C * D) / den : 0.5;
  if (!(s >= 0)) s = 0;
  if (s > 1) s = 1;
  const Vec3 qd = a + s * e;
  return {s, (qd - ray.origin).dot(d) / C};
}

// A try's point: a + s·(b − a) exactly (a vertex: b = a, s = 0), met by the ray moved at tp.
struct ThroughPoint {
  Vec3 a, b;
  double s, tp;
  bool of_subject;
  std::array<Dyadic, 3> exact() const {
    std::array<Dyadic, 3> q;
    const Dyadic sq = Dyadic::of(s);
    for (int k = 0; k < 3; ++k) {
      const Dyadic ak = Dyadic::of(a[k]);
      q[k] = ak + sq * (Dyadic::of(b[k]) - ak);
    }
    return q;
  }
  // A lower bound of the try's ε before any vertex moves, in double: its move m = q − (o + tp·d)
  // is Δo + tp·Δd, so |m_k| ≤ ε·u·(S + tp·‖d‖∞); m computed in double errs by less than 8 units
  // of rounding of its terms (three roundings for q, two for o + tp·d, one for the difference).
  double least_ulps(const Ray& ray, double u, double scale) const {
    const double dn = max_abs(ray.direction);
    double most = 0;
    for (int k = 0; k < 3; ++k) {
      const double e = b[k] - a[k], q = a[k] + s * e, on_ray = ray.origin[k] + tp * ray.direction[k];
      const double slack =
          8 * kUnitRoundoff *
          (std::abs(a[k]) + std::abs(s * e) + std::abs(ray.origin[k]) + std::abs(tp * ray.direction[k]));
      most = std::max(most, std::abs(q - on_ray) * (1 - 4 * kUnitRoundoff) - slack);
    }
    return most / (u * (scale + tp * dn) * (1 + 0x1p-40));
  }
};

// Where a contact moved along the line must land: after lo (tmin; a closed range includes it) and
// before hi (included or not), inside either end by `room`: a 2^-12-ulp move, or half the span
// where less.
struct Landing {
  Q lo;
  std::optional<Q> hi;
  bool hi_included = false;
  Q room;
  // The shift s along the line (the contact then at t − s) that lands t; nullopt where it lies
  // inside already.
  std::optional<double> shift_for(const Q& t, RangeRule range) const {
    if (range == RangeRule::closed ? t < lo : t <= lo) return Q(t - (lo + room)).get_d();
    if (hi && (t > *hi || (t == *hi && !hi_included))) return Q(t - (*hi - room)).get_d();
    return std::nullopt;
  }
};
// nullopt where there is no room (hi at or before lo).
std::optional<Landing> landing(const TracerRay& r, std::optional<Q> hi, bool hi_included, double u, double scale) {
  Landing out{exact_of(r.tmin), std::move(hi), hi_included, exact_of(0x1p-12 * u * scale / max_abs(r.ray.direction))};
  if (out.hi && (*out.hi - out.lo) / 2 < out.room) out.room = (*out.hi - out.lo) / 2;
  if (out.room <= 0) return std::nullopt;
  return out;
}

// Moves the triangles' vertices (each once, all by the same shift along d: a shared edge moves
// whole) so that the first of them out of place comes into range and, in nearest mode, to at or
// before the first required crossing; `no` where that triangle has no contact with the line.
// `truth_out`: set to the exact truth of w as it ends (computed before the move, brought up to date after).
// `step_out`: where the move was dyadic, each vertex's move along each axis (the same for all).
enum class Placed { no, in_place, moved };
Placed move_into_place(const MeshOracle& oracle, const TracerRay& r, Witness& w, const std::set<std::uint32_t>& tris,
                       RangeRule range, double u, bool nearest, std::optional<ExactTruth>& truth_out,
                       std::optional<std::array<Dyadic, 3>>* step_out = nullptr) {
  const MovedInput in{oracle.mesh(), w};
  const std::vector<std::uint32_t> also(tris.begin(), tris.end());
  KnownContacts contacts;  // of the triangles to place, for the truth and the shift
  for (std::uint32_t tri : tris) contacts.emplace_back(tri, in.contact(tri));
  ExactTruth truth = exact_truth(oracle, r, w, range, also, contacts);
  const auto req = truth.first_required();
  std::optional<Q> hi;  // the latest t a contact may take
  bool hi_included = false;
  if (req && nearest) hi = truth.contacts[truth.points[*req].front()].t, hi_included = true;  // any-hit: in range
  if (!std::isinf(r.tmax) && (!hi || exact_of(r.tmax) <= *hi)) hi = exact_of(r.tmax), hi_included = false;
  const std::optional<Landing> land = landing(r, std::move(hi), hi_included, u, w.scale);
  if (!land) return Placed::no;
  std::optional<double> shift;  // contact at t − shift: vertices move by −shift·d
  for (const auto& [tri, c] : contacts) {
    if (c.kind != LineContact::crossing) return Placed::no;
    if ((shift = land->shift_for(c.t, range))) break;
  }
  if (!shift) {  // in place already
    truth_out = std::move(truth);
    return Placed::in_place;
  }
  std::set<std::uint32_t> vertices;
  for (std::uint32_t tri : tris)
    for (std::uint32_t v : oracle.mesh().corners(tri)) vertices.insert(v);
  // In dyadic integers where the numbers are dyadic (a witness's always are), else in rationals.
  const Dyadic sq = Dyadic::of(*shift);
  std::array<std::optional<Dyadic>, 3> step;
  for (int k = 0; k < 3; ++k)
    if (const auto dk = Dyadic::of(w.direction[k])) step[k] = sq * *dk;
  for (std::uint32_t v : vertices) {
    ExactVec p = in.vertex(v);
    for (int k = 0; k < 3; ++k) {
      const auto pk = Dyadic::of(p[k]);
      p[k] = pk && step[k] ? (*pk - *step[k]).rational() : Q(p[k] - exact_of(*shift) * w.direction[k]);
    }
    w.vertices[v] = p;
  }
  if (step_out && step[0] && step[1] && step[2]) *step_out = {*step[0], *step[1], *step[2]};
  // Every corner of a triangle to place moved by the same −shift·d: the triangle moved along the
  // line, which meets it at t − shift with the same edge signs (a triple product with d is
  // unchanged by adding multiples of d) — no need to judge it again.
  const Q moved_by = exact_of(*shift);
  for (auto& [tri, c] : contacts) c.t -= moved_by;
  update_after_move(truth, oracle, r, w, range, vertices, contacts);
  truth_out = std::move(truth);
  return Placed::moved;
}

// The unmoved witness w with its origin moved along d so that triangle t's contact, past a range
// end, lands inside it as move_into_place's would (Landing): o + s·d meets every point at its t − s, with the
// same edge signs (d·((v − o − s·d) × (v' − o − s·d)) = d·((v − o) × (v' − o))). Sets w's origin
// and ε (the moves s·d_k, exact) and returns t's contact after the move; nullopt where t is in
// range or not crossed, or ε exceeds `most` or `check_up_to` (w then is not a witness).
std::optional<KnownContacts> origin_along_d(const MeshOracle& oracle, const TracerRay& r, Witness& w, std::uint32_t t,
                                            RangeRule range, double u, double most, double check_up_to) {
  LineContact c = MovedInput{oracle.mesh(), w}.contact(t);
  if (c.kind != LineContact::crossing) return std::nullopt;
  const std::optional<Landing> land =
      landing(r, std::isinf(r.tmax) ? std::nullopt : std::optional(exact_of(r.tmax)), false, u, w.scale);
  const std::optional<double> shift = land ? land->shift_for(c.t, range) : std::nullopt;
  if (!shift) return std::nullopt;
  const Dyadic s = Dyadic::of(*shift);
  LargestMove points, directions;
  for (int k = 0; k < 3; ++k) {
    const Dyadic move = s * Dyadic::of(r.ray.direction[k]);
    w.origin[k] = (Dyadic::of(r.ray.origin[k]) + move).rational();
    if (move.sign() != 0) points.add_move(move);
  }
  w.ulps = ulps_of_moves(points, directions, w.scale, r.ray, u);
  if (!(w.ulps <= most) || w.ulps > check_up_to) return std::nullopt;
  c.t -= exact_of(*shift);
  return KnownContacts{{t, std::move(c)}};
}

}  // namespace

// ------------------------------------------------------------------------------ the witness
json Witness::to_json() const {
  json out = {{"ulps", ulps},
              {"scale", hex_double(scale)},
              {"ray", {{"origin", exact_vec_json(origin)}, {"direction", exact_vec_json(direction)}}}};
  if (shape) {  // the case format's fields (shape_to_json's walk), each number exact
    json j = {{"type", std::string(to_string(*shape))}};
    int next = 0;
    for (const ShapeField& f : shape_fields(*shape)) {
      json& field = j[std::string(f.name)];
      if (f.vectors == 0) {
        field = hex_exact(shape_numbers[next++]);
        continue;
      }
      json vecs = json::array();
      for (int i = 0; i < f.vectors; ++i, next += 3)
        vecs.push_back(exact_vec_json({shape_numbers[next], shape_numbers[next + 1], shape_numbers[next + 2]}));
      field = f.nested() ? vecs : vecs[0];
    }
    out["shape"] = std::move(j);
    return out;
  }
  json v = json::object();
  for (const auto& [i, p] : vertices) v[std::to_string(i)] = exact_vec_json(p);
  out["vertices"] = std::move(v);
  return out;
}

Witness Witness::from_json(const json& j) {
  Witness w;
  if (!j.is_object()) throw FieldError("witness", "expected an object");
  w.ulps = read_number(j.at("ulps"), "witness.ulps");
  w.scale = read_number(j.at("scale"), "witness.scale");
  const json& ray = require_object(j.at("ray"), "witness.ray");
  w.origin = read_exact_vec(ray.at("origin"), "witness.ray.origin");
  w.direction = read_exact_vec(ray.at("direction"), "witness.ray.direction");
  if (j.contains("shape")) {
    const json& sh = require_object(j.at("shape"), "witness.shape");
    const auto kind = sh.contains("type") && sh.at("type").is_string()
                          ? shape_kind_from_string(sh.at("type").get<std::string>())
                          : std::nullopt;
    if (!kind) throw FieldError("witness.shape.type", "expected sphere, plane, triangle or box");
    w.shape = *kind;
    int next = 0;
    for (const ShapeField& f : shape_fields(*kind)) {
      const std::string field = "witness.shape." + std::string(f.name);
      if (!sh.contains(std::string(f.name))) throw FieldError(field, "missing");
      const json& x = sh.at(std::string(f.name));
      if (f.vectors == 0) {
        const json one = json::array({x, x, x});  // read as a vector's component: one parser
        w.shape_numbers[next++] = read_exact_vec(one, field)[0];
        continue;
      }
      if (f.nested() && (!x.is_array() || x.size() != static_cast<std::size_t>(f.vectors)))
        throw FieldError(field, "expected " + std::to_string(f.vectors) + " vectors");
      for (int i = 0; i < f.vectors; ++i, next += 3) {
        const ExactVec v = read_exact_vec(f.nested() ? x[i] : x, field);
        for (int k = 0; k < 3; ++k) w.shape_numbers[next + k] = v[k];
      }
    }
  }
  if (j.contains("vertices")) {
    const json& v = require_object(j.at("vertices"), "witness.vertices");
    for (auto it = v.begin(); it != v.end(); ++it) {
      const std::string field = "witness.vertices." + printable_prefix(it.key(), 20);
      char* end = nullptr;
      const unsigned long i = std::strtoul(it.key().c_str(), &end, 10);
      if (it.key().empty() || *end != 0 || i > 0xfffffffeul) throw FieldError(field, "expected a vertex index");
      w.vertices[static_cast<std::uint32_t>(i)] = read_exact_vec(it.value(), field);
    }
  }
  return w;
}

// ------------------------------------------------------------------------------ MeshOracle
bool MeshOracle::touches_at(const Ray& ray, std::uint32_t triangle, double t0) const {
  if (triangle >= mesh_->triangle_count() || !std::isfinite(t0)) return false;
  const ExactVec o = exact_vec(ray.origin), d = exact_vec(ray.direction);
  const Triangle tri = mesh_->triangle(triangle);
  const std::array<ExactVec, 3> v = {exact_vec(tri.v[0]), exact_vec(tri.v[1]), exact_vec(tri.v[2])};
  const LineContact c = line_contact(o, d, v);
  const Q t = exact_of(t0);
  if (c.kind == LineContact::crossing) return c.t == t;
  if (c.kind != LineContact::in_plane) return false;
  ExactVec p;
  for (int k = 0; k < 3; ++k) p[k] = o[k] + t * d[k];
  return in_plane_point_inside(p, v);
}

RangeEnd MeshOracle::range_end_touched(const TracerRay& r, std::uint32_t triangle) const {
  if (triangle >= mesh_->triangle_count()) return RangeEnd::none;
  const Triangle tri = mesh_->triangle(triangle);
  {  // expansions first (exact while valid, no allocation): a crossing at t = num/den is at tmin
     // where num − tmin·den is 0; rationals where they cannot say, and for a line in the plane
    Expansion num, den;
    const EVec o = expansion_of(r.ray.origin), d = expansion_of(r.ray.direction);
    const auto c = contact_terms<Expansion>(
        o, d, cross(d, o), {expansion_of(tri.v[0]), expansion_of(tri.v[1]), expansion_of(tri.v[2])}, false, num, den);
    auto at = [&](double t) -> std::optional<bool> {
      const Expansion rest = num - Expansion(t) * den;
      return rest.valid() ? std::optional<bool>(sgn(rest) == 0) : std::nullopt;
    };
    if (c && c->kind != LineContact::crossing && c->kind != LineContact::in_plane) return RangeEnd::none;
    if (c && c->kind == LineContact::crossing) {
      const auto at_min = at(r.tmin);
      const auto at_max = std::isfinite(r.tmax) ? at(r.tmax) : std::optional<bool>(false);
      if (at_min && *at_min) return RangeEnd::tmin;
      if (at_min && at_max) return *at_max ? RangeEnd::tmax : RangeEnd::none;
    }
  }
  const ExactVec o = exact_vec(r.ray.origin), d = exact_vec(r.ray.direction);
  const std::array<ExactVec, 3> v = {exact_vec(tri.v[0]), exact_vec(tri.v[1]), exact_vec(tri.v[2])};
  const LineContact c = line_contact(o, d, v);
  if (c.kind == LineContact::crossing) {
    if (c.t == exact_of(r.tmin)) return RangeEnd::tmin;
    if (std::isfinite(r.tmax) && c.t == exact_of(r.tmax)) return RangeEnd::tmax;
    return RangeEnd::none;
  }
  if (c.kind != LineContact::in_plane) return RangeEnd::none;
  if (touches_at(r.ray, triangle, r.tmin)) return RangeEnd::tmin;
  if (std::isfinite(r.tmax) && touches_at(r.ray, triangle, r.tmax)) return RangeEnd::tmax;
  return RangeEnd::none;
}

// ------------------------------------------------------------------------------ β
double involved_scale(const MeshOracle& oracle, const TracerRay& r, const MeshTruth& truth, const MeshAnswer& a,
                      std::optional<std::uint32_t> subject) {
  const TriangleMesh& mesh = oracle.mesh();
  double s = max_abs(r.ray.origin);
  auto add = [&](std::uint32_t t) {
    if (t >= mesh.triangle_count()) return;
    for (std::uint32_t v : mesh.corners(t)) s = std::max(s, max_abs(mesh.vertex(v)));
  };
  for (std::uint32_t t : reported_of(a, mesh.triangle_count())) add(t);
  if (!truth.points.empty())
    for (std::uint32_t t : truth.points.front().triangles) add(t);
  if (const CrossingPoint* p = truth.first_required())
    for (std::uint32_t t : p->triangles) add(t);
  if (subject) add(*subject);
  return s > 0 ? s : 0x1p-1022;
}

namespace {
// The answer right on the witness's input, exactly (its ε not checked).
// `known`: the truth of this very input, computed with every reported triangle among its candidates
// (move_into_place's): the same contacts, and each reported triangle's kind.
std::optional<bool> answer_right_on(const MeshOracle& oracle, const TracerRay& r, const Witness& w, RangeRule range,
                                    const MeshAnswer& a, const ExactTruth* known = nullptr) {
  for (const auto& [i, v] : w.vertices)
    if (i >= oracle.mesh().vertex_count()) return false;
  if (w.direction[0] == 0 && w.direction[1] == 0 && w.direction[2] == 0) return false;
  if (known) return exact_answer_right(*known, a);
  const ExactTruth truth = exact_truth(oracle, r, w, range, reported_of(a, oracle.mesh().triangle_count()));
  return exact_answer_right(truth, a);
}
}  // namespace

std::optional<bool> witness_holds(const MeshOracle& oracle, const TracerRay& r, const Witness& w, RangeRule range,
                                  const MeshAnswer& a, Precision p) {
  if (!(w.scale > 0) || !(w.ulps >= 0)) return false;
  // A witness that moves more than it claims is refused.
  if (witness_ulps(oracle, r, w, unit_roundoff(p)) > w.ulps) return false;
  return answer_right_on(oracle, r, w, range, a);
}

BackwardError backward_error(const MeshOracle& oracle, const TracerRay& r, const MeshTruth& truth,
                             const TraceJudgement& j, const MeshAnswer& a, Precision p, RangeRule range,
                             double check_up_to) {
  BackwardError out;
  const TriangleMesh& mesh = oracle.mesh();
  // A double hit on a manifold edge or a closed fan's centre: every ray near it crosses the same
  // triangles, whichever way the input moves (verdicts.md: β none).
  if (j.kind == TraceKind::double_hit || (a.all && j.edge_double)) return out;
  const double u = unit_roundoff(p);
  std::optional<std::uint32_t> subject;  // a reported triangle to bring into place, or a missed one
  std::set<std::uint32_t> to_place;      // the reported triangles not touched in range (any-hit: all of them)
  bool place_subject = false;            // false_hit, not_nearest: the subject is moved into place
  bool only_open = false;                // a hole with nothing reported: only an open edge or vertex ends it
  std::set<std::uint32_t> around;        // the ray is tried through these triangles' edges and vertices
  const std::set<std::uint32_t> reported(a.triangles.begin(), a.triangles.end());
  switch (j.kind) {
    case TraceKind::hole: {
      const CrossingPoint* hole = truth.first_required();
      if (a.all)  // the first required point none of whose triangles is reported
        for (const CrossingPoint& q : truth.points) {
          if (!q.required()) continue;
          if (std::none_of(q.triangles.begin(), q.triangles.end(),
                           [&](std::uint32_t t) { return reported.contains(t); })) {
            hole = &q;
            break;
          }
        }
      if (!hole) return out;
      around.insert(hole->triangles.begin(), hole->triangles.end());
      // Nothing reported: only a move onto an open edge or vertex, or across a silhouette (a
      // shared edge whose triangles face the ray from opposite sides), can end it; where none
      // of the tries works and the crossing has no open edge or vertex, β is none.
      only_open = reported.empty();
      for (std::uint32_t t : reported)
        if (t < mesh.triangle_count()) around.insert(t);
      break;
    }
    case TraceKind::false_hit:
    case TraceKind::not_nearest:
      if (!a.all) {
        subject = a.triangle;
      } else {
        for (std::uint32_t t : a.triangles)
          if (t < mesh.triangle_count() && !truth.contact_of(t)) {
            subject = t;
            break;
          }
      }
      if (!subject || *subject >= mesh.triangle_count()) return out.refused = true, out;
      place_subject = true;
      to_place.insert(*subject);
      for (std::uint32_t t : a.triangles)
        if (t < mesh.triangle_count() && !truth.contact_of(t)) to_place.insert(t);
      around.insert(*subject);
      if (const CrossingPoint* req = truth.first_required())
        around.insert(req->triangles.begin(), req->triangles.end());
      break;
    case TraceKind::missed_in_any_hit:
      for (const CrossingPoint& q : truth.points)
        for (std::uint32_t t : q.triangles)
          if (!subject && !reported.contains(t) && !truth.contact_of(t)->boundary) subject = t;
      if (!subject) return out.refused = true, out;
      around.insert(*subject);
      break;
    default: return out.refused = true, out;  // tracer errors, crashes: no β
  }
  const double scale = involved_scale(oracle, r, truth, a, subject);
  const ExactRay given(r.ray);
  struct Try {
    Witness w;
    bool through_subject = false;     // through a point of the subject's own boundary
    bool placed = false;              // the subject moved into place (or no subject to place)
    bool unmoved = false;             // the subject moved along d alone
    std::optional<ExactTruth> truth;  // of w, once placed
  };
  // A truth computed while placing serves the check when it had every reported triangle among its
  // candidates (the placed ones are).
  const std::vector<std::uint32_t> reported_triangles = reported_of(a, mesh.triangle_count());
  const bool placing_sees_reported =
      std::ranges::all_of(reported_triangles, [&](std::uint32_t t) { return to_place.contains(t); });
  // The ray onto the nearest point of each edge, and onto each vertex: where a crossing stops
  // being required (an open edge, a vertex that is no closed fan's centre: either answer is right
  // there), joins a reported neighbour's (a shared edge or fan centre: the one-hit rule), or
  // reaches the reported triangle.
  std::vector<ThroughPoint> points;
  bool any_open = false;
  std::set<std::uint32_t> vertices;
  for (std::uint32_t t : around) {
    const auto c = mesh.corners(t);
    for (int k = 0; k < 3; ++k) {
      const bool open = !oracle.manifold_edge(c[k], c[(k + 1) % 3]);
      any_open = any_open || open;
      const Vec3 &va = mesh.vertex(c[k]), &vb = mesh.vertex(c[(k + 1) % 3]);
      const auto [s, tp] = nearest_on_edge(r.ray, va, vb);
      if (tp > 0) points.push_back({va, vb, s, tp, subject == t});
      vertices.insert(c[k]);
    }
  }
  for (std::uint32_t v : vertices) {
    const bool open = !oracle.closed_fan_centre(v);
    any_open = any_open || open;
    const Vec3& p = mesh.vertex(v);
    const bool of_subject = subject && std::ranges::count(mesh.corners(*subject), v) > 0;
    const double tp = (p - r.ray.origin).dot(r.ray.direction) / r.ray.direction.squaredNorm();
    if (tp > 0) points.push_back({p, p, 0, tp, of_subject});
  }
  // The subject moved along d alone (the unmoved ray, ε 0 before the move) is the first try; where
  // it still is after its move (every other try's ε is at least its lower bound) and holds, it is
  // β, as the search below would find, without building the other tries in rationals.
  // Where it is not, the search below reuses what was learnt of it.
  struct FirstTry {
    std::optional<Witness> placed;    // nullopt: it could not be moved into place
    std::optional<ExactTruth> truth;  // of placed
    bool refused = false;             // checked, and the answer is not right on it
  };
  std::optional<FirstTry> first_try;
  if (place_subject) {
    double lowest = INFINITY;
    for (const ThroughPoint& q : points) lowest = std::min(lowest, q.least_ulps(r.ray, u, scale));
    // A reported contact just past a range end: the ray's origin moved along d instead, by the
    // very move the try below gives the subject's vertices (the same ε), carries every contact
    // with it and no vertex; its truth is one search over the moved ray, without judging again
    // the triangles around moved vertices. Checked as any witness; where it fails, the tries go on.
    if (to_place.size() == 1 && lowest > 0) {
      Witness along = unmoved(given, scale);
      if (const auto known = origin_along_d(oracle, r, along, *subject, range, u, lowest, check_up_to))
        // answer_right_on's own check: no vertex moved, and d (the ray's own) is not zero.
        if (exact_answer_right(exact_truth(oracle, r, along, range, reported_triangles, *known), a) == true) {
          out.beta = along.ulps;
          out.witness = std::make_shared<const Witness>(std::move(along));
          out.checked = true;
          return out;
        }
    }
    Witness first = unmoved(given, scale);
    if (lowest > 0 && MovedInput{mesh, first}.crosses(*subject)) {
      first_try.emplace();
      std::optional<ExactTruth> truth_of_first;
      std::optional<std::array<Dyadic, 3>> step;
      if (move_into_place(oracle, r, first, to_place, range, u, !a.all, truth_of_first, &step) != Placed::no) {
        // Its ε: the ray stayed and every moved vertex moved by `step` (witness_ulps' number).
        LargestMove points, directions;
        if (step)
          for (const Dyadic& move : *step)
            if (move.sign() != 0) points.add_move(move);
        first.ulps = step ? ulps_of_moves(points, directions, scale, r.ray, u) : witness_ulps(oracle, r, first, u);
        if (first.ulps <= lowest && first.ulps <= check_up_to) {
          const ExactTruth* known = placing_sees_reported ? &*truth_of_first : nullptr;
          if (answer_right_on(oracle, r, first, range, a, known) == true) {
            out.beta = first.ulps;
            out.witness = std::make_shared<const Witness>(std::move(first));
            out.checked = true;
            return out;
          }
          first_try->refused = true;
        }
        first_try->placed = std::move(first);
        first_try->truth = std::move(truth_of_first);
      }
    }
  }
  std::vector<Try> candidates;
  candidates.reserve(points.size() + 1);
  if (place_subject) candidates.push_back({unmoved(given, scale), false, false, true});  // moved along d below
  for (const ThroughPoint& q : points) {
    Witness w;
    w.scale = scale;
    move_ray_through(w, r, q.exact(), q.tp, u);  // sets the whole ray, and ε
    candidates.push_back({std::move(w), q.of_subject});
  }
  // Nothing reported, no open edge or vertex at the crossing: a closed, consistently wound
  // surface there, none — unless a try slips past a silhouette (a fold grazed) after all.
  const bool closed_around = only_open && !any_open;
  if (candidates.empty()) return closed_around ? out : (out.refused = true, out);
  // Each try's ε is set: 0 unmoved, move_ray_through's own otherwise. The tries stay where they
  // are; their order is a list of positions (a try holds rationals, costly to move).
  std::vector<std::size_t> order(candidates.size());
  std::iota(order.begin(), order.end(), std::size_t{0});
  std::sort(order.begin(), order.end(),
            [&](std::size_t x, std::size_t y) { return candidates[x].w.ulps < candidates[y].w.ulps; });
  // The few smallest tries go on (each check is a rational truth over the triangles near the
  // ray); a reported triangle that the moved ray meets beyond the first required crossing, or out
  // of range, is then moved along d into place as well, which only adds to the try's ε.
  // Six tries where each needs the reported triangle moved into place first, eight otherwise
  // (a hole's escape may be the fifth-nearest vertex, the fan centre a reported neighbour owns).
  const std::size_t kTries = place_subject ? 6 : 8;
  if (place_subject) {  // first the tries whose moved ray meets the reported triangle at all
    // A try through a point q of the subject's closed boundary (q exact on it, and the moved
    // line passes exactly through q: move_ray_through) meets a non-degenerate subject exactly
    // where its line is not parallel to the plane: each edge function is 0 or of n·d's sign at q.
    const auto sc = mesh.corners(*subject);
    const std::array<Vec3, 3> sv = {mesh.vertex(sc[0]), mesh.vertex(sc[1]), mesh.vertex(sc[2])};
    const IVec normal =
        cross(sub(point_interval(sv[1]), point_interval(sv[0])), sub(point_interval(sv[2]), point_interval(sv[0])));
    const bool subject_degenerate = oracle.degenerate(*subject);
    auto meets = [&](const Try& c) {
      if (!c.through_subject || subject_degenerate) return MovedInput{mesh, c.w}.crosses(*subject);
      if (dot(normal, interval_vec(c.w.direction)).sign() != 0) return true;
      const ExactVec a = exact_vec(sv[0]);
      return sgn(dot(cross(sub(exact_vec(sv[1]), a), sub(exact_vec(sv[2]), a)), c.w.direction)) != 0;
    };
    // As a stable partition followed by keeping kTries, testing only as far as it needs.
    std::vector<std::size_t> meeting, other;
    for (std::size_t i : order) {
      if (meeting.size() == kTries) break;
      (meets(candidates[i]) ? meeting : other).push_back(i);
    }
    meeting.insert(meeting.end(), other.begin(), other.end());
    order = std::move(meeting);
  }
  if (order.size() > kTries) order.resize(kTries);
  // Best first: a try's ε before it is moved into place bounds its ε after from below (a move only
  // adds), so the tries are taken by what they may still reach, each moved into place (a rational
  // truth) only when it comes first and checked only when, placed, it is still the smallest: the
  // same β as moving and checking every try, with far fewer rational truths.
  std::vector<std::size_t> tries = std::move(order);
  for (std::size_t i : tries) candidates[i].placed = !place_subject;
  const double smallest = candidates[tries.front()].w.ulps;  // sorted above
  std::optional<double> least_placed;  // the smallest ε of a try in place: β where every check fails
  while (!tries.empty()) {
    const auto next = std::min_element(tries.begin(), tries.end(), [&](std::size_t i, std::size_t j) {
      const Try &x = candidates[i], &y = candidates[j];
      return x.w.ulps != y.w.ulps ? x.w.ulps < y.w.ulps : x.placed > y.placed;
    });
    Try& t = candidates[*next];
    const bool known = t.unmoved && first_try;  // placed (and maybe checked) above already
    if (!t.placed) {
      const Placed placed = known ? (first_try->placed ? Placed::moved : Placed::no)
                                  : move_into_place(oracle, r, t.w, to_place, range, u, !a.all, t.truth);
      if (placed == Placed::no) {
        tries.erase(next);
        continue;
      }
      if (known)
        t.w = *first_try->placed, t.truth = std::move(first_try->truth);
      else if (placed == Placed::moved)  // its ε grew (in place, it is move_ray_through's still)
        t.w.ulps = witness_ulps(oracle, r, t.w, u);
      t.placed = true;
      continue;
    }
    if (!least_placed) least_placed = t.w.ulps;
    if (t.w.ulps > check_up_to) {
      out.beta = *least_placed;
      if (out.beta > check_up_to) return out.estimated = true, out;  // a bug, whichever try would pass
      break;
    }
    // Its ε is witness_ulps' own (above): what witness_holds would recompute first.
    const ExactTruth* truth_of_w = placing_sees_reported && t.truth ? &*t.truth : nullptr;
    if (!(known && first_try->refused) && answer_right_on(oracle, r, t.w, range, a, truth_of_w) == true) {
      out.beta = t.w.ulps;
      out.witness = std::make_shared<const Witness>(std::move(t.w));
      out.checked = true;
      return out;
    }
    tries.erase(next);
  }
  if (!least_placed) return out.beta = smallest, out.refused = true, out;  // none could be placed: unproved
  out.beta = *least_placed;
  if (closed_around) return BackwardError{};  // closed around the crossing, nothing reported: none
  out.refused = true;
  return out;
}

}  // namespace rayproof
