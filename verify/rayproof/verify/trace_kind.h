// What one ray's outcome was for a whole tracer (docs/spec/tracer.md, verdicts.md), as one table:
// every kind once, with its name, its count field in a tally and what it is. The names, the
// tally, the tables, the findings' quotas and --fail-on all read this table, so a new kind is one
// row here.
#pragma once

#include <cstddef>
#include <string_view>

namespace rayproof {

enum class TraceKind {
  right,
  hole,
  false_hit,
  not_nearest,
  double_hit,
  missed_in_any_hit,
  in_plane,           // a miss where every contact is optional: cannot tell
  tracer_error,       // NaN t, a triangle out of range, a repeated index
  unsupported,        // any-hit asked of a tracer without it
  not_representable,  // a float tracer's case that overflows float (or the far family beyond 2^40)
  crash,
  timeout,
  build_failed,
  out_of_memory,  // the tracer's worker died at its --worker-memory limit (a compatible extra kind)
};

//   verdict       the answer was judged against the exact truth (right, or a disagreement with
//                 it); otherwise a failure: the tracer gave no answer that could be judged
//   disagreement  counted among the tracer's disagreements (bugs unless levelled as rounding)
//   levelled      split by verdicts.md into KIND_bugs and KIND_rounding (it has a backward error)
//   spec_field    a count field of tracer.md's summary, written even when zero; the others are
//                 compatible extras, written where met. tally_key: its name there.
struct TraceKindInfo {
  TraceKind kind;
  std::string_view name, tally_key;
  bool verdict, disagreement, levelled, spec_field;
};
// clang-format off
inline constexpr TraceKindInfo kTraceKinds[] = {
    // kind,                       name,                tally_key,           verdict, disagreement, levelled, spec_field
    {TraceKind::right,             "right",             "right",             true,  false, false, true},
    {TraceKind::hole,              "hole",              "hole",              true,  true,  true,  true},
    {TraceKind::false_hit,         "false_hit",         "false_hit",         true,  true,  true,  true},
    {TraceKind::not_nearest,       "not_nearest",       "not_nearest",       true,  true,  true,  true},
    {TraceKind::double_hit,        "double_hit",        "double_hit",        true,  true,  true,  true},
    {TraceKind::missed_in_any_hit, "missed_in_any_hit", "missed_in_any_hit", true,  true,  true,  true},
    {TraceKind::in_plane,          "in_plane",          "in_plane",          true,  false, false, true},
    {TraceKind::tracer_error,      "tracer_error",      "tracer_errors",     false, true,  false, true},
    {TraceKind::unsupported,       "unsupported",       "unsupported",       false, false, false, true},
    {TraceKind::not_representable, "not_representable", "not_representable", false, false, false, false},
    {TraceKind::crash,             "crash",             "crash",             false, true,  false, true},
    {TraceKind::timeout,           "timeout",           "timeout",           false, true,  false, true},
    {TraceKind::build_failed,      "build_failed",      "build_failed",      false, false, false, false},
    {TraceKind::out_of_memory,     "out_of_memory",     "out_of_memory",     false, true,  false, false},
};
// clang-format on
constexpr bool rows_in_enum_order() {
  for (std::size_t i = 0; i < std::size(kTraceKinds); ++i)
    if (static_cast<std::size_t>(kTraceKinds[i].kind) != i) return false;
  return true;
}
static_assert(rows_in_enum_order(), "kTraceKinds: one row per TraceKind, in the enum's order");

constexpr const TraceKindInfo& info(TraceKind k) { return kTraceKinds[static_cast<std::size_t>(k)]; }
constexpr std::string_view to_string(TraceKind k) { return info(k).name; }
constexpr bool is_disagreement(TraceKind k) { return info(k).disagreement; }
// Whether a kind is split into bugs and rounding-level disagreements (verdicts.md §4).
constexpr bool has_backward_error(TraceKind k) { return info(k).levelled; }

}  // namespace rayproof
