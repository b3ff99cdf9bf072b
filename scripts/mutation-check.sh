#!/usr/bin/env bash
# Deliberate bugs, one at a time, each of which the test suite must catch: applies a mutation,
# builds the tests in build-mutants/, runs ctest, reverts. Prints which tests failed per mutant.
# Usage: scripts/mutation-check.sh   (about 2 minutes per mutant on 2 cores)
set -uo pipefail
cd "$(dirname "$0")/.."
build=build-mutants
cmake -S . -B "$build" -DCMAKE_BUILD_TYPE=Release -DRAYPROOF_BUILD_BENCH=OFF > /dev/null

mutate() {  # name file from to
  local name=$1 file=$2 from=$3 to=$4
  cp "$file" "$file.orig"
  python3 - "$file" "$from" "$to" <<'PY'
import sys
path, old, new = sys.argv[1:4]
text = open(path).read()
if old not in text:
    sys.exit(f"mutation anchor not found in {path}: {old}")
open(path, "w").write(text.replace(old, new, 1))
PY
  if [ $? -ne 0 ]; then mv "$file.orig" "$file"; echo "$name: NOT APPLIED"; return; fi
  if cmake --build "$build" -j2 > "$build/mutant-build.log" 2>&1; then
    failed=$(cd "$build" && ctest -j2 2>&1 | grep -E "\*\*\*Failed|\*\*\*Exception" | sed -E 's/.*Test +#[0-9]+: ([^ ]+) .*/\1/' | tr '\n' ' ')
    if [ -n "$failed" ]; then echo "$name: CAUGHT by $failed"; else echo "$name: SURVIVED"; fi
  else
    echo "$name: does not build"
  fi
  mv "$file.orig" "$file"
  touch "$file"
}

mutate "ulp-distance-off-by-one" lib/rayproof/core/fp.h \
  "return ia > ib ? std::uint64_t(ia) - std::uint64_t(ib) : std::uint64_t(ib) - std::uint64_t(ia);" \
  "return (ia > ib ? std::uint64_t(ia) - std::uint64_t(ib) : std::uint64_t(ib) - std::uint64_t(ia)) + (ia != ib);"
mutate "wrong-cannot-tell-swapped" verify/compare.cpp \
  "exact_is_a_touch && reported_is_plain ? Agreement::cannot_tell : Agreement::wrong" \
  "exact_is_a_touch && reported_is_plain ? Agreement::wrong : Agreement::cannot_tell"
mutate "textbook-one-ulp" lib/variants.cpp \
  "const double t0 = (-b - root) / (2 * a);" \
  "const double t0 = std::nextafter((-b - root) / (2 * a), INFINITY);"
mutate "robust-slab-no-widening" lib/variants.cpp \
  "* inv * (1 + 2 * gamma(3));" "* inv;"
mutate "oracle-ties-to-odd" verify/oracle.cpp \
  "return (bits & 1) == 0 ? a : b;" "return (bits & 1) == 0 ? b : a;"
mutate "coplanar-orientation-flipped" verify/oracle.cpp \
  "const int orient = sgn(n[drop]);" "const int orient = sgn(n[drop]) * (drop == 1 ? -1 : 1);"
mutate "batched-mt-nan-semantics" lib/batch.cpp \
  "(det != 0) & !(u < 0) & !(u > 1) & !(v < 0) & !(uv > 1) & (t > 0)" \
  "(det != 0) & (u >= 0) & (u <= 1) & (v >= 0) & (uv <= 1) & (t > 0)"
cmake --build "$build" -j2 > /dev/null 2>&1  # leave the build matching the sources
