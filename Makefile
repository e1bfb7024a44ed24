# What `./hysid-setup run|test` (the README's two commands) hand over to once make is installed.
# Both install what is missing (Debian packages), configure a Release build in build/, and build;
# then `run` runs the default job and `test` runs every test.
BUILD_DIR ?= build
JOBS ?= $(shell nproc 2>/dev/null || echo 2)
CMAKE_FLAGS ?=

.PHONY: run test build deps configure clean check-sanitize deps-sanitize check-long check-usersys check-matrix check-compare-rates example-figures check-bench

deps:
	./scripts/install-deps.sh

configure: deps
	cmake -S . -B $(BUILD_DIR) -G Ninja -DCMAKE_BUILD_TYPE=Release $(CMAKE_FLAGS)

build: configure
	cmake --build $(BUILD_DIR) -j $(JOBS)

run: build
	./scripts/run-default.sh $(BUILD_DIR)

# Every test but those labelled `long` (check-long), which keep `make test` short on 2 cores.
test: build
	ctest --test-dir $(BUILD_DIR) --no-tests=error --output-on-failure -j $(JOBS) -LE long

# The long tests: the cube's free flight, two compare checks, the scipy reference fit of Cascaded
# Tanks, the small late impacts at 10 % noise.
check-long: build
	ctest --test-dir $(BUILD_DIR) --no-tests=error --output-on-failure -j $(JOBS) -L long

clean:
	rm -rf $(BUILD_DIR)

# Sanitizers and fuzzers (docs/architecture.md "Checks beyond the unit tests"): ASan+UBSan (gcc), UBSan with
# float-cast-overflow (clang 14), libFuzzer harnesses for FUZZ_RUNS executions each (default 1 M).
deps-sanitize:
	./scripts/install-deps.sh sanitize

check-sanitize: deps-sanitize
	JOBS=$(JOBS) ./scripts/check-sanitize.sh

# The user systems' targets (tests/usersys/README.md): five noise draws of four systems identified
# with the defaults; fails while the targets are not met. Skipped by a plain `ctest`.
check-usersys: build
	HYSID_USERSYS=1 ctest --test-dir $(BUILD_DIR) -L usersys --output-on-failure

# The combination matrix (tests/matrix/README.md): 64 cells of feature combinations, each identified
# on simulated data; a cell fails unless ok within 4 SE (known failures expected to fail).
check-matrix: build
	HYSID_MATRIX=1 ctest --test-dir $(BUILD_DIR) -L matrix --output-on-failure -j $(JOBS)

# How often `hysid compare` picks the true mode count of a thermostat and a hopper over 50 noise draws
# (tests/compare/rates.py; fails below 95 % by BIC).
check-compare-rates: build
	HYSID_COMPARE_RATES=1 ctest --test-dir $(BUILD_DIR) -L compare-rates --output-on-failure

# The fit figure of every example (examples/*/fit.png and fit.txt, shown in each README): its README's
# commands, identify --json --trace, then analysis/hysid_plots fit (scripts/example-figures.sh).
example-figures:
	HYSID=$(BUILD_DIR)/bin/hysid OUT=$(BUILD_DIR)/example-figures ./scripts/example-figures.sh

# The identification step's regression guard (BENCHMARKS.md): BM_IdentifyStep ÷
# BM_IdentifyStepFusedReference ≤ 1.6 on an idle machine; fails above. Skipped by a plain `ctest`.
check-bench: build
	HYSID_BENCH_GUARD=1 ctest --test-dir $(BUILD_DIR) -L bench --output-on-failure
