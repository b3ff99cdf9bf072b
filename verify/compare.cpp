#include "rayproof/verify/compare.h"

namespace rayproof {

Agreement agreement_of(HitClass exact, HitClass reported) {
  if (reported == exact) return Agreement::agrees;
  const bool exact_is_a_touch = exact == HitClass::tangent || exact == HitClass::boundary;
  const bool reported_is_plain = reported == HitClass::enter || reported == HitClass::exit || reported == HitClass::miss;
  return exact_is_a_touch && reported_is_plain ? Agreement::cannot_tell : Agreement::wrong;
}

VariantOutcome judge_answer(const Verdict& exact, const Hit& reported) {
  VariantOutcome out;
  out.hit = reported;
  out.agreement = agreement_of(exact.cls, reported.cls);
  if (exact.t && reported.has_t()) out.ulp = ulp_distance(reported.t, *exact.t);
  return out;
}

VariantOutcome compare_variant(const Variant& v, const Verdict& exact, const Ray& ray, const Shape& shape,
                               HitRule rule) {
  VariantOutcome out = judge_answer(exact, v.intersect(ray, shape, rule));
  out.variant = &v;
  return out;
}

ordered_json check_line(const std::string& id, const Verdict& exact, const std::vector<VariantOutcome>& outcomes) {
  ordered_json line;
  line["id"] = id;
  line["exact"] = {{"class", std::string(to_string(exact.cls))},
                   {"t", exact.t ? ordered_json(hex_double(*exact.t)) : ordered_json(nullptr)}};
  ordered_json variants = ordered_json::object();
  for (const VariantOutcome& o : outcomes)
    variants[std::string(o.variant->name)] = {
        {"class", std::string(to_string(o.hit.cls))},
        {"t", o.hit.has_t() ? ordered_json(hex_double(o.hit.t)) : ordered_json(nullptr)},
        {"ulp", o.ulp ? ordered_json(*o.ulp) : ordered_json(nullptr)},
        {"agrees", o.agreement == Agreement::agrees}};
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
