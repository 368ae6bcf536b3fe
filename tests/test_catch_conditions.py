"""The energy swing-up's catch conditions ([swingup] catch_deficit and catch_base,
ipgen_loop_energy_ready in cpp/include/ipgen_loop.h): the C test against a formula written here
and against tests/loop_reference.py's law, the catches they refuse, one-line errors for bad
values, and in the simulator a QUBE draw of the random sweep that the conditions turn from a
catch that runs the arm out of its travel into a swing-up."""

from __future__ import annotations

import ctypes
import math
from pathlib import Path

import loop_reference as reference
import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

ROOT = Path(__file__).resolve().parents[1]
MASSES, LENGTHS = [0.095, 0.024], [0.085, 0.129]


def qube_law(**options: float):
    from ipgen.control.casadi_model import plant
    from ipgen.control.energy import energy_swingup

    qube = plant("rotary", 1, MASSES, LENGTHS, [0.0005, 0.0])
    return energy_swingup(qube, u_max=0.5, catch_angle=0.5, catch_rate=6.0, **options)


def energy(angle: float, rate: float) -> float:
    """The law's E of the link [J] (0 upright at rest), from the masses and lengths above."""
    m1, l1 = MASSES[1], LENGTHS[1]
    return 0.5 * m1 * l1**2 / 3 * rate**2 + 0.5 * m1 * 9.81 * l1 * (math.cos(angle) - 1.0)


def ready(deficit: float, base: float, x: np.ndarray) -> bool:
    """ipgen_loop_energy_ready through ctypes, for the QUBE law with these conditions."""
    from ipgen.common.loop_runtime import EnergyLaw, address, library

    law = qube_law(catch_deficit=deficit, catch_base=base)
    m1, l1 = MASSES[1], LENGTHS[1]
    constants = EnergyLaw(
        law.gain_energy, law.gain_position, law.gain_velocity, law.accel_max, law.catch_angle,
        law.catch_rate, 0.0, m1 * l1**2 / 3, 0.5 * m1 * law.plant.g * l1, 0, 1.0, 0.0, deficit, base,
    )  # fmt: skip
    state = np.asarray(x, dtype=float)
    return bool(library().ipgen_loop_energy_ready(ctypes.byref(constants), 2, address(state)))


@settings(max_examples=60, deadline=None)
@given(
    arm=st.floats(-1.2, 1.2),
    off=st.floats(-0.7, 0.7),
    turns=st.integers(-2, 2),
    arm_rate=st.floats(-8, 8),
    rate=st.floats(-8, 8),
    deficit=st.sampled_from([0.0, 3e-4, 6e-4, 1.5e-3]),
    base=st.sampled_from([0.0, 0.3, 0.45, 0.9]),
)
def test_ready_is_the_window_the_energy_and_the_base(
    arm: float, off: float, turns: int, arm_rate: float, rate: float, deficit: float, base: float
) -> None:
    """Caught exactly when |θ1 − 2πk| ≤ 0.5, |θ̇1| ≤ 6, E ≥ −deficit (if set) and |θ0| ≤ base
    (if set), E and the window computed here."""
    angle = 2 * math.pi * turns + off
    in_window = abs(off) <= 0.5 and abs(rate) <= 6.0
    e = energy(angle, rate)
    assume(abs(e + deficit) > 1e-12 and abs(abs(arm) - base) > 1e-12)  # off a condition's edge
    expected = in_window and (deficit == 0 or e >= -deficit) and (base == 0 or abs(arm) <= base)
    assert ready(deficit, base, np.array([arm, angle, arm_rate, rate])) == expected


def test_a_link_too_slow_for_upright_is_left_to_the_swing() -> None:
    """The link 0.49 rad from upright at 3 rad/s (E = −1.19 mJ: it turns short of upright) is caught
    without a deficit bound and left to the swing with a 0.6 mJ one; at 5 rad/s (E = −0.12 mJ) it
    is caught with it."""
    slow, fast = np.array([0.0, 0.49, 0.0, -3.0]), np.array([0.0, 0.49, 0.0, -5.0])
    assert energy(0.49, -3.0) < -6e-4 < energy(0.49, -5.0)
    assert ready(0.0, 0.0, slow) and not ready(6e-4, 0.0, slow) and ready(6e-4, 0.0, fast)
    law = qube_law(catch_deficit=6e-4)
    assert law.control(0, slow)[1] == "swing"
    assert law.control(1, fast)[1] == "hold"


def test_an_arm_far_out_is_left_to_the_swing() -> None:
    """The link in the window with the arm at 0.6 rad: caught without a base bound, left to the
    swing with 0.45 rad, then caught once the arm is at 0.4 rad."""
    out, centred = np.array([0.6, 0.2, 0.0, 1.0]), np.array([0.4, 0.2, 0.0, 1.0])
    law = qube_law(catch_base=0.45)
    assert qube_law().control(0, out)[1] == "hold"
    assert law.control(0, out)[1] == "swing"
    assert law.control(1, centred)[1] == "hold"


@settings(max_examples=15, deadline=None)
@given(
    amplitude=st.floats(2.7, 3.1),
    omega=st.floats(3.0, 6.0),
    arm=st.floats(0.3, 0.9),
    deficit=st.sampled_from([0.0, 6e-4, 1.5e-3]),
    base=st.sampled_from([0.0, 0.45]),
)
def test_the_gated_law_equals_the_reference(
    amplitude: float, omega: float, arm: float, deficit: float, base: float
) -> None:
    """Swings about hanging that turn inside the window (caught, released past 0.8 rad, caught
    again), the arm swinging out and back: the C law's phase and u at every sample are the
    reference's (its catch test written apart)."""
    t = np.arange(0.0, 1.5, 0.01)
    angles = math.pi + amplitude * np.sin(omega * t)
    rates = amplitude * omega * np.cos(omega * t)
    arms, arm_rates = arm * np.cos(4 * t), -4 * arm * np.sin(4 * t)  # out and back, both sides
    law = qube_law(catch_deficit=deficit, catch_base=base, release_angle=0.8)
    ref = reference.EnergyControl(law)
    for k in range(t.size):
        x = np.array([arms[k], angles[k], arm_rates[k], rates[k]])
        (u, phase), (u_ref, phase_ref) = law.control(k, x), ref.control(k, x)
        assert phase == phase_ref, k
        assert abs(u - u_ref) <= 1e-12 * max(1.0, abs(u_ref)), (k, u, u_ref)


@given(
    name=st.sampled_from(["catch_deficit", "catch_base"]),
    value=st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.floats(-10, 0)),
)
def test_a_bad_catch_condition_is_one_line(name: str, value: float) -> None:
    from ipgen.control.trajectory import PlanError

    assume(not (math.isfinite(value) and value >= 0))
    with pytest.raises(PlanError, match=name) as error:
        qube_law(**{name: value})
    assert "\n" not in str(error.value)


# ---- in the simulator ----------------------------------------------------------------------------

# Run 76 of `ipgen sweep --preset qube_servo2_mpc_swingup_m4f --random 1000` (the default seed):
# the motor 10 % stronger than the loop's model (Rm), the pendulum 2 % heavier.
DRAW = (
    ("parameters.m", [0.09372615288982099, 0.024471066672504867]),
    ("parameters.delta", [5.128401062268274e-06, 1.1551953479656535e-06]),
    ("actuator.Rm", 7.554443312105122),
    ("initial.theta", [0.0009314290807987124, 3.106980592404167]),
    ("initial.dtheta", [0.0, 0.0]),
)


def test_the_conditions_turn_a_catch_that_leaves_the_travel_into_a_swing_up() -> None:
    """qube_servo2_mpc_swingup_m4f's design (without its learnt input gain) on that draw: without
    the conditions its first catch takes the link 0.5 rad from upright at 3 rad/s (E about −1.2 mJ,
    short of upright) with the arm moving at 4 rad/s, and the MPC runs the arm out of its travel;
    with E ≥ −0.8 mJ and |θ0| ≤ 0.45 rad that swing is left to the energy law and a later catch
    is held."""
    from cxx import require_toolchain

    from ipgen.sweeps import execute
    from ipgen.sweeps.success import Success

    require_toolchain()
    from preset_runs import preset_text

    text = preset_text()  # the design the draw was found on
    # the preset's design without its learnt input gain, which catches this draw by itself
    plain = "\n".join(line for line in text.splitlines() if not line.startswith("gain_spread"))
    assert "\nenergy_step = " in plain and "\ngain_spread = " not in plain
    conditions = "\ncatch_deficit = 0.0008\ncatch_base = 0.45"
    gated = plain.replace("\nenergy_step = ", conditions + "\nenergy_step = ", 1)
    results = {}
    for name, scene in (("gated", gated), ("plain", plain)):
        task = execute.Task(0, "random", 0, 0, 0, DRAW)
        results[name] = execute.run_one(execute.SceneSource(f"qube_{name}", scene), task, Success())
    plain_run = results["plain"]
    assert (plain_run.outcome, plain_run.reason) == ("fail", "left the travel"), plain_run
    assert results["gated"].outcome == "pass", results["gated"]
