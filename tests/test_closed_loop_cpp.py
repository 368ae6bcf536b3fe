"""The C++ side of the controller: the header's linearize against ipgen.linearize, and ipsim's
closed loop (continuous and sampled-data, saturated) with a gain from ipgen.lqr."""

from __future__ import annotations

import subprocess
import warnings
from pathlib import Path

import numpy as np
import pytest
from cxx import cxx_command, ipsim_core, require_toolchain
from numeric import assert_close

import ipgen
from ipgen.control import linear as control
from ipgen.model.system import System
from ipgen.pipeline.generate import generate_header
from ipgen.pipeline.simulator import SEPARATE, optimisation

ROOT = Path(__file__).resolve().parents[1]
# A whole ipsim program of the model's C++ header (8-10 s of compiling): make test-slow, beside the
# docs' own programs.
pytestmark = pytest.mark.user_program

SUNDIALS = tuple(
    f"-lsundials_{n}" for n in ("cvode", "arkode", "nvecserial", "sunmatrixdense", "sunlinsoldense")
)
SUNDIALS += ("-lsundials_sunnonlinsolfixedpoint", "-llapack")  # LAPACK: ipsim's eigenvalue guards

PARAMS = {"m": [0.5, 0.275, 0.275], "l": [0.6, 0.5, 0.5], "delta": [0.3, 0.011458, 0.011458]}
STATE = [0.2, 0.3, -0.4, 0.5, -1.0, 0.7]  # not an equilibrium
U = 0.3
SATURATION = 3.0
PERIOD = 0.01
SAMPLE = 0.002

DRIVER = r"""
#include <cstdio>
#include <cstring>
#include "rdip.hpp"
#include "ipsim/ipsim.hpp"
using Model = ipgen::rdip::Model;
int main(int argc, char** argv) {
  const Model::Params<double> p{{0.5, 0.275, 0.275}, {0.6, 0.5, 0.5}, {0.3, 0.011458, 0.011458}};
  if (argc > 1 && std::strcmp(argv[1], "linearize") == 0) {
    const double x[6] = {STATE};
    const Model::Vector<double> q(x[0], x[1], x[2]), qd(x[3], x[4], x[5]);
    const auto lin = Model::linearize<double>(q, qd, U_VALUE, p);
    for (int i = 0; i < 6; ++i) {
      for (int j = 0; j < 6; ++j) std::printf("%.17g ", lin.A(i, j));
      std::printf("%.17g\n", lin.B(i));
    }
    return 0;
  }
  if (argc > 1 && std::strcmp(argv[1], "wrong-size") == 0) {  // a gain of another model: refused
    ipsim::LinearFeedback wrong;
    wrong.gain = Eigen::VectorXd::Ones(4);
    wrong.equilibrium = Eigen::VectorXd::Zero(4);
    try {
      ipsim::closed_loop_poles<Model>(p, wrong);
    } catch (const ipsim::InvalidInput& error) {
      std::printf("%s\n", error.what());
      return 0;
    }
    return 1;
  }
  ipsim::LinearFeedback c;
  c.gain = Eigen::VectorXd(6);
  c.gain << GAIN;
  c.equilibrium = Eigen::VectorXd::Zero(6);
  c.saturation = SATURATION;
  c.period = argc > 1 && std::strcmp(argv[1], "sampled") == 0 ? PERIOD : 0.0;
  ipsim::Settings<Model> s;
  s.t_end = 10.0;
  s.sample = SAMPLE;
  s.rtol = 1e-10;
  s.atol = 1e-12;
  s.theta << 0.0, 0.1, 0.0;
  s.input = c.input();
  // "monitored": the samples go through the simulator's divergence check (ipsim/divergence.hpp)
  // into a MemorySink; stderr says whether it stopped the run.
  ipsim::Result r;
  if (argc > 2 && std::strcmp(argv[2], "monitored") == 0) {
    ipsim::MemorySink memory(r);
    ipsim::DivergenceMonitor monitor(memory, c.equilibrium, Model::kDof);
    const ipsim::Result summary = ipsim::simulate<Model>(p, s, monitor);
    memory.finish();
    r.max_abs_input = summary.max_abs_input;
    std::fprintf(stderr, "stopped %d\n", summary.stopped_early ? 1 : 0);
  } else {
    r = ipsim::simulate<Model>(p, s);
  }
  const Eigen::VectorXcd poles = ipsim::closed_loop_poles<Model>(p, c);
  std::printf("poles");
  for (Eigen::Index i = 0; i < poles.size(); ++i) {
    std::printf(" %.17g %.17g", poles(i).real(), poles(i).imag());
  }
  std::printf("\nmax %.17g\n", r.max_abs_input);
  for (std::size_t k = 0; k < r.times.size(); ++k) {
    std::printf("%.17g %.17g", r.times[k], r.inputs[k]);
    for (int j = 0; j < 6; ++j) std::printf(" %.17g", r.states(static_cast<Eigen::Index>(k), j));
    std::printf("\n");
  }
  return 0;
}
"""


@pytest.fixture(scope="module")
def driver(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, np.ndarray]:
    require_toolchain()
    folder = tmp_path_factory.mktemp("closed_loop")
    generate_header(System("rotary", 2), "rdip", folder)
    gain = ipgen.lqr("rotary", 2, **PARAMS, Q=np.ones(6), R=1.0)[0]  # the row of the 1 x 6 gain
    source = DRIVER
    for name, value in {
        "STATE": ", ".join(map(repr, STATE)),
        "U_VALUE": repr(U),
        "GAIN": ", ".join(map(repr, gain.tolist())),
        "SATURATION": repr(SATURATION),
        "PERIOD": repr(PERIOD),
        "SAMPLE": repr(SAMPLE),
    }.items():
        source = source.replace(name, value)
    (folder / "driver.cpp").write_text(source)
    binary = folder / "driver"
    # ipsim's model-independent code compiled once (the CMake build's, else the test run's
    # simulator cache's; same flags: the tests' optimisation, -DNDEBUG), as `ipgen run` links it,
    # so that it is not compiled once more here; the README's examples compile ipsim header-only.
    _std, level, *defines = optimisation()  # ("-std=c++17", level, "-DNDEBUG")
    build = subprocess.run(
        cxx_command(
            *defines,
            SEPARATE,
            f"-I{folder}",
            f"-I{ROOT / 'cpp/include'}",
            str(folder / "driver.cpp"),
            str(ipsim_core()),
            "-o",
            str(binary),
            *SUNDIALS,
            optimisation=level,
        ),
        capture_output=True,
        text=True,
    )
    assert build.returncode == 0, build.stderr[-3000:]
    return binary, gain


def run(binary: Path, *mode: str) -> tuple[np.ndarray, float, np.ndarray]:
    out = subprocess.run([str(binary), *mode], capture_output=True, text=True, check=True).stdout.splitlines()
    numbers = [float(v) for v in out[0].split()[1:]]
    poles = np.array(numbers[0::2]) + 1j * np.array(numbers[1::2])
    largest = float(out[1].split()[1])
    rows = np.array([[float(v) for v in line.split()] for line in out[2:]])
    return poles, largest, rows


def test_header_linearize_agrees_with_python(driver: tuple[Path, np.ndarray]) -> None:
    binary, _ = driver
    out = subprocess.run([str(binary), "linearize"], capture_output=True, text=True, check=True).stdout
    table = np.array([[float(v) for v in line.split()] for line in out.splitlines()])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", control.EquilibriumWarning)
        a, b = ipgen.linearize("rotary", 2, **PARAMS, q=STATE[:3], qd=STATE[3:], u=U)
    assert_close(table[:, :6], a, 1e-12, "A", ("C++ header", "Python"))
    assert_close(table[:, 6:], b, 1e-12, "B", ("C++ header", "Python"))


@pytest.mark.parametrize("mode", ["continuous", "sampled"])
def test_closed_loop_saturated_and_converging(driver: tuple[Path, np.ndarray], mode: str) -> None:
    binary, gain = driver
    poles, largest, rows = run(binary, mode)
    a, b = ipgen.linearize("rotary", 2, **PARAMS)
    reference = control.closed_loop_poles(a, b, gain)
    both = (np.column_stack([poles.real, poles.imag]), np.column_stack([reference.real, reference.imag]))
    assert_close(*both, 1e-9, "closed-loop poles", ("C++", "Python"))
    assert np.max(poles.real) < 0
    t, u, x = rows[:, 0], rows[:, 1], rows[:, 2:]
    assert np.max(np.abs(u)) <= SATURATION and largest <= SATURATION
    assert largest == SATURATION  # the bound is reached at the start, so the check above can fail
    assert np.max(np.abs(x[-1])) < 1e-3, x[-1]
    # u = clip(−K x) at every sample (continuous) or at every sampling instant (sampled)
    expected = np.clip(-x @ gain, -SATURATION, SATURATION)
    instants = np.isclose(np.remainder(t + 1e-9, PERIOD), 1e-9, atol=1e-7) if mode == "sampled" else t >= 0
    instants[-1] = mode == "continuous"  # at t_end a sampled input shows the value held before
    assert_close(u[instants], expected[instants], 1e-12, f"{mode} u", ("simulated", "−K x"))
    if mode == "sampled":
        per_window = round(PERIOD / SAMPLE)
        assert np.count_nonzero(instants) == (len(t) - 1) // per_window
        held = np.flatnonzero(instants)
        for start in held:
            window = u[start : start + per_window]
            assert np.all(window == window[0]), f"u changes between sampling instants after t = {t[start]}"
        assert np.any(u[~instants][:-1] != expected[~instants][:-1])  # held, not recomputed


@pytest.mark.parametrize("mode", ["continuous", "sampled"])
def test_divergence_check_leaves_a_holding_loop_alone(driver: tuple[Path, np.ndarray], mode: str) -> None:
    """The simulator's divergence check (a link beyond π/2 from x_eq) does not stop these closed
    loops, which come back from 0.1 rad; the samples are the same as without it."""
    binary, _ = driver
    checked = subprocess.run([str(binary), mode, "monitored"], capture_output=True, text=True, check=True)
    assert checked.stderr.strip() == "stopped 0"
    _, largest, rows = run(binary, mode, "monitored")
    _, reference_largest, reference = run(binary, mode)
    assert rows.shape == reference.shape and np.array_equal(rows, reference)
    assert largest == reference_largest
    assert np.max(np.abs(rows[:, 3:5])) < np.pi / 2  # the links (θ1, θ2 after t and u)


def test_closed_loop_poles_refuse_a_gain_of_another_size(driver: tuple[Path, np.ndarray]) -> None:
    """A LinearFeedback of 4 entries on the 6-state rdip: InvalidInput naming the sizes (it read
    past the gain's end: a crash, or poles of garbage)."""
    done = subprocess.run([str(driver[0]), "wrong-size"], capture_output=True, text=True)
    assert done.returncode == 0, done.stdout + done.stderr
    assert "controller.gain: has 4 entries, the model's state has 2·kDof = 6" in done.stdout
