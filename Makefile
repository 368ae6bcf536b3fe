# ipgen: `make demo` (the paper's experiments) and `make test` (every test) set up what they
# need on a fresh Debian machine: apt packages, then a virtualenv .venv with the Python side.
# Both are idempotent: a second run installs nothing.

SHELL := /bin/bash
.SHELLFLAGS := -eu -o pipefail -c
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
BUILD := build
# BUILD_PACKAGES compile and run everything (liblapack-dev: ipsim's eigenvalue guards);
# DOC_PACKAGES typeset the equations documents (--emit equations: pdflatex, pdftoppm), which only
# pytest's document tests and make demo need.
BUILD_PACKAGES := g++ make cmake ninja-build libeigen3-dev libsundials-dev liblapack-dev python3 python3-venv
DOC_PACKAGES := texlive-latex-base texlive-latex-recommended poppler-utils
SUDO := $(if $(filter 0,$(shell id -u)),,sudo)
JOBS ?= $(shell nproc)
# Recipes write .pyc files (into the git-ignored __pycache__/ folders) even where the environment
# sets PYTHONDONTWRITEBYTECODE (this machine does): otherwise every process of a test run compiles
# ipgen's and the tests' sources again (pytest's collection: 13.5 s of CPU time per worker
# instead of 6.2 s, docs/testing.md).
unexport PYTHONDONTWRITEBYTECODE
# The tests' processes use glibc's malloc on transparent huge pages (where the kernel offers
# them, `madvise`): the compilers spend about a tenth less time on the same object files
# (docs/testing.md). Other C libraries ignore it; a value already set is kept. Not for make bench
# and make stability, whose timings stay comparable with those recorded before.
test test-slow: export GLIBC_TUNABLES ?= glibc.malloc.hugetlb=1

.PHONY: all deps deps-build deps-docs deps-bench-time deps-bench-arm venv test test-slow test-slow-python test-cpp-slow ipsim-simulate test-python test-cpp test-cpp-logged cpp-early lint demo bench bench-workprecision bench-specialisation bench-compile bench-embedded bench-control bench-swingup bench-estimation bench-memory bench-general-links bench-identify bench-dfki bench-sweep bench-gym bench-runtime bench-mpc bench-mpc-method bench-mpc-m4 bench-hold-margins bench-leaderboard stability configure build clean

all: test

## Debian packages $(1), installed only when missing (a second run installs nothing).
define apt_install
missing=""; for p in $(1); do \
	  dpkg-query -W -f='$${Status}' $$p 2>/dev/null | grep -q "ok installed" || missing="$$missing $$p"; \
	done; \
	if [ -n "$$missing" ]; then \
	  echo "installing Debian packages:$$missing"; \
	  $(SUDO) apt-get update -qq; \
	  $(SUDO) env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends $$missing; \
	fi
endef

## System packages (Debian) of make test and make demo. On a fresh machine the documents' TeX
## packages take about 40 s of one core (most of it building TeX's formats): make test installs
## them beside the virtualenv and the first compiles (deps-docs is test-python's prerequisite), not
## before them. Never two apt-get at once: deps-docs waits for deps-build.
deps: deps-build deps-docs
deps-build:
	@$(call apt_install,$(BUILD_PACKAGES))
deps-docs: deps-build
	@$(call apt_install,$(DOC_PACKAGES))

## Python virtualenv with ipgen (editable) and the test tools; rebuilt when pyproject changes.
venv: $(VENV)/.installed
$(VENV)/.installed: pyproject.toml | deps-build
	@# A .venv whose creation was interrupted (python there, pip not) is made again.
	@$(PY) -m pip --version >/dev/null 2>&1 || $(PYTHON) -m venv --clear $(VENV)
	$(PY) -m pip install -q --upgrade pip
	@# The distribution was called ipgen before it became ipgen-pendulum (PyPI's ipgen is another
	@# project): a .venv made before keeps a record under the old name; drop it.
	@if $(PY) -m pip show -q ipgen >/dev/null 2>&1; then $(PY) -m pip uninstall -q -y ipgen; fi
	@# uv installs what pip would, in parallel: a fresh .venv in about 10 s instead of pip's
	@# 70-90 s, which make test waits for (docs/testing.md). It compiles no .pyc files (that took
	@# 20-25 s more, for every module of sympy, scipy, matplotlib & co., most never imported): each
	@# module's .pyc is written the first time a recipe's Python imports it (PYTHONDONTWRITEBYTECODE
	@# is unexported above), so after make test or make demo the modules ipgen uses have theirs.
	@# pip does it where uv cannot be installed or cannot reach the index (uv reads no pip
	@# configuration).
	$(PY) -m pip install -q uv && $(VENV)/bin/uv pip install -q --python $(PY) -e '.[test]' \
	  || $(PY) -m pip install -q -e '.[test]'
	@touch $@

lint: venv
	$(VENV)/bin/ruff check generator tests tools bench

## pytest (after ruff: make lint), all but the tests marked fresh_venv or user_program (make
## test-slow). The
## simulators `ipgen run` compiles go to one cache for the whole run, build/test-cache/, at -Og
## (tests/conftest.py): a second make test compiles none of them. --dist worksteal: a worker that
## runs out of tests takes some queued for the other, so the run does not end on one worker's long
## queue.
test-python: lint deps-docs ipsim-simulate
	$(SIMULATOR_ENV) $(PY) -m pytest -q -n $(JOBS) --dist worksteal -m "not fresh_venv and not user_program"

## The tests that take minutes by design (pytest marker fresh_venv): the README's install lines in
## a fresh virtualenv, then its CMake project (tests/test_package.py); and the docs' own whole C++
## programs, compiled as a reader would (marker user_program). CI runs it after make test.
## --dist loadfile: a file's tests on one worker, so that a module's compiled program (the closed
## loop's) is built once. And the C++ tests slow by design (ctest label slow: ipsim compiled for one model's C++ header,
## the n = 10 models' stability; cpp/tests/CMakeLists.txt), beside them: make test's build
## configures without them (IPGEN_SLOW_TESTS=OFF), this one adds them to the same build folder.
test-slow: venv deps-docs
	$(MAKE) --no-print-directory -j 2 test-slow-python test-cpp-slow
	@echo "make test-slow: all tests passed"

test-slow-python: venv deps-docs ipsim-simulate
	$(SIMULATOR_ENV) $(PY) -m pytest -q -n $(JOBS) --dist loadfile -m "fresh_venv or user_program"

test-cpp-slow: venv ipsim-simulate
	@mkdir -p $(BUILD)
	@if { $(CMAKE_CONFIGURE) -DIPGEN_WITH_GENERATOR=AUTO -DIPGEN_PYTHON=$(abspath $(PY)) -DIPGEN_SLOW_TESTS=ON && \
	      cmake --build $(BUILD) -j $(JOBS) && \
	      ctest --test-dir $(BUILD) --output-on-failure -j $(JOBS) -L slow; } > $(BUILD)/test-cpp-slow.log 2>&1; then \
	  grep -E "tests passed|tests failed" $(BUILD)/test-cpp-slow.log || true; \
	else \
	  tail -n 80 $(BUILD)/test-cpp-slow.log; echo "make test-cpp-slow failed: the whole log is $(BUILD)/test-cpp-slow.log"; exit 1; \
	fi

## C++ side: configure, build and run ctest (skipped until CMakeLists.txt exists).
## CMAKE_OPT: the optimisation level of the Release build, C++ and C (the model libraries; CMake's own
## is -O3). -Og by default: no
## ctest measures speed, and Eigen-heavy targets compile in a fifth to a third less time than at
## -O1 (docs/testing.md); make stability, whose report states run times, builds at -O3.
CMAKE_OPT ?= -Og
CMAKE_CONFIGURE = cmake -S . -B $(BUILD) -G Ninja -DCMAKE_BUILD_TYPE=Release "-DCMAKE_CXX_FLAGS_RELEASE=$(CMAKE_OPT) -DNDEBUG" \
  "-DCMAKE_C_FLAGS_RELEASE=$(CMAKE_OPT) -DNDEBUG"
configure: venv
	$(CMAKE_CONFIGURE) -DIPGEN_WITH_GENERATOR=AUTO -DIPGEN_PYTHON=$(abspath $(PY)) -DIPGEN_SLOW_TESTS=OFF >/dev/null

## What the C++ build can do before the virtualenv exists, beside its install (from a fresh clone,
## which both sides of make test wait for): configure without the generator and compile ipsim's
## core (ipgen_ipsim_core, which the generated models link too) and ipsim's simulator (ipsim_simulate,
## which pytest runs). Only in a build folder not configured yet; `configure` then switches the
## generator on, and neither is rebuilt (same command lines).
cpp-early: deps-build
	@if [ ! -f $(BUILD)/CMakeCache.txt ]; then \
	  $(CMAKE_CONFIGURE) -DIPGEN_WITH_GENERATOR=OFF -DIPGEN_SLOW_TESTS=OFF >/dev/null && \
	  cmake --build $(BUILD) -j $(JOBS) --target ipsim_simulate >/dev/null; \
	fi

## ipsim's simulator as `ipgen run` uses it (CMake target ipsim_simulate: cpp/src/simulate.cpp over
## the model interface, linking the same ipgen_ipsim_core as every CMake program), brought up to
## date before either side starts (one ninja at a time in the build folder). pytest takes it through
## $IPGEN_SIMULATOR instead of compiling a copy of its own into build/test-cache (about 40 s of
## compiler CPU); `ipgen run` checks that it was built from the same ipsim sources. The tests' own
## ipsim programs link the same ipgen_ipsim_core ($IPGEN_TEST_IPSIM_CORE, tests/cxx.py; about 20 s).
SIMULATOR_ENV = IPGEN_SIMULATOR=$(abspath $(BUILD))/bin/ipsim-simulate \
  IPGEN_TEST_IPSIM_CORE=$(abspath $(BUILD))/cpp/libipgen_ipsim_core.a
## It configures first, as `configure` does: a build folder configured with other flags (make
## stability's -O3, a CMAKE_OPT) would otherwise be switched back by test-cpp's configure while
## pytest runs, and the simulator and ipsim's library rebuilt under it.
ipsim-simulate: venv cpp-early
	$(CMAKE_CONFIGURE) -DIPGEN_WITH_GENERATOR=AUTO -DIPGEN_PYTHON=$(abspath $(PY)) -DIPGEN_SLOW_TESTS=OFF >/dev/null
	cmake --build $(BUILD) -j $(JOBS) --target ipsim_simulate >/dev/null

build: configure
	cmake --build $(BUILD) -j $(JOBS)

test-cpp: build
	ctest --test-dir $(BUILD) --output-on-failure -j $(JOBS)

## pytest and the C++ build side by side: pytest alone keeps 2 cores about 60 % busy (its workers
## wait on each other's simulator compiles and on subprocesses), and the CMake build fills the rest
## (docs/testing.md). pytest's progress goes to the terminal; the C++ side's output to
## build/test-cpp.log, of which its summary is printed (all of its end, if it failed).
## The two sides start as soon as they can: the C++ one with cpp-early while the virtualenv and
## the TeX packages install (-j 3: the three at once), the Python one (ruff, then pytest) once both
## are installed.
test: deps-build
	$(MAKE) --no-print-directory -j 3 test-python test-cpp-logged
	@echo "make test: all tests passed"

test-cpp-logged: venv cpp-early ipsim-simulate
	@mkdir -p $(BUILD)
	@if $(MAKE) --no-print-directory test-cpp > $(BUILD)/test-cpp.log 2>&1; then \
	  grep -E "tests passed|tests failed" $(BUILD)/test-cpp.log || true; \
	else \
	  tail -n 80 $(BUILD)/test-cpp.log; echo "make test-cpp failed: the whole log is $(BUILD)/test-cpp.log"; exit 1; \
	fi

demo: configure deps-docs
	cmake --build $(BUILD) -j $(JOBS) --target scene_cdip_pulse scene_rsip_pulse scene_rdip_lqr scene_cdip_lqr_tilt
	$(PY) tools/demo.py --build $(BUILD)
	$(PY) tools/fmu_demo.py --build $(BUILD) --out out/demo
	$(PY) tools/identify_demo.py --out out/demo/identify

## Benchmarks (bench/): generation against sympy.physics.mechanics, generated code against
## Pinocchio, the integrators' work-precision, general against specialised headers; writes
## docs/bench/. Its extra packages go into the same venv (stamp files).
## BENCH_ARGS passes options to bench.run, e.g. make bench BENCH_ARGS=--quick; a --quick in it is
## passed on to the other two parts, which then also write to build/bench/quick/ and leave
## docs/bench/ alone.
BENCH_ARGS ?=
BENCH_QUICK := $(filter --quick,$(BENCH_ARGS))
# The benchmarks without a quick mode run in full under --quick too, but write their pages into
# build/bench/quick/ (a folder, or the page named): docs/bench/ stays as measured.
QUICK_DIR := build/bench/quick
quick_out = $(if $(BENCH_QUICK),--out $(QUICK_DIR)$(if $(1),/$(1)))
$(VENV)/.bench-installed: pyproject.toml $(VENV)/.installed
	$(PY) -m pip install -q -e '.[test,bench]'
	@touch $@

bench: $(VENV)/.bench-installed bench-workprecision bench-specialisation bench-compile bench-embedded bench-control bench-swingup bench-estimation bench-memory bench-general-links bench-identify bench-dfki bench-sweep bench-gym bench-runtime bench-mpc bench-mpc-method bench-mpc-m4 bench-hold-margins bench-leaderboard
	$(PY) -m bench.run $(BENCH_ARGS)

## The links as built against the rods-only generator (67de603): forward_dynamics operations and
## generation time, same run (bench/general_links.py, docs/bench/general_links.md).
## GENERAL_LINKS_ARGS passes options, e.g. make bench-general-links GENERAL_LINKS_ARGS=--rounds=3
GENERAL_LINKS_ARGS ?=
bench-general-links: $(VENV)/.bench-installed
	$(PY) -m bench.general_links $(GENERAL_LINKS_ARGS) $(call quick_out)

## Identification of a 60 s, 1 kHz recording of the QUBE-Servo 2 preset (rotary, DC motor):
## target <= 10 s (bench/identify.py, docs/bench/identify.md). IDENTIFY_ARGS: e.g. --quick
IDENTIFY_ARGS ?= $(BENCH_QUICK)
bench-identify: $(VENV)/.bench-installed
	$(PY) -m bench.identify $(IDENTIFY_ARGS)

## The DFKI double pendulum (design C.0) identified from its real recordings against DFKI's
## model_3.0 (bench/dfki_identify.py, docs/bench/dfki_identify.md); DFKI_RECORDINGS: their folder
## (a copy in bench/data/dfki, BSD-3-Clause)
DFKI_RECORDINGS ?= bench/data/dfki
bench-dfki: $(VENV)/.bench-installed
	$(PY) -m bench.dfki_identify --recordings $(DFKI_RECORDINGS) $(call quick_out)

## ipgen sweep: the rotary single pendulum's scorecard and a ~700-run sweep (LQR at 1 kHz, 10 s runs;
## target <= 2 min on 2 cores), 1 vs 2 local workers and a Dask LocalCluster (docs/bench/sweep.md);
## the robustness scorecards of LQR (rotary single, double) and both swing-ups (docs/bench/robustness.md).
## SWEEP_ARGS: e.g. --quick, --part speed
SWEEP_ARGS ?= $(BENCH_QUICK)
bench-sweep: $(VENV)/.bench-installed
	$(PY) -m bench.sweep $(SWEEP_ARGS)

## The simulator compiled once against one compiled per model: what a new model and a cached run
## cost (with and without the PNG), the simulation's speed on the same .cfg, and at equal error
## against MuJoCo RK4 before issue 45 and now (bench/runtime.py, bench/runtime_speed.py: MuJoCo
## from the workprecision extra; docs/bench/runtime.md). RUNTIME_ARGS: e.g. --quick, --repeat 9
RUNTIME_ARGS ?= $(BENCH_QUICK)
bench-runtime: $(VENV)/.workprecision-installed
	$(PY) -m bench.runtime $(RUNTIME_ARGS)

## ipgen.gym's throughput on one core against gymnasium's CartPole-v1 and MuJoCo's
## InvertedDoublePendulum-v5 in the same run (bench/gym.py, docs/bench/gym.md). GYM_ARGS: e.g. --quick
GYM_ARGS ?= $(BENCH_QUICK)
bench-gym: $(VENV)/.bench-installed
	$(PY) -m bench.gym $(GYM_ARGS)

## The MPC's real-time iteration on the host (QUBE-Servo 2, N = 30) beside DAQP on the condensed QP,
## OSQP on the sparse one and IPOPT on the whole NLP (bench/mpc.py, docs/bench/mpc.md).
## bench-mpc-m4 edits its own section of the same page: the two take turns (flock, util-linux).
bench-mpc: $(VENV)/.bench-installed
	flock docs/bench/mpc.md $(PY) -m bench.mpc $(call quick_out,mpc.md)

## The MPC's microcontroller method (one barrier Newton step a sample, frozen sensitivities) against
## the interior point in closed loop: cost, bounds, time (bench/mpc_method.py, docs/bench/mpc_method.md).
bench-mpc-method: venv
	$(PY) -m bench.mpc_method $(call quick_out,mpc_method.md)

## How far a hold of the QUBE (the MPC's unconstrained law) can go against the scorecard's delay,
## lag and drive noise at once, linear at upright, over designs (docs/bench/hold_margins.md).
bench-hold-margins: $(VENV)/.bench-installed
	$(PY) -m bench.hold_margins $(call quick_out)

## The RealAIGym simulation leaderboard's acrobot and pendubot swung up in ipsim, scored by the v2
## formula, with GIFs (bench/leaderboard.py, docs/bench/leaderboard.md). LEADERBOARD_ARGS: --replan
bench-leaderboard: $(VENV)/.bench-installed
	$(PY) -m bench.leaderboard $(LEADERBOARD_ARGS) $(BENCH_QUICK)

## Compile time of a program with one model and one ipsim::simulate call, against the headers of
## the commit before the compile-cost work (bench/compile_time.py, docs/bench/compile.md).
## COMPILE_ARGS passes options, e.g. make bench-compile COMPILE_ARGS=--repeat=1
COMPILE_ARGS ?=
bench-compile: venv
	$(PY) -m bench.compile_time $(COMPILE_ARGS) $(call quick_out,compile.md)

## General against scene-specialised headers (bench/specialisation.py, docs/bench/specialisation.md).
## SPECIALISATION_ARGS passes options, e.g. make bench-specialisation SPECIALISATION_ARGS=--quick
SPECIALISATION_ARGS ?= $(BENCH_QUICK)
bench-specialisation: venv
	$(PY) -m bench.specialisation $(SPECIALISATION_ARGS)

## Code size of the C header (--emit c) on a Cortex-M4F (bench/embedded.py, docs/bench/embedded.md).
## Debian's arm-none-eabi cross compiler and newlib are large: installed here when missing, never by make test.
ARM_PACKAGES := gcc-arm-none-eabi libnewlib-arm-none-eabi qemu-system-arm
## The benchmarks' Debian packages: under make -j bench one apt-get at a time (each waits for the
## one before it: dpkg's lock).
deps-bench-time: deps-build
	@$(call apt_install,time)
deps-bench-arm: deps-bench-time
	@$(call apt_install,$(ARM_PACKAGES))
bench-embedded: venv deps-bench-arm
	$(PY) -m bench.embedded $(call quick_out)

## One real-time iteration of the MPC (the QUBE preset, N = 30, float) on a Cortex-M4F under QEMU:
## instructions, cycles, RAM, flash and where the instructions go (bench/mpc_m4.py, docs/bench/mpc.md).
bench-mpc-m4: venv deps-bench-arm
	flock docs/bench/mpc.md $(PY) -m bench.mpc_m4 --profile $(call quick_out,mpc.md)

## How far LQR (Q = I, R = 1) brings classical and rotary n = 1..3 back: continuous, 100 Hz and
## 20 Hz sampled, with and without saturation (bench/control.py, docs/bench/control.md).
## CONTROL_ARGS passes options, e.g. make bench-control CONTROL_ARGS=--quick
CONTROL_ARGS ?= $(BENCH_QUICK)
bench-control: $(VENV)/.bench-installed
	$(PY) -m bench.control $(CONTROL_ARGS)

## Swing-up: plan solve times and IPOPT iterations (classical and rotary n = 1..4) and the
## closed loop's robustness to ±5 % link masses and ±20 % damping (bench/swingup.py,
## docs/bench/swingup.md). SWINGUP_ARGS passes options, e.g. make bench-swingup SWINGUP_ARGS=--quick
SWINGUP_ARGS ?= $(BENCH_QUICK)
bench-swingup: $(VENV)/.bench-installed
	$(PY) -m bench.swingup $(SWINGUP_ARGS)

## What measuring costs the loop: LQR on the exact state, the backward difference, the 50 rad/s
## filter and the Kalman filter with 2048-count encoders at 1 kHz and 500 Hz (rsip, rdip, QUBE):
## basin, RMS estimation error, largest delay (bench/estimation.py, docs/bench/estimation.md).
## ESTIMATION_ARGS passes options, e.g. make bench-estimation ESTIMATION_ARGS=--quick
ESTIMATION_ARGS ?= $(BENCH_QUICK)
bench-estimation: $(VENV)/.bench-installed
	$(PY) -m bench.estimation $(ESTIMATION_ARGS)

## Peak resident memory of the simulator `ipgen run` builds (cdip_pulse) for 10^4 and 10^7 output
## samples: the CSV is streamed, so both must be within 20 MB (bench/simulator_memory.py,
## docs/bench/simulator_memory.md).
bench-memory: $(VENV)/.bench-installed deps-bench-time
	$(PY) -m bench.simulator_memory $(call quick_out,simulator_memory.md)

## Work-precision of the simulator's integrators against MuJoCo and scipy (bench/workprecision/,
## writes docs/bench/workprecision*); its extra (mujoco) behind its own stamp.
## WORKPRECISION_ARGS passes options, e.g. make bench-workprecision WORKPRECISION_ARGS=--quick
WORKPRECISION_ARGS ?= $(BENCH_QUICK)
$(VENV)/.workprecision-installed: pyproject.toml $(VENV)/.installed $(VENV)/.bench-installed
	$(PY) -m pip install -q -e '.[test,workprecision]'
	@touch $@

bench-workprecision: $(VENV)/.workprecision-installed
	$(PY) -m bench.workprecision $(WORKPRECISION_ARGS)

## Numerical stability at the extremes (cpp/stability/, tools/stability.py): builds every scenario
## driver (the n = 20 models too) and writes docs/stability.md; fails if a scenario misses its bound.
stability: CMAKE_OPT := -O3
stability: configure
	cmake --build $(BUILD) -j $(JOBS) --target stability_drivers
	$(PY) tools/stability.py --build $(BUILD) --out docs/stability.md

## What make wrote: the build folder and make demo's out/demo (the README's commands write into
## out/ too, where a user's own files may be: those stay).
clean:
	rm -rf $(BUILD) out/demo
