// libFuzzer harness: every reader of text and bytes from users, on arbitrary input — case files,
// scenes, PLY and STL meshes (counts before their data), campaign summaries as `merge` reads them,
// and exec answer lines (variants' and tracers', nearest and any-hit). A malformed input must end in the readers' own
// error types (FieldError, std::runtime_error, nlohmann's json exceptions), never a crash, a hang or any other
// exception. Built for libFuzzer (-DRAYPROOF_LIBFUZZER=ON) and, with replay_main.cpp, as a test that replays
// fuzz/corpus/parsers_fuzzer under the sanitizer build.
#include <cstdint>
#include <stdexcept>
#include <string>

#include "rayproof/core/casefile.h"
#include "rayproof/core/mesh.h"
#include "rayproof/core/scene.h"
#include "rayproof/fuzz/campaign.h"
#include "rayproof/fuzz/tracer_campaign.h"
#include "rayproof/peers/external.h"
#include "rayproof/peers/tracers.h"

namespace {
template <class Read>
void expect_only_reader_errors(Read read) {
  try {
    read();
  } catch (const rayproof::FieldError&) {
  } catch (const nlohmann::json::exception&) {
  } catch (const std::runtime_error&) {}
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  expect_only_reader_errors([&] {
    const rayproof::Case c = rayproof::parse_case(text);
    const rayproof::Case back = rayproof::parse_case(rayproof::case_to_json(c).dump());  // round trip
    if (back.ray.origin != c.ray.origin || back.ray.direction != c.ray.direction) __builtin_trap();
  });
  expect_only_reader_errors([&] { rayproof::parse_scene(text, "fuzz-input"); });
  expect_only_reader_errors([&] { rayproof::parse_ply_mesh(text, "fuzz-input.ply"); });
  expect_only_reader_errors([&] { rayproof::parse_stl_mesh(text, "fuzz-input.stl"); });
  expect_only_reader_errors([&] {
    const rayproof::json j = rayproof::parse_json_text(text);
    if (j.is_object() && j.value("kind", "") == "tracers") {
      const auto r = rayproof::fuzz::TracerCampaignReport::from_json(j);
      (void)rayproof::fuzz::TracerCampaignReport::from_json(r.to_json());  // what it read, it writes back readably
    } else {
      const auto r = rayproof::fuzz::CampaignReport::from_json(j);
      (void)rayproof::fuzz::CampaignReport::from_json(r.to_json());
    }
  });
  expect_only_reader_errors([&] { rayproof::peers::parse_answer_line(text); });
  for (const bool all : {false, true})  // an exec tracer's answer line, nearest and any-hit
    expect_only_reader_errors([&] { rayproof::peers::read_tracer_answer_line(text, "r0", all); });
  return 0;
}
