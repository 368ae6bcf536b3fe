"""The fixed-pivot chain's headers (`ipgen --type fixed`): C++17 and C99, against the Python model.

For n = 1–3 links and the driven joints [1], [2], [1, 2] (where the chain has them), with random
links as built (negative com too), damping and geared rotors (signed gear ratios):
- NAME.hpp compiles with g++ -std=c++17 -Wall -Wextra -Wpedantic -Werror, NAME.h with gcc
  -std=c99 (double, and for two chains float with -Wdouble-promotion -Wconversion) under the same
  flags;
- at random states and inputs, M, the bias, q̈, the linearisation's A and B (exact derivatives),
  T, V and D of the C header (every chain) and of the C++ header (four chains: CPP_CASES) equal
  the sympy model `ipgen.model.fixed_numeric.FixedModel` (its own check:
  sympy.physics.mechanics, tests/test_fixed_model.py) to 1e-12 relative; B is the model's input
  matrix;
- the command line refuses what the fixed headers do not take, in one line.
"""

from __future__ import annotations

import subprocess
from pathlib import Path

import numpy as np
import pytest
from c_models import c_command, compile_c, require_cc
from cxx import cxx_command, require_toolchain

from ipgen.codegen.fixed_header import FixedHeaderRequest, render_fixed
from ipgen.model.fixed import FixedPendulum
from ipgen.model.fixed_numeric import FixedModel

CASES = [(1, (1,)), (2, (1,)), (2, (2,)), (2, (1, 2)), (3, (1,)), (3, (2,)), (3, (1, 2)), (3, (3, 1))]
IDS = [f"n{n}-j{''.join(map(str, j))}" for n, j in CASES]
# The C++ header's Eigen driver and the float C build (warnings only) cost 2-3 s of compiling each:
# for these cases; the double C header, printed from the same expressions, is run for every case.
CPP_CASES = {(1, (1,)), (2, (1, 2)), (3, (2,)), (3, (3, 1))}
FLOAT_CASES = {(2, (2,)), (3, (1, 2))}
RELATIVE = 1e-12
STATES = 6

C_DRIVER = r"""
#include <stdio.h>
#include "NAME.h"
#define D IPGEN_NAMEU_DOF
#define I IPGEN_NAMEU_INPUTS
static double get(void) { double v = 0; if (scanf("%lf", &v) != 1) v = 0; return v; }
static void put(const IPGEN_SCALAR *x, int size) {
  int i;
  for (i = 0; i < size; ++i) printf("%.17g ", (double)x[i]);
  printf("\n");
}
int main(void) {
  ipgen_NAME_params p;
  ipgen_NAME_links links;
  IPGEN_SCALAR q[D], qd[D], u[I], M[D*D], b[D], qdd[D], A[4*D*D], B[2*D*I], T, V, Dv, Bm[D*I];
  int i, k, states;
  for (i = 0; i < D; ++i) p.m[i] = (IPGEN_SCALAR)get();
  for (i = 0; i < D; ++i) p.l[i] = (IPGEN_SCALAR)get();
  for (i = 0; i < D; ++i) p.delta[i] = (IPGEN_SCALAR)get();
  p.g = (IPGEN_SCALAR)get();
  for (i = 0; i < D; ++i) links.com[i] = (IPGEN_SCALAR)get();
  for (i = 0; i < D; ++i) links.J[i] = (IPGEN_SCALAR)get();
  for (i = 0; i < I; ++i) p.Ir[i] = (IPGEN_SCALAR)get();
  for (i = 0; i < I; ++i) p.gr[i] = (IPGEN_SCALAR)get();
  states = (int)get();
  ipgen_NAME_input_matrix(Bm);
  put(Bm, D*I);
  for (k = 0; k < states; ++k) {
    for (i = 0; i < D; ++i) q[i] = (IPGEN_SCALAR)get();
    for (i = 0; i < D; ++i) qd[i] = (IPGEN_SCALAR)get();
    for (i = 0; i < I; ++i) u[i] = (IPGEN_SCALAR)get();
    ipgen_NAME_mass_matrix_built(q, &p, &links, M);
    ipgen_NAME_bias_built(q, qd, &p, &links, b);
    if (ipgen_NAME_forward_dynamics_built(q, qd, u, &p, &links, qdd) != 0) return 3;
    if (ipgen_NAME_linearize_built(q, qd, u, &p, &links, A, B) != 0) return 4;
    T = ipgen_NAME_kinetic_energy_built(q, qd, &p, &links);
    V = ipgen_NAME_potential_energy_built(q, &p, &links);
    Dv = ipgen_NAME_dissipation(qd, &p);
    put(M, D*D); put(b, D); put(qdd, D); put(A, 4*D*D); put(B, 2*D*I); put(&T, 1); put(&V, 1); put(&Dv, 1);
  }
  return 0;
}
"""

CPP_DRIVER = r"""
#include <cstdio>
#include <iostream>
#include "NAME.hpp"
namespace m = ipgen::NAME;
static double get() { double v = 0; std::cin >> v; return v; }
template <class X> static void put(const X& x) {
  for (int r = 0; r < x.rows(); ++r) for (int c = 0; c < x.cols(); ++c) std::printf("%.17g ", x(r, c));
  std::printf("\n");
}
static void put1(double x) { std::printf("%.17g\n", x); }
int main() {
  m::Params<double> p;
  for (auto& v : p.m) v = get();
  for (auto& v : p.l) v = get();
  for (auto& v : p.delta) v = get();
  p.g = get();
  for (auto& v : p.com) v = get();
  for (auto& v : p.J) v = get();
  for (auto& v : p.Ir) v = get();
  for (auto& v : p.gr) v = get();
  const int states = static_cast<int>(get());
  put(m::input_matrix<double>());
  for (int k = 0; k < states; ++k) {
    m::Vector<double> q, qd;
    m::InputVector<double> u;
    for (int i = 0; i < m::kDof; ++i) q(i) = get();
    for (int i = 0; i < m::kDof; ++i) qd(i) = get();
    for (int i = 0; i < m::kInputs; ++i) u(i) = get();
    const auto lin = m::linearize(q, qd, u, p);
    put(m::mass_matrix(q, p)); put(m::bias(q, qd, p)); put(m::forward_dynamics(q, qd, u, p));
    put(lin.A); put(lin.B);
    put1(m::kinetic_energy(q, qd, p)); put1(m::potential_energy(q, p)); put1(m::dissipation(qd, p));
  }
  return 0;
}
"""


def _pendulum(links: int, joints: tuple[int, ...], rng: np.random.Generator) -> FixedPendulum:
    return FixedPendulum(
        links,
        m=rng.uniform(0.2, 2, links),
        l=rng.uniform(0.2, 1, links),
        delta=rng.uniform(0, 0.3, links),
        g=9.81,
        com=rng.uniform(-0.2, 0.8, links),
        J=rng.uniform(0.01, 0.1, links),
        joints=joints,
        Ir=rng.uniform(1e-4, 1e-2, len(joints)),
        gr=rng.uniform(-8, 8, len(joints)),
    )


def _input_text(pendulum: FixedPendulum, states: np.ndarray) -> str:
    values = [*pendulum.m, *pendulum.l, *pendulum.delta, pendulum.g, *pendulum.resolved("com")]
    values += [*pendulum.resolved("J"), *pendulum.motor("Ir"), *pendulum.motor("gr"), len(states)]
    values += [v for row in states for v in row]
    return " ".join(repr(float(v)) for v in values)


def _expected(pendulum: FixedPendulum, model: FixedModel, state: np.ndarray) -> list[np.ndarray]:
    n = pendulum.links
    q, qd, u = state[:n], state[n : 2 * n], state[2 * n :]
    mass = model.mass_matrix(q)
    a, b = model.linearize(q, qd, u)
    e = model.equations
    numbers = pendulum.numbers() | {s.name: v for s, v in zip(e.q, q, strict=True)}
    potential = float(e.potential_energy.subs({s: numbers[s.name] for s in e.potential_energy.free_symbols}))
    rates = [qd[0], *(qd[i] - qd[i - 1] for i in range(1, n))]
    dissipation = 0.5 * sum(d * w * w for d, w in zip(pendulum.delta, rates, strict=True))
    return [
        mass.reshape(-1),
        model.bias(q, qd),
        model.forward_dynamics(q, qd, u, coulomb=False),
        a.reshape(-1),
        b.reshape(-1),
        np.array([0.5 * qd @ mass @ qd]),
        np.array([potential]),
        np.array([dissipation]),
    ]


def _check(output: str, pendulum: FixedPendulum, model: FixedModel, states: np.ndarray, label: str) -> None:
    lines = [np.array([float(v) for v in line.split()]) for line in output.strip().splitlines()]
    np.testing.assert_array_equal(lines[0], model.B.reshape(-1), err_msg=f"{label}: B")
    names = ("M", "bias", "qdd", "A", "B", "T", "V", "D")
    for k, state in enumerate(states):
        got = lines[1 + k * len(names) : 1 + (k + 1) * len(names)]
        for name, ours, theirs in zip(names, got, _expected(pendulum, model, state), strict=True):
            scale = max(1.0, float(np.max(np.abs(theirs))))
            np.testing.assert_allclose(
                ours, theirs, rtol=0, atol=RELATIVE * scale, err_msg=f"{label}: {name} at state {k}"
            )


def _states(pendulum: FixedPendulum, rng: np.random.Generator) -> np.ndarray:
    n, m = pendulum.links, pendulum.inputs
    return np.hstack(
        [
            rng.uniform(-np.pi, np.pi, (STATES, n)),
            rng.uniform(-3, 3, (STATES, n)),
            rng.uniform(-2, 2, (STATES, m)),
        ]
    )


def _run(program: Path, text: str) -> str:
    result = subprocess.run(
        [str(program)], input=text, capture_output=True, text=True, check=False, timeout=60
    )
    assert result.returncode == 0, f"{program.name} exited {result.returncode}: {result.stderr[:400]}"
    return result.stdout


@pytest.mark.parametrize(("links", "joints"), CASES, ids=IDS)
def test_headers_equal_python_model(links: int, joints: tuple[int, ...], tmp_path: Path) -> None:
    require_cc()
    require_toolchain()
    name = f"chain{links}_{''.join(map(str, joints))}"
    request = FixedHeaderRequest(name, links, joints, "ipgen --type fixed (test)")
    for target in ("cpp", "library"):
        for suffix, text in render_fixed(request, target).items():
            (tmp_path / f"{name}{suffix}").write_text(text, encoding="utf-8")
    rng = np.random.default_rng(100 * links + sum(joints))
    pendulum = _pendulum(links, joints, rng)
    model = FixedModel(pendulum)
    states = _states(pendulum, rng)
    text = _input_text(pendulum, states)

    c_source = tmp_path / "driver.c"
    c_source.write_text(C_DRIVER.replace("NAMEU", name.upper()).replace("NAME", name), encoding="utf-8")
    for scalar in ("double", "float") if (links, joints) in FLOAT_CASES else ("double",):
        program = tmp_path / f"driver_c_{scalar}"
        failure = compile_c(c_command(f"-I{tmp_path}", str(c_source), "-o", str(program), scalar=scalar))
        assert failure is None, failure
    _check(_run(tmp_path / "driver_c_double", text), pendulum, model, states, f"{name}.h")
    if (links, joints) not in CPP_CASES:
        return

    cpp_source = tmp_path / "driver.cpp"
    cpp_source.write_text(CPP_DRIVER.replace("NAME", name), encoding="utf-8")
    program = tmp_path / "driver_cpp"
    failure = compile_c(cxx_command(f"-I{tmp_path}", str(cpp_source), "-o", str(program)))
    assert failure is None, failure
    _check(_run(program, text), pendulum, model, states, f"{name}.hpp")


def test_command_writes_the_headers(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from ipgen.command.cli import run as cli

    out = tmp_path / "out"
    arguments = ["--type", "fixed", "--links", "2", "--joints", "2", "--name", "acrobot"]
    assert cli([*arguments, "--emit", "cpp,library", "-o", str(out)]) == 0
    assert sorted(p.name for p in out.iterdir()) == ["acrobot.h", "acrobot.hpp", "acrobot_model.c"]
    header = (out / "acrobot.hpp").read_text(encoding="utf-8")
    assert "ipgen --type fixed --links 2 --joints 2 --name acrobot --emit cpp,library -o <dir>" in header
    assert "inline constexpr std::array<int, kInputs> kJoints = {2};" in header
    assert "fixed, 2 links" not in capsys.readouterr().err


@pytest.mark.parametrize(
    ("arguments", "says"),
    [
        (["--type", "fixed", "--links", "2", "--joints", "3"], "joint 3 is out of range"),
        (["--type", "fixed", "--links", "2", "--joints", "1,1"], "listed twice"),
        (["--type", "fixed", "--links", "2", "--joints", "a"], "expected joint numbers"),
        (["--type", "fixed", "--links", "2", "--inertia", "full"], "--inertia with --type fixed"),
        (["--type", "fixed", "--links", "2", "--angles", "relative"], "--angles with --type fixed"),
        (["--type", "rotary", "--links", "2", "--joints", "1"], "--joints is for --type fixed"),
        (["--type", "fixed", "--joints", "1"], "missing --links"),
    ],
)
def test_command_refuses_in_one_line(
    arguments: list[str], says: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from ipgen.command.cli import run as cli

    assert cli([*arguments, "-o", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and says in err, err
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize(
    ("links", "joints"), [(2, (1,)), (2, (2,)), (3, (3, 1))], ids=["pendubot", "acrobot", "n3-j31"]
)
def test_model_library_behind_the_interface(links: int, joints: tuple[int, ...], tmp_path: Path) -> None:
    """The model library (`--emit library`) through ipgen_model.h with ctypes: ABI 4, type
    "fixed", dof = n, m inputs, B and joints; forward_dynamics, linearize, M, the energies and
    rod_links against the Python model, parameters in the interface's layout (index i: link
    i + 1; Ir, gr per input)."""
    import ctypes

    from test_runtime import Model, Parameters, compile_library

    require_cc()
    name = "chain"
    request = FixedHeaderRequest(name, links, joints, "ipgen --type fixed (test)")
    for suffix, text in render_fixed(request, "library").items():
        (tmp_path / f"{name}{suffix}").write_text(text, encoding="utf-8")
    lib = ctypes.CDLL(str(compile_library(tmp_path, name)))
    lib.ipgen_model_get.restype = ctypes.POINTER(Model)
    model = lib.ipgen_model_get().contents
    n, m = links, len(joints)
    assert (model.abi, model.type, model.links, model.dof, model.inputs) == (4, b"fixed", n, n, m)
    assert [model.joints[k] for k in range(m)] == list(joints)
    assert not model.rk4_step  # ipsim steps a fixed chain itself (its inputs go through B)
    rng = np.random.default_rng(46)
    pendulum = _pendulum(links, joints, rng)
    python = FixedModel(pendulum)
    np.testing.assert_array_equal(
        np.array([model.input_matrix[i] for i in range(n * m)]), python.B.reshape(-1)
    )
    p = Parameters()
    for field in ("m", "l", "delta"):
        getattr(p, field)[:n] = getattr(pendulum, field)
    p.g = pendulum.g
    p.com[:n], p.J[:n] = pendulum.resolved("com"), pendulum.resolved("J")
    p.Ir[:m], p.gr[:m] = pendulum.motor("Ir"), pendulum.motor("gr")

    def array(values: np.ndarray | list[float]) -> ctypes.Array:
        return (ctypes.c_double * max(1, len(values)))(*values)

    for state in _states(pendulum, rng):
        q, qd, u = state[:n], state[n : 2 * n], state[2 * n :]
        qdd, a, b, mass = (
            array([0.0] * n),
            array([0.0] * 4 * n * n),
            array([0.0] * 2 * n * m),
            array([0.0] * n * n),
        )
        assert model.forward_dynamics(array(q), array(qd), array(u), ctypes.byref(p), qdd) == 0
        assert model.linearize(array(q), array(qd), array(u), ctypes.byref(p), a, b) == 0
        model.mass_matrix(array(q), ctypes.byref(p), mass)
        expected = _expected(pendulum, python, state)
        for label, ours, theirs in (
            ("M", mass, expected[0]),
            ("qdd", qdd, expected[2]),
            ("A", a, expected[3]),
            ("B", b, expected[4]),
        ):
            scale = max(1.0, float(np.max(np.abs(theirs))))
            np.testing.assert_allclose(
                np.array(ours[:]), theirs, rtol=0, atol=RELATIVE * scale, err_msg=label
            )
        energies = (
            model.kinetic_energy(array(q), array(qd), ctypes.byref(p)),
            model.potential_energy(array(q), ctypes.byref(p)),
        )
        np.testing.assert_allclose(energies, [expected[5][0], expected[6][0]], rtol=RELATIVE, atol=RELATIVE)
    rods = Parameters()
    rods.m[:n], rods.l[:n] = pendulum.m, pendulum.l
    rods.com[:n] = rods.J[:n] = [float("nan")] * n
    model.rod_links(ctypes.byref(rods))
    np.testing.assert_allclose(rods.com[:n], np.array(pendulum.l) / 2, rtol=1e-15)
    np.testing.assert_allclose(rods.J[:n], np.array(pendulum.m) * np.array(pendulum.l) ** 2 / 12, rtol=1e-15)
