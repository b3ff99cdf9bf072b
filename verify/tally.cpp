#include "rayproof/verify/tally.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <limits>

#include "rayproof/core/tracer.h"
#include "rayproof/verify/report.h"

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
  add_to(bucket(ulp), 1);
  ++count_;
  max_ = std::max(max_, ulp);
}
void UlpHistogram::merge(const UlpHistogram& o) {
  for (size_t b = 0; b < o.buckets_.size(); ++b)
    if (o.buckets_[b] > 0) add_to(static_cast<int>(b), o.buckets_[b]);
  count_ += o.count_;
  max_ = std::max(max_, o.max_);
}
std::uint64_t UlpHistogram::quantile(double q) const {
  if (count_ == 0) return 0;
  const std::uint64_t rank = std::max<std::uint64_t>(1, static_cast<std::uint64_t>(std::ceil(q * count_)));
  std::uint64_t seen = 0;
  for (size_t b = 0; b < buckets_.size(); ++b) {
    seen += buckets_[b];
    if (buckets_[b] > 0 && seen >= rank) return std::min(lower_bound(static_cast<int>(b)), max_);
  }
  return max_;
}
json UlpHistogram::to_json() const {
  json b = json::object();
  for (size_t k = 0; k < buckets_.size(); ++k)
    if (buckets_[k] > 0) b[std::to_string(k)] = buckets_[k];
  return {{"count", count_}, {"max", max_}, {"buckets", b}};
}
// Summaries are read back by `merge` from files users hand it: every count is a whole number
// >= 0, every bucket one that add() can fill, and the totals add up, or a FieldError names why.
UlpHistogram UlpHistogram::from_json(const json& j) {
  UlpHistogram h;
  h.count_ = read_count(j.at("count"), "count");
  h.max_ = read_count(j.at("max"), "max");
  std::uint64_t total = 0;
  const int last = bucket(std::numeric_limits<std::uint64_t>::max());
  for (auto it = j.at("buckets").begin(); it != j.at("buckets").end(); ++it) {
    int b = -1;
    const std::string& key = it.key();
    const auto [end, ec] = std::from_chars(key.data(), key.data() + key.size(), b);
    if (ec != std::errc() || end != key.data() + key.size() || b < 0 || b > last)
      throw FieldError("buckets." + printable_prefix(key, 40), "not a bucket (0.." + std::to_string(last) + ")");
    const std::uint64_t n = read_count(it.value(), "buckets." + key);
    if (n > h.count_ - std::min(h.count_, total)) throw FieldError("buckets", "hold more than count");
    if (b < static_cast<int>(h.buckets_.size()) && h.buckets_[b] > 0) throw FieldError("buckets." + key, "given twice");
    h.add_to(b, n), total += n;
  }
  if (total != h.count_)
    throw FieldError("count", std::to_string(h.count_) + " but the buckets hold " + std::to_string(total));
  const auto highest = std::find_if(h.buckets_.rbegin(), h.buckets_.rend(), [](std::uint64_t n) { return n > 0; });
  if (h.count_ > 0 && bucket(h.max_) != static_cast<int>(h.buckets_.rend() - highest) - 1)
    throw FieldError("max", std::to_string(h.max_) + " is not in the highest bucket");
  return h;
}

void Tally::add(HitClass case_exact, const VariantOutcome& o) {
  switch (o.answer.failure) {
    case AnswerFailure::none: break;
    case AnswerFailure::crash:
    case AnswerFailure::out_of_memory: ++crashes; return;  // a death all the same (its finding says which)
    case AnswerFailure::timeout: ++timeouts; return;
    case AnswerFailure::protocol: ++protocol_errors; return;
    case AnswerFailure::not_representable: ++not_representable; return;
    case AnswerFailure::stopped: return;  // counted once, as what stopped it
    case AnswerFailure::bad_answer:
    case AnswerFailure::nan_t:
    case AnswerFailure::t_unwritten:
    case AnswerFailure::build_refused: ++plugin_errors; return;  // (whole tracers only: never a variant's)
  }
  const HitClass exact = o.own_exact ? o.own_exact->cls : case_exact;
  ++cases;
  switch (o.agreement) {
    case Agreement::agrees: ++agree; break;
    case Agreement::cannot_tell: ++cannot_tell; break;
    case Agreement::wrong: ++wrong; break;
  }
  if (o.agreement != Agreement::agrees) ++confusion[{exact, o.answer.cls}];
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
  ++confusion[{exact.cls, h.cls}];
  return a;
}

std::string DisagreementKind::to_string() const {
  return std::string(rayproof::to_string(exact)) + "->" + std::string(rayproof::to_string(reported));
}

std::optional<DisagreementKind> DisagreementKind::from_string(std::string_view text) {
  const std::size_t arrow = text.find("->");
  if (arrow == std::string_view::npos) return std::nullopt;
  const auto exact = hit_class_from_string(text.substr(0, arrow));
  const auto reported = answer_class_from_string(text.substr(arrow + 2));
  if (!exact || !reported) return std::nullopt;
  return DisagreementKind{*exact, *reported};
}

namespace {
// Every count of a Tally with its JSON name, the one list merge, to_json and from_json walk. The
// failures of external code are written only where they happened (and read as 0 where absent).
struct TallyCount {
  const char* key;
  std::uint64_t Tally::*member;
  bool written_when_zero;
};
constexpr TallyCount kTallyCounts[] = {
    {"cases", &Tally::cases, true},
    {"agree", &Tally::agree, true},
    {"wrong", &Tally::wrong, true},
    {"cannot_tell", &Tally::cannot_tell, true},
    {"shared_edge_holes", &Tally::shared_edge_holes, true},
    {"crashes", &Tally::crashes, false},
    {"timeouts", &Tally::timeouts, false},
    {"protocol_errors", &Tally::protocol_errors, false},
    {"plugin_errors", &Tally::plugin_errors, false},
    {"not_representable", &Tally::not_representable, false},
};
}  // namespace

void Tally::add_level(const DisagreementKind& kind, bool bug, const std::string& beta_bucket) {
  ++(bug ? bugs : rounding)[kind];
  ++beta[beta_bucket];
}

std::uint64_t Tally::bug_count() const {
  std::uint64_t n = 0;
  for (const auto& [k, x] : bugs) n += x;
  return n;
}
std::uint64_t Tally::rounding_count() const {
  std::uint64_t n = 0;
  for (const auto& [k, x] : rounding) n += x;
  return n;
}

void Tally::merge(const Tally& o) {
  // A tally without levels (a fresh one) takes the other's K; two different K do not add up.
  if (o.tolerance_ulps) {
    if (tolerance_ulps && *tolerance_ulps != *o.tolerance_ulps)
      throw std::runtime_error("tallies judged with different --tolerance-ulps (" + std::to_string(*tolerance_ulps) +
                               " and " + std::to_string(*o.tolerance_ulps) + ") cannot be merged");
    tolerance_ulps = o.tolerance_ulps;
  }
  for (const TallyCount& c : kTallyCounts) this->*c.member += o.*c.member;
  for (const auto& [k, n] : o.confusion) confusion[k] += n;
  for (const auto& [k, n] : o.bugs) bugs[k] += n;
  for (const auto& [k, n] : o.rounding) rounding[k] += n;
  for (const auto& [k, n] : o.beta) beta[k] += n;
  at_range_end += o.at_range_end;
  ulps.merge(o.ulps);
  ulps_own.merge(o.ulps_own);
}

json Tally::to_json() const {
  json kinds = json::object();
  for (const auto& [kind, n] : confusion) kinds[kind.to_string()] = n;
  json j = {{"disagreements", kinds}, {"ulp", ulps.to_json()}};
  for (const TallyCount& c : kTallyCounts)
    if (c.written_when_zero || this->*c.member > 0) j[c.key] = this->*c.member;
  if (ulps_own.count() > 0) j["ulp_own"] = ulps_own.to_json();
  if (tolerance_ulps) {  // verdicts.md §4
    json b = json::object(), r = json::object();
    for (const auto& [kind, n] : bugs) b[kind.to_string()] = n;
    for (const auto& [kind, n] : rounding) r[kind.to_string()] = n;
    j["tolerance_ulps"] = *tolerance_ulps;
    j["bugs"] = bug_count(), j["rounding"] = rounding_count(), j["at_range_end"] = at_range_end;
    j["disagreement_bugs"] = b, j["disagreement_rounding"] = r, j["beta"] = beta;
  }
  return j;
}

Tally Tally::from_json(const json& j) {
  Tally t;
  for (const TallyCount& c : kTallyCounts)
    t.*c.member = c.written_when_zero || j.contains(c.key) ? read_count(j.at(c.key), c.key) : 0;
  if (t.agree > t.cases || t.wrong > t.cases - t.agree || t.cannot_tell != t.cases - t.agree - t.wrong)
    throw FieldError("cases", "agree + wrong + cannot_tell must equal cases (" + std::to_string(t.agree) + " + " +
                                  std::to_string(t.wrong) + " + " + std::to_string(t.cannot_tell) + " vs " +
                                  std::to_string(t.cases) + ")");
  std::uint64_t disagreements = 0;
  for (auto it = j.at("disagreements").begin(); it != j.at("disagreements").end(); ++it) {
    const std::uint64_t n = read_count(it.value(), "disagreements." + printable_prefix(it.key(), 40));
    if (n > t.cases - std::min(t.cases, disagreements)) throw FieldError("disagreements", "count more than cases");
    const auto kind = DisagreementKind::from_string(it.key());
    if (!kind) throw FieldError("disagreements." + printable_prefix(it.key(), 40), "not exact->reported classes");
    t.confusion[*kind] = n;
    disagreements += n;
  }
  if (disagreements != t.wrong + t.cannot_tell)
    throw FieldError("disagreements", "sum to " + std::to_string(disagreements) + ", not wrong + cannot_tell");
  try {
    t.ulps = UlpHistogram::from_json(j.at("ulp"));
    if (j.contains("ulp_own")) t.ulps_own = UlpHistogram::from_json(j.at("ulp_own"));
  } catch (const FieldError& e) {
    throw FieldError("ulp." + e.field, e.what());
  }
  if (t.ulps.count() > t.agree || t.ulps_own.count() > t.agree)
    throw FieldError("ulp.count", "more t errors than agreeing cases");
  if (j.contains("tolerance_ulps")) {  // levels (verdicts.md §4): each kind's within its count
    t.tolerance_ulps = read_number(j.at("tolerance_ulps"), "tolerance_ulps");
    if (!(*t.tolerance_ulps >= 0)) throw FieldError("tolerance_ulps", "expected a number of ulps >= 0");
    for (const char* key : {"disagreement_bugs", "disagreement_rounding"}) {
      const json& levels = require_object(j.at(key), key);
      for (auto it = levels.begin(); it != levels.end(); ++it) {
        const std::string field = std::string(key) + "." + printable_prefix(it.key(), 40);
        const auto kind = DisagreementKind::from_string(it.key());
        if (!kind) throw FieldError(field, "not exact->reported classes");
        (std::string_view(key) == "disagreement_bugs" ? t.bugs : t.rounding)[*kind] = read_count(it.value(), field);
      }
    }
    auto count_of = [](const std::map<DisagreementKind, std::uint64_t>& m, const DisagreementKind& k) {
      const auto it = m.find(k);
      return it == m.end() ? std::uint64_t{0} : it->second;
    };
    for (const auto& [kind, n] : t.bugs)  // (a kind absent from the disagreements counts 0)
      if (n + count_of(t.rounding, kind) > count_of(t.confusion, kind))
        throw FieldError("disagreement_bugs." + kind.to_string(), "more bugs and rounding-level than disagreements");
    for (const auto& [kind, n] : t.rounding)
      if (n + count_of(t.bugs, kind) > count_of(t.confusion, kind))
        throw FieldError("disagreement_rounding." + kind.to_string(),
                         "more bugs and rounding-level than disagreements");
    t.at_range_end = read_count(j.at("at_range_end"), "at_range_end");
    const json& beta = require_object(j.at("beta"), "beta");
    for (auto it = beta.begin(); it != beta.end(); ++it)
      t.beta[it.key()] = read_count(it.value(), "beta." + printable_prefix(it.key(), 20));
  }
  return t;
}

// ------------------------------------------------------------------------------- TracerTally
namespace {
// The notes beside the levelled kinds (trace_kind.h).
constexpr const char* kNotes[] = {"ties",
                                  "at_range_end",
                                  "at_tmin",
                                  "at_tmax",
                                  "edge_hole_bugs",
                                  "witness_refused",
                                  "zero_direction_hole_bugs",
                                  "zero_direction_edge_hole_bugs"};
bool is_level_key(const std::string& k) {
  if (k.rfind("det_hole:", 0) == 0 || k.rfind("det_right:", 0) == 0) return true;  // |det| histograms
  for (const char* n : kNotes)
    if (k == n) return true;
  for (const TraceKindInfo& kind : kTraceKinds)
    if (kind.levelled && (k == std::string(kind.name) + "_bugs" || k == std::string(kind.name) + "_rounding"))
      return true;
  return false;
}
}  // namespace

std::uint64_t TracerTally::count(TraceKind kind) const {
  const auto it = kinds.find(std::string(info(kind).tally_key));
  return it == kinds.end() ? 0 : it->second;
}

void TracerTally::add(TraceKind kind) {
  ++cases;
  ++kinds[std::string(info(kind).tally_key)];
}

std::uint64_t TracerTally::disagreements() const {
  std::uint64_t n = 0;
  for (const TraceKindInfo& k : kTraceKinds)
    if (k.disagreement) n += count(k.kind);
  return n;
}

std::uint64_t TracerTally::level(std::string_view key) const {
  const auto it = levels.find(std::string(key));
  return it == levels.end() ? 0 : it->second;
}

void TracerTally::note_max(const std::string& key, double x) {
  const auto [it, fresh] = extremes.try_emplace(key, x);
  if (!fresh && x > it->second) it->second = x;
}
void TracerTally::note_min(const std::string& key, double x) {
  const auto [it, fresh] = extremes.try_emplace(key, x);
  if (!fresh && x < it->second) it->second = x;
}

void TracerTally::merge(const TracerTally& o) {
  for (const auto& [k, x] : o.extremes) k.ends_with("_max") ? note_max(k, x) : note_min(k, x);
  if (cases && o.cases && tolerance_ulps != o.tolerance_ulps)
    throw std::runtime_error("tallies judged with different --tolerance-ulps cannot be merged");
  if (!cases || !tolerance_ulps) tolerance_ulps = o.tolerance_ulps;
  if (range.empty()) range = o.range;
  for (const auto& [k, n] : o.levels) levels[k] += n;
  for (const auto& [k, n] : o.beta) beta[k] += n;
  for (const auto& [k, n] : o.kinds) kinds[k] += n;
  cases += o.cases, edge_rays += o.edge_rays, edge_holes += o.edge_holes, edge_double_hits += o.edge_double_hits;
  ulps.merge(o.ulps);
  seconds += o.seconds, timed_rays += o.timed_rays;
}

json TracerTally::to_json() const {
  json j = {{"cases", cases}};
  for (const TraceKindInfo& k : kTraceKinds)
    if (k.spec_field) j[std::string(k.tally_key)] = count(k.kind);
  for (const auto& [k, n] : kinds)  // the compatible extras: not_representable, build_failed
    if (!j.contains(k)) j[k] = n;
  j["bits"] = bits_json(ulps);
  j["ns_per_ray"] = std::round(ns_per_ray() * 10) / 10;
  j["edge_rays"] = edge_rays, j["edge_holes"] = edge_holes, j["edge_double_hits"] = edge_double_hits;
  j["ulp"] = ulps.to_json();
  j["seconds"] = seconds, j["timed_rays"] = timed_rays;
  if (tolerance_ulps) {
    for (const TraceKindInfo& k : kTraceKinds)
      if (k.levelled)
        for (const char* l : {"_bugs", "_rounding"}) j[std::string(k.name) + l] = level(std::string(k.name) + l);
    for (const char* k : kNotes) j[k] = level(k);
    for (const auto& [k, n] : levels)
      if (k.rfind("det_", 0) == 0) j[k] = n;
    j["tolerance_ulps"] = *tolerance_ulps;
    j["beta"] = beta;
  }
  if (!range.empty()) j["range"] = range;
  if (!extremes.empty()) j["extremes"] = extremes;
  return j;
}

TracerTally TracerTally::from_json(const json& j) {
  TracerTally t;
  t.cases = read_count(j.at("cases"), "cases");
  std::uint64_t total = 0;
  for (auto it = j.begin(); it != j.end(); ++it) {
    const std::string& k = it.key();
    if (k == "cases" || k == "bits" || k == "ns_per_ray" || k == "ulp" || k == "seconds" || k == "timed_rays" ||
        k.rfind("edge_", 0) == 0 || k == "tolerance_ulps" || k == "beta" || k == "range" || k == "extremes" ||
        is_level_key(k))
      continue;
    const std::uint64_t n = read_count(it.value(), printable_prefix(k, 40));
    if (n > t.cases - std::min(t.cases, total)) throw FieldError(k, "the kinds count more rays than cases");
    if (n > 0) t.kinds[k] = n;
    total += n;
  }
  if (total != t.cases)
    throw FieldError("cases", std::to_string(t.cases) + " but the kinds count " + std::to_string(total));
  t.edge_rays = read_count(j.at("edge_rays"), "edge_rays");
  t.edge_holes = read_count(j.at("edge_holes"), "edge_holes");
  t.edge_double_hits = read_count(j.at("edge_double_hits"), "edge_double_hits");
  if (t.edge_rays > t.cases || t.edge_holes > t.edge_rays || t.edge_double_hits > t.edge_rays)
    throw FieldError("edge_rays", "edge holes and double hits are among the edge rays, which are among the cases");
  try {
    t.ulps = UlpHistogram::from_json(j.at("ulp"));
  } catch (const FieldError& e) {
    throw FieldError("ulp." + e.field, e.what());
  }
  if (!j.at("seconds").is_number() || !(j.at("seconds").get<double>() >= 0))
    throw FieldError("seconds", "expected a number >= 0");
  t.seconds = j.at("seconds").get<double>();
  t.timed_rays = read_count(j.at("timed_rays"), "timed_rays");
  if (j.contains("tolerance_ulps")) {
    const double k = read_number(j.at("tolerance_ulps"), "tolerance_ulps");
    if (!(k >= 0)) throw FieldError("tolerance_ulps", "expected a number >= 0");
    t.tolerance_ulps = k;
    for (auto it = j.begin(); it != j.end(); ++it)
      if (is_level_key(it.key())) {
        const std::uint64_t n = read_count(it.value(), it.key());
        if (n) t.levels[it.key()] = n;
      }
    for (const TraceKindInfo& k : kTraceKinds) {
      if (!k.levelled) continue;
      const std::string name(k.name);
      if (t.level(name + "_bugs") + t.level(name + "_rounding") != t.count(k.kind))
        throw FieldError(name + "_bugs", name + "_bugs and " + name + "_rounding do not add up to " + name);
    }
    if (j.contains("beta")) {
      if (!j.at("beta").is_object()) throw FieldError("beta", "expected an object of counts");
      for (auto it = j.at("beta").begin(); it != j.at("beta").end(); ++it)
        t.beta[it.key()] = read_count(it.value(), "beta." + printable_prefix(it.key(), 20));
    }
  }
  if (j.contains("extremes")) {
    if (!j.at("extremes").is_object()) throw FieldError("extremes", "expected an object of numbers");
    for (auto it = j.at("extremes").begin(); it != j.at("extremes").end(); ++it)
      t.extremes[it.key()] = read_number(it.value(), "extremes." + printable_prefix(it.key(), 20));
  }
  if (j.contains("range")) {
    if (!j.at("range").is_string() || !range_rule_from_string(j.at("range").get<std::string>()))
      throw FieldError("range", "expected \"open\" or \"closed\"");
    t.range = j.at("range").get<std::string>();
  }
  return t;
}

}  // namespace rayproof
