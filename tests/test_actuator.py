"""A DC motor on the base (`actuator=`, kind "dc_motor"): u is the motor voltage [V].

Checked against things ipgen does not compute: the manufacturer's formula applied by hand to
the published torque-input model (Quanser's "add actuator dynamics" step, done in the right
order), and the energy balance of a nonlinear simulation in which the motor's current is
computed from the manufacturer's formula (electrical power in minus copper loss = mechanical
power into the base).

Published numbers found wrong: the QUBE-Servo 2 linear model circulated with Quanser's
courseware scripts (e.g. the copy github.com/shaobow/CMU_MLC_24773 HW8/plant.m, based on Quanser's
QUBE-Servo scripts) adds the actuator as

    B = km * B / Rm;  A(3,3) = A(3,3) - km*km/Rm*B(3);  A(4,3) = A(4,3) - km*km/Rm*B(4)

i.e. the back-EMF uses B *after* it was already scaled by km/Rm: the θ̇ column's motor damping
comes out km/Rm = 0.042/8.4 = 1/200 of the true value (200× too small).
`test_the_circulated_back_emf_column_is_200_times_too_small` shows it.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
import sympy as sp
from hypothesis import example, given, settings
from hypothesis import strategies as st
from scipy.integrate import solve_ivp
from test_published_rig import DP, DR, JP, JR, LP, LR, MP, MR, G, published

import ipgen
from ipgen.control.linear import ControlError, dynamics
from ipgen.model.actuator import Actuator, fold
from ipgen.model.derivation import derive
from ipgen.model.pendulum import Pendulum
from ipgen.model.system import System


def flat_parameters(system, m, l, delta, g, links=None):  # noqa: E741
    """`Dynamics`' flat parameters of these values (the Pendulum's `flat`)."""
    return Pendulum(system.type, system.links, m, l, delta, g, system.inertia, **(links or {})).flat()


RM, KT, KM = 8.4, 0.042, 0.042  # qube2_rotpen_param.m
QUBE = Actuator("dc_motor", Rm=RM, kt=KT, km=KM)
S = np.diag([1.0, -1.0, 1.0, -1.0])  # Quanser's α is counter-clockwise


def qube(actuator: Actuator | dict | None = QUBE) -> tuple[np.ndarray, np.ndarray]:
    a, b = ipgen.linearize(
        "rotary", 1, m=[MR, MP], l=[LR, LP], delta=[DR, DP], g=G, J=[JR, JP], actuator=actuator
    )
    return S @ a @ S, S @ b


def by_hand() -> tuple[np.ndarray, np.ndarray]:
    """The manufacturer's τ = kt (V − km θ̇)/Rm applied to the published torque model."""
    a, b = published()
    a = a.copy()
    a[:, 2] -= (KT * KM / RM) * b[:, 0]  # back-EMF: the torque's θ̇ term, through the torque's B
    return a, b * KT / RM


def test_qube_servo_2_in_volts_matches_the_hand_derivation() -> None:
    a, b = qube()
    a_hand, b_hand = by_hand()
    assert np.allclose(a, a_hand, rtol=1e-12, atol=1e-12), (a, a_hand)
    assert np.allclose(b, b_hand, rtol=1e-12, atol=1e-12)
    # ... and the motor changed something: B is per volt, the arm is damped by km²/Rm more.
    a_torque, b_torque = qube(None)
    assert not np.allclose(b, b_torque)
    assert a[2, 2] < a_torque[2, 2] - 1e-3


def test_the_circulated_back_emf_column_is_200_times_too_small() -> None:
    a_pub, b_pub = published()
    b_circ = KM * b_pub / RM  # the scripts' order: B scaled first ...
    a_circ = a_pub.copy()
    a_circ[2, 2] -= KM * KM / RM * b_circ[2, 0]  # ... then used for the back-EMF
    a_circ[3, 2] -= KM * KM / RM * b_circ[3, 0]
    a, b = qube()
    motor_true = a[2:, 2] - a_pub[2:, 2]
    motor_circ = a_circ[2:, 2] - a_pub[2:, 2]
    assert np.allclose(motor_true / motor_circ, RM / KM, rtol=1e-12)  # 200
    assert pytest.approx(200.0) == RM / KM
    assert np.allclose(b, b_circ, rtol=1e-12)  # B itself is right in the circulated model


def test_geared_cart_motor_by_hand() -> None:
    """IP02-like cart: F = ηg Kg ηm kt (V − Kg km ẋ/r)/(Rm r), rotor mass ηg Kg² Jm/r² on the cart."""
    motor = {"kind": "dc_motor", "Rm": 2.6, "kt": 0.00767, "km": 0.00767, "Kg": 3.71, "eta_g": 0.9}
    motor |= {"eta_m": 0.69, "Jm": 3.9e-7, "r": 6.35e-3}
    m, l, delta = [0.57, 0.23], [0.0, 0.6413], [4.3, 0.0024]  # noqa: E741
    a, b = ipgen.linearize("classical", 1, m=m, l=l, delta=delta, actuator=motor)
    gain = 0.9 * 3.71 * 0.69 * 0.00767 / (2.6 * 6.35e-3)
    emf = gain * 3.71 * 0.00767 / 6.35e-3
    reflected = 0.9 * 3.71**2 * 3.9e-7 / 6.35e-3**2
    a_hand, b_force = ipgen.linearize("classical", 1, m=[m[0] + reflected, m[1]], l=l, delta=delta)
    a_hand[:, 2] -= emf * b_force[:, 0]
    assert np.allclose(a, a_hand, rtol=1e-12, atol=1e-12)
    assert np.allclose(b, gain * b_force, rtol=1e-12, atol=1e-12)


def test_direct_is_the_default() -> None:
    assert all(np.array_equal(x, y) for x, y in zip(qube(None), qube({"kind": "direct"}), strict=True))


def test_energy_balance_with_the_motor() -> None:
    """Simulate the QUBE arm-and-pendulum with the rotor's inertia, driven by a voltage:
    ∫ (V i − Rm i²) dt = ΔE + ∫ 2 D dt, i = (V − Kg km θ̇0)/Rm the motor's current and E the
    mechanical energy including the rotor's ½ Kg² Jm θ̇0² (ηg = ηm = 1, kt = km: the motor
    converts all of V i − Rm i² into shaft power)."""
    kg, jm = 3.0, 4.0e-6
    motor = Actuator("dc_motor", Rm=RM, kt=KT, km=KM, Kg=kg, Jm=jm)
    system = System("rotary", 1)
    m, delta, j, gain = fold(motor, system, [MR, MP], [DR, DP], [JR, JP])
    folded = flat_parameters(system, m, [LR, LP], delta, G, {"J": j})
    dyn = dynamics(system)
    eq = derive(system)
    s = eq.symbols
    mech = dict(
        zip(
            (*s.parameters, *s.link_parameters),
            flat_parameters(system, [MR, MP], [LR, LP], [DR, DP], G, {"J": [JR, JP]}),
            strict=True,
        )
    )
    energy = sp.lambdify((*s.q, *s.qd), (eq.kinetic_energy + eq.potential_energy).subs(mech))
    dissipation = sp.lambdify(s.qd, eq.dissipation.subs(mech))

    def voltage(t: float) -> float:
        return 3.0 * np.sin(5.0 * t)

    def rhs(t: float, y: np.ndarray) -> np.ndarray:
        q, qd = y[:2], y[2:4]
        v = voltage(t)
        current = (v - kg * KM * qd[0]) / RM
        qdd = dyn.forward_dynamics(q, qd, gain * v, folded)
        return np.array([*qd, *qdd, v * current - RM * current**2, 2.0 * dissipation(*qd)])

    def total(y: np.ndarray) -> float:
        return energy(*y[:4]) + 0.5 * kg**2 * jm * y[2] ** 2

    y0 = np.array([0.0, 3.0, 0.0, 0.0, 0.0, 0.0])
    sol = solve_ivp(rhs, (0.0, 2.0), y0, rtol=1e-11, atol=1e-12)
    y1 = sol.y[:, -1]
    electrical = y1[4]
    assert abs(electrical) > 1e-3  # the motor did work
    assert electrical == pytest.approx(total(y1) - total(y0) + y1[5], rel=1e-7, abs=1e-10)


@pytest.mark.parametrize(
    ("actuator", "message"),
    [
        ({"kind": "dc_motor", "Rm": 8.4, "kt": 0.042}, "needs km"),
        ({"kind": "dc_motor", "Rm": -1, "kt": 0.042, "km": 0.042}, "Rm = -1: must be > 0"),
        (
            {"kind": "dc_motor", "Rm": 8.4, "kt": 0.042, "km": 0.042, "r": 0.01},
            "r (pinion radius) is for a cart",
        ),
        ({"kind": "dc_motor", "Rm": 8.4, "kt": 0.042, "km": 0.042, "eta_g": 1.5}, "efficiency"),
        ({"kind": "direct", "Rm": 8.4}, "applies to kind 'dc_motor' only"),
        ({"kind": "servo"}, "expected 'direct' or 'dc_motor'"),
        (
            {"kind": "dc_motor", "Rm": 8.4, "kt": 0.042, "km": 0.042, "Lm": 1e-3},
            "unknown actuator constant 'Lm'",
        ),
    ],
)
def test_bad_actuators_are_one_line_errors(actuator: dict, message: str) -> None:
    with pytest.raises(ControlError, match=re.escape(message)) as caught:
        qube(actuator)
    assert "\n" not in str(caught.value)


def test_a_cart_motor_needs_a_pinion() -> None:
    with pytest.raises(ipgen.Error, match="needs r, the pinion radius"):
        ipgen.lqr("classical", 1, [1, 0.2], [0, 0.5], [0, 0], [1] * 4, 1, actuator=QUBE)


def test_lqr_in_volts() -> None:
    k = ipgen.lqr(
        "rotary", 1, [MR, MP], [LR, LP], [DR, DP], [1, 1, 1, 1], 1.0, g=G, J=[JR, JP], actuator=QUBE
    )
    a, b = ipgen.linearize(
        "rotary", 1, m=[MR, MP], l=[LR, LP], delta=[DR, DP], g=G, J=[JR, JP], actuator=QUBE
    )
    assert np.max(np.linalg.eigvals(a - b @ k).real) < 0
    k_torque = ipgen.lqr("rotary", 1, [MR, MP], [LR, LP], [DR, DP], [1, 1, 1, 1], 1.0, g=G, J=[JR, JP])
    assert not np.allclose(k, k_torque)


CPP_MOTOR = """
#include <cstdio>
#include "model.hpp"
namespace m = ipgen::model;
int main() {
  m::Params<double> p{{M}, {L}, {D}};
  p.J = {J};
  m::DcMotor motor{RM, KT, KM, KG, ETA_G, ETA_M, JM R};
  const m::Vector<double> q{0.3, -0.2}, qd{1.5, -2.0};
  const auto qdd = m::forward_dynamics<double>(q, qd, motor.gain() * 4.0, m::with_motor(p, motor));
  std::printf("%.17g %.17g\\n", qdd(0), qdd(1));
}
"""


@pytest.mark.parametrize("kind", ["rotary", "classical"])
def test_cpp_header_dc_motor(kind: str, tmp_path: Path) -> None:
    """The C++ header's DcMotor and with_motor, driven by 4 V, against θ̈ from the mechanics
    with the manufacturer's torque (or force) and the rotor's inertia added by hand."""
    import subprocess

    from cxx import cxx_command, require_toolchain
    from motor_by_hand import MOTOR, R, accelerations_by_hand, rig

    from ipgen.codegen.header import HeaderRequest, render_header

    require_toolchain()
    system = System(kind, 1)  # type: ignore[arg-type]
    m, l, delta, j = rig(kind)  # noqa: E741
    values = {"M": m, "L": l, "D": delta, "J": j}
    program = CPP_MOTOR
    for key, value in values.items():
        program = program.replace("{" + key + "}", "{" + ", ".join(repr(v) for v in value) + "}")
    constants = dict(zip(("RM", "KT", "KM", "KG", "ETA_G", "ETA_M", "JM"), MOTOR, strict=True))
    for key, value in constants.items():
        program = program.replace(key, repr(value), 1)
    program = program.replace(" R}", f", {R!r}}}" if kind == "classical" else "}")
    (tmp_path / "model.hpp").write_text(render_header(derive(system), HeaderRequest("model", "test")))
    (tmp_path / "main.cpp").write_text(program)
    subprocess.run(
        cxx_command(f"-I{tmp_path}", str(tmp_path / "main.cpp"), "-o", str(tmp_path / "main")), check=True
    )
    out = subprocess.run([str(tmp_path / "main")], capture_output=True, text=True, check=True).stdout
    qdd_cpp = np.array([float(x) for x in out.split()])

    qdd_hand = accelerations_by_hand(kind)
    assert np.allclose(qdd_cpp, qdd_hand, rtol=1e-12, atol=1e-12), (qdd_cpp, qdd_hand)


_NUMBERS = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True),
    st.integers(-5, 5),
    st.none(),
    st.text(max_size=3),
)


@settings(max_examples=200, deadline=None)
@given(
    kind=st.sampled_from(["direct", "dc_motor", "servo", ""]),
    constants=st.dictionaries(
        st.sampled_from(["Rm", "kt", "km", "Kg", "eta_g", "eta_m", "Jm", "r", "Lm", "kind2"]), _NUMBERS
    ),
    cart=st.booleans(),
)
@example(kind="dc_motor", constants={"Rm": 5e-324, "kt": 1, "km": 1}, cart=False)  # an infinite gain
def test_any_actuator_is_a_model_or_one_line_error(kind: str, constants: dict, cart: bool) -> None:
    """Bad input class: actuator constants of any type and value, through the Python API. Either
    a finite linear model or a ControlError of one line; nothing else escapes."""
    try:
        a, b = ipgen.linearize(
            "classical" if cart else "rotary", 1, [0.5, 0.2], [0.3, 0.5], [0.1, 0.01],
            actuator={"kind": kind, **constants},
        )  # fmt: skip
    except ControlError as exc:
        assert "\n" not in str(exc) and str(exc)
        return
    assert np.all(np.isfinite(a)) and np.all(np.isfinite(b))
