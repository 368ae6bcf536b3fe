"""The LQR's stabilisability test does not depend on units (an audit found lqr refusing, as "no
gain can stabilise this equilibrium", a 10⁷ kg cart, a 10 nm link and δ0 = 10⁵ N s/m, where
scipy's Riccati gain stabilises them): a cart or arm pendulum of any scale is stabilisable (its
input reaches every mode), and a pair that is not stays refused after any change of units."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import ipgen
from ipgen.control import linear as control
from ipgen.control.linear import ControlError


@settings(max_examples=40, deadline=None)
@given(
    kind=st.sampled_from(["classical", "rotary"]),
    links=st.integers(1, 2),
    mass=st.floats(-3, 7),
    length=st.floats(-8, 3),
    damping=st.one_of(st.just(0.0), st.floats(-3, 5).map(lambda e: 10.0**e)),
)
def test_a_pendulum_of_any_scale_gets_a_stabilising_gain(
    kind: str, links: int, mass: float, length: float, damping: float
) -> None:
    m = [10.0**mass] * (links + 1)
    lengths = [10.0**length if kind == "rotary" else 0.0] + [10.0**length] * links
    p = ipgen.Pendulum(kind, links, m=m, l=lengths, delta=[damping] + [0.0] * links)
    a, b = ipgen.linearize(p)
    try:
        k = ipgen.lqr(p, Q=[1.0] * (2 * links + 2), R=1.0)
    except ControlError as error:
        # "Not stabilisable" only where a stiff model defeats double precision (both the rank test
        # and scipy's Riccati solve fail from about 1e5 between the fastest mode and the slowest
        # unstable one), and saying so; else only scipy's own failure (weights far from the
        # model's scale: R = 1 against B = 1e-10 on a 10⁴ kg arm) may stop it, named as that, or
        # a gain that then fails its closed-loop check.
        if "not stabilisable" in str(error):
            assert stiffness(a) > STIFF and "hide the input's reach" in str(error), (m, lengths, damping)
        else:  # or the computed gain's own check
            assert "no stabilising solution" in str(error) or "does not stabilise" in str(error), str(error)
        return
    assert np.max(np.linalg.eigvals(a - b @ k).real) < 0


STIFF = 1e5


def stiffness(a: np.ndarray) -> float:
    """The fastest mode's |s| over the slowest unstable one's (inf without an unstable mode)."""
    modes = np.linalg.eigvals(a)
    unstable = np.abs(modes[modes.real > 1e-9])
    return float(np.max(np.abs(modes)) / np.min(unstable)) if unstable.size else float("inf")


def test_a_truly_unstabilisable_pendulum_is_refused_as_such() -> None:
    """Link 2 balanced on its joint (com2 = 0): no input moves its angle, whatever the friction's
    slow mode makes of the modes' spread (a review found it called undecided)."""
    p = ipgen.Pendulum("classical", 2, m=[1, 0.5, 0.5], l=[0, 0.3, 0.3], com=[0, 0.15, 0.0],
                       J=[0, 0.004, 0.004], delta=[1e-3, 1e-3, 0])  # fmt: skip
    with pytest.raises(ControlError, match="not stabilisable"):
        ipgen.lqr(p, Q=[1.0] * 6, R=1.0)


@pytest.mark.parametrize(
    ("a", "b"),
    [
        (np.array([[0.0, 1, 0], [0, 0, 0], [0, 0, 1]]), np.array([[0.0], [1], [0]])),  # s = 1 unreached
        (np.diag([1.0, -1e6, -1e-3]), np.array([[0.0], [1], [1]])),  # and modes 1e9 apart
    ],
)
def test_an_unreachable_mode_is_refused_by_the_gain_in_any_units(a: np.ndarray, b: np.ndarray) -> None:
    t = np.array([[1.0, 2, 0], [0, 1, 3], [1, 0, 1]]) @ np.diag([1e-3, 1.0, 1e4])
    with pytest.raises(ControlError, match="not stabilisable"):
        control.continuous_lqr_gain(t @ a @ np.linalg.inv(t), t @ b, np.eye(3), np.eye(1))


@settings(max_examples=60, deadline=None)
@given(
    exponents=st.lists(st.floats(-8, 8), min_size=2, max_size=2),
    input_scale=st.floats(-8, 8),
    angle=st.floats(0.1, 1.4),
)
def test_an_unstabilisable_pair_stays_refused_in_any_units(
    exponents: list[float], input_scale: float, angle: float
) -> None:
    """Two copies of one unstable mode driven by one input column (never separable), seen in
    other units: states scaled and rotated, the input scaled."""
    rotation = np.array([[np.cos(angle), -np.sin(angle)], [np.sin(angle), np.cos(angle)]])
    t = np.diag([10.0**e for e in exponents]) @ rotation
    a = t @ np.diag([1.0, 1.0]) @ np.linalg.inv(t)
    b = t @ np.array([[1.0], [1.0]]) * 10.0**input_scale
    with pytest.raises(ControlError, match="not stabilisable"):
        control.check_stabilisable(a, b, np.eye(2))
    control.check_stabilisable(t @ np.diag([1.0, 2.0]) @ np.linalg.inv(t), b, np.eye(2))  # distinct: fine


@settings(max_examples=40, deadline=None)
@given(
    kind=st.sampled_from(["classical", "rotary"]),
    mass=st.floats(-3, 7),
    length=st.floats(-8, 3),
    damping=st.one_of(st.just(0.0), st.floats(-3, 5).map(lambda e: 10.0**e)),
    period=st.sampled_from([1e-3, 1e-2]),
)
def test_the_sampled_hold_gains_refuse_no_rig_the_continuous_lqr_holds(
    kind: str, mass: float, length: float, damping: float, period: float
) -> None:
    """The swing-up's hold (`discrete_zoh_lqr`) and the plan's hold (`tvlqr.discrete_lqr`) refused
    stiff rigs on the rank test alone, where `ipgen.lqr` gave a stabilising gain (a 1 g cart under
    a 0.1 mm link with δ0 = 10⁵ N s/m). Now: where the continuous LQR holds a rig and no mode
    grows more than 1e8-fold a sample, neither calls it unstabilisable: each gives a gain that
    holds the sampled model (scipy's `cont2discrete`, independent of theirs), or names what stops
    it (the period for a faster mode, the planner's RK4 steps for a stiff one, scipy's DARE)."""
    from scipy.signal import cont2discrete

    from ipgen.common.limits import MAX_SAMPLE_GROWTH
    from ipgen.control.casadi_model import Plant
    from ipgen.control.energy import discrete_zoh_lqr
    from ipgen.control.tvlqr import discrete_lqr

    m = [10.0**mass] * 2
    lengths = [10.0**length if kind == "rotary" else 0.0, 10.0**length]
    p = ipgen.Pendulum(kind, 1, m=m, l=lengths, delta=[damping, 0.0])
    a, b = ipgen.linearize(p)
    try:
        ipgen.lqr(p, Q=[1.0] * 4, R=1.0)
    except ControlError:
        return  # the continuous test's own subject
    growth = float(np.exp(np.max(np.linalg.eigvals(a).real) * period))
    exact = cont2discrete((a, b, np.eye(4), np.zeros((4, 1))), period, method="zoh")[:2]

    def on_rk4() -> tuple[np.ndarray, tuple[np.ndarray, np.ndarray]]:
        k, _, ad, bd = discrete_lqr(Plant(p), period, np.eye(4), np.eye(1), np.zeros(4))
        return k, (ad, bd)  # the planner's RK4 model, which it holds (a 10 µm link's differs from e^(A T))

    for design in (lambda: (discrete_zoh_lqr(Plant(p), period, np.eye(4), np.eye(1)), exact), on_rk4):
        try:
            k, (ad, bd) = design()
        except ControlError as error:
            text = str(error)
            assert "not stabilisable" not in text, text
            stiff = "too fast for the planner's RK4" in text  # a stable mode RK4 steps out of
            if growth > 10 * MAX_SAMPLE_GROWTH:
                assert stiff or ("sample faster" in text and f"period {period:g} s" in text), text
            else:  # or scipy's DARE itself: no solution, or one whose gain does not hold the model
                assert stiff or "has no solution" in text or "does not hold the sampled model" in text, text
            continue
        assert np.max(np.abs(np.linalg.eigvals(ad - bd @ k.reshape(1, -1)))) < 1, (kind, m, lengths, damping)
