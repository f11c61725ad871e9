# Thin wrapper over CMake. On a fresh Debian 12 machine:
#   make run    installs what is missing, builds, runs the quickstart sweep in sim, plots it
#   make test   installs what is missing, builds, runs every test
BUILD ?= build
JOBS ?= $(shell nproc)
PYTHON := /usr/bin/python3
ROSGUARD := $(BUILD)/rosguard

.PHONY: all deps configure build test run reproduce bench format clean

all: build

deps:
	@tools/install-deps.sh

configure: deps
	@cmake -S . -B $(BUILD) -DCMAKE_BUILD_TYPE=Release >/dev/null

build: configure
	@cmake --build $(BUILD) -j $(JOBS)

test: build
	cd $(BUILD) && ctest --output-on-failure -j $(JOBS)

run: build
	$(ROSGUARD) run scenarios/quickstart.json --out results/quickstart --overwrite
	$(ROSGUARD) plot results/quickstart --out results/quickstart/figures
	@echo "Figures (PNG and PDF): results/quickstart/figures/   data: results/quickstart/points.csv"

# Every experiment of the paper on the sim backend, plotted into results/paper/<experiment>/,
# then the README gallery (docs/figures/) and the paper-vs-sim table regenerated from them.
reproduce: build
	@tools/reproduce.sh $(ROSGUARD)

bench: build
	$(BUILD)/tests/bench/rosguard_bench --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
	tests/bench/time_sweep.sh $(BUILD) 5 $(JOBS)

format:
	@git ls-files '*.cpp' '*.h' | xargs clang-format -i

clean:
	rm -rf $(BUILD)
