#include "rayproof/verify/tracer_judge.h"

#include <cmath>
#include <span>
#include <vector>

namespace rayproof {

std::optional<MeshCase> as_seen_by(const Tracer& t, const MeshCase& c) {
  if (t.precision == Precision::f64) return c;
  const auto mesh = mesh_rounded_to_float(*c.mesh);
  const auto ray = ray_rounded_to_float(c.ray);
  if (!mesh || !ray) return std::nullopt;
  MeshCase seen = c;
  seen.mesh = std::make_shared<TriangleMesh>(*mesh);
  seen.ray = *ray;
  return seen;
}

TraceKind kind_of_failure(AnswerFailure f) {
  return f == AnswerFailure::timeout         ? TraceKind::timeout
         : f == AnswerFailure::out_of_memory ? TraceKind::out_of_memory
         : f == AnswerFailure::crash         ? TraceKind::crash
         : f == AnswerFailure::build_refused ? TraceKind::build_failed
                                             : TraceKind::tracer_error;
}

const BackwardError* BackwardErrorMemo::find(const TracerOutcome& o, Precision p, const MeshAnswer& a) const {
  for (const Entry& e : entries_)
    if (e.kind == o.kind && e.edge_double == o.judgement.edge_double && e.precision == p && e.range == o.range &&
        e.answer.all == a.all && e.answer.triangle == a.triangle && e.answer.triangles == a.triangles)
      return &e.backward;
  return nullptr;
}

void BackwardErrorMemo::keep(const TracerOutcome& o, Precision p, const MeshAnswer& a) {
  entries_.push_back({o.kind, o.judgement.edge_double, p, o.range, a, o.backward});
}

void add_backward_error(TracerOutcome& o, const MeshOracle& oracle, const TracerRay& ray, const MeshTruth& truth,
                        Precision p, const VerdictSettings& settings, bool all, BackwardErrorMemo* memo) {
  o.level = Level::bug;
  o.backward = {};
  if (!has_backward_error(o.kind) || !settings.backward_error) return;
  MeshAnswer a;
  a.all = all;
  a.triangle = o.answer.triangle;
  a.triangles = o.all.triangles;
  const BackwardError* known = memo ? memo->find(o, p, a) : nullptr;
  o.backward = known ? *known : backward_error(oracle, ray, truth, o.judgement, a, p, o.range, settings.tolerance_ulps);
  o.level = level_of(o.backward, settings.tolerance_ulps);
  if (memo && !known) memo->keep(o, p, a);
}

void add_verdict_fields(json& found, const TracerOutcome& o) {
  found["range"] = std::string(to_string(o.range));
  if (!has_backward_error(o.kind)) {
    if (is_disagreement(o.kind)) found["level"] = "bug";
    return;
  }
  found["level"] = std::string(to_string(o.level));
  found["beta"] = beta_json(o.backward);
  if (o.backward.witness) found["witness"] = o.backward.witness->to_json();
  if (o.backward.refused) found["witness_check"] = "refused";
  if (o.backward.estimated) found["witness_check"] = "not needed: beyond the tolerance";
}

TracerOutcome judge_tracer_on_case(const Tracer& t, const MeshCase& seen, const VerdictSettings& settings,
                                   bool with_backward_error) {
  TracerOutcome out;
  out.range = settings.range_of(t);
  BuiltScene built = [&] {
    const PausedOracleBudget tracer_time;  // check's oracle budget counts the oracle's time alone
    return t.build(*seen.mesh);
  }();
  if (!built.scene) {
    // A tracer that stopped earlier answers nothing more: no kind of its own to show (shrinking
    // then keeps the case as found).
    const bool declined = built.failure == AnswerFailure::none || built.failure == AnswerFailure::stopped;
    out.kind = declined ? TraceKind::build_failed : kind_of_failure(built.failure);
    out.reason = built.reason;
    return out;
  }
  MeshOracle oracle(seen.mesh);
  if (seen.all) {
    if (!t.has_all_hits) return out.kind = TraceKind::unsupported, out;
    std::vector<AllHitsAnswer> a(1);
    {
      const PausedOracleBudget tracer_time;
      built.scene->all_hits(std::span(&seen.ray, 1), a);
    }
    out.all = a[0];
    if (out.all.unsupported) return out.kind = TraceKind::unsupported, out;
    if (out.all.failure != AnswerFailure::none) {
      out.kind = kind_of_failure(out.all.failure);
      out.reason = t.stop_reason();
      return out;
    }
    const MeshTruth truth = oracle.truth(seen.ray, true);
    out.judgement = oracle.judge_all_hits(seen.ray, truth, out.all, settings.rules_for(t));
    out.kind = out.judgement.kind;
    if (with_backward_error) add_backward_error(out, oracle, seen.ray, truth, t.precision, settings, seen.all);
  } else {
    std::vector<TraceAnswer> a(1);
    {
      const PausedOracleBudget tracer_time;
      built.scene->nearest(std::span(&seen.ray, 1), a);
    }
    out.answer = a[0];
    if (out.answer.failure != AnswerFailure::none) {
      out.kind = kind_of_failure(out.answer.failure);
      out.reason = t.stop_reason();
      return out;
    }
    const MeshTruth truth = oracle.truth(seen.ray, false);
    out.judgement = oracle.judge_nearest(seen.ray, truth, out.answer, t.precision, settings.rules_for(t));
    out.kind = out.judgement.kind;
    if (with_backward_error) add_backward_error(out, oracle, seen.ray, truth, t.precision, settings, seen.all);
  }
  out.reason = out.judgement.detail;
  return out;
}

json expect_json(const MeshTruth& complete) {
  const auto t = complete.first_required() ? std::optional(complete.first_required()->t) : complete.t_star();
  return {{"touched", complete.touched()},
          {"nearest", complete.nearest()},
          {"t", t ? json(hex_double(*t)) : json(nullptr)}};
}

json expect_json(MeshOracle& oracle, const TracerRay& ray) { return expect_json(oracle.truth(ray, true)); }

json reported_json(const TracerOutcome& o, bool all) {
  if (all) return {{"triangles", o.all.triangles}};
  if (!o.answer.hit()) return {{"triangle", nullptr}};
  return {{"triangle", o.answer.triangle}, {"t", std::isnan(o.answer.t) ? json("nan") : json(hex_double(o.answer.t))}};
}

nlohmann::ordered_json check_entry(const TracerOutcome& o, bool all) {
  nlohmann::ordered_json entry = reported_json(o, all);
  entry["kind"] = std::string(to_string(o.kind));
  if (has_backward_error(o.kind)) {
    entry["beta"] = beta_json(o.backward);
    entry["level"] = std::string(to_string(o.level));
  } else if (is_disagreement(o.kind)) {
    entry["level"] = "bug";
  }
  if (!o.reason.empty()) entry["reason"] = o.reason;
  if (o.judgement.ulp) entry["ulp"] = *o.judgement.ulp;
  return entry;
}

}  // namespace rayproof
