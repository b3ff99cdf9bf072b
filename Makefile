# Thin wrapper: the build itself is CMake. Every target installs missing packages first.
BUILD ?= build
JOBS  ?= 2

.PHONY: deps build demo test test-sanitize bench fuzz-smoke clean
deps:
	@bash scripts/install-deps.sh

build: deps
	@cmake -S . -B $(BUILD) -DCMAKE_BUILD_TYPE=Release > /dev/null
	@cmake --build $(BUILD) -j$(JOBS) -- --no-print-directory

# The demo's build is quiet: its log is kept, and shown (its end) only when the build fails.
demo: deps
	@cmake -S . -B $(BUILD) -DCMAKE_BUILD_TYPE=Release > /dev/null
	@echo "rayproof demo: building (log: $(BUILD)/build.log) ..."
	@cmake --build $(BUILD) -j$(JOBS) -- --no-print-directory > $(BUILD)/build.log 2>&1 || { tail -60 $(BUILD)/build.log; exit 1; }
	@bash scripts/demo.sh $(BUILD)

test: build
	@bash scripts/install-deps.sh test
	@cd $(BUILD) && ctest --output-on-failure -j$(JOBS)

# The whole test suite again under ASan + UBSan, built with clang (whose -fsanitize=undefined
# includes float-cast-overflow, unlike GCC's), in its own build directory. .ci/run runs it.
# Not the Python module: loading an instrumented module needs an instrumented interpreter.
# Three tests repeat at full size what smaller tests already run under the sanitizers, and take
# 1,290 of the instrumented suite's 2,560 s (CI's whole budget is 90 minutes): README's counts
# (compiler agreement is pinned by test_generator_digest; the code paths by every fuzz test), the
# headroom of two whole audits (Audit.HeadroomIsTheLast... runs headroom), and four shards of a
# campaign merged (Cluster.OddShardBounds... shards and merges). `make test` runs all three.
SANITIZE_SKIP ?= ^(readme_numbers|Audit.HeadroomCountsShadowsAndStopsWhereTheSceneCollapses|Cluster.FourShardsMergeIntoTheUnshardedCampaign)$$
test-sanitize:
	@bash scripts/install-deps.sh sanitize
	@cmake -S . -B build-sanitize -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ \
	  -DRAYPROOF_SANITIZE=ON -DRAYPROOF_BUILD_BENCH=OFF -DRAYPROOF_BUILD_PYTHON=OFF > /dev/null
	@cmake --build build-sanitize -j$(JOBS) -- --no-print-directory
	@cd build-sanitize && ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS=print_stacktrace=1 ctest --output-on-failure -j$(JOBS) \
	  -E '$(SANITIZE_SKIP)'

# A short run of every benchmark (one binary, so ratios come from one run), then the goals.
BENCH_MIN_TIME ?= 0.05
bench: build
	@bash scripts/install-deps.sh bench
	@$(BUILD)/bench/rayproof_bench --benchmark_min_time=$(BENCH_MIN_TIME) \
	  --benchmark_out=$(BUILD)/bench.json --benchmark_out_format=json
	@python3 scripts/bench-goals.py $(BUILD)/bench.json
	@python3 scripts/exactness-table.py $(BUILD)/bench.json
	@python3 scripts/instruction-counts.py $(BUILD) --csv $(BUILD)/instructions.csv
	@echo "benchmark results: $(BUILD)/bench.json, $(BUILD)/instructions.csv"

# libFuzzer harnesses under ASan + UBSan, each run for FUZZ_SECONDS (not part of `make test`).
FUZZ_SECONDS ?= 30
FUZZERS = sphere_fuzzer plane_fuzzer triangle_fuzzer box_fuzzer parsers_fuzzer
fuzz-smoke:
	@bash scripts/install-deps.sh fuzz
	@cmake -S . -B build-fuzz -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ \
	  -DRAYPROOF_LIBFUZZER=ON -DRAYPROOF_BUILD_TESTS=OFF -DRAYPROOF_BUILD_BENCH=OFF -DRAYPROOF_BUILD_PYTHON=OFF > /dev/null
	@cmake --build build-fuzz -j$(JOBS) --target $(FUZZERS)
	@for f in $(FUZZERS); do \
	  mkdir -p build-fuzz/corpus/$$f; \
	  echo "fuzz-smoke: $$f for $(FUZZ_SECONDS) s"; \
	  dict=""; [ -f fuzz/libfuzzer/$${f%_fuzzer}.dict ] && dict="-dict=fuzz/libfuzzer/$${f%_fuzzer}.dict"; \
	  build-fuzz/fuzz/libfuzzer/$$f -max_total_time=$(FUZZ_SECONDS) -print_final_stats=1 $$dict \
	    build-fuzz/corpus/$$f fuzz/corpus/$$f 2>&1 | grep -E "Done|ERROR|SUMMARY|stat::number_of_executed_units" || exit 1; \
	done

clean:
	rm -rf $(BUILD) build-fuzz build-sanitize
