"""The energy law's learnt target ([swingup] energy_step, ipgen_loop_energy_learn in
cpp/include/ipgen_loop.h): the C rules against tests/loop_reference.py's, the offsets they give
on swings whose passes and turns are counted here, and, in the simulator, the QUBE whose
pendulum is lighter than the law's model: whirled past the catch with a fixed target, caught
with a learnt one."""

from __future__ import annotations

import math
from pathlib import Path

import loop_reference as reference
import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

ROOT = Path(__file__).resolve().parents[1]
STEP = 0.001  # J
PERIOD = 0.002  # s between samples


def qube_law(step: float = STEP, **options: float):
    from ipgen.control.casadi_model import plant
    from ipgen.control.energy import energy_swingup

    qube = plant("rotary", 1, [0.095, 0.024], [0.085, 0.129], [0.0005, 0.0])
    return energy_swingup(qube, u_max=0.5, energy_step=step, **options)


def run(law, angles: np.ndarray, rates: np.ndarray) -> list[tuple[float, str, float]]:
    """(u, phase, learnt offset) of the C law at each sample (the arm at rest, centred)."""
    out = []
    for k, (angle, rate) in enumerate(zip(angles, rates, strict=True)):
        u, phase = law.control(k, np.array([0.0, angle, 0.0, rate]))
        out.append((u, phase, law._state.energy_offset))
    return out


def test_a_whirl_lowers_the_target_once_a_pass() -> None:
    """The link whirls at 8 rad/s (past catch_rate 3): each pass of an upright lowers E0 by one step."""
    t = np.arange(0.0, 2.0, PERIOD)
    angles, rates = math.pi + 8.0 * t, np.full_like(t, 8.0)
    law = qube_law()
    offsets = [offset for _, _, offset in run(law, angles, rates)]
    passes = sum(1 for k in range(1, 4) if angles[-1] >= 2 * math.pi * k - 0.3)  # uprights 2π, 4π, 6π reached
    assert passes == 3
    assert offsets[-1] == pytest.approx(-passes * STEP, abs=1e-15)
    assert len(set(offsets)) == passes + 1  # one step a pass, not one a sample within the window


def test_a_stalled_swing_raises_the_target_each_turn_after_the_first() -> None:
    """A swing of amplitude 2.5 rad about hanging turns 0.64 rad short of upright, every turn as
    high as the last: the first turn is remembered, each later one raises E0 by one step."""
    t = np.arange(0.0, 3.0, PERIOD)
    omega = 2 * math.pi
    angles, rates = math.pi + 2.5 * np.sin(omega * t), 2.5 * omega * np.cos(omega * t)
    turns = int(np.sum(np.sign(rates[1:]) * np.sign(rates[:-1]) < 0))
    assert turns == 6
    offsets = [offset for _, _, offset in run(qube_law(), angles, rates)]
    assert offsets[-1] == pytest.approx((turns - 1) * STEP, abs=1e-15)


def test_a_turn_that_flickers_counts_once() -> None:
    """The stalled swing above with its rate flickering about 0 at every turn (an estimate's noise
    below catch_rate, one sample read as exactly 0): still one raise a turn after the first."""
    t = np.arange(0.0, 3.0, PERIOD)
    omega = 2 * math.pi
    angles, rates = math.pi + 2.5 * np.sin(omega * t), 2.5 * omega * np.cos(omega * t)
    turns = np.flatnonzero(np.sign(rates[1:]) * np.sign(rates[:-1]) < 0) + 1
    for k in turns:  # the sign flips three more times about the turn, once through an exact 0
        rates[k - 3 : k + 3] = np.array([0.5, -0.5, 0.5, 0.0, -0.5, 0.5]) * np.sign(rates[k + 3])
    offsets = [offset for _, _, offset in run(qube_law(), angles, rates)]
    assert offsets[-1] == pytest.approx((len(turns) - 1) * STEP, abs=1e-15)
    rates = 2.5 * omega * np.cos(omega * t)
    rates[turns] = 0.0  # a quantised rate: the sample after each turn reads exactly 0
    offsets = [offset for _, _, offset in run(qube_law(), angles, rates)]
    assert offsets[-1] == pytest.approx((len(turns) - 1) * STEP, abs=1e-15)


def test_a_release_keeps_the_offset_and_forgets_the_last_turn() -> None:
    """Learnt −1 step on a whirl, caught, then released falling back: the offset stays, and the
    first swing sample (its rate opposite to the last one before the catch) is not a turn."""
    law = qube_law(release_angle=0.8)
    ref = reference.EnergyControl(law)
    states = [(math.pi + 2.0, 8.0), (2 * math.pi - 0.25, 8.0),  # enters the window fast: −1 step
              (2 * math.pi + 0.1, 0.5),  # caught
              (2 * math.pi + 0.9, -2.0), (2 * math.pi + 0.85, -9.0)]  # released, falling back
    for k, (angle, rate) in enumerate(states):
        x = np.array([0.0, angle, 0.0, rate])
        (u, phase), (u_ref, phase_ref) = law.control(k, x), ref.control(k, x)
        assert phase == phase_ref and abs(u - u_ref) <= 1e-12 * max(1.0, abs(u_ref)), k
    assert law._state.energy_offset == pytest.approx(-STEP, abs=1e-15) == ref.offset
    assert law._state.last_peak == 0.0 and law._state.swinging == 1  # afresh: 9 rad/s since the release


def test_a_growing_swing_and_a_fixed_target_learn_nothing() -> None:
    """A swing whose turns come nearer upright each time raises nothing; energy_step = 0 keeps E0."""
    t = np.arange(0.0, 3.0, PERIOD)
    omega = 2 * math.pi
    amplitude = 1.8 + 0.2 * t  # turns 1.24 .. 0.74 rad short of upright, nearer each time
    angles = math.pi + amplitude * np.sin(omega * t)
    rates = 0.2 * np.sin(omega * t) + amplitude * omega * np.cos(omega * t)
    assert {offset for _, _, offset in run(qube_law(), angles, rates)} == {0.0}
    whirl = np.arange(0.0, 1.0, PERIOD)
    assert {o for _, _, o in run(qube_law(step=0.0), math.pi + 8 * whirl, np.full_like(whirl, 8.0))} == {0.0}


@settings(max_examples=15, deadline=None)
@given(
    amplitude=st.floats(1.0, 3.0),
    growth=st.floats(-0.3, 0.3),
    omega=st.floats(3.0, 9.0),
    whirl=st.floats(4.0, 10.0),
    noise=st.floats(0.0, 0.5),
    seed=st.integers(0, 2**16),
)
def test_the_learnt_law_equals_the_reference(
    amplitude: float, growth: float, omega: float, whirl: float, noise: float, seed: int
) -> None:
    """Swings that grow or shrink, then a whirl, with noise on the rate (turns that flicker): the
    C law's u, phase and offset at every sample are the reference's."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, 1.2, 0.01)
    a = amplitude + growth * t
    angles = np.concatenate([math.pi + a * np.sin(omega * t), 3 * math.pi + whirl * t])
    swing = growth * np.sin(omega * t) + a * omega * np.cos(omega * t)
    rates = np.concatenate([swing, np.full_like(t, whirl)])
    rates = rates + noise * rng.normal(size=rates.size)
    law = qube_law(catch_angle=0.2, catch_rate=1.0)
    ref = reference.EnergyControl(law)
    for k, (u, phase, offset) in enumerate(run(law, angles, rates)):
        u_ref, phase_ref = ref.control(k, np.array([0.0, angles[k], 0.0, rates[k]]))
        assert phase == phase_ref, k
        assert offset == pytest.approx(ref.offset, abs=1e-15), k
        assert abs(u - u_ref) <= 1e-12 * max(1.0, abs(u_ref)), (k, u, u_ref)


def test_the_offset_stays_within_the_links_energy_range() -> None:
    """Steps larger than the link's whole energy range: a whirl stops at −m1 g l1, a stalled swing at
    +m1 g l1."""
    limit = 0.024 * 9.81 * 0.129
    t = np.arange(0.0, 2.0, PERIOD)
    whirl = [o for _, _, o in run(qube_law(step=1.0), math.pi + 8.0 * t, np.full_like(t, 8.0))]
    assert min(whirl) == pytest.approx(-limit, rel=1e-3)
    omega = 2 * math.pi
    swing = math.pi + 2.5 * np.sin(omega * t), 2.5 * omega * np.cos(omega * t)
    stalled = [o for _, _, o in run(qube_law(step=1.0), *swing)]
    assert max(stalled) == pytest.approx(limit, rel=1e-3)


@given(step=st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.floats(-10, 0)))
def test_a_bad_energy_step_is_one_line(step: float) -> None:
    from ipgen.control.trajectory import PlanError

    assume(not (math.isfinite(step) and step >= 0))
    with pytest.raises(PlanError, match="energy_step") as error:
        qube_law(step=step)
    assert "\n" not in str(error.value)


# ---- in the simulator ----------------------------------------------------------------------------


def test_a_lighter_pendulum_whirls_with_a_fixed_target_and_is_caught_with_a_learnt_one() -> None:
    """qube_servo2_mpc_swingup_m4f on a rig whose pendulum is 15 % lighter and whose motor is 15 %
    stronger (Rm) than the loop's model (a sweep's run: the energy law, EKF and MPC keep the
    nominal model). E0 fixed at 2 mJ above upright pumps the link past the catch's 6 rad/s every
    turn for the whole run; learnt, it is caught and held."""
    from cxx import require_toolchain

    from ipgen.sweeps import execute
    from ipgen.sweeps.success import Success

    require_toolchain()
    text = (ROOT / "scenes" / "rigs" / "qube_servo2_mpc_swingup_m4f.toml").read_text()
    # the preset's design without its learnt input gain (which corrects the motor by itself)
    text = "\n".join(line for line in text.splitlines() if not line.startswith("gain_spread"))
    assert "\nenergy_step = " in text
    fixed = "\n".join(line for line in text.splitlines() if not line.startswith("energy_step"))
    lighter = (("parameters.m", [0.095, 0.024 * 0.85]), ("actuator.Rm", 8.4 * 0.85))
    results = {}
    for name, scene in (("learnt", text), ("fixed", fixed)):
        task = execute.Task(0, "random", 0, 0, 0, lighter)
        results[name] = execute.run_one(execute.SceneSource(f"qube_{name}", scene), task, Success())
    assert results["learnt"].outcome == "pass", results["learnt"]
    assert results["fixed"].outcome == "fail", results["fixed"]
    assert results["fixed"].rate_error > 6.0 and results["fixed"].t_final == 10.0  # whirling to the end
