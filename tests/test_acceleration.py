"""An acceleration-driven base (`actuator=`, kind "acceleration"): u is θ̈0 [m/s² or rad/s²].

The base coordinate is kinematic and the links follow the link rows of M θ̈ + b = e0 τ:
θ̈_L = −M_LL⁻¹ (M_L0 u + b_L). Checked against things `linearize` does not compute:

- the textbook model of a pendulum on a cart whose acceleration is commanded, derived by hand
  below from the torque balance about the moving pivot (no mass matrix involved);
- central differences of the nonlinear dynamics (A and B about arbitrary, moving states);
- the force-driven model: applying the base force τ that `acceleration_dynamics` reports to the
  ordinary forward dynamics must give the same accelerations, with θ̈0 = u;
- the power balance: d(T + V)/dt = τ θ̇0 − 2 D along a nonlinear simulation.
"""

from __future__ import annotations

import math
import warnings
from pathlib import Path

import numpy as np
import pytest
import sympy as sp
from hypothesis import given, settings
from hypothesis import strategies as st
from run_csv import read_run_csv
from run_summary import simulator_of
from scipy.integrate import solve_ivp

import ipgen
from ipgen.control.linear import ControlError, EquilibriumWarning, dynamics
from ipgen.model.actuator import Actuator, ActuatorError, fold
from ipgen.model.derivation import derive
from ipgen.model.pendulum import Pendulum
from ipgen.model.system import System


def flat_parameters(system, m, l, delta, g, links=None):  # noqa: E741
    """`Dynamics`' flat parameters of these values (the Pendulum's `flat`)."""
    return Pendulum(system.type, system.links, m, l, delta, g, system.inertia, **(links or {})).flat()


ACCEL = {"kind": "acceleration"}


def test_cart_pendulum_textbook_model() -> None:
    """A link of mass m, CoG at c from the pivot, inertia J about the CoG, on a cart whose
    acceleration a is imposed. In the cart's frame the link feels gravity g up-down and the
    inertial force −m a horizontally at its CoG (x + c sin θ, c cos θ; θ from upright,
    positive towards +x). Torques about the pivot:
        (J + m c²) θ̈ = m g c sin θ − m a c cos θ − δ1 θ̇,
    linear about upright: θ̈ = (m g c θ − m c a − δ1 θ̇) / (J + m c²)."""
    m0, m1, l1, c, j, d1, g = 0.7, 0.23, 0.64, 0.29, 0.011, 0.004, 9.81
    a, b = ipgen.linearize(
        "classical", 1, m=[m0, m1], l=[0.0, l1], delta=[5.0, d1], g=g,
        com=[0.0, c], J=[0.0, j], actuator=ACCEL,
    )  # fmt: skip
    jp = j + m1 * c**2
    expected_a = np.array(
        [
            [0, 0, 1, 0],
            [0, 0, 0, 1],
            [0, 0, 0, 0],  # θ̈0 = u: the base is kinematic
            [0, m1 * g * c / jp, 0, -d1 / jp],
        ]
    )
    expected_b = np.array([[0], [0], [1], [-m1 * c / jp]])
    np.testing.assert_allclose(a, expected_a, rtol=1e-13, atol=1e-15)
    np.testing.assert_allclose(b, expected_b, rtol=1e-13, atol=1e-15)
    # The paper's rod (c = l/2, J = m l²/12): the famous θ̈ = 3g/(2l) θ − 3/(2l) u.
    a, b = ipgen.linearize("classical", 1, [m0, m1], [0.0, l1], [0.0, 0.0], g=g, actuator=ACCEL)
    assert a[3, 1] == pytest.approx(3 * g / (2 * l1), rel=1e-13)
    assert b[3, 0] == pytest.approx(-3 / (2 * l1), rel=1e-13)


def test_rotary_pendulum_textbook_model() -> None:
    """A Furuta pendulum whose arm's angular acceleration α̈ is imposed (arm radius r = l0, link
    CoG at c, inertia J about its CoG, pivot variant: no axial inertia). The pivot moves on a
    circle; about upright, its tangential acceleration r α̈ acts on the link like a cart's
    acceleration, so the linear model is θ̈ = (m g c θ − m c r α̈ − δ1 θ̇) / (J + m c²), and the
    sign of the coupling is the one the direct model's M10 has."""
    m0, m1, l0, l1, c, j, d1, g = 0.095, 0.024, 0.085, 0.129, 0.0645, 3.3e-5, 1e-5, 9.81
    a, b = ipgen.linearize(
        "rotary", 1, [m0, m1], [l0, l1], [1e-3, d1], g=g, com=[0, c], J=[5e-4, j], actuator=ACCEL
    )
    jp = j + m1 * c**2
    mass = np.asarray(dynamics(System("rotary", 1))._mass(0.0, 0.0, *_p_rotary(m0, m1, l0, l1, c, j, g)))
    sign = np.sign(mass[1, 0])
    np.testing.assert_allclose(a[3], [0, m1 * g * c / jp, 0, -d1 / jp], rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(b[:, 0], [0, 0, 1, -sign * m1 * c * l0 / jp], rtol=1e-12)
    np.testing.assert_array_equal(a[2], np.zeros(4))


def _p_rotary(m0: float, m1: float, l0: float, l1: float, c: float, j: float, g: float) -> list[float]:
    return flat_parameters(
        System("rotary", 1), [m0, m1], [l0, l1], [0, 0], g, {"com": [0, c], "J": [5e-4, j]}
    )


CASES = [
    ("classical", 2, "pivot", [0.5, 0.2, 0.15], [0.0, 0.4, 0.3], [0.3, 0.01, 0.02]),
    ("classical", 3, "pivot", [0.9, 0.2, 0.15, 0.1], [0.0, 0.4, 0.3, 0.2], [0.3, 0.01, 0.02, 0.01]),
    ("rotary", 2, "full", [0.3, 0.2, 0.1], [0.25, 0.3, 0.2], [0.02, 0.01, 0.005]),
]


@pytest.mark.parametrize(("kind", "links", "inertia", "m", "l", "delta"), CASES)
def test_linearisation_matches_central_differences(kind, links, inertia, m, l, delta) -> None:  # noqa: E741
    """A, B about an arbitrary moving state against central differences of the nonlinear
    acceleration-driven dynamics."""
    system = System(kind, links, inertia)
    dof = system.dof
    rng = np.random.default_rng(7)
    params = flat_parameters(system, m, l, delta, 9.81)
    dyn = dynamics(system)
    for _ in range(3):
        q, qd, u = rng.uniform(-2, 2, dof), rng.uniform(-3, 3, dof), float(rng.uniform(-4, 4))
        with pytest.warns(EquilibriumWarning):
            a, b = ipgen.linearize(kind, links, m, l, delta, inertia=inertia, q=q, qd=qd, u=u, actuator=ACCEL)
        x = np.concatenate([q, qd])

        def f(x: np.ndarray, u: float) -> np.ndarray:
            return np.concatenate([x[dof:], dyn.acceleration_dynamics(x[:dof], x[dof:], u, params)[0]])

        h = 1e-6
        numeric_a = np.column_stack([(f(x + h * e, u) - f(x - h * e, u)) / (2 * h) for e in np.eye(2 * dof)])
        numeric_b = (f(x, u + h) - f(x, u - h)) / (2 * h)
        np.testing.assert_allclose(a, numeric_a, rtol=1e-6, atol=1e-7)
        np.testing.assert_allclose(b[:, 0], numeric_b, rtol=1e-6, atol=1e-7)


@pytest.mark.parametrize(("kind", "links", "inertia", "m", "l", "delta"), CASES)
def test_base_force_reproduces_the_acceleration(kind, links, inertia, m, l, delta) -> None:  # noqa: E741
    """The force-driven model with the reported base force τ gives θ̈0 = u and the same link
    accelerations (a second solve, of the full M)."""
    system = System(kind, links, inertia)
    params = flat_parameters(system, m, l, delta, 9.81)
    dyn = dynamics(system)
    rng = np.random.default_rng(3)
    for _ in range(5):
        q, qd, u = rng.uniform(-3, 3, system.dof), rng.uniform(-3, 3, system.dof), float(rng.uniform(-5, 5))
        qdd, tau = dyn.acceleration_dynamics(q, qd, u, params)
        assert qdd[0] == u
        np.testing.assert_allclose(dyn.forward_dynamics(q, qd, tau, params), qdd, rtol=1e-10, atol=1e-10)


def test_base_mass_and_damping_do_not_matter() -> None:
    """The servo imposes θ̈0: m0 and δ0 change τ, not the links' motion, so not A or B."""
    first = ipgen.linearize(
        "classical", 2, [0.5, 0.2, 0.15], [0, 0.4, 0.3], [0.3, 0.01, 0.02], actuator=ACCEL
    )
    second = ipgen.linearize(
        "classical", 2, [50.0, 0.2, 0.15], [0, 0.4, 0.3], [9.0, 0.01, 0.02], actuator=ACCEL
    )
    for x, y in zip(first, second, strict=True):
        np.testing.assert_array_equal(x, y)


def test_power_balance_of_the_servo() -> None:
    """Simulate a rotary double pendulum whose arm follows a sine acceleration: the work of the
    base torque τ (∫ τ θ̇0 dt) equals the change of T + V plus the energy ∫ 2 D dt the dampers
    dissipated. T, V, D from the derivation's energies (sympy), not from the dynamics."""
    system = System("rotary", 2, "full")
    m, l, delta = [0.3, 0.2, 0.1], [0.25, 0.3, 0.2], [0.02, 0.01, 0.005]  # noqa: E741
    params = flat_parameters(system, m, l, delta, 9.81)
    dyn = dynamics(system)
    eq = derive(system)
    s = eq.symbols
    values = dict(zip((*s.parameters, *s.link_parameters), params, strict=True))
    energy = sp.lambdify((*s.q, *s.qd), (eq.kinetic_energy + eq.potential_energy).subs(values))
    dissipation = sp.lambdify(s.qd, eq.dissipation.subs(values))
    dof = system.dof

    def rhs(t: float, y: np.ndarray) -> np.ndarray:
        q, qd = y[:dof], y[dof : 2 * dof]
        qdd, tau = dyn.acceleration_dynamics(q, qd, 20.0 * math.sin(4.0 * t), params)
        return np.array([*qd, *qdd, tau * qd[0], 2.0 * dissipation(*qd)])

    y0 = np.array([0.0, 2.5, 3.0, 0.0, 0.0, 0.0, 0.0, 0.0])
    y1 = solve_ivp(rhs, (0.0, 3.0), y0, rtol=1e-11, atol=1e-12).y[:, -1]
    work = y1[-2]
    assert abs(work) > 1e-2
    change = energy(*y1[: 2 * dof]) - energy(*y0[: 2 * dof])
    assert work == pytest.approx(change + y1[-1], rel=1e-7, abs=1e-10)


def test_lqr_in_acceleration() -> None:
    """K in m/s² per unit of state stabilises the linear model, and the cart pendulum's gain
    agrees with the Riccati solution of the hand-derived textbook model."""
    from scipy.linalg import solve_continuous_are

    l1, g = 0.5, 9.81
    k = ipgen.lqr(
        "classical", 1, [1.0, 0.2], [0.0, l1], [0.0, 0.0], Q=[1, 10, 1, 1], R=0.1, g=g, actuator=ACCEL
    )
    a = np.array([[0, 0, 1, 0], [0, 0, 0, 1], [0, 0, 0, 0], [0, 3 * g / (2 * l1), 0, 0]])
    b = np.array([[0], [0], [1], [-3 / (2 * l1)]])
    p = solve_continuous_are(a, b, np.diag([1, 10, 1, 1]), np.array([[0.1]]))
    np.testing.assert_allclose(k, (b.T @ p) / 0.1, rtol=1e-8)
    assert np.all(np.linalg.eigvals(a - b @ k).real < 0)


def test_acceleration_has_no_folded_model() -> None:
    with pytest.raises(ActuatorError, match="not a folded direct model"):
        fold(Actuator("acceleration"), System("classical", 1), [1, 1], [0, 0], [0, 0])


@pytest.mark.parametrize(
    ("actuator", "message"),
    [
        ({"kind": "acceleration", "Rm": 8.4}, "applies to kind 'dc_motor' only"),
        ({"kind": "acceleration", "r": 0.01}, "applies to kind 'dc_motor' only"),
        ({"kind": "accel"}, "or 'acceleration'"),
    ],
)
def test_bad_acceleration_actuators(actuator: dict, message: str) -> None:
    with pytest.raises(ControlError, match=message) as info:
        ipgen.linearize("classical", 1, [1, 0.2], [0, 0.5], [0, 0], actuator=actuator)
    assert "\n" not in str(info.value)


_VALUES = st.one_of(
    st.none(),
    st.floats(allow_nan=True, allow_infinity=True),
    st.integers(min_value=-(10**30), max_value=10**30),
    st.text(max_size=5),
    st.lists(st.floats(), max_size=2),
)


@settings(max_examples=150, deadline=None)
@given(
    kind=st.sampled_from(["acceleration", "Acceleration", "acceleration ", "direct"]),
    constants=st.dictionaries(
        st.sampled_from(["Rm", "Kg", "Jm", "r", "a_max", "kind2"]), _VALUES, max_size=2
    ),
    u=st.floats(allow_nan=True, allow_infinity=True),
    cart=st.booleans(),
)
def test_any_acceleration_actuator_is_a_model_or_one_line_error(kind, constants, u, cart) -> None:
    """Bad input class: kind "acceleration" with stray constants of any type, and any u. Either
    a finite linear model or a ControlError of one line."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", EquilibriumWarning)  # u ≠ 0 moves the links: expected
            a, b = ipgen.linearize(
                "classical" if cart else "rotary", 1, [0.5, 0.2], [0.3, 0.5], [0.1, 0.01],
                u=u, actuator={"kind": kind, **constants},
            )  # fmt: skip
    except ControlError as exc:
        assert "\n" not in str(exc) and str(exc)
        return
    assert np.all(np.isfinite(a)) and np.all(np.isfinite(b))


CPP_PROGRAM = """
#include <cstdio>
#include "model.hpp"
int main() {
  using namespace ipgen::model;
  Params<double> p{{M}, {L}, {D}};
  p.g = 9.81;
  Vector<double> q, qd;
  q << Q;
  qd << QD;
  double tau = 0.0;
  const Vector<double> qdd = forward_dynamics_acceleration(q, qd, A, p, &tau);
  for (int i = 0; i < kDof; ++i) std::printf("%.17g ", qdd(i));
  std::printf("%.17g\\n", tau);
  const auto lin = linearize_acceleration(q, qd, A, p);
  for (int i = 0; i < 2 * kDof; ++i) {
    for (int j = 0; j < 2 * kDof; ++j) std::printf("%.17g ", lin.A(i, j));
    std::printf("%.17g\\n", lin.B(i));
  }
}
"""


@pytest.mark.parametrize(("kind", "links", "inertia", "m", "l", "delta"), CASES[::2])
def test_cpp_header_acceleration_functions(kind, links, inertia, m, l, delta, tmp_path) -> None:  # noqa: E741
    """The C++ header's forward_dynamics_acceleration (θ̈ and τ) and linearize_acceleration
    against the Python reduced solve and central differences of it, at a moving state."""
    import subprocess

    from cxx import cxx_command, require_toolchain

    from ipgen.codegen.header import HeaderRequest, render_header

    require_toolchain()
    system = System(kind, links, inertia)
    dof = system.dof
    rng = np.random.default_rng(11)
    q, qd, u = rng.uniform(-2, 2, dof), rng.uniform(-2, 2, dof), 1.7
    program = CPP_PROGRAM
    for key, value in {"M": m, "L": l, "D": delta}.items():
        program = program.replace("{" + key + "}", "{" + ", ".join(repr(v) for v in value) + "}")
    program = program.replace("QD;", ", ".join(repr(float(v)) for v in qd) + ";")
    program = program.replace("Q;", ", ".join(repr(float(v)) for v in q) + ";")
    program = program.replace(", A, p", f", {u!r}, p")
    (tmp_path / "model.hpp").write_text(render_header(derive(system), HeaderRequest("model", "test")))
    (tmp_path / "main.cpp").write_text(program)
    subprocess.run(
        cxx_command(f"-I{tmp_path}", str(tmp_path / "main.cpp"), "-o", str(tmp_path / "main")), check=True
    )
    lines = subprocess.run(
        [str(tmp_path / "main")], capture_output=True, text=True, check=True
    ).stdout.splitlines()
    first = np.array([float(v) for v in lines[0].split()])
    table = np.array([[float(v) for v in line.split()] for line in lines[1:]])
    params = flat_parameters(system, m, l, delta, 9.81)
    qdd, tau = dynamics(system).acceleration_dynamics(q, qd, u, params)
    np.testing.assert_allclose(first[:dof], qdd, rtol=1e-11, atol=1e-11)
    assert first[dof] == pytest.approx(tau, rel=1e-11, abs=1e-11)
    with pytest.warns(EquilibriumWarning):
        a, b = ipgen.linearize(kind, links, m, l, delta, inertia=inertia, q=q, qd=qd, u=u, actuator=ACCEL)
    np.testing.assert_allclose(table[:, :-1], a, rtol=1e-9, atol=1e-10)
    np.testing.assert_allclose(table[:, -1], b[:, 0], rtol=1e-9, atol=1e-10)


RIG = Path(__file__).resolve().parents[1] / "scenes" / "rigs" / "acin_double_accel.toml"


def test_scene_reads_the_acceleration_actuator() -> None:
    """[actuator] kind = "acceleration": the LQR gain is in m/s² per unit of state (the Python
    API's), the resolved config says so and carries the parameters unchanged."""
    from ipgen.experiment.config import resolved_config
    from ipgen.experiment.scene import load_scene

    scene = load_scene(RIG)
    assert scene.actuator.is_acceleration
    assert scene.controller is not None and scene.controller.unit == "base acceleration [m/s^2]"
    k = ipgen.lqr(
        "classical", 2, [0.2, 0.9363, 0.5505], [0, 0.419, 0.484], [0.1, 0.0042, 0.0003],
        Q=[10, 10, 10, 1, 1, 1], R=0.1, com=[0, 0.2687, 0.2256], J=[0, 0.0243, 0.0183], actuator=ACCEL,
    )  # fmt: skip
    np.testing.assert_allclose(scene.controller.gain, k.ravel(), rtol=1e-12)
    config = resolved_config(scene)
    assert "actuator = acceleration\n" in config and "actuator.gain" not in config
    assert "m = 0.2 0.9363 0.5505\n" in config


@pytest.mark.parametrize(
    ("table", "message"),
    [
        ('kind = "acceleration"\nRm = 2.0', "applies to kind 'dc_motor' only"),
        ('kind = "accel"', "actuator.kind"),
    ],
)
def test_scene_refuses_bad_acceleration_tables(tmp_path: Path, table: str, message: str) -> None:
    from ipgen.experiment.scene import load_scene

    text = RIG.read_text().replace(
        'kind = "acceleration"             # u is the cart\'s acceleration [m/s²]', table
    )
    scene = tmp_path / "bad.toml"
    scene.write_text(text)
    with pytest.raises(ipgen.Error, match=message) as caught:
        load_scene(scene)
    assert "\n" not in str(caught.value)


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        ("specialise = true", "acceleration with specialise = true or an FMU"),
        ('emit = ["fmu"]', "acceleration with specialise = true or an FMU"),
    ],
)
def test_scene_refuses_what_an_acceleration_base_cannot_do(tmp_path: Path, extra: str, message: str) -> None:
    from ipgen.experiment.scene import load_scene

    text = RIG.read_text().replace('name = "acin_double_accel"', f'name = "acin_double_accel"\n{extra}')
    scene = tmp_path / "bad.toml"
    scene.write_text(text)
    with pytest.raises(ipgen.Error, match=message) as caught:
        load_scene(scene)
    assert "\n" not in str(caught.value)


def test_ipgen_run_acceleration_scene(tmp_path: Path) -> None:
    """`ipgen run` on the acceleration-driven double: the CSV's u is the clipped −K x in m/s²,
    the trajectory is that of an independent Python simulation of the reduced dynamics, the
    summary's energy balance (input work of the cart force τ) closes, the summary's base force
    is the largest |τ| of the samples and its closed-loop poles are eig(A − B K)."""
    import os
    import re
    import subprocess
    import sys

    from cxx import require_toolchain

    require_toolchain()
    env = dict(os.environ)  # the run's shared simulator cache (tests/conftest.py)
    done = subprocess.run(
        [sys.executable, "-m", "ipgen", "run", str(RIG), "-o", str(tmp_path / "out"), "--no-plot"],
        capture_output=True,
        text=True,
        env=env,
    )
    assert done.returncode == 0, done.stderr
    run_ = read_run_csv(tmp_path / "out" / "acin_double_accel.csv", phase=False)
    names, data = run_.names, run_.data
    assert names[-1] == "u" and "input_work" in names
    x = data[:, 1:7]
    m, l, delta = [0.2, 0.9363, 0.5505], [0, 0.419, 0.484], [0.1, 0.0042, 0.0003]  # noqa: E741
    links = {"com": [0, 0.2687, 0.2256], "J": [0, 0.0243, 0.0183]}
    k = ipgen.lqr(
        "classical", 2, m, l, delta, Q=[10, 10, 10, 1, 1, 1], R=0.1, actuator=ACCEL, **links
    ).ravel()
    np.testing.assert_allclose(data[:, -1], np.clip(-(x @ k), -20, 20), rtol=1e-9, atol=1e-9)
    assert np.max(np.abs(data[:, -1])) > 10  # the run does move the cart hard
    assert np.max(np.abs(x[-1])) < 1e-3  # balanced at the end

    system = System("classical", 2)
    params = flat_parameters(system, m, l, delta, 9.81, links)
    dyn = dynamics(system)

    def rhs(_: float, y: np.ndarray) -> np.ndarray:
        a = float(np.clip(-(k @ y), -20, 20))
        return np.concatenate([y[3:], dyn.acceleration_dynamics(y[:3], y[3:], a, params)[0]])

    sol = solve_ivp(rhs, (0.0, 2.0), x[0], rtol=1e-11, atol=1e-12, dense_output=True)
    for row in data[data[:, 0] <= 2.0][::10]:
        np.testing.assert_allclose(row[1:7], sol.sol(row[0]), atol=1e-6)

    summary = (tmp_path / "out" / "acin_double_accel.txt").read_text()
    balance = float(re.search(r"balance error (\S+) J", summary).group(1))
    work = float(re.search(r"input work (\S+) J", summary).group(1))
    assert abs(work) > 1e-3 and abs(balance) < 1e-7 * max(1.0, abs(work))
    np.testing.assert_allclose(data[-1, names.index("input_work")], work, rtol=1e-8)
    forces = [dyn.acceleration_dynamics(r[1:4], r[4:7], r[-1], params)[1] for r in data]
    peak = float(re.search(r"force peaked at (\S+) N", summary).group(1))
    assert peak == pytest.approx(max(abs(f) for f in forces), rel=1e-5)
    a, b = ipgen.linearize("classical", 2, m, l, delta, actuator=ACCEL, **links)
    poles = np.sort_complex(np.linalg.eigvals(a - b @ k.reshape(1, -1)))
    text = re.search(r"closed-loop poles of the linear model \[1/s\]: ([^;]+);", summary).group(1)
    stated = np.sort_complex(np.array([complex(p.strip().replace("i", "j")) for p in text.split(",")]))
    np.testing.assert_allclose(stated, poles, rtol=1e-5)

    # The simulator's own checks of the resolved config's actuator lines: one line, exit 2.
    simulator = simulator_of(summary)
    config = (tmp_path / "out" / "acin_double_accel.cfg").read_text()
    for old, new, message in (
        (
            "actuator = acceleration",
            "actuator = acceleration\nactuator.gain = 2",
            "applies to actuator = dc_motor",
        ),
        ("actuator = acceleration", "actuator = accelerate", "(or `acceleration`)"),
    ):
        bad = tmp_path / "bad.cfg"
        bad.write_text(config.replace(old, new))
        result = subprocess.run(
            [str(simulator), str(bad), "--csv", str(tmp_path / "bad.csv")], capture_output=True, text=True
        )
        assert result.returncode == 2, result.stderr
        assert message in result.stderr and result.stderr.count("\n") == 1, result.stderr


SWING = """
[system]
type = "classical"
links = 1
name = "cart_accel_swing"
emit = ["cpp", "c"]

[parameters]
m = [1.096, 0.109]
l = [0, 0.5]
delta = [0.1, 0.0005]

[actuator]
kind = "acceleration"

[outputs]
energy = true

[simulation]
t_end = 6.0

[swingup]
method = "energy"
u_max = 10.0
period = 0.01
hold = 2.0
"""


def test_energy_swingup_with_an_acceleration_input(tmp_path: Path) -> None:
    """[swingup] energy with [actuator] acceleration: the law's a is u (|u| <= u_max m/s²). The
    simulator's run follows an independent sampled simulation (scipy, the Python reduced
    dynamics and the Python law `EnergySwingUp.control`), catches the link, and its energy
    balance (the cart force's work) closes; the C header returns a and compiles."""
    import os
    import re
    import subprocess
    import sys

    from c_models import c_command
    from cxx import require_toolchain

    from ipgen.control.casadi_model import plant
    from ipgen.control.energy import energy_swingup

    require_toolchain()
    scene = tmp_path / "cart_accel_swing.toml"
    scene.write_text(SWING)
    env = dict(os.environ)  # the run's shared simulator cache (tests/conftest.py)
    done = subprocess.run(
        [sys.executable, "-m", "ipgen", "run", str(scene), "-o", str(tmp_path / "out"), "--no-plot"],
        capture_output=True,
        text=True,
        env=env,
    )
    assert done.returncode == 0, done.stderr
    run_ = read_run_csv(tmp_path / "out" / "cart_accel_swing.csv", phase=True)
    names, data, phases = run_.names, run_.data, run_.phase
    assert "hold" in phases and np.max(np.abs(data[:, names.index("u")])) == pytest.approx(10.0)
    assert abs(math.remainder(data[-1, 2], 2 * math.pi)) < 0.05

    model = plant("classical", 1, [1.096, 0.109], [0, 0.5], [0.1, 0.0005])
    law = energy_swingup(model, u_max=10.0, period=0.01, acceleration=True)
    law.reset()
    dyn = dynamics(model.system)
    x = np.array([0.0, math.pi, 0.0, 0.0])
    caught = phases.index("hold")
    for k in range(caught + 50):  # through the catch and half a second of the hold
        u, _ = law.control(k, x)
        assert data[k, names.index("u")] == pytest.approx(u, abs=1e-5), k

        def rhs(_: float, y: np.ndarray, u: float = u) -> np.ndarray:
            return np.concatenate([y[2:], dyn.acceleration_dynamics(y[:2], y[2:], u, list(model.params))[0]])

        x = solve_ivp(rhs, (0.0, 0.01), x, method="DOP853", rtol=1e-11, atol=1e-12).y[:, -1]
        np.testing.assert_allclose(data[k + 1, 1:5], x, atol=1e-6)

    summary = (tmp_path / "out" / "cart_accel_swing.txt").read_text()
    work = float(re.search(r"input work (\S+) J", summary).group(1))
    balance = float(re.search(r"balance error (\S+) J", summary).group(1))
    assert work > 0.1 and abs(balance) < 1e-6 * work
    ipgen.write_header(tmp_path / "gen", scene=scene)
    text = (tmp_path / "gen" / "cart_accel_swing.h").read_text()
    assert "1, /* acceleration: the input is the base's acceleration */" in text  # ipgen_loop_energy_law
    (tmp_path / "main.c").write_text('#include "cart_accel_swing.h"\nint main(void) { return 0; }\n')
    subprocess.run(
        c_command(f"-I{tmp_path / 'gen'}", str(tmp_path / "main.c"), "-o", str(tmp_path / "a")), check=True
    )


_SCENE_VALUES = st.one_of(
    st.floats(allow_nan=False, allow_infinity=False, width=32),
    st.integers(-3, 3),
    st.text(alphabet="abcdeilnortu_ ", max_size=14),
    st.booleans(),
)


@settings(max_examples=120, deadline=None)
@given(
    kind=st.one_of(st.sampled_from(["acceleration", "direct", "dc_motor"]), st.text(max_size=8)),
    extra=st.dictionaries(
        st.sampled_from(["Rm", "kt", "km", "r", "Jm", "a_max", "gain"]), _SCENE_VALUES, max_size=2
    ),
    saturation=st.one_of(st.none(), st.floats(allow_nan=False, allow_infinity=False, width=32)),
)
def test_any_actuator_table_is_a_scene_or_one_line_error(tmp_path_factory, kind, extra, saturation) -> None:
    """Bad input class: an [actuator] table with any kind and stray keys of any type, and any
    [controller] saturation, on the acceleration preset. Either a scene (its actuator the one
    declared) or one `ipgen.Error` line; nothing else escapes."""
    import json

    from ipgen.experiment.scene import load_scene

    table = "[actuator]\n" + f"kind = {json.dumps(kind)}\n"
    table += "".join(f"{key} = {json.dumps(value)}\n" for key, value in extra.items())
    text = RIG.read_text().replace(
        '[actuator]\nkind = "acceleration"             # u is the cart\'s acceleration [m/s²]\n', table
    )
    if saturation is not None:
        text = text.replace("saturation = 20 ", f"saturation = {json.dumps(saturation)} ")
    path = tmp_path_factory.mktemp("scene") / "s.toml"
    path.write_text(text)
    try:
        scene = load_scene(path)
    except ipgen.Error as exc:
        assert str(exc) and "\n" not in str(exc)
        return
    assert scene.actuator.kind == kind
