// libFuzzer harness: the case-file and scene parsers on arbitrary text. A malformed input
// must end in the parsers' own error types, never a crash or any other exception.
#include <cstdint>
#include <stdexcept>
#include <string>

#include "rayproof/core/casefile.h"
#include "rayproof/core/scene.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    const rayproof::Case c = rayproof::parse_case(text);
    const rayproof::Case back = rayproof::parse_case(rayproof::case_to_json(c).dump());  // round trip
    if (back.ray.origin != c.ray.origin || back.ray.direction != c.ray.direction) __builtin_trap();
  } catch (const rayproof::FieldError&) {
  }
  try {
    rayproof::parse_scene(text, "fuzz-input");
  } catch (const std::runtime_error&) {
  }
  return 0;
}
