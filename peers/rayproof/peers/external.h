// The user's own intersectors (docs/spec/plugin.md): plugins built against rayproof/plugin.h,
// run in worker processes so a crash or a hang costs one variant and nothing already found, and
// commands in any language spoken to over pipes (--exec). Each becomes a registered Variant
// (core/variants.h) whose ExternalIntersector answers in batches.
//
// Process start: linking the plugin and tracer-plugin code installs a static initializer each
// (plugin.cpp, tracer_plugin.cpp). A process whose environment holds RAYPROOF_PLUGIN_WORKER or
// RAYPROOF_TRACER_WORKER becomes a worker before main runs and never returns to main: that is how
// plugins run isolated, rayproof re-executing its own binary (/proc/self/exe) with one of them
// set. A static initializer, not a call in main, so that every binary that loads plugins (the
// CLI, the tests, the benchmarks) can serve as its own worker. Never set them yourself.
#pragma once

#include <string>
#include <vector>

#include "rayproof/core/variants.h"

namespace rayproof::peers {

struct ExternalOptions {
  double case_timeout_seconds = 10;           // --case-timeout: no answer to a case within this is a `timeout`
  Precision exec_precision = Precision::f64;  // --exec-precision float: exec commands are sent float-rounded cases
  int max_crashes = 10;  // --max-crashes: crashes or hangs before a variant is stopped (a fresh worker after each)
};

// Loads a plugin and registers its variants (docs/spec/plugin.md). Throws std::runtime_error
// with one line naming the file for every loading error (missing file or symbol, ABI mismatch,
// a bad name, shape or rule, both or neither function, a name clash).
std::vector<const Variant*> load_plugin(const std::string& path, const ExternalOptions& options);

// Registers `name` as a variant answered by `/bin/sh -c command` over the exec protocol; it
// answers the shapes declared (`--exec NAME:sphere,box=COMMAND`), or every shape when none
// are. Throws on a bad or clashing name.
const Variant& add_exec_variant(const std::string& name, const std::string& command, const ExternalOptions& options,
                                const std::vector<ShapeKind>& shapes = {});

// One answer line of an answers file or an exec command: {"id", "class", "t"} (plugin.md). A
// contact other than a tangent without t, or a NaN t, is a plugin error in `answer.failure`;
// anything unreadable throws FieldError naming the field.
struct AnswerLine {
  std::string id;
  Answer answer;
};
AnswerLine parse_answer_line(const std::string& text);
// One case line of the exec protocol: the case format without expect and found, every number a
// hex-float string.
std::string exec_case_line(const Query& q, const std::string& id);

// Registers `name` as the answers in an answers file (check --answers NAME=FILE): looked up by
// case id; it answers every shape. Throws when the file cannot be opened or the name is bad.
const Variant& add_answers_variant(const std::string& name, const std::string& path);
// An answers variant's problems, each with FILE:LINE or the case id: unreadable lines, repeated
// ids, cases without an answer, answers without a case (complete once the cases are judged).
std::vector<std::string> answers_problems(const Variant& v);

// "NAME=VALUE" split at the first '=' (for --exec and --answers), or std::runtime_error.
std::pair<std::string, std::string> split_assignment(const std::string& flag, const std::string& text);

// Whether `name` is a valid variant name: [a-z0-9-]+.
bool valid_variant_name(const std::string& name);

}  // namespace rayproof::peers
