#include "rayproof/verify/tally.h"

#include <algorithm>
#include <cmath>

namespace rayproof {

int UlpHistogram::bucket(std::uint64_t ulp) {
  if (ulp < 128) return static_cast<int>(ulp);
  const int log2 = 63 - __builtin_clzll(ulp);                 // ≥ 7
  const int sub = static_cast<int>((ulp >> (log2 - 3)) & 7);  // next three bits
  return 128 + (log2 - 7) * 8 + sub;
}
std::uint64_t UlpHistogram::lower_bound(int b) {
  if (b < 128) return static_cast<std::uint64_t>(b);
  const int log2 = (b - 128) / 8 + 7, sub = (b - 128) % 8;
  return (std::uint64_t(8 + sub)) << (log2 - 3);
}
void UlpHistogram::add(std::uint64_t ulp) {
  ++buckets_[bucket(ulp)];
  ++count_;
  max_ = std::max(max_, ulp);
}
void UlpHistogram::merge(const UlpHistogram& o) {
  for (const auto& [b, n] : o.buckets_) buckets_[b] += n;
  count_ += o.count_;
  max_ = std::max(max_, o.max_);
}
std::uint64_t UlpHistogram::quantile(double q) const {
  if (count_ == 0) return 0;
  const std::uint64_t rank = std::max<std::uint64_t>(1, static_cast<std::uint64_t>(std::ceil(q * count_)));
  std::uint64_t seen = 0;
  for (const auto& [b, n] : buckets_) {
    seen += n;
    if (seen >= rank) return std::min(lower_bound(b), max_);
  }
  return max_;
}
json UlpHistogram::to_json() const {
  json b = json::object();
  for (const auto& [k, n] : buckets_) b[std::to_string(k)] = n;
  return {{"count", count_}, {"max", max_}, {"buckets", b}};
}
UlpHistogram UlpHistogram::from_json(const json& j) {
  UlpHistogram h;
  h.count_ = j.at("count");
  h.max_ = j.at("max");
  for (auto it = j.at("buckets").begin(); it != j.at("buckets").end(); ++it) h.buckets_[std::stoi(it.key())] = it.value();
  return h;
}

void Tally::add(HitClass case_exact, const VariantOutcome& o) {
  switch (o.hit.failure) {
    case HitFailure::none: break;
    case HitFailure::crash: ++crashes; return;
    case HitFailure::timeout: ++timeouts; return;
    case HitFailure::protocol: ++protocol_errors; return;
    case HitFailure::not_representable: ++not_representable; return;
    case HitFailure::stopped: return;  // counted once, as what stopped it
    case HitFailure::bad_answer:
    case HitFailure::nan_t:
    case HitFailure::t_unwritten: ++plugin_errors; return;
  }
  const HitClass exact = o.own_exact ? o.own_exact->cls : case_exact;
  ++cases;
  switch (o.agreement) {
    case Agreement::agrees: ++agree; break;
    case Agreement::cannot_tell: ++cannot_tell; break;
    case Agreement::wrong: ++wrong; break;
  }
  if (o.agreement != Agreement::agrees)
    ++confusion[std::string(to_string(exact)) + "->" + std::string(to_string(o.hit.cls))];
  if (o.ulp && o.agreement == Agreement::agrees) ulps.add(*o.ulp);  // a wrong class's t says nothing of accuracy
  if (o.ulp_own && o.agreement == Agreement::agrees) ulps_own.add(*o.ulp_own);
}

Agreement Tally::add_answer(const Verdict& exact, const Hit& h) {
  const Agreement a = agreement_of(exact.cls, h.cls);
  ++cases;
  switch (a) {
    case Agreement::agrees:
      ++agree;
      if (exact.t && h.has_t()) ulps.add(*ulp_distance(h.t, *exact.t));
      return a;
    case Agreement::cannot_tell: ++cannot_tell; break;
    case Agreement::wrong: ++wrong; break;
  }
  ++confusion[std::string(to_string(exact.cls)) + "->" + std::string(to_string(h.cls))];
  return a;
}

void Tally::merge(const Tally& o) {
  cases += o.cases, agree += o.agree, wrong += o.wrong, cannot_tell += o.cannot_tell;
  shared_edge_holes += o.shared_edge_holes, crashes += o.crashes, timeouts += o.timeouts;
  protocol_errors += o.protocol_errors, plugin_errors += o.plugin_errors, not_representable += o.not_representable;
  for (const auto& [k, n] : o.confusion) confusion[k] += n;
  ulps.merge(o.ulps);
  ulps_own.merge(o.ulps_own);
}

json Tally::to_json() const {
  json j = {{"cases", cases}, {"agree", agree}, {"wrong", wrong}, {"cannot_tell", cannot_tell},
            {"shared_edge_holes", shared_edge_holes}, {"disagreements", confusion}, {"ulp", ulps.to_json()}};
  for (const auto& [key, n] : {std::pair{"crashes", crashes}, {"timeouts", timeouts}, {"protocol_errors", protocol_errors},
                               {"plugin_errors", plugin_errors}, {"not_representable", not_representable}})
    if (n > 0) j[key] = n;
  if (ulps_own.count() > 0) j["ulp_own"] = ulps_own.to_json();
  return j;
}

Tally Tally::from_json(const json& j) {
  Tally t;
  t.cases = j.at("cases"), t.agree = j.at("agree"), t.wrong = j.at("wrong"), t.cannot_tell = j.at("cannot_tell");
  t.shared_edge_holes = j.at("shared_edge_holes");
  t.crashes = j.value("crashes", std::uint64_t(0));
  t.timeouts = j.value("timeouts", std::uint64_t(0));
  t.protocol_errors = j.value("protocol_errors", std::uint64_t(0));
  t.plugin_errors = j.value("plugin_errors", std::uint64_t(0));
  t.not_representable = j.value("not_representable", std::uint64_t(0));
  if (j.contains("ulp_own")) t.ulps_own = UlpHistogram::from_json(j.at("ulp_own"));
  t.confusion = j.at("disagreements").get<std::map<std::string, std::uint64_t>>();
  t.ulps = UlpHistogram::from_json(j.at("ulp"));
  return t;
}

}  // namespace rayproof
