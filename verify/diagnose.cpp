#include "rayproof/verify/diagnose.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <set>

#include "rayproof/core/geometry.h"
#include "rayproof/core/json_fields.h"
#include "rayproof/core/shapes.h"

namespace rayproof {

std::string Disagreement::kind() const {
  return failure.empty() ? std::string(to_string(exact)) + "->" + std::string(to_string(answered)) : failure;
}

std::vector<Disagreement> disagreements_in_findings(const std::vector<Case>& findings, const std::string& file) {
  std::vector<Disagreement> out;
  for (const Case& c : findings) {
    if (!c.expect || !c.found.is_object() || !c.found.contains("disagreeing")) continue;
    Case bare;  // the case without `found` (witnesses make it large; nothing below reads it)
    static_cast<Query&>(bare) = c;
    bare.expect = c.expect;
    for (const auto& [variant, answer] : c.found.at("disagreeing").items()) {
      Disagreement d;
      d.variant = variant;
      d.c = bare;
      d.file = file;
      d.exact = c.expect->cls;
      d.exact_t = c.expect->t;
      if (answer.contains("error")) {
        d.failure = answer.at("error").is_string() ? answer.at("error").get<std::string>() : "error";
        if (d.failure == "answer outside 0..5" || d.failure.rfind("contact with", 0) == 0) d.failure = "plugin_error";
      } else {
        const auto cls = answer_class_from_string(answer.value("class", ""));
        if (!cls) continue;
        d.answered = *cls;
        if (answer.contains("t") && !answer.at("t").is_null()) {
          try {
            d.answered_t = read_number(answer.at("t"), "t");
          } catch (const FieldError&) {  // "inf": a contact beyond the double range
            d.answered_t = INFINITY;
          }
        }
      }
      out.push_back(std::move(d));
    }
  }
  return out;
}

std::vector<KindExample> examples_by_kind(const std::vector<Disagreement>& all) {
  std::map<std::pair<std::string, std::string>, KindExample> by;
  std::vector<std::pair<std::string, std::string>> order;
  for (std::size_t i = 0; i < all.size(); ++i) {
    const auto key = std::pair{all[i].variant, all[i].kind()};
    auto [it, fresh] = by.try_emplace(key, KindExample{key.first, key.second, 0, i});
    if (fresh) order.push_back(key);
    ++it->second.count;
  }
  std::vector<KindExample> out;
  for (const auto& key : order) out.push_back(by.at(key));
  std::stable_sort(out.begin(), out.end(),
                   [](const KindExample& a, const KindExample& b) { return a.count > b.count; });
  return out;
}

namespace {

// |v| without overflow or underflow (directions of 1e-320 have a length).
double norm(const Vec3& v) { return std::hypot(v.x(), v.y(), v.z()); }

std::string number(double x) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3g", x);
  return buf;
}

// The largest magnitude among a case's numbers (ray and shape), and the smallest non-zero one.
std::pair<double, double> magnitudes(const Case& c) {
  double numbers[6 + kMaxShapeNumbers];
  for (int k = 0; k < 3; ++k) numbers[k] = c.ray.origin[k], numbers[3 + k] = c.ray.direction[k];
  shape_numbers(c.shape, numbers + 6);
  const int n = 6 + shape_number_count(kind_of(c.shape));
  double hi = 0, lo = INFINITY;
  for (int i = 0; i < n; ++i) {
    const double a = std::abs(numbers[i]);
    hi = std::max(hi, a);
    if (a > 0) lo = std::min(lo, a);
  }
  return {hi, lo};
}

// The shape's size: a sphere's radius, a triangle's longest edge, a box's diagonal; a plane's
// offset or the origin's distance from 0, whichever is larger.
double size_of(const Case& c) {
  return std::visit(
      [&](const auto& s) -> double {
        using S = std::decay_t<decltype(s)>;
        if constexpr (std::is_same_v<S, Sphere>)
          return s.radius;
        else if constexpr (std::is_same_v<S, Triangle>)
          return std::max({norm(s.v[1] - s.v[0]), norm(s.v[2] - s.v[1]), norm(s.v[0] - s.v[2])});
        else if constexpr (std::is_same_v<S, Box>)
          return norm(s.max - s.min);
        else
          return std::max(std::abs(s.offset), norm(c.ray.origin));
      },
      c.shape);
}

// A threshold the data shows: a value T in [least, most] where the values fall off a cliff — at
// least 5 in (T/10, T], at most an eighth as many in (T, 10T], at least a fifth of all values
// <= T — the sharpest such edge (a fixed epsilon makes one, blurred a little when the code
// rounds to float; a spread of rounding errors does not).
struct Edge {
  std::size_t below = 0, just_above = 0;
  double threshold = 0, sharpness = 0;  // sharpness: values in (T/10, T] per value in (T, 10T], plus one
};
std::optional<Edge> sharp_upper_edge(std::vector<double> v, double least, double most) {
  if (v.size() < 5) return std::nullopt;
  std::sort(v.begin(), v.end());
  auto count_in = [&](double lo, double hi) {  // values in (lo, hi]
    return static_cast<std::size_t>(std::upper_bound(v.begin(), v.end(), hi) -
                                    std::upper_bound(v.begin(), v.end(), lo));
  };
  std::optional<Edge> best;
  for (std::size_t i = 0; i < v.size(); ++i) {
    if (v[i] < least || v[i] > most || (i + 1 < v.size() && v[i + 1] == v[i])) continue;
    const std::size_t under = count_in(v[i] / 10, v[i]), over = count_in(v[i], 10 * v[i]);
    if (under < 5 || 8 * over > under || 5 * (i + 1) < v.size()) continue;
    const double sharpness = double(under) / double(over + 1);
    if (!best || sharpness >= best->sharpness) best = Edge{i + 1, over, v[i], sharpness};
  }
  return best;
}

// Where squares and products of a case's numbers leave the format: the magnitudes H4 reports.
int overflow_exponent(Precision p) { return p == Precision::f32 ? 31 : 250; }
int underflow_exponent(Precision p) { return p == Precision::f32 ? -37 : -250; }

// A contact answered as a miss, on a case whose numbers stay clear of overflow and underflow
// (those are H4's: a threshold seen there would be theirs, not an epsilon's).
bool contact_missed(const Disagreement& d, Precision p) {
  if (!(d.failure.empty() && d.answered == HitClass::miss &&
        (d.exact == HitClass::enter || d.exact == HitClass::exit) && d.exact_t && *d.exact_t > 0 &&
        std::isfinite(*d.exact_t)))
    return false;
  const auto [hi, lo] = magnitudes(d.c);
  return std::ilogb(hi) < overflow_exponent(p) && (lo == INFINITY || std::ilogb(lo) > underflow_exponent(p));
}

// H1: contacts missed below a threshold: a fixed t_min on t, a minimum distance t·|d|, or — when
// the edge is sharper relative to the shape's size — the code's own rounding of the origin
// (a ray spawned from a surface). The measure whose edge is sharpest is the one reported.
// Epsilons people write lie in [1e-13, 0.1]; rounding edges at 2^-(p-8) or below. Returns what
// it found, so later hints leave out what it explains.
struct Explained {
  double t_min = 0;              // contacts with exact t <= this
  double relative_distance = 0;  // contacts within this x the shape's size of the origin
  bool covers(const Disagreement& d) const {
    if (!d.exact_t) return false;
    const double size = size_of(d.c);
    return *d.exact_t <= t_min || (size > 0 && *d.exact_t * norm(d.c.ray.direction) <= relative_distance * size);
  }
};
Explained near_contacts_dropped(const std::vector<const Disagreement*>& ds, Precision precision,
                                std::vector<Hint>& hints) {
  std::vector<double> ts, distances, relative;
  for (const Disagreement* d : ds)
    if (contact_missed(*d, precision)) {
      ts.push_back(*d->exact_t);
      distances.push_back(*d->exact_t * norm(d->c.ray.direction));
      const double size = size_of(d->c);
      relative.push_back(size > 0 ? distances.back() / size : INFINITY);
    }
  const int p = precision == Precision::f32 ? 24 : 53;
  const std::optional<Edge> edges[3] = {sharp_upper_edge(ts, 1e-13, 0.1), sharp_upper_edge(distances, 1e-13, 0.1),
                                        sharp_upper_edge(relative, 0, std::ldexp(1.0, -(p - 8)))};
  int best = -1;
  for (int m = 0; m < 3; ++m)
    if (edges[m] && (best < 0 || edges[m]->sharpness > edges[best]->sharpness)) best = m;
  if (best < 0) return {};
  const Edge& e = *edges[best];
  const std::string counts =
      std::to_string(e.below) + " of " + std::to_string(ts.size()) + " enter->miss/exit->miss findings";
  const std::string edge =
      number(e.threshold) + ", only " + std::to_string(e.just_above) + " between that and 10x more";
  if (best == 2) {
    hints.push_back({"the origin's rounding: a spawn offset is needed",
                     counts + " have their contact within " + number(e.threshold) +
                         " x the shape's size of the origin (only " + std::to_string(e.just_above) +
                         " between that and 10x more): the " + (p == 24 ? "float" : "double") +
                         " rounding of the origin (2^-" + std::to_string(p) +
                         " relative) decides them: rays spawned from a surface need an offset (see rayproof spawn)?"});
    return {0, e.threshold};
  }
  std::string hint = counts + " have exact " + (best == 1 ? "distance t*|d|" : "t") + " <= " + edge + ": a minimum " +
                     (best == 1 ? "distance" : "t (t_min, an epsilon)") + " of about " + number(e.threshold) +
                     " drops near contacts?";
  if (best == 0) {  // compared with t, the threshold does not scale with |d|: show the distances it spans
    double lo = INFINITY, hi = 0;
    for (std::size_t i = 0; i < ts.size(); ++i)
      if (ts[i] <= e.threshold) lo = std::min(lo, distances[i]), hi = std::max(hi, distances[i]);
    if (lo > 0 && hi > 1000 * lo)
      hint += " Their distances t*|d| run from " + number(lo) + " to " + number(hi) +
              ": a t_min on t is not scaled with the direction's length.";
  }
  hints.push_back({"a minimum t or distance drops near contacts", hint});
  return {best == 0 ? e.threshold : 0, 0};
}

// H2 (triangles): contacts dropped where the determinant e1·(d×e2) is small — an absolute
// "parallel" epsilon, not scaled with the triangle's size and the direction's length.
void small_determinants_dropped(const std::vector<const Disagreement*>& ds, Precision precision,
                                std::vector<Hint>& hints) {
  std::vector<double> dets;
  std::size_t missed = 0;
  for (const Disagreement* d : ds) {
    const auto* tri = std::get_if<Triangle>(&d->c.shape);
    if (!tri || !contact_missed(*d, precision)) continue;
    ++missed;
    const Vec3 e1 = tri->v[1] - tri->v[0], e2 = tri->v[2] - tri->v[0];
    const double det = std::abs(dot(e1, cross(d->c.ray.direction, e2)));
    if (det > 0) dets.push_back(det);
  }
  const auto edge = sharp_upper_edge(dets, 1e-13, 1e-2);
  if (!edge) return;
  hints.push_back(
      {"an absolute epsilon on the determinant",
       std::to_string(edge->below) + " of " + std::to_string(missed) +
           " enter->miss/exit->miss findings have |e1.(d x e2)| <= " + number(edge->threshold) + ", only " +
           std::to_string(edge->just_above) +
           " between that and 10x more: an absolute epsilon on the determinant (the \"parallel\" test) drops "
           "small triangles and short directions?"});
}

// H3: float code on numbers whose rounding to float moves them by 1/16 of the shape or more:
// the case itself changes before any arithmetic (the float-rounded case's own verdict is what
// `check` shows as the variant's `exact`).
void inputs_rounded_away(const std::vector<const Disagreement*>& ds, Precision precision, std::vector<Hint>& hints) {
  if (precision != Precision::f32) return;
  std::map<std::string, std::pair<std::size_t, std::size_t>> by_kind;  // kind → (rounded away, all)
  for (const Disagreement* d : ds) {
    if (!d->failure.empty()) continue;
    auto& [away, all] = by_kind[d->kind()];
    ++all;
    const double size = size_of(d->c);
    if (size > 0 && std::ldexp(magnitudes(d->c).first, -24) >= size / 16) ++away;
  }
  for (const auto& [kind, n] : by_kind)
    if (n.first >= 10 && 4 * n.first >= 3 * n.second)
      hints.push_back(
          {"float rounding of the inputs moves the shape",
           std::to_string(n.first) + " of " + std::to_string(n.second) + " " + kind +
               " findings have coordinates whose rounding to float (2^-24 of their magnitude) is 1/16 of the shape "
               "or more: the case changes before any arithmetic; translate the scene near the origin, or compute in "
               "double?"});
}

// H4: overflow or underflow: most findings of one kind have numbers beyond a magnitude where
// squares and products of three or four of them leave the format.
void magnitudes_beyond(const std::vector<const Disagreement*>& ds, Precision precision, std::vector<Hint>& hints) {
  std::map<std::string, std::vector<std::pair<double, double>>> by_kind;
  for (const Disagreement* d : ds) by_kind[d->kind()].push_back(magnitudes(d->c));
  const bool f32 = precision == Precision::f32;
  const int big = overflow_exponent(precision), small = underflow_exponent(precision);
  const char* type = f32 ? "float (2^128)" : "double (2^1024)";
  const char* tiny = f32 ? "float (2^-149)" : "double (2^-1074)";
  for (const auto& [kind, ms] : by_kind) {
    const bool failures = kind.find("->") == std::string::npos;  // crashes and plugin errors are rare and telling
    if (ms.size() < (failures ? 2u : 10u)) continue;
    std::size_t large = 0, little = 0;
    double large_lo = INFINITY, little_hi = 0;
    for (const auto& [hi, lo] : ms) {
      if (std::ilogb(hi) >= big) ++large, large_lo = std::min(large_lo, hi);
      if (lo < INFINITY && std::ilogb(lo) <= small) ++little, little_hi = std::max(little_hi, lo);
    }
    if (4 * large >= 3 * ms.size() && large >= 2)
      hints.push_back({std::string("overflow of ") + type, std::to_string(large) + " of " + std::to_string(ms.size()) +
                                                               " " + kind + " findings have numbers of magnitude 2^" +
                                                               std::to_string(std::ilogb(large_lo)) +
                                                               " or more: their squares and products overflow " + type +
                                                               "; scale the ray and shape first?"});
    else if (4 * little >= 3 * ms.size() && little >= 2)
      hints.push_back({std::string("underflow of ") + tiny,
                       std::to_string(little) + " of " + std::to_string(ms.size()) + " " + kind +
                           " findings have numbers as small as 2^" + std::to_string(std::ilogb(little_hi)) +
                           ": their squares and products underflow " + tiny + " (a d.d of 0, a division by it)?"});
  }
}

// H5: contacts answered at t = 0 (or below) where the exact answer is miss: t >= 0 where t > 0 is meant.
void contacts_at_zero(const std::vector<const Disagreement*>& ds, std::vector<Hint>& hints) {
  std::size_t zero = 0, total = 0;
  for (const Disagreement* d : ds)
    if (d->failure.empty() && d->exact == HitClass::miss && d->answered != HitClass::miss) {
      ++total;
      if (d->answered_t && *d->answered_t <= 0) ++zero;
    }
  if (zero >= 2 && 2 * zero >= total)
    hints.push_back({"the origin counted (t >= 0)",
                     std::to_string(zero) + " of " + std::to_string(total) +
                         " contacts answered where the exact answer is miss are at t <= 0: the ray's origin is counted "
                         "(t >= 0 where t > 0 is meant)?"});
}

// H6 (spheres): exits missed from inside with the centre always behind the origin (none ahead):
// an early "centre behind the ray: miss" test (tca < 0) made before asking whether the origin is
// inside. Exits already explained (a t_min, the origin's rounding) are left out.
void exits_missed_centre_behind(const std::vector<const Disagreement*>& ds, Precision precision,
                                const Explained& explained, std::vector<Hint>& hints) {
  std::size_t behind = 0, ahead = 0;
  for (const Disagreement* d : ds) {
    if (!contact_missed(*d, precision) || d->exact != HitClass::exit || explained.covers(*d)) continue;
    const auto* s = std::get_if<Sphere>(&d->c.shape);
    if (!s) continue;
    ++(dot(s->center - d->c.ray.origin, d->c.ray.direction) < 0 ? behind : ahead);
  }
  if (behind >= 10 && ahead == 0)
    hints.push_back(
        {"an early centre-behind test",
         "all " + std::to_string(behind) +
             " exit->miss findings start inside the sphere with its centre behind the origin (none with it ahead): "
             "an early \"centre behind the ray: miss\" test (tca < 0) rejects rays that leave the sphere?"});
}

// H7 (triangles): holes where the ray crosses an edge the case's fan shares (the campaign counts
// them): not watertight.
void shared_edge_holes_found(std::uint64_t holes, std::vector<Hint>& hints) {
  if (holes > 0)
    hints.push_back(
        {"not watertight",
         std::to_string(holes) +
             " holes where the ray crosses an edge shared with another triangle of the case's fan: not watertight "
             "(both triangles can miss their shared edge); see the watertight variants"});
}

}  // namespace

std::vector<Hint> diagnose(const std::vector<const Disagreement*>& of_variant, Precision precision,
                           std::uint64_t shared_edge_holes) {
  std::vector<Hint> hints;
  const Explained explained = near_contacts_dropped(of_variant, precision, hints);
  small_determinants_dropped(of_variant, precision, hints);
  exits_missed_centre_behind(of_variant, precision, explained, hints);
  contacts_at_zero(of_variant, hints);
  inputs_rounded_away(of_variant, precision, hints);
  magnitudes_beyond(of_variant, precision, hints);
  shared_edge_holes_found(shared_edge_holes, hints);
  return hints;
}

std::string loading_flags(const Variant& v) {
  if (!v.external) return "";
  const std::string origin(v.origin);
  if (origin.rfind("answers: ", 0) == 0) return "";
  if (origin.rfind("exec: ", 0) == 0) {
    const std::string shapes = shapes_answered(v);
    return "--exec " +
           shell_quoted(std::string(v.name) + (shapes == "any" ? "" : ":" + shapes) + "=" + origin.substr(6));
  }
  return "--plugin " + shell_quoted(origin);
}

namespace {
std::string describe(const Disagreement& d) {
  auto vec = [](const Vec3& v) { return "(" + number(v.x()) + ", " + number(v.y()) + ", " + number(v.z()) + ")"; };
  std::string shape;
  std::visit(
      [&](const auto& s) {
        using S = std::decay_t<decltype(s)>;
        if constexpr (std::is_same_v<S, Sphere>)
          shape = "sphere centre " + vec(s.center) + " radius " + number(s.radius);
        else if constexpr (std::is_same_v<S, Plane>)
          shape = "plane normal " + vec(s.normal) + " offset " + number(s.offset);
        else if constexpr (std::is_same_v<S, Triangle>)
          shape = "triangle " + vec(s.v[0]) + " " + vec(s.v[1]) + " " + vec(s.v[2]);
        else
          shape = "box " + vec(s.min) + " to " + vec(s.max);
      },
      d.c.shape);
  std::string truth = std::string(to_string(d.exact)) + (d.exact_t ? " at t = " + number(*d.exact_t) : "");
  std::string answer =
      d.failure.empty() ? std::string(to_string(d.answered)) + (d.answered_t ? " at t = " + number(*d.answered_t) : "")
                        : d.failure;
  return printable(d.c.id) + ": ray from " + vec(d.c.ray.origin) + " along " + vec(d.c.ray.direction) +
         " (|d| = " + number(norm(d.c.ray.direction)) + "), " + shape + "; exact " + truth + ", answered " + answer;
}
}  // namespace

void print_examples_and_hints(std::ostream& out, const std::vector<Disagreement>& all,
                              const std::function<std::string(const Disagreement&)>& replay, std::size_t max_examples,
                              const std::vector<std::string>& variants,
                              const std::function<std::uint64_t(const std::string&)>& shared_edge_holes) {
  auto shown = [&](const std::string& v) {
    return variants.empty() || std::count(variants.begin(), variants.end(), v) > 0;
  };
  std::vector<KindExample> examples = examples_by_kind(all);
  std::erase_if(examples, [&](const KindExample& e) { return !shown(e.variant); });
  if (examples.empty()) return;
  out << "examples (one case per variant and kind, the most frequent first; replay each with the command below it):\n";
  for (std::size_t i = 0; i < examples.size() && i < max_examples; ++i) {
    const KindExample& e = examples[i];
    const Disagreement& d = all[e.first];
    out << "  " << e.variant << " " << e.kind << " (" << e.count << (e.count == 1 ? " case" : " cases") << "), e.g. "
        << describe(d) << "\n    " << replay(d) << "\n";
  }
  if (examples.size() > max_examples)
    out << "  … and " << examples.size() - max_examples << " more variant and kind pairs (see the findings)\n";
  std::map<std::string, std::vector<const Disagreement*>> by_variant;
  for (const Disagreement& d : all)
    if (shown(d.variant)) by_variant[d.variant].push_back(&d);
  // One line per cause (issue 41: one overflow sentence was printed 27 times, once per variant and
  // kind): the variants it applies to, then the first one's numbers.
  struct Cause {
    std::vector<std::string> variants;
    std::string example;  // "VARIANT: the hint's sentence"
  };
  std::vector<std::pair<std::string, Cause>> causes;  // in order of first appearance
  for (const auto& [name, ds] : by_variant) {
    const Variant* v = find_variant(name);
    for (const Hint& h :
         diagnose(ds, v ? v->precision : Precision::f64, shared_edge_holes ? shared_edge_holes(name) : 0)) {
      auto at = std::find_if(causes.begin(), causes.end(), [&](const auto& c) { return c.first == h.cause; });
      if (at == causes.end()) at = causes.insert(causes.end(), {h.cause, Cause{{}, name + ": " + h.text}});
      if (std::find(at->second.variants.begin(), at->second.variants.end(), name) == at->second.variants.end())
        at->second.variants.push_back(name);
    }
  }
  if (causes.empty()) return;
  out << "diagnosis (from the findings; one line per cause, the variants it applies to, the numbers behind it):\n";
  for (const auto& [cause, c] : causes) {
    if (c.variants.size() == 1) {
      out << "  " << c.example << "\n";
      continue;
    }
    std::string names;
    for (const std::string& n : c.variants) names += (names.empty() ? "" : ", ") + n;
    out << "  " << cause << " (" << c.variants.size() << " variants: " << names << "), e.g. " << c.example << "\n";
  }
}

}  // namespace rayproof
