#!/bin/bash -eu
# OSS-Fuzz / ClusterFuzz build script. The OSS-Fuzz environment provides $SRC, $OUT, $CXX,
# $CXXFLAGS (with its sanitizer) and $LIB_FUZZING_ENGINE; each harness is one
# LLVMFuzzerTestOneInput per file in fuzz/libfuzzer/, with a seed corpus in fuzz/corpus/NAME/.
cmake -S "$SRC/rayproof" -B build -DCMAKE_BUILD_TYPE=Release -DCMAKE_CXX_COMPILER="$CXX" \
  -DCMAKE_CXX_FLAGS="$CXXFLAGS" -DRAYPROOF_LIBFUZZER=ON -DRAYPROOF_FUZZ_SANITIZE=OFF \
  -DRAYPROOF_FUZZ_ENGINE="$LIB_FUZZING_ENGINE" -DRAYPROOF_BUILD_TESTS=OFF -DRAYPROOF_BUILD_BENCH=OFF
for f in sphere plane triangle box parsers; do
  cmake --build build -j"$(nproc)" --target "${f}_fuzzer"
  cp "build/fuzz/libfuzzer/${f}_fuzzer" "$OUT/"
  (cd "$SRC/rayproof/fuzz/corpus/${f}_fuzzer" && zip -q -r "$OUT/${f}_fuzzer_seed_corpus.zip" .)
  if [ -f "$SRC/rayproof/fuzz/libfuzzer/${f}.dict" ]; then cp "$SRC/rayproof/fuzz/libfuzzer/${f}.dict" "$OUT/${f}_fuzzer.dict"; fi
done
