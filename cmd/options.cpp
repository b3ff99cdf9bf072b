// The flag vocabulary every command shares, the contenders of `trade`, and the progress line.
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstdio>
#include <fstream>
#include <sstream>

#include "commands.h"
#include "rayproof/core/parallel.h"
#include "rayproof/peers/child_process.h"
#include "rayproof/peers/external.h"
#include "rayproof/peers/tracers.h"
#ifdef RAYPROOF_HAVE_EMBREE
#include "rayproof/peers/embree.h"
#endif

namespace rayproof::cli {

void add_variants_flag(CLI::App* cmd, std::vector<std::string>& names) {
  cmd->add_option("--variants,--variant", names, "variants, comma separated or repeated, or all (default: all)");
}
void add_shapes_flag(CLI::App* cmd, std::vector<std::string>& names) {
  cmd->add_option("--shapes,--shape", names, "shapes, comma separated: sphere, plane, triangle, box, all");
}
void add_families_flag(CLI::App* cmd, std::vector<std::string>& names) {
  cmd->add_option("--families,--family", names,
                  "families, comma separated (default: all): for variants random, tangent, grazing, near-origin, "
                  "exit-entry, extremes; for tracers (with --tracer, --tracer-exec or --tracers) shared-edges, fans, "
                  "axis-planes, needles, spawned, shells, far, random");
}
void add_rule_flag(CLI::App* cmd, std::string& rule) {
  cmd->add_option("--rule", rule, "hit rule: nearest (first contact) or enter-only")
      ->check(CLI::IsMember({"nearest", "enter-only"}));
}
void add_threads_flag(CLI::App* cmd, int& threads) {
  cmd->add_option("--threads", threads, "worker threads (default: all cores)")->check(CLI::Range(0, 256));
}
void add_seed_flag(CLI::App* cmd, std::uint64_t& seed) {
  cmd->add_option("--seed", seed, "seed: the same seed and count give the same cases on any machine")
      ->check(CLI::Validator(
          [](std::string& text) {
            return text.find_first_not_of("0123456789") == std::string::npos && !text.empty()
                       ? std::string()
                       : "expected a whole number from 0 to 18446744073709551615, got '" + text + "'";
          },
          "UINT64"));
}

namespace {
// Whole numbers written plainly or in scientific notation ("100000", "1e5"), rewritten as digits.
CLI::Validator whole_number(std::uint64_t most) {
  return CLI::Validator(
      [most](std::string& text) {
        const std::string bad =
            "expected a whole number from 1 to " + std::to_string(most) + " (e.g. 100000 or 1e5), got '" + text + "'";
        if (text.empty() || text.find_first_not_of("0123456789.eE+") != std::string::npos) return bad;
        char* end = nullptr;
        const double value = std::strtod(text.c_str(), &end);
        if (*end != '\0' || !(value >= 1) || value > static_cast<double>(most) || value != std::floor(value))
          return bad;
        text = std::to_string(static_cast<std::uint64_t>(value));
        return std::string();
      },
      "COUNT");
}
}  // namespace
// CLI::Range lets "nan" through (no comparison with NaN fails): a number of seconds is checked
// here instead, finite and within [lo, hi].
CLI::Validator seconds_from(double lo, double hi) {
  return CLI::Validator(
      [lo, hi](std::string& text) {
        char* end = nullptr;
        const double value = std::strtod(text.c_str(), &end);
        if (text.empty() || *end != '\0' || !(value >= lo && value <= hi))
          return "expected seconds from " + CLI::detail::to_string(lo) + " to " + CLI::detail::to_string(hi) +
                 ", got '" + text + "'";
        return std::string();
      },
      "SECONDS");
}
void add_format_flag(CLI::App* cmd, std::string& format) {
  cmd->add_option("--format", format, "summary format: table (aligned text), markdown (paste-ready) or json")
      ->check(CLI::IsMember({"table", "markdown", "json"}));
}
void add_count_flag(CLI::App* cmd, std::uint64_t& count, const std::string& what, std::uint64_t most) {
  cmd->add_option("--count", count, what + " (default " + std::to_string(count) + ")")->transform(whole_number(most));
}

namespace {
// --worker-memory's bytes: SIZE[K|M|G] (binary), none (0), auto (half of MemAvailable).
std::uint64_t worker_memory_bytes(const std::string& text) {
  if (text == "none") return 0;
  if (text == "auto") {
    std::ifstream meminfo("/proc/meminfo");
    std::string key;
    std::uint64_t kib = 0;
    while (meminfo >> key >> kib)
      if (key == "MemAvailable:") return kib * 1024 / 2;
    return 0;  // unknown: no limit
  }
  std::size_t used = 0;
  unsigned long long n = 0;
  try {
    n = std::stoull(text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  const std::string unit = text.substr(used);
  const int shift = unit.empty() ? 0 : unit == "K" ? 10 : unit == "M" ? 20 : unit == "G" ? 30 : -1;
  if (used == 0 || shift < 0 || text[0] == '-' || n == 0 || n > (1ull << (63 - shift)))
    throw std::invalid_argument("expected SIZE (as 512M or 4G), none or auto, got '" + printable(text) + "'");
  return static_cast<std::uint64_t>(n) << shift;
}
}  // namespace

void add_external_flags(CLI::App* cmd, ExternalFlags& flags) {
  cmd->add_option("--plugin", flags.plugins,
                  "a shared library exporting rayproof_plugin (rayproof/plugin.h); repeatable");
  cmd->add_option("--exec", flags.execs,
                  "NAME=COMMAND: a command that answers cases over pipes (docs/spec/plugin.md); repeatable");
  cmd->add_option("--case-timeout", flags.case_timeout,
                  "seconds a plugin or exec command may take on one case (default 10)")
      ->check(seconds_from(0.001, 86400));
  cmd->add_option("--max-crashes", flags.max_crashes,
                  "crashes or hangs of one plugin or exec variant before it is stopped; after each a fresh worker "
                  "goes on with the next case (default 10)")
      ->check(CLI::Range(1, 1000000));
  cmd->add_option("--exec-precision", flags.exec_precision, "double, or float: exec commands get float-rounded cases")
      ->check(CLI::IsMember({"double", "float"}));
  cmd->add_option("--worker-memory", flags.worker_memory,
                  "data each plugin or tracer worker and exec command may hold (RLIMIT_DATA): SIZE as 512M or 4G, "
                  "none, or auto (default: half the memory available at start); a worker that dies at it is a "
                  "finding of kind out_of_memory")
      ->check(CLI::Validator(
          [](std::string& text) {
            try {
              worker_memory_bytes(text);
              return std::string();
            } catch (const std::invalid_argument& e) {
              return std::string(e.what());
            }
          },
          "SIZE"));
}

void load_externals(const ExternalFlags& flags) {
  peers::child_memory_limit = worker_memory_bytes(flags.worker_memory);  // before any worker starts
  peers::ExternalOptions options;
  options.case_timeout_seconds = flags.case_timeout;
  options.exec_precision = flags.exec_precision == "float" ? Precision::f32 : Precision::f64;
  options.max_crashes = flags.max_crashes;
  for (const std::string& path : flags.plugins) peers::load_plugin(path, options);
  for (const std::string& text : flags.execs) {
    // NAME=COMMAND, or NAME:SHAPE[,SHAPE]=COMMAND for a command that answers only those shapes.
    const auto [declared, command] = peers::split_assignment("--exec", text);
    const std::size_t colon = declared.find(':');
    std::vector<ShapeKind> shapes;
    if (colon != std::string::npos) {
      std::stringstream list(declared.substr(colon + 1));
      for (std::string shape; std::getline(list, shape, ',');) {
        const auto k = shape_kind_from_string(shape);
        if (!k)
          throw std::runtime_error("--exec " + printable(declared) + "=...: '" + printable(shape) +
                                   "' is not a shape (sphere, plane, triangle, box)");
        if (std::find(shapes.begin(), shapes.end(), *k) == shapes.end()) shapes.push_back(*k);
      }
      if (shapes.empty()) throw std::runtime_error("--exec " + printable(declared) + "=...: no shape after ':'");
    }
    peers::add_exec_variant(declared.substr(0, colon), command, options, shapes);
  }
}

void add_tolerance_flag(CLI::App* cmd, double& tolerance_ulps) {
  cmd->add_option("--tolerance-ulps", tolerance_ulps,
                  "K: a disagreement whose backward error is at most K ulps (with a witness) is rounding-level, "
                  "not a bug (default 16; 0: the strict reading)")
      ->check(CLI::Validator(
          [](std::string& text) {
            char* end = nullptr;
            const double k = std::strtod(text.c_str(), &end);
            return text.empty() || *end != '\0' || !(k >= 0 && k <= 1e15)  // refuses nan, inf, negatives
                       ? "expected a number of ulps from 0 to 1e15, got '" + text + "'"
                       : std::string();
          },
          "K"));
}

void add_tracer_flags(CLI::App* cmd, TracerFlags& flags) {
  cmd->add_option("--tracer", flags.plugins,
                  "a shared library exporting rayproof_tracers (rayproof/tracer.h); repeatable");
  cmd->add_option("--tracer-exec", flags.execs,
                  "NAME=COMMAND: a whole tracer over pipes (docs/spec/tracer.md); repeatable");
  cmd->add_option("--tracers", flags.names,
                  "tracers to judge, comma list or `all` (default: those --tracer and --tracer-exec loaded, else the "
                  "built-in bvh-*; peers such as cgal-aabb only when named or `all`; see `rayproof variants`)");
  cmd->add_option("--tracer-precision", flags.precision,
                  "double, or float: --tracer-exec commands get float-rounded meshes and rays")
      ->check(CLI::IsMember({"double", "float"}));
  cmd->add_option("--tracer-range", flags.ranges,
                  "NAME=open|closed: declares or overrides a tracer's range (docs/spec/verdicts.md); repeatable");
  cmd->add_option("--variant-range", flags.variant_ranges,
                  "NAME=open|closed: declares a variant's range, closed admitting t = 0 (docs/spec/verdicts.md); "
                  "repeatable");
  add_tolerance_flag(cmd, flags.tolerance_ulps);
  cmd->add_option("--fail-on", flags.fail_on,
                  "bug|rounding|none: exit 1 when a tracer shows a bug-level disagreement (or a crash), any "
                  "disagreement, or never (default)")
      ->check(CLI::IsMember({"bug", "rounding", "none"}));
}

bool fails_on(const std::string& fail_on, TraceKind kind, Level level) {
  if (fail_on == "none" || !is_disagreement(kind)) return false;
  return fail_on == "rounding" || level == Level::bug;
}

void load_tracers(const TracerFlags& flags, double case_timeout) {
  static const bool peers_registered = [] {
#ifdef RAYPROOF_HAVE_EMBREE
    peers::register_embree_tracers();
#endif
    peers::register_cgal_aabb_tracer();
    return true;
  }();
  (void)peers_registered;
  peers::ExternalOptions options;
  options.case_timeout_seconds = case_timeout;
  options.exec_precision = flags.precision == "float" ? Precision::f32 : Precision::f64;
  for (const std::string& path : flags.plugins) peers::load_tracer_plugin(path, options);
  for (const std::string& text : flags.execs) {
    const auto [name, command] = peers::split_assignment("--tracer-exec", text);
    peers::add_exec_tracer(name, command, options);
  }
  // --tracer-range and --variant-range (the latter after load_externals: plugins' variants too).
  auto declare_ranges = [](const std::vector<std::string>& texts, const std::string& flag, const std::string& what,
                           bool (*set)(std::string_view, RangeRule)) {
    for (const std::string& text : texts) {
      const auto [name, value] = peers::split_assignment(flag, text);
      const auto range = range_rule_from_string(value);
      if (!range) throw std::runtime_error(flag + " " + printable(text) + ": expected NAME=open or NAME=closed");
      if (!set(name, *range))
        throw std::runtime_error(flag + " " + printable(text) + ": no " + what + " is named '" + printable(name) +
                                 "' (see rayproof variants)");
    }
  };
  declare_ranges(flags.ranges, "--tracer-range", "tracer", &set_tracer_range);
  declare_ranges(flags.variant_ranges, "--variant-range", "variant", &set_variant_range);
}

std::vector<std::string> split_list(const std::vector<std::string>& lists) {
  std::vector<std::string> out;
  for (const std::string& l : lists) {
    std::stringstream ss(l);
    for (std::string x; std::getline(ss, x, ',');)
      if (!x.empty()) out.push_back(x);
  }
  return out;
}

namespace {
// Names resolved by `lookup`; `all` (or no name) means every one of `all_values`.
template <class T, class Lookup>
std::vector<T> parse_named(const std::vector<std::string>& names, const std::vector<T>& all_values,
                           const std::string& flag, const std::string& what, Lookup lookup,
                           const std::string& known = "") {
  std::vector<T> out;
  const auto items = split_list(names);
  if (!names.empty() && items.empty()) throw CLI::ValidationError(flag, "an empty list names no " + what);
  for (const std::string& name : items) {
    if (name == "all") {
      for (const T& v : all_values)
        if (std::find(out.begin(), out.end(), v) == out.end()) out.push_back(v);
      continue;
    }
    const auto value = lookup(name);
    if (!value)
      throw CLI::ValidationError(
          flag, "unknown " + what + " '" + name + "'" + (known.empty() ? "" : " (known: " + known + ")"));
    if (std::find(out.begin(), out.end(), *value) == out.end()) out.push_back(*value);
  }
  return items.empty() ? all_values : out;
}
}  // namespace

std::vector<ShapeKind> parse_shapes(const std::vector<std::string>& names) {
  return parse_named<ShapeKind>(names, {kAllShapeKinds.begin(), kAllShapeKinds.end()}, "--shapes", "shape",
                                shape_kind_from_string);
}

std::vector<fuzz::Family> parse_families(const std::vector<std::string>& names) {
  return parse_named<fuzz::Family>(names, {std::begin(fuzz::kAllFamilies), std::end(fuzz::kAllFamilies)}, "--families",
                                   "family", fuzz::family_from_string);
}

namespace {
// Variants named by --exec or --answers: always judged (plugin.md, Selection).
bool given_by_name(const Variant& v) { return v.origin.rfind("exec: ", 0) == 0 || v.origin.rfind("answers: ", 0) == 0; }
}  // namespace

std::vector<const Variant*> parse_variants(const std::vector<std::string>& names,
                                           const std::vector<ShapeKind>& shapes) {
  std::vector<const Variant*> every;
  for (const Variant& v : all_variants()) every.push_back(&v);
  auto lookup = [](const std::string& name) -> std::optional<const Variant*> {
    if (const Variant* v = find_variant(name)) return v;
    return std::nullopt;
  };
  std::string known;
  for (const Variant* v : every) known += (known.empty() ? "" : ", ") + std::string(v->name);
  std::vector<const Variant*> chosen =
      parse_named<const Variant*>(names, every, "--variants", "variant", lookup, known);
  for (const Variant* v : every)  // --exec and --answers variants are always judged (plugin.md, Selection)
    if (given_by_name(*v) && std::find(chosen.begin(), chosen.end(), v) == chosen.end()) chosen.push_back(v);
  std::erase_if(chosen, [&](const Variant* v) {
    return std::none_of(shapes.begin(), shapes.end(), [&](ShapeKind k) { return v->handles(k); });
  });
  return chosen;
}

std::vector<const Tracer*> parse_tracers(const std::vector<std::string>& names) {
  const std::vector<const Tracer*> every = all_tracers();
  std::string known;
  for (const Tracer* t : every) known += (known.empty() ? "" : ", ") + t->name;
  auto lookup = [](const std::string& name) -> std::optional<const Tracer*> {
    if (const Tracer* t = find_tracer(name)) return t;
    return std::nullopt;
  };
  // Unnamed, the tracers the user loaded (--tracer, --tracer-exec) are judged, else the built-in
  // bvh-* ones; peers (Embree, CGAL) only when named or `all` (issue 41: one exec tracer also ran
  // the peers, silently, for minutes).
  auto loaded_by_user = [](const Tracer* t) { return t->origin != "built-in" && !t->origin.starts_with("peer"); };
  std::vector<const Tracer*> defaults;
  for (const Tracer* t : every)
    if (loaded_by_user(t)) defaults.push_back(t);
  if (defaults.empty())
    for (const Tracer* t : every)
      if (t->origin == "built-in") defaults.push_back(t);
  std::vector<const Tracer*> chosen =
      names.empty() ? defaults : parse_named<const Tracer*>(names, every, "--tracers", "tracer", lookup, known);
  for (const Tracer* t : every)  // --tracer-exec tracers are always judged (tracer.md)
    if (t->always_judged && std::find(chosen.begin(), chosen.end(), t) == chosen.end()) chosen.push_back(t);
  return chosen;
}

std::vector<fuzz::TracerFamily> parse_tracer_families(const std::vector<std::string>& names) {
  return parse_named<fuzz::TracerFamily>(
      names, {std::begin(fuzz::kAllTracerFamilies), std::end(fuzz::kAllTracerFamilies)}, "--families", "tracer family",
      fuzz::tracer_family_from_string, "shared-edges, fans, axis-planes, needles, spawned, shells, far, random");
}

HitRule parse_rule(const std::string& rule) {
  const auto r = hit_rule_from_string(rule);
  if (!r) throw CLI::ValidationError("--rule", "unknown rule '" + rule + "' (nearest or enter-only)");
  return *r;
}

int thread_count(int flag) { return flag > 0 ? flag : default_threads(); }

std::vector<studies::Contender> trade_contenders() {
  std::vector<studies::Contender> all = studies::variant_contenders();
  for (studies::Contender& c : studies::batched_contenders()) all.push_back(std::move(c));
#ifdef RAYPROOF_HAVE_EMBREE
  for (studies::Contender& c : peers::embree_contenders()) all.push_back(std::move(c));
#endif
  return all;
}

Progress::Progress(std::string label, bool logged) : label_(std::move(label)), terminal_(isatty(2)), logged_(logged) {}

void Progress::update(long done, long total) {
  if (!terminal_ && !logged_) return;
  const auto now = std::chrono::steady_clock::now();
  const double since_shown = std::chrono::duration<double>(now - last_shown_).count();
  if (since_shown < (terminal_ ? 0.25 : 30.0)) return;
  last_shown_ = now;
  const double elapsed = std::chrono::duration<double>(now - start_).count();
  const double rate = elapsed > 0 ? done / elapsed : 0;
  char line[256];
  if (total <= 0) {  // unknown total (a case file read as it streams)
    std::snprintf(line, sizeof line, "%s: %ld done, %.0f/s", label_.c_str(), done, rate);
  } else {
    const double left = rate > 0 ? (total - done) / rate : 0;
    std::snprintf(line, sizeof line, "%s: %ld/%ld (%ld%%), %.0f/s, %.0f s left", label_.c_str(), done, total,
                  done * 100 / total, rate, left);
  }
  if (terminal_)
    std::fprintf(stderr, "\r%s\033[K", line);  // rewritten in place, cleared to the line's end
  else
    std::fprintf(stderr, "%s\n", line);
  std::fflush(stderr);
  shown_ = true;
}

void Progress::finish() {
  if (terminal_ && shown_) std::fprintf(stderr, "\n");
  shown_ = false;
}

void print_digest(std::ostream& out, const std::vector<Disagreement>& all, const std::vector<const Variant*>& selected,
                  const std::function<std::uint64_t(const std::string&)>& shared_edge_holes) {
  std::vector<std::string> shown;
  for (const Variant* v : selected)
    if (v->external) shown.push_back(std::string(v->name));
  const auto replay = [&](const Disagreement& d) {
    const Variant* v = find_variant(d.variant);
    const std::string flags = v ? loading_flags(*v) : "";
    return "rayproof check " + shell_quoted(printable(d.file)) + " --id " + shell_quoted(printable(d.c.id)) +
           " --variants " + d.variant + (flags.empty() ? "" : " " + flags);
  };
  print_examples_and_hints(out, all, replay, 12, shown, shared_edge_holes);
}

}  // namespace rayproof::cli
