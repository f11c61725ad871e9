# Thin wrapper over CMake. On a fresh Debian 12 machine:
#   make run    installs what is missing, builds rosguard (not the tests), runs the quickstart
#               sweep in sim, plots it
#   make test   installs what is missing, builds, runs every test
#   make ros2   the ROS 2 side of the tests (tools/ros2/workspace.sh): a ROS 2 Humble (the one
#               sourced, or one built from ../shared/thirdparty/ros2-humble and cached under
#               ~/.cache/rosguard), rosguard_msgs and the rclcpp test peer in $(BUILD)/ros2/;
#               where there is no ROS 2 the ROS 2 tests skip and say why (ROSGUARD_ROS2=OFF: none)
#   make install [PREFIX=/usr/local]   installs bin/rosguard, share/rosguard/, the CMake package
#   make test-nosim   builds without the sim backend (no SystemC) in $(BUILD)-nosim, runs its tests
#   make test-aarch64 cross-builds for aarch64 (the Orin's architecture; hw backend, no sim) in
#                     $(BUILD)-aarch64 and runs under qemu-user the tests that need no PMU or root
#   make validate     runs scenarios/validation/ on hw and in sim, writes results/validation/report.md
#   make fit-table1   refits the seven Table 1 workloads (base_ipc; measured profiles' rates scaled)
#   make bench-middleware  the paper's experiments 1-3 on hw, transport inproc vs dds, as a table
#   make bench-middleware-ros2  the same on rclcpp (rosguard_rclcpp's middleware_bench; make ros2 first)
#   make docs         regenerates every command transcript in README.md and docs/ (tools/docs.py)
BUILD ?= build
JOBS ?= $(shell nproc)
PREFIX ?= /usr/local
# Warnings are errors here, for run as for test: both share $(BUILD), and a different flag for
# each would rebuild everything whenever one follows the other. The build is warning-free on
# Debian 12 (CI checks it); with another compiler pass WERROR=OFF (CMake's default is OFF).
WERROR ?= ON
# More CMake options, e.g. CMAKE_ARGS=-DROSGUARD_WITH_HW=OFF
CMAKE_ARGS ?=
PYTHON := /usr/bin/python3
ROSGUARD := $(BUILD)/rosguard

.PHONY: all deps configure build rosguard ros2 test test-nosim test-aarch64 run install reproduce sensitivity audit-hw validate \
        validate-readme docs bench-parallel bench-large bench-soak bench-middleware bench-middleware-ros2 bench format clean fit-table1

all: build

deps:
	@tools/install-deps.sh

configure: deps
	@cmake -S . -B $(BUILD) -DCMAKE_BUILD_TYPE=Release -DROSGUARD_WERROR=$(WERROR) $(CMAKE_ARGS) >/dev/null

build: configure
	@cmake --build $(BUILD) -j $(JOBS)

# The rosguard executable and the libraries it links, nothing else (no tests, benchmarks, man
# page): what run and the experiment targets below need. Same configure as build, so a later
# make test compiles only what this did not.
rosguard: configure
	@cmake --build $(BUILD) -j $(JOBS) --target rosguard

ros2:
	@tools/ros2/workspace.sh $(BUILD)

test: build ros2
	cd $(BUILD) && ctest --output-on-failure -j $(JOBS)

test-nosim:
	@ROSGUARD_WITH_SIM=OFF tools/install-deps.sh
	@cmake -S . -B $(BUILD)-nosim -DCMAKE_BUILD_TYPE=Release -DROSGUARD_WERROR=$(WERROR) \
	  -DROSGUARD_WITH_SIM=OFF $(CMAKE_ARGS) >/dev/null
	@cmake --build $(BUILD)-nosim -j $(JOBS)
	cd $(BUILD)-nosim && ctest --output-on-failure -j $(JOBS)

# The aarch64 build (cmake/aarch64-linux-gnu.cmake): the cross compiler, qemu-user and the arm64
# libraries (Debian multiarch) installed first; without the sim backend (the board runs hw, and
# SystemC would double the build); through ccache, so that a rebuild takes seconds. Its ctest
# holds only what runs under the emulator (tests/cross/CMakeLists.txt).
test-aarch64:
	@ROSGUARD_AARCH64=ON ROSGUARD_WITH_SIM=OFF tools/install-deps.sh
	@cmake -S . -B $(BUILD)-aarch64 --toolchain cmake/aarch64-linux-gnu.cmake \
	  -DCMAKE_BUILD_TYPE=Release -DROSGUARD_WERROR=$(WERROR) -DROSGUARD_WITH_SIM=OFF \
	  -DCMAKE_CXX_COMPILER_LAUNCHER=ccache -DCMAKE_C_COMPILER_LAUNCHER=ccache $(CMAKE_ARGS) >/dev/null
	@cmake --build $(BUILD)-aarch64 -j $(JOBS)
	cd $(BUILD)-aarch64 && ctest --output-on-failure -j $(JOBS)

install: build
	cmake --install $(BUILD) --prefix $(PREFIX)

run: rosguard
	$(ROSGUARD) run scenarios/quickstart.json --out results/quickstart --overwrite
	$(ROSGUARD) plot results/quickstart --out results/quickstart/figures
	@echo "Figures (PNG and PDF): results/quickstart/figures/   data: results/quickstart/points.csv"

# The seven Table 1 workloads fitted on orin-agx (tools/fit_table1.py: the SD-VBS sim sections
# rebuilt from their measured profiles in scenarios/profiles/, then base_ipc and one stated scale
# on the L2 rates fitted to the paper's isolation IPC and Eq. 1 MB/s). Re-run after a change to
# the sim's memory model; FIT_ARGS=--check prints the fit without writing.
fit-table1: build
	$(PYTHON) tools/fit_table1.py --build $(BUILD) $(FIT_ARGS)

# Every experiment of the paper on the sim backend, plotted into results/paper/<experiment>/,
# then the paper-vs-sim table and gallery (docs/paper-vs-sim.md, docs/figures/) regenerated.
reproduce: rosguard
	@tools/reproduce.sh $(ROSGUARD)

# Each guessed number of scenarios/platforms/orin-agx.json ("guess, plausible range LOW-HIGH" in
# its source) at both ends of its range: the paper's scenarios in sim on each variant into
# results/sensitivity/, the paper checks re-run, the table of docs/sensitivity.md regenerated.
sensitivity: build
	@$(PYTHON) tools/sensitivity.py --rosguard $(ROSGUARD) --jobs $(JOBS) --doc docs/sensitivity.md

# The timing-dependent tests again and again: PASSES passes of the hw tests (AUDIT_REGEX),
# alternately idle and beside one busy process, and per test its failures and skips
# (results/hw-audit/audit.md). Run it on a machine with nothing else to do.
PASSES ?= 10
AUDIT_REGEX ?= ^hw/
audit-hw: build
	@$(PYTHON) tools/hw_audit.py --build $(BUILD) --passes $(PASSES) --regex '$(AUDIT_REGEX)'

# The sim-vs-hw validation suite (scenarios/validation/, held out from the calibration): hw and
# sim runs into results/validation/{hw,sim}/, then report.md / report.json and the
# predicted-vs-measured figure. validate-readme puts the last report into README.md.
validate: rosguard
	@tools/validate.sh $(ROSGUARD)

validate-readme:
	@tools/validate.sh --readme

# Every `$ rosguard` transcript in README.md and docs/ run again and written between its
# markers (tools/docs.py), then the pages' links and markers checked. Builds rosguard alone.
docs: rosguard
	@$(PYTHON) tools/docs.py --rosguard $(ROSGUARD)

bench: build
	$(BUILD)/tests/bench/rosguard_bench --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
	tests/bench/time_sweep.sh $(BUILD) 5 $(JOBS)

# Parallel efficiency on scenarios/bench/sweep-10k.json (10,000 points; long: 2 x 5 whole
# sweeps, alternating): --jobs 1 against --jobs $(JOBS). Take it on a quiet machine (it says
# when other processes took more than 2 % of a run's CPU time).
bench-parallel: rosguard
	tests/bench/parallel_efficiency.sh $(BUILD) 5 $(JOBS)

# A 100,000-point sweep (scenarios/bench/sweep-100k.json): time, the runner's peak memory per
# point, and `rosguard status` on the result (long: some 10 minutes on 2 CPUs; 1.6 GB of
# samples in a temporary folder).
bench-large: rosguard
	tests/bench/large_sweep.sh $(BUILD) $(JOBS)

# The paper's experiments 1-3 on hw, transport inproc vs dds (scenarios/bench/hw-middleware.json),
# and the middleware table of docs/middleware-costs.md from them (printed).
bench-middleware: rosguard
	$(ROSGUARD) run scenarios/bench/hw-middleware.json --backend hw --out results/hw-middleware --overwrite
	$(PYTHON) tools/middleware_table.py results/hw-middleware

# The paper's experiments 1-3 on rclcpp (rosguard_rclcpp's middleware_bench, one process), self
# and external sampling at 100 .. 5000 us, as the table of docs/middleware-costs.md (printed).
# Needs the ROS 2 workspace: make ros2 first.
bench-middleware-ros2:
	tools/ros2/middleware_bench.sh $(BUILD)

# rosguard guard under regulation for SOAK_S seconds (default 30 min): its memory and log growth.
SOAK_S ?= 1800
bench-soak: rosguard
	tests/bench/guard_soak.sh $(BUILD) $(SOAK_S) results/soak

format:
	@git ls-files '*.cpp' '*.h' | xargs clang-format -i

clean:
	rm -rf $(BUILD) $(BUILD)-nosim $(BUILD)-aarch64
