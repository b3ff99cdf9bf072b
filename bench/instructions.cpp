// Instructions per call, where time alone cannot say why a ratio stands where it does: runs one
// routine over the benchmark's random-hit ring (inputs.h, the same queries as the timed runs)
// inside counted_loop, which scripts/instruction-counts.py has callgrind count alone
// (--toggle-collect). The loop's own instructions are counted by the routine `none` and
// subtracted there.
//
// Usage: rayproof_instructions ROUTINE SHAPE PASSES
//   ROUTINE: none | class | judge | a variant's name (e.g. robust-slab)
#include <charconv>
#include <cstdio>
#include <string>
#include <string_view>

#include "inputs.h"
#include "rayproof/core/variants.h"

namespace rayproof::bench {

// Kept out of line, and named, so that callgrind counts exactly its instructions.
template <class Routine>
[[gnu::noinline]] long counted_loop(const std::vector<Query>& qs, int passes, Routine&& routine) {
  long sink = 0;
  for (int p = 0; p < passes; ++p)
    for (const Query& q : qs) sink += routine(q);
  return sink;
}

int run(const std::string& routine, ShapeKind shape, int passes) {
  const std::vector<Query>& qs = inputs(shape, "random-hit");
  Oracle oracle;
  long sink = 0;
  if (routine == "none") {
    sink = counted_loop(qs, passes, [](const Query& q) { return static_cast<long>(q.shape.index()); });
  } else if (routine == "class") {
    sink = counted_loop(qs, passes, [&](const Query& q) { return static_cast<long>(oracle.classify(q.ray, q.shape)); });
  } else if (routine == "judge") {
    sink =
        counted_loop(qs, passes, [&](const Query& q) { return static_cast<long>(oracle.judge(q.ray, q.shape).cls); });
  } else if (const Variant* v = find_variant(routine); v && v->kernel && v->shape == shape) {
    sink = counted_loop(qs, passes, [&](const Query& q) {
      return static_cast<long>(v->intersect(q.ray, q.shape, HitRule::nearest_contact).cls);
    });
  } else {
    std::fprintf(stderr,
                 "rayproof_instructions: unknown routine '%s' for %s (none, class, judge or a built-in %s variant)\n",
                 routine.c_str(), std::string(to_string(shape)).c_str(), std::string(to_string(shape)).c_str());
    return 2;
  }
  std::printf("%s %s %zu queries x %d passes (sink %ld)\n", routine.c_str(), std::string(to_string(shape)).c_str(),
              qs.size(), passes, sink);
  return 0;
}

}  // namespace rayproof::bench

int main(int argc, char** argv) {
  const auto shape = argc == 4 ? rayproof::shape_kind_from_string(argv[2]) : std::nullopt;
  int passes = 0;  // 1 to 1000 (each pass is the 4096-query ring, ~1 s under callgrind)
  if (argc == 4) {
    const std::string_view text(argv[3]);
    const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), passes);
    if (error != std::errc() || end != text.data() + text.size() || passes > 1000) passes = 0;
  }
  if (!shape || passes <= 0) {
    std::fprintf(stderr, "usage: rayproof_instructions none|class|judge|VARIANT sphere|plane|triangle|box PASSES\n");
    return 2;
  }
  return rayproof::bench::run(argv[1], *shape, passes);
}
