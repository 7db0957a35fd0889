# rigid_body_sim: set-up, run and test in a local virtualenv (.venv) with pinned wheels.
#
#   make run        set up if needed, then run rigid_body_sim_node on the default scene
#   make test       set up if needed, then pytest (slow tests excluded)   <- what CI runs
#   make test-slow  set up if needed, then pytest -m slow (long stability/soak runs)
#   make venv       only the set-up: .venv with Python 3.11, pinned requirements, package -e
#   make clean      remove caches and build output (keeps .venv); make distclean also .venv
#
# Variables: PYTHON=/path/to/python3.11, PYTEST_ARGS="-k foo -x", RUN_ARGS="--ros-args ...",
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

.PHONY: venv run test test-slow clean distclean

venv: $(STAMP)

# The venv is (re)provisioned when a pin, the build script or the manifest changes.
$(STAMP): requirements.txt requirements-test.txt setup.py setup.cfg package.xml
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
	say "installing pinned requirements (pip $(PIP_VERSION), requirements-test.txt)"
	$(PIP) install "pip==$(PIP_VERSION)"
	$(PIP) install -r requirements-test.txt
	say "installing rigid_body_sim in editable mode"
	$(PIP) install --no-deps -e .
	$(PIP) check >/dev/null || { $(PIP) check; die "pip check found inconsistent dependencies"; }
	say "compiling the numba kernels once (cached in rigid_body_sim/core/kernels/__pycache__; about a minute)"
	$(VENV_PY) -c 'from rigid_body_sim.core.kernels.compile import compile_kernels; compile_kernels()'
	touch "$@"
	say "ready: $(VENV) ($$($(VENV_PY) -V 2>&1))"

run: $(STAMP)
	exec $(VENV)/bin/rigid_body_sim_node $(RUN_ARGS)

# --foreground: Ctrl-C still reaches pytest; SIGINT first so pytest prints its summary.
test: $(STAMP)
	timeout --foreground -s INT -k 60 $(TEST_TIMEOUT_S) $(VENV_PY) -m pytest $(PYTEST_ARGS)

test-slow: $(STAMP)
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
# one body driven per step, work-precision on the top and the forced box, model reduction, a kernel
# profile and node timing. Every figure is a median of >= 5 samples with its min-max.
# bench: quick mode (fewer sizes, a few minutes); bench-full: every size up to 1e5, 20 s node windows.
# Into the default BENCH_OUT they also write docs/choosing_an_integrator.md (+ .claims.json) and the
# README's generated "Speed and accuracy" table, so README, docs and results.md come from one run.
# BENCH_BASELINE=<git rev>: also time that revision's core beside this one at N = 1e4 (core_compare.py).
BENCH_OUT ?= benchmarks/results
BENCH_ARGS ?=
BENCH_BASELINE ?=
BENCH_DEFAULT_OUT := $(filter benchmarks/results,$(BENCH_OUT))
BENCH_FLAGS = --out $(BENCH_OUT) --docs $(if $(BENCH_DEFAULT_OUT),docs,$(BENCH_OUT)) \
	$(if $(BENCH_DEFAULT_OUT),--readme README.md) $(if $(BENCH_BASELINE),--baseline-core $(BENCH_BASELINE)) $(BENCH_ARGS)
.PHONY: bench bench-full bench-deps
bench-deps: $(STAMP)
	$(PIP) install -r requirements-bench.txt
bench: bench-deps
	$(VENV_PY) -m pytest -q -m bench
	$(VENV_PY) -m benchmarks.run --quick $(BENCH_FLAGS)
bench-full: bench-deps
	$(VENV_PY) -m pytest -q -m bench
	$(VENV_PY) -m benchmarks.run --full $(BENCH_FLAGS)

# The node with batched output (issue 15): 1, 100, 1000, 10000 bodies at 100 Hz and 100 at 1 kHz, rk4, 1 substep,
# per_body_topics false, a `poses` subscriber in another process; sim/wall, ticks delivered, CPU per tick, RSS,
# start to first poses, stop time (medians of 5 runs of 10 s; BENCH_NODE_ARGS=--quick for 3 runs of 5 s).
# Writes benchmarks/results/node_batch.md (the README's "Many bodies" figures come from it).
BENCH_NODE_ARGS ?=
.PHONY: bench-node
bench-node: $(STAMP)
	$(VENV_PY) -m benchmarks.node_batch $(BENCH_NODE_ARGS)
