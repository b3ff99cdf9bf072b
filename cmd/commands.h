// Subcommands of the `rayproof` executable; each registers itself on the CLI11 app. The flag
// vocabulary they share lives in options.cpp, so every command spells a flag the same way.
#pragma once

#include <CLI/CLI.hpp>
#include <cstdint>
#include <chrono>
#include <functional>
#include <ostream>
#include <string>
#include <vector>

#include "rayproof/core/hit.h"
#include "rayproof/core/tracer.h"
#include "rayproof/core/variants.h"
#include "rayproof/fuzz/generators.h"
#include "rayproof/fuzz/tracer_families.h"
#include "rayproof/studies/trade.h"
#include "rayproof/verify/backward_error.h"
#include "rayproof/verify/diagnose.h"

namespace rayproof::cli {

void add_variants_command(CLI::App& app, int& exit_code);
void add_intersect_command(CLI::App& app, int& exit_code);
void add_render_command(CLI::App& app, int& exit_code);
void add_check_command(CLI::App& app, int& exit_code);
void add_fuzz_command(CLI::App& app, int& exit_code);
void add_spawn_command(CLI::App& app, int& exit_code);
void add_trade_command(CLI::App& app, int& exit_code);
void add_stability_command(CLI::App& app, int& exit_code);
void add_merge_command(CLI::App& app, int& exit_code);
void add_audit_command(CLI::App& app, int& exit_code);
void add_offsets_command(CLI::App& app, int& exit_code);
// The spawn study's table on stderr and its CSV (shared by `spawn` and `fuzz --families near-origin`).
void run_spawn_report(const std::vector<const Variant*>& variants, const std::vector<int>& scales, std::uint64_t count,
                      std::uint64_t seed, int threads, const std::string& csv_path);

// ---- the shared flags: one spelling each, lists comma separated or repeated, `all` anywhere.
// --variants (alias --variant), --shapes (--shape), --families (--family), --rule, --threads,
// --seed, --count; -o is each command's own (its meaning differs: file or directory).
void add_variants_flag(CLI::App* cmd, std::vector<std::string>& names);
void add_shapes_flag(CLI::App* cmd, std::vector<std::string>& names);
void add_families_flag(CLI::App* cmd, std::vector<std::string>& names);
void add_rule_flag(CLI::App* cmd, std::string& rule);
void add_threads_flag(CLI::App* cmd, int& threads);
void add_seed_flag(CLI::App* cmd, std::uint64_t& seed);
// --format table|markdown|json: how summaries print (table: aligned text for a terminal).
void add_format_flag(CLI::App* cmd, std::string& format);
void add_count_flag(CLI::App* cmd, std::uint64_t& count, const std::string& what, std::uint64_t most);
// A number of seconds: finite, from lo to hi.
CLI::Validator seconds_from(double lo, double hi);

// --plugin PATH (repeatable), --exec NAME=COMMAND (repeatable), --case-timeout SECONDS,
// --exec-precision double|float (docs/spec/plugin.md): the user's own code as variants.
struct ExternalFlags {
  std::vector<std::string> plugins, execs;
  double case_timeout = 10;
  std::string exec_precision = "double";
  int max_crashes = 10;
  std::string worker_memory = "auto";  // --worker-memory: SIZE (512M, 4G), none, or auto
};
void add_external_flags(CLI::App* cmd, ExternalFlags& flags);
// Loads the plugins and starts nothing yet (exec commands start on first use); call first in a
// command's callback, before parse_variants. Loading errors are std::runtime_error (exit code 2).
void load_externals(const ExternalFlags& flags);

// --tracer PATH, --tracer-exec NAME=COMMAND (repeatable), --tracers LIST, --tracer-precision
// double|float (docs/spec/tracer.md): whole tracers for fuzz, check and variants.
struct TracerFlags {
  std::vector<std::string> plugins, execs, names;
  std::string precision = "double";
  std::vector<std::string> ranges;          // --tracer-range NAME=open|closed
  std::vector<std::string> variant_ranges;  // --variant-range NAME=open|closed
  double tolerance_ulps = kDefaultToleranceUlps;
  std::string fail_on = "none";  // --fail-on bug|rounding|none
  bool given() const { return !plugins.empty() || !execs.empty() || !names.empty(); }
};
void add_tracer_flags(CLI::App* cmd, TracerFlags& flags);
// --tolerance-ulps K (verdicts.md): nan, inf and negatives refused.
void add_tolerance_flag(CLI::App* cmd, double& tolerance_ulps);
// Registers the peer tracers (Embree where built, CGAL's AABB tree), loads the plugins and
// registers the exec tracers; loading errors are std::runtime_error (exit code 2).
void load_tracers(const TracerFlags& flags, double case_timeout);
// --fail-on: whether a tracer outcome of this kind and level makes the run exit 1 (bug: bug-level
// disagreements, tracer errors, crashes and timeouts; rounding: every disagreement; none: never).
bool fails_on(const std::string& fail_on, TraceKind kind, Level level);
// The chosen tracers: named ones (every one for `all` or nothing given) and every exec tracer.
std::vector<const Tracer*> parse_tracers(const std::vector<std::string>& names);
std::vector<fuzz::TracerFamily> parse_tracer_families(const std::vector<std::string>& names);

// Comma-separated option values, flattened ("a,b" "c" → a, b, c); empty items dropped.
std::vector<std::string> split_list(const std::vector<std::string>& lists);
// The chosen shapes (every shape for `all` or nothing given), or CLI::ValidationError.
std::vector<ShapeKind> parse_shapes(const std::vector<std::string>& names);
std::vector<fuzz::Family> parse_families(const std::vector<std::string>& names);
// The chosen variants of the chosen shapes: named ones (every one for `all` or nothing given),
// kept only where their shape is among `shapes`, and every --exec variant (always judged).
// Throws CLI::ValidationError for an unknown name.
std::vector<const Variant*> parse_variants(const std::vector<std::string>& names,
                                           const std::vector<ShapeKind>& shapes = {kAllShapeKinds.begin(),
                                                                                   kAllShapeKinds.end()});
HitRule parse_rule(const std::string& rule);

// After a table of `fuzz` or `check`: one example per variant and kind with the `check --id`
// command that replays it, then the diagnosis hints (verify/diagnose.h). Only the user's own
// code is shown when some is among `selected`.
void print_digest(std::ostream& out, const std::vector<Disagreement>& all, const std::vector<const Variant*>& selected,
                  const std::function<std::uint64_t(const std::string&)>& shared_edge_holes = nullptr);
int thread_count(int flag);  // 0: every hardware thread

// Everything `trade` and the benchmarks measure: the registered variants, their batched forms
// and, when built, peer libraries.
std::vector<studies::Contender> trade_contenders();

// Progress on stderr: done/total, rate and time left. On a terminal one line rewritten in place;
// otherwise (a log, CI) a line every 30 s, so no long run is silent (issue 41).
class Progress {
 public:
  // `logged`: off a terminal too (false for a run whose standard error is JSON: --format json).
  explicit Progress(std::string label, bool logged = true);
  void update(long done, long total);
  void finish();

 private:
  std::string label_;
  bool terminal_, logged_;
  std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now(), last_shown_ = start_;
  bool shown_ = false;
};

}  // namespace rayproof::cli
