# rigid_body_sim: set-up, run and test in a local virtualenv (.venv) with pinned wheels.
#
#   make run        set up if needed, then run rigid_body_sim_node on the default scene, with the browser view
#   make test       set up if needed, then pytest (slow tests excluded; a budget of ~3 min)  <- what CI runs
#   make test-slow  set up if needed, then pytest -m slow (soak, statistics, repeated runs:
#                   1e5-1e6 steps, the 100,000-message DDS fuzz, colcon test, environment probes)
#   make venv       only the set-up: .venv with Python 3.11, pinned requirements, package -e
#   make browser-deps   Debian's chromium and chromium-driver (apt if missing) for test/test_view.py
#   make foxglove-deps  Node.js (apt if missing) and the pinned npm modules of test/foxglove (Foxglove's readers)
#   make bench-contact  contact beside MuJoCo and PyBullet (docs/contact_benchmarks.md; about 10 min)
#   make clean      remove caches and build output (keeps .venv); make distclean also .venv
#
# Variables: PYTHON=/path/to/python3.11, PYTEST_ARGS="-k foo -x", TEST_WORKERS=auto|N|0, RUN_ARGS="--ros-args ...",
# TEST_TIMEOUT_S / SLOW_TIMEOUT_S (wall-clock limit of the whole pytest run).

SHELL := /bin/bash
.SHELLFLAGS := -euo pipefail -c
.ONESHELL:
.DEFAULT_GOAL := test
.DELETE_ON_ERROR:

PYTHON ?= $(firstword $(shell command -v python3.11 python3 2>/dev/null))
VENV := .venv
VENV_PY := $(VENV)/bin/python
# Inside .venv: deleting the venv deletes the stamp, so a stale stamp can never lie.
STAMP := $(VENV)/.rigid_body_sim-installed.stamp
PIP_VERSION := 26.3
PIP := $(VENV_PY) -m pip --disable-pip-version-check --no-input -q

TEST_TIMEOUT_S ?= 1800
SLOW_TIMEOUT_S ?= 5400
PYTEST_ARGS ?=
RUN_ARGS ?=

# Keep DDS discovery on loopback unless the caller says otherwise (this rcl ignores
# ROS_LOCALHOST_ONLY; ROS_AUTOMATIC_DISCOVERY_RANGE is the variable it reads).
export ROS_AUTOMATIC_DISCOVERY_RANGE ?= LOCALHOST

.PHONY: venv run test test-slow clean distclean foxglove-deps browser-deps

venv: $(STAMP)

# The venv is (re)provisioned when a pin, the build script or the manifest changes.
$(STAMP): requirements.txt requirements-test.txt requirements-view.txt setup.py setup.cfg package.xml \
		tools/ros_interfaces/build.py $(wildcard tools/ros_interfaces/*/msg/*.msg)
	@say() { printf '[make venv] %s\n' "$$*"; }
	die() { printf '[make venv] ERROR: %s\n' "$$*" >&2; exit 1; }
	is_py311() { "$$1" -c 'import sys; sys.exit(sys.version_info[:2] != (3, 11))' 2>/dev/null; }
	apt_install() {
	  command -v apt-get >/dev/null || return 1
	  [ "$$(id -u)" = 0 ] || return 1
	  say "installing Debian packages: $$* (apt-get update first)"
	  export DEBIAN_FRONTEND=noninteractive
	  apt-get update -qq && apt-get install -y -qq --no-install-recommends "$$@" >/dev/null
	}
	if [ -x "$(VENV_PY)" ]; then
	  is_py311 "$(VENV_PY)" || die "$(VENV) is not Python 3.11 ($$($(VENV_PY) -V 2>&1)). Remove it (rm -rf $(VENV)) and run make again."
	else
	  py="$(PYTHON)"
	  if [ -z "$$py" ]; then
	    apt_install python3.11 python3.11-venv \
	      || die "no python3.11 or python3 on PATH. Install Python 3.11 (Debian 12: apt-get install python3.11 python3.11-venv) or pass PYTHON=/path/to/python3.11."
	    py=/usr/bin/python3.11
	  fi
	  command -v "$$py" >/dev/null || die "PYTHON=$$py: no such interpreter. Pass PYTHON=/path/to/python3.11."
	  is_py311 "$$py" || die "$$py is $$($$py -V 2>&1); rigid_body_sim needs Python 3.11 (the pins are verified on 3.11). Pass PYTHON=/path/to/python3.11."
	  if ! "$$py" -c 'import ensurepip, venv' 2>/dev/null; then
	    say "$$py has no ensurepip/venv module (Debian splits it into python3.11-venv)"
	    apt_install python3.11-venv \
	      || die "install it first: sudo apt-get install python3.11-venv (or python3-venv)."
	    "$$py" -c 'import ensurepip, venv' 2>/dev/null \
	      || die "$$py still has no ensurepip/venv module; install Python 3.11 with venv support."
	  fi
	  say "creating $(VENV) with $$py ($$($$py -V 2>&1))"
	  "$$py" -m venv "$(VENV)"
	fi
	say "installing pinned requirements (pip $(PIP_VERSION), requirements-view.txt: test and view pins)"
	$(PIP) install "pip==$(PIP_VERSION)"
	$(PIP) install -r requirements-view.txt
	# tf2_msgs has no wheel on PyPI: build it from its message definition (needs gcc and g++).
	command -v g++ >/dev/null || apt_install gcc g++ || die "no C/C++ compiler: install gcc and g++ (Debian: apt-get install gcc g++)"
	say "building tf2_msgs from its message definition (tools/ros_interfaces)"
	$(VENV_PY) tools/ros_interfaces/build.py tf2_msgs 2>&1 | grep -v -e 'duplicate entry point' -e '^Reading input' -e '^Writing output' || true
	$(VENV_PY) -c 'import tf2_msgs.msg' || die "tf2_msgs did not build (tools/ros_interfaces/build.py)"
	say "installing rigid_body_sim in editable mode"
	$(PIP) install --no-deps -e .
	$(PIP) check >/dev/null || { $(PIP) check; die "pip check found inconsistent dependencies"; }
	say "compiling the numba kernels once (cached in rigid_body_sim/core/kernels/__pycache__; several minutes)"
	$(VENV_PY) -c 'from rigid_body_sim.core.simulator import compile_kernels; compile_kernels()'
	touch "$@"
	say "ready: $(VENV) ($$($(VENV_PY) -V 2>&1))"

# The node in the foreground and the browser view beside it (it prints its address; VIEW=0: the
# node alone; VIEW_ARGS="--port 8090"). Ctrl-C stops both.
VIEW ?= 1
VIEW_ARGS ?=
run: $(STAMP)
	@if [ "$(VIEW)" = 1 ]; then
	  $(VENV)/bin/rigid-body-sim view $(VIEW_ARGS) &
	  view=$$!
	  trap 'kill -INT $$view 2>/dev/null || true; wait $$view 2>/dev/null || true' EXIT
	fi
	$(VENV)/bin/rigid_body_sim_node $(RUN_ARGS)

# Foxglove's own readers (@mcap/core, @mcap/support, @foxglove/rosmsg, @foxglove/rosmsg2-serialization), pinned
# in test/foxglove/package-lock.json, for test/test_foxglove_readers.py. Node.js and npm come from apt if missing.
FOXGLOVE_DIR := test/foxglove
FOXGLOVE_STAMP := $(FOXGLOVE_DIR)/node_modules/.package-lock.json
foxglove-deps: $(FOXGLOVE_STAMP)

$(FOXGLOVE_STAMP): $(FOXGLOVE_DIR)/package.json $(FOXGLOVE_DIR)/package-lock.json
	@say() { printf '[make foxglove-deps] %s\n' "$$*"; }
	die() { printf '[make foxglove-deps] ERROR: %s\n' "$$*" >&2; exit 1; }
	if ! command -v node >/dev/null || ! command -v npm >/dev/null; then
	  command -v apt-get >/dev/null && [ "$$(id -u)" = 0 ] \
	    || die "node and npm are needed for the Foxglove reader test: install Node.js >= 18 (Debian: apt-get install nodejs npm)"
	  say "installing Debian packages: nodejs npm (apt-get update first)"
	  export DEBIAN_FRONTEND=noninteractive
	  apt-get update -qq && apt-get install -y -qq --no-install-recommends nodejs npm >/dev/null
	fi
	say "installing the pinned npm modules of $(FOXGLOVE_DIR) (node $$(node --version))"
	npm ci --prefix "$(FOXGLOVE_DIR)" --no-audit --no-fund --ignore-scripts --loglevel=error
	touch "$@"

# The browser test/test_view.py drives: Debian's chromium through Debian's chromedriver (never a
# downloaded browser build). Installed with apt when missing and root; otherwise the command to run.
browser-deps:
	@if [ ! -x /usr/bin/chromium ] || [ ! -x /usr/bin/chromedriver ]; then
	  command -v apt-get >/dev/null && [ "$$(id -u)" = 0 ] \
	    || { echo "[make browser-deps] ERROR: test/test_view.py needs /usr/bin/chromium and /usr/bin/chromedriver: sudo apt-get install chromium chromium-driver" >&2; exit 1; }
	  echo "[make browser-deps] installing Debian packages: chromium chromium-driver (apt-get update first)"
	  export DEBIAN_FRONTEND=noninteractive
	  apt-get update -qq && apt-get install -y -qq --no-install-recommends chromium chromium-driver >/dev/null
	fi

# --foreground: Ctrl-C still reaches pytest; SIGINT first so pytest prints its summary.
# The test files run in TEST_WORKERS processes (pytest-xdist; one file stays in one process, with its
# module fixtures; each process claims its own ROS_DOMAIN_ID). TEST_WORKERS=0: one process. One more than
# the CPUs: about a fifth of the suite's time waits (DDS discovery, signal and grace periods, page loads).
TEST_WORKERS ?= $(shell echo $$(( $$(nproc) + 1 )))
# Bytecode on for the tests even where the environment turns it off (PYTHONDONTWRITEBYTECODE): else every
# worker rewrites the asserts of all test modules again (about 7 s of CPU each) and every node process
# compiles the package from source. The .pyc files go to __pycache__/ (git-ignored; make clean removes them).
test test-slow: export PYTHONDONTWRITEBYTECODE :=
# A test blocked in C code with the GIL held leaves its stacks in RIGID_BODY_SIM_STUCK_DIR (test/conftest.py): printed.
test: $(STAMP) $(FOXGLOVE_STAMP) browser-deps
	@rc=0; stuck=$$(mktemp -d)
	RIGID_BODY_SIM_STUCK_DIR=$$stuck timeout --foreground -s INT -k 60 $(TEST_TIMEOUT_S) $(VENV_PY) -m pytest -n $(TEST_WORKERS) --dist loadfile --max-worker-restart 0 $(PYTEST_ARGS) || rc=$$?
	cat "$$stuck"/* 2>/dev/null || true; rm -rf "$$stuck"
	exit "$$rc"

# The slow run also runs the whole suite from a colcon workspace (test_workspace.py): the same readers and browser.
test-slow: $(STAMP) $(FOXGLOVE_STAMP) browser-deps
	@rc=0
	timeout --foreground -s INT -k 60 $(SLOW_TIMEOUT_S) $(VENV_PY) -m pytest -m slow $(PYTEST_ARGS) || rc=$$?
	if [ "$$rc" = 5 ]; then echo "[make test-slow] no test is marked slow yet"; rc=0; fi
	exit "$$rc"

clean:
	@rm -rf build dist log install .pytest_cache .hypothesis *.egg-info "$(STAMP)"
	find . -path ./$(VENV) -prune -o -name __pycache__ -type d -prune -exec rm -rf {} +

distclean: clean
	rm -rf "$(VENV)"

# The stability envelope of every integrator, measured into docs/stability.md (tens of minutes:
# it runs 1e6 steps per integrator; ENVELOPE_ARGS="--no-long" for the quick columns only).
# test/test_stability.py checks the file against fresh measurements.
ENVELOPE_ARGS ?=
.PHONY: envelope
envelope: $(STAMP)
	$(VENV_PY) -m rigid_body_sim.tools.envelope --out docs/stability.md $(ENVELOPE_ARGS)

# Speed and accuracy benchmarks (benchmarks/; not part of `make test`), beside MuJoCo (requirements-bench.txt):
# throughput against N with the plain-loop floor and a numpy loop, the per-frame cost of a force and
# one body driven per step, work-precision on the top and the forced box, model reduction and a kernel
# profile. Every figure is a median of >= 5 samples with its min-max.
# bench: quick mode (fewer sizes, a few minutes); bench-full: every size up to 1e5, longer samples.
# Into the default BENCH_OUT they also write docs/choosing_an_integrator.md (+ .claims.json) and the
# generated block of docs/performance.md, so the docs and results.md come from one run.
# BENCH_BASELINE=<git rev>: also time that revision's core beside this one at N = 1e4 (core_compare.py).
BENCH_OUT ?= benchmarks/results
BENCH_ARGS ?=
BENCH_BASELINE ?=
BENCH_DEFAULT_OUT := $(filter benchmarks/results,$(BENCH_OUT))
BENCH_FLAGS = --out $(BENCH_OUT) --docs $(if $(BENCH_DEFAULT_OUT),docs,$(BENCH_OUT)) \
	$(if $(BENCH_DEFAULT_OUT),--performance docs/performance.md) $(if $(BENCH_BASELINE),--baseline-core $(BENCH_BASELINE)) $(BENCH_ARGS)
.PHONY: bench bench-full bench-deps
bench-deps: $(STAMP)
	$(PIP) install -r requirements-bench.txt
bench: bench-deps
	$(VENV_PY) -m pytest -q -m bench
	$(VENV_PY) -m benchmarks.run --quick $(BENCH_FLAGS)
bench-full: bench-deps
	$(VENV_PY) -m pytest -q -m bench
	$(VENV_PY) -m benchmarks.run --full $(BENCH_FLAGS)

# The step on every core: threads vs one thread at 1e5, the parallel threshold, one thread vs the
# plain loops at 1e4; writes benchmarks/results/threads.{csv,md} and the block in docs/performance.md.
.PHONY: bench-threads
bench-threads: $(STAMP)
	$(VENV_PY) -m benchmarks.threads --performance docs/performance.md

# Body–body narrow phase against MuJoCo (mj_geomDistance, 10,000 random poses per pair) and, for the pairs with a
# cylinder, against the independent reference exact/convex_distance.py (~15 min of it); its ns per pair, and
# the broad phase's cost at 1e3, 1e4, 1e5 bodies: writes benchmarks/results/pair_oracle.md (docs/contact.md quotes it).
.PHONY: bench-oracle
bench-oracle: bench-deps
	$(VENV_PY) -m pytest -q -m bench test/test_bench_pairs.py
	$(VENV_PY) -m benchmarks.pair_oracle --out $(BENCH_OUT)

# Contact beside MuJoCo and PyBullet (benchmarks/contact_peers.py): every closed-form contact case at
# dt = 10, 1, 0.1 ms (errors and µs per step), with the ground and between two bodies (tunnelling too),
# 1000 cubes resting on a plane (body-steps/s), and the
# free-body scene at N = 1e4 with and without a ground (and the core before contact: BENCH_CONTACT_ARGS=--baseline '' skips it).
# Writes benchmarks/results/contact_peers.csv and .md and the generated block of docs/contact_benchmarks.md.
BENCH_CONTACT_ARGS ?=
.PHONY: bench-contact
bench-contact: bench-deps
	$(VENV_PY) -m benchmarks.contact_peers --out $(BENCH_OUT) \
		$(if $(BENCH_DEFAULT_OUT),--docs docs/contact_benchmarks.md) $(BENCH_CONTACT_ARGS)

# Bodies resting on bodies beside MuJoCo and PyBullet (benchmarks/contact_stacks.py): a 10-cube tower at rest for 60 s
# (sink, drift, speed) and a pile of STACK_BODIES cubes dropped into a bin (penetration, energy rise, body-steps/s
# landing and settled, sleeping off and on). Writes benchmarks/results/contact_stacks.{csv,md}.
STACK_BODIES ?= 1000
BENCH_STACKS_ARGS ?=
.PHONY: bench-stacks
bench-stacks: bench-deps
	$(VENV_PY) -m benchmarks.contact_stacks --out $(BENCH_OUT) --bodies $(STACK_BODIES) $(BENCH_STACKS_ARGS)

# How a pile's cost grows with its bodies (benchmarks/contact_scaling.py), ours beside MuJoCo: 1e3, 1e4 and 1e5 cubes
# in bins side by side (the settled 1000-cube pile copied), and one pile of 10,000 cubes dropped into one bin.
# Writes benchmarks/results/contact_scaling_cost.{csv,md} and contact_scaling_pile.{csv,md}.
BENCH_SCALING_ARGS ?=
.PHONY: bench-scaling
bench-scaling: bench-deps
	$(VENV_PY) -m benchmarks.contact_scaling --part cost --out $(BENCH_OUT) $(BENCH_SCALING_ARGS)
	$(VENV_PY) -m benchmarks.contact_scaling --part pile --out $(BENCH_OUT) $(BENCH_SCALING_ARGS)

# The node benchmark: batched output and shared inputs, 1 to 10000 bodies at 100 Hz, 100 at 1 kHz, 100000 at
# 10 Hz, the 10000 and 100000 cases also recording; rk4, 1 substep, a plain rclpy `poses` subscriber in its own
# process; start to first poses, RSS, sim/wall, ticks delivered and recorded, CPU per tick, stop time, and the
# node's targets (medians of 5 runs of 10 s; BENCH_NODE_ARGS=--quick for 3 runs of 5 s,
# BENCH_NODE_ARGS="--bodies 10000 100000" for the target sizes only).
# Writes benchmarks/results/node_batch.md (linked from docs/performance.md).
BENCH_NODE_ARGS ?=
.PHONY: bench-node
bench-node: $(STAMP)
	$(VENV_PY) -m benchmarks.node_batch $(BENCH_NODE_ARGS)

# The browser view's frame rate at 1, 100 and 1000 bodies and the node's CPU per tick with and without a
# viewer (headless Debian chromium; medians of 5 windows of 3 s). Writes benchmarks/results/view.md and the
# generated block of docs/view.md.
.PHONY: bench-view
bench-view: $(STAMP) browser-deps
	$(VENV_PY) -m benchmarks.view_fps --docs
