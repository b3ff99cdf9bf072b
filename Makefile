# Thin wrapper: the build itself is CMake. Every target installs missing packages first.
BUILD ?= build
JOBS  ?= 2

.PHONY: deps build demo test bench clean
deps:
	@bash scripts/install-deps.sh

build: deps
	@cmake -S . -B $(BUILD) -DCMAKE_BUILD_TYPE=Release > /dev/null
	@cmake --build $(BUILD) -j$(JOBS)

demo: build
	@bash scripts/demo.sh $(BUILD)

test: build
	@cd $(BUILD) && ctest --output-on-failure -j$(JOBS)

bench: build
	@$(BUILD)/bench/rayproof_bench --benchmark_min_time=0.2 --benchmark_out=$(BUILD)/bench.json --benchmark_out_format=json
	@echo "benchmark results: $(BUILD)/bench.json"

clean:
	rm -rf $(BUILD)
