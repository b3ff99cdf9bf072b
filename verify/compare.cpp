#include "rayproof/verify/compare.h"

#include <cmath>
#include <limits>
#include <cstring>

namespace rayproof {

// The exact t rounded to the nearest float (ties to even), from its correctly rounded double d.
// fl32(d) = fl32(t) unless d is itself a float midpoint: a midpoint m strictly between t and d
// would be a double nearer t than d. Only then is t's side of m decided exactly, in rationals.
float exact_t_as_float(const Query& q, HitRule rule, double d) {
  const float f = to_nearest_float(d);
  if (std::isinf(f)) return f;  // beyond float's range either way
  // The neighbouring floats (not doubles: fp.h's next_up and next_down are of double).
  const double below = std::nextafter(f, -std::numeric_limits<float>::infinity());
  const double above = std::nextafter(f, std::numeric_limits<float>::infinity());
  const double m = d < f ? (f + below) / 2 : (f + above) / 2;  // exact: floats have 24 bits, doubles 53
  if (d != m) return f;
  Oracle rational(Oracle::Options{.keep_exact_parameter = true});
  const Verdict v = rational.judge(q.ray, q.shape, rule);
  const int side = compare(*v.exact_t, mpq_class(m));
  const float lower = static_cast<float>(d < f ? below : f), upper = static_cast<float>(d < f ? f : above);
  if (side != 0) return side < 0 ? lower : upper;
  std::uint32_t bits;
  std::memcpy(&bits, &lower, sizeof bits);
  return bits % 2 == 0 ? lower : upper;  // ties to even
}

void judge_variant_all(Oracle& oracle, const Variant& v, std::span<const Query> qs, std::span<const Verdict> exact,
                       HitRule rule, std::vector<VariantOutcome>& out, FloatView* shared) {
  const HitRule own_rule = v.rule_for(rule);
  const bool f32 = v.precision == Precision::f32, own = f32 || own_rule != rule;
  out.resize(qs.size());           // every entry is written whole below
  thread_local FloatView scratch;  // a view for this variant alone where none is shared
  FloatView& view = shared && f32 ? *shared : scratch;
  if (!shared || !f32 || !view.ready_ || view.rule_ != own_rule) {
    view.queries_.clear(), view.from_.clear(), view.exact_.clear(), view.exact_t_.clear();
    view.rule_ = own_rule, view.ready_ = f32;
    if (f32) {
      for (size_t i = 0; i < qs.size(); ++i)
        if (auto r = rounded_to_float(qs[i])) view.queries_.push_back(std::move(*r)), view.from_.push_back(i);
      for (const Query& q : view.queries_) view.exact_.push_back(oracle.judge(q.ray, q.shape, own_rule));
      view.exact_t_.assign(view.queries_.size(), std::numeric_limits<float>::quiet_NaN());
    }
  }
  if (f32) {  // the cases float cannot hold (from_ ascends)
    for (size_t i = 0, next = 0; i < qs.size(); ++i)
      if (next < view.from_.size() && view.from_[next] == i)
        ++next;
      else
        out[i] = VariantOutcome{&v, Answer::failure_of(AnswerFailure::not_representable)};
  }
  thread_local std::vector<Answer> answers;
  const std::span<const Query> asked = f32 ? std::span<const Query>(view.queries_) : qs;
  answers.resize(asked.size());
  v.intersect_all(asked, rule, answers);
  for (size_t k = 0; k < asked.size(); ++k) {
    VariantOutcome& o = out[f32 ? view.from_[k] : k];
    o.variant = &v;
    if (answers[k].failed()) {
      o.answer = answers[k];
      o.agreement = Agreement::agrees, o.ulp.reset(), o.own_exact.reset(), o.ulp_own.reset();
      continue;
    }
    if (!own) {
      judge_answer_into(o, exact[k], answers[k]);
      continue;
    }
    std::optional<Verdict> judged;  // (the float view's verdict is read in place, not copied)
    const Verdict& truth = f32 ? view.exact_[k] : judged.emplace(oracle.judge(asked[k].ray, asked[k].shape, own_rule));
    judge_answer_into(o, truth, answers[k]);
    if (f32 && truth.t && answers[k].has_t()) {
      if (std::isnan(view.exact_t_[k])) view.exact_t_[k] = exact_t_as_float(asked[k], own_rule, *truth.t);
      o.ulp_own = ulp_distance_f32(to_nearest_float(answers[k].t), view.exact_t_[k]);
    }
    VariantOutcome::OwnVerdict& own_verdict = o.own_exact.emplace();  // field by field, as judge_answer_into
    own_verdict.cls = truth.cls, own_verdict.t = truth.t, own_verdict.front = truth.front;
  }
}

std::vector<VariantOutcome> judge_variant_all(Oracle& oracle, const Variant& v, std::span<const Query> qs,
                                              std::span<const Verdict> exact, HitRule rule) {
  std::vector<VariantOutcome> out;
  judge_variant_all(oracle, v, qs, exact, rule, out);
  return out;
}

VariantOutcome compare_variant(Oracle& oracle, const Variant& v, const Verdict& exact, const Query& q, HitRule rule) {
  return judge_variant_all(oracle, v, std::span(&q, 1), std::span(&exact, 1), rule)[0];
}

ordered_json check_line(const std::string& id, const Verdict& exact, const std::vector<VariantOutcome>& outcomes) {
  ordered_json line;
  line["id"] = id;
  line["exact"] = {{"class", std::string(to_string(exact.cls))},
                   {"t", exact.t ? ordered_json(hex_double(*exact.t)) : ordered_json(nullptr)}};
  ordered_json variants = ordered_json::object();
  for (const VariantOutcome& o : outcomes) {
    ordered_json& entry = variants[std::string(o.variant->name)];
    if (o.answer.failure == AnswerFailure::not_representable) {
      entry = {{"skipped", "not_representable"}};
      continue;
    }
    if (o.answer.failed()) {
      entry = {{"error", std::string(to_string(o.answer.failure))}};
      continue;
    }
    entry = {{"class", std::string(to_string(o.answer.cls))},
             {"t", o.answer.has_t() ? ordered_json(hex_double(o.answer.t)) : ordered_json(nullptr)},
             {"ulp", o.ulp ? ordered_json(*o.ulp) : ordered_json(nullptr)},
             {"agrees", o.agreement == Agreement::agrees}};
    if (o.variant->precision == Precision::f32 && o.own_exact) {
      entry["exact"] = {{"class", std::string(to_string(o.own_exact->cls))},
                        {"t", o.own_exact->t ? ordered_json(hex_double(*o.own_exact->t)) : ordered_json(nullptr)}};
      entry["ulp_own"] = o.ulp_own ? ordered_json(*o.ulp_own) : ordered_json(nullptr);
    }
  }
  line["variants"] = std::move(variants);
  return line;
}

std::string expectation_mismatch(const Expectation& expect, const Verdict& exact) {
  if (expect.cls != exact.cls)
    return "expect.class is " + std::string(to_string(expect.cls)) + ", the exact class is " +
           std::string(to_string(exact.cls));
  if (expect.t) {
    if (!exact.t) return "expect.t is given but the exact contact has no t";
    if (*ulp_distance(*expect.t, *exact.t) != 0)
      return "expect.t is " + hex_double(*expect.t) + ", the correctly rounded exact t is " + hex_double(*exact.t);
  }
  return "";
}

bool crosses_shared_edge(const Verdict& first, const Verdict& second) {
  const bool hit_first = first.cls != HitClass::miss, hit_second = second.cls != HitClass::miss;
  const bool silhouette = hit_first && hit_second && first.front != second.front;
  return (hit_first || hit_second) && !silhouette;
}

}  // namespace rayproof
