// libFuzzer harness: a ray and a box from raw bytes (see shape_fuzzer.h).
#include "shape_fuzzer.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, size_t size) {
  using namespace rayproof;
  fuzz::harness::Bytes in(data, size);
  const Ray ray{in.vec(), in.vec()};
  fuzz::harness::exercise(ray, Box{in.vec(), in.vec()});
  return 0;
}
