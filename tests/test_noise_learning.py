"""The EKF that learns its measurement noise ([estimator] noise_memory, ipgen_loop_ekf's noise_*
fields in cpp/include/ipgen_loop.h): the C filter against tests/loop_reference.py's numpy one,
the variance it finds on a simulated QUBE whose encoders are noisier or quieter than its Rn says
(the truth integrated by scipy), the estimate it gives there against a filter with the same
wrong Rn fixed, one-line errors for bad values in the API and in a scene, and the numbers a scene
hands the simulator. The C header's loop with it against the simulator's is a variant of
tests/test_estimator_c.py."""

from __future__ import annotations

import functools
import math
from pathlib import Path

import loop_reference as reference
import numpy as np
import pytest
from estimation_cases import EKF_SAMPLES, QUBE, RSIP
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from test_gain_learning import STEP, _true_run

from ipgen.estimation import EstimationError
from ipgen.estimation.covariance import NOISE_CEILING, NOISE_MARGIN
from ipgen.estimation.estimators import ExtendedKalman

ROOT = Path(__file__).resolve().parents[1]


@settings(max_examples=20, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    samples=EKF_SAMPLES,
    case=st.sampled_from(["rsip", "qube"]),
    memory=st.sampled_from([0.004, 0.02, 1.0]),
    margin=st.sampled_from([1.0, 10.0]),
    floor=st.sampled_from([1e-12, 1e-5]),
    ceiling=st.sampled_from([1e-3, 10.0]),
    spread=st.sampled_from([0.0, 0.2]),
)
def test_the_noise_learning_ekf_equals_the_reference(
    samples, case, memory, margin, floor, ceiling, spread
) -> None:
    """x̂, P and the variances used of the C EKF (ipgen_loop_ekf_update) and the numpy one agree,
    with and without the gain state (both clamps reached: the test after it)."""
    pendulum = {"rsip": RSIP, "qube": QUBE}[case]
    ekf = ExtendedKalman(
        pendulum, 0.002, np.eye(4) * 1e-3, np.eye(2) * 1e-6, gain_spread=spread,
        noise_memory=memory, noise_margin=margin, noise_floor=floor, noise_ceiling=ceiling,
    )  # fmt: skip
    ref = reference.ExtendedKalman(ekf)
    for y, u in samples:
        x, x_ref = ekf.step(y, u), ref.step(y, u)
        assert np.allclose(x, x_ref, rtol=1e-9, atol=1e-10)
        assert np.allclose(ekf.covariance, ref.covariance, rtol=1e-8, atol=1e-12)
        assert ref.learnt is not None
        expected = np.clip(margin * ref.learnt, floor, ceiling) if ekf._k > 1 else np.diag(ekf.Rn)
        assert np.allclose(ekf.noise_used, expected, rtol=1e-9, atol=1e-15)


def test_the_reference_equality_covers_both_clamps() -> None:
    """The equality above on one fixed sequence that surely reaches both clamps of the variance
    used: readings jumping ±50 mrad (innovations far above the ceiling's 1e-3 rad²), then still
    ones (the learnt variance decays below the floor's 1e-5). The variances used (noise_used, the
    learnt means clipped) meet both bounds, and the C filter's x̂ and P, which the clipped
    variances shape, equal the reference's throughout."""
    ekf = ExtendedKalman(
        QUBE, 0.002, np.eye(4) * 1e-3, np.eye(2) * 1e-4,
        noise_memory=0.004, noise_margin=10.0, noise_floor=1e-5, noise_ceiling=1e-3,
    )  # fmt: skip
    ref = reference.ExtendedKalman(ekf)
    jumps = [(np.array([0.05, -0.05]) * (-1) ** k, 0.0) for k in range(20)]
    still = [(np.zeros(2), 0.0)] * 60
    reached = set()
    for y, u in jumps + still:
        assert np.allclose(ekf.step(y, u), ref.step(y, u), rtol=1e-9, atol=1e-10)
        assert np.allclose(ekf.covariance, ref.covariance, rtol=1e-8, atol=1e-12)
        expected = np.clip(10.0 * ref.learnt, 1e-5, 1e-3) if ekf._k > 1 else np.diag(ekf.Rn)
        assert np.allclose(ekf.noise_used, expected, rtol=1e-9, atol=1e-15)
        reached |= {"ceiling"} if np.any(ekf.noise_used == 1e-3) else set()
        reached |= {"floor"} if np.any(ekf.noise_used == 1e-5) else set()
    assert reached == {"floor", "ceiling"}


@functools.cache
def _truth() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The QUBE hanging, driven by two sines of volts (test_gain_learning's truth, 6 s at 2 ms):
    its states, 2048-count readings and inputs (computed once)."""
    return _true_run(1.0, 6.0, 0)


def _noisy_readings(sigma: float, seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The truth's readings plus Gaussian noise of `sigma` rad (seeded)."""
    states, readings, inputs = _truth()
    rng = np.random.default_rng(seed + 100)
    return states, readings + sigma * rng.standard_normal(readings.shape), inputs


def _run(ekf: ExtendedKalman, readings: np.ndarray, inputs: np.ndarray) -> np.ndarray:
    estimates, u_previous = [], 0.0
    for y, u in zip(readings, inputs, strict=True):
        estimates.append(ekf.step(y, u_previous))
        u_previous = float(u)
    return np.array(estimates)


@pytest.mark.parametrize(("sigma", "seed"), [(0.01, 0), (0.003, 1)])
def test_the_ekf_learns_the_encoders_noise(sigma: float, seed: int) -> None:
    """Encoders 3 to 10 times noisier than the quantization its Rn was designed for: with
    noise_memory = 0.5 s and margin 1 the variance the filter uses ends within 30 % of the
    readings' true σ² + Δ²/12, on both coordinates; and its rate estimates beat those of the
    same filter with Rn fixed (it trusts noisy readings less)."""
    states, readings, inputs = _noisy_readings(sigma, seed)
    quantization = STEP**2 / 12.0
    designed = dict(pendulum=QUBE, period=0.002, Qn=np.diag([0, 0, 1e-3, 1e-3]), Rn=np.eye(2) * quantization)
    fixed = ExtendedKalman(**designed, equilibrium="hanging")
    learning = ExtendedKalman(
        **designed, equilibrium="hanging", noise_memory=0.5, noise_margin=1.0,
        noise_floor=quantization, noise_ceiling=1.0,
    )  # fmt: skip
    rates_fixed = _run(fixed, readings, inputs)[:, 2:]
    rates_learnt = _run(learning, readings, inputs)[:, 2:]
    truth = sigma**2 + quantization
    assert np.all(np.abs(learning.noise_used / truth - 1.0) < 0.3), (learning.noise_used, truth)
    late = slice(len(states) // 2, None)  # after 3 s: the variance learnt
    error = lambda rates: np.sqrt(np.mean((rates[late] - states[late, 2:]) ** 2, axis=0))  # noqa: E731
    assert np.all(error(rates_learnt) < 0.8 * error(rates_fixed)), (error(rates_learnt), error(rates_fixed))


def test_quiet_encoders_take_the_filter_down_to_a_few_counts_variance() -> None:
    """Encoders as designed (quantization only) under an Rn 300 times too large: the variance
    used (the default margin, 10 times the learnt one) falls from Rn to within 5 times the
    quantization's Δ²/12."""
    _, readings, inputs = _truth()
    quantization = STEP**2 / 12.0
    learning = ExtendedKalman(
        QUBE, 0.002, np.diag([0, 0, 1e-3, 1e-3]), np.eye(2) * 300 * quantization, equilibrium="hanging",
        noise_memory=1.0, noise_floor=quantization,
    )  # fmt: skip
    _run(learning, readings, inputs)
    assert np.all(learning.noise_used <= 5 * quantization), learning.noise_used / quantization


BAD_NUMBERS = st.one_of(
    st.floats(max_value=-1e-12, allow_nan=False),
    st.just(math.nan),
    st.just(math.inf),
    st.booleans(),
    st.text(max_size=3),
)


@settings(max_examples=30, deadline=None)
@given(
    value=BAD_NUMBERS, key=st.sampled_from(["noise_memory", "noise_margin", "noise_floor", "noise_ceiling"])
)
def test_bad_noise_learning_values_are_refused(value, key: str) -> None:
    """Negative, non-finite, boolean or text values of each noise key: one EstimationError line."""
    with pytest.raises(EstimationError) as error:
        ExtendedKalman(QUBE, 0.002, np.eye(4) * 1e-3, np.eye(2) * 1e-6, **{"noise_memory": 0.5, key: value})
    assert "\n" not in str(error.value) and key in str(error.value)


def test_a_zero_margin_a_short_memory_a_full_rn_and_a_ceiling_under_the_floor_are_refused() -> None:
    """One EstimationError line each: margin 0, floor above ceiling, a memory under the period
    (the mean's weight above 1), an Rn with off-diagonal entries (only the diagonal is learnt)."""
    rn, full = np.eye(2) * 1e-6, np.array([[1e-6, 5e-7], [5e-7, 1e-6]])
    cases = (
        ({"noise_margin": 0.0}, rn, "noise_margin"),
        ({"noise_floor": [1e-4, 1e-4], "noise_ceiling": 1e-5}, rn, "noise_floor"),
        ({"noise_memory": 0.001}, rn, "shorter than the period"),
        ({}, full, "diagonal Rn"),
    )
    for extra, noise, message in cases:
        with pytest.raises(EstimationError, match=message) as error:
            ExtendedKalman(QUBE, 0.002, np.eye(4) * 1e-3, noise, **{"noise_memory": 0.5, **extra})
        assert "\n" not in str(error.value)


def test_a_scene_refuses_a_short_memory_and_a_full_rn(tmp_path) -> None:
    """In a scene: noise_memory under the loop's period, and with a non-diagonal measurement_noise:
    one line each, naming the key."""
    from ipgen.errors import SceneError
    from ipgen.experiment.scene import load_scene

    preset = (ROOT / "scenes" / "rigs" / "qube_servo2_mpc_swingup_m4f.toml").read_text()
    short = preset.replace("noise_memory = 1.0 ", "noise_memory = 0.0005 ", 1)
    full = preset.replace("measurement_noise = 3e-4 ", "measurement_noise = [[3e-4, 1e-5], [1e-5, 3e-4]] ", 1)
    for text, message in ((short, "shorter than the loop's period"), (full, "diagonal")):
        assert text != preset
        path = tmp_path / "scene.toml"
        path.write_text(text)
        with pytest.raises(SceneError, match=message) as error:
            load_scene(path)
        assert "\n" not in str(error.value) and "estimator.noise_memory" in str(error.value)


def test_without_a_memory_the_filter_is_the_fixed_one() -> None:
    """noise_memory = 0 (the default): the same estimates as before to the last bit, the floor
    and ceiling unused."""
    _, readings, inputs = _noisy_readings(0.003, 3)
    args = (QUBE, 0.002, np.diag([0, 0, 1e-3, 1e-3]), np.eye(2) * 1e-5)
    plain = _run(ExtendedKalman(*args, equilibrium="hanging"), readings[:500], inputs[:500])
    zero = ExtendedKalman(*args, equilibrium="hanging", noise_memory=0.0, noise_floor=1.0, noise_ceiling=2.0)
    assert np.array_equal(plain, _run(zero, readings[:500], inputs[:500]))


def test_a_scene_hands_the_simulator_the_floor_and_ceiling(tmp_path) -> None:
    """The QUBE m4f preset's [estimator] noise_memory: the .cfg holds the memory, the margin
    (NOISE_MARGIN), the floor (the encoders' quantization, Δ²/12 at 2048 counts) and the
    ceiling (NOISE_CEILING times the preset's Rn); without the key none of them."""
    from ipgen.experiment.config import resolved_config
    from ipgen.experiment.scene import load_scene

    preset = ROOT / "scenes" / "rigs" / "qube_servo2_mpc_swingup_m4f.toml"
    text = resolved_config(load_scene(preset))
    lines = dict(line.split(" = ", 1) for line in text.splitlines() if " = " in line and line[0] != "#")
    assert float(lines["estimator.noise_memory"]) == 1.0
    assert float(lines["estimator.noise_margin"]) == NOISE_MARGIN
    floor = [float(v) for v in lines["estimator.noise_floor"].split()]
    ceiling = [float(v) for v in lines["estimator.noise_ceiling"].split()]
    assert floor == pytest.approx([STEP**2 / 12.0] * 2, rel=1e-12)
    assert ceiling == pytest.approx([NOISE_CEILING * 3e-4] * 2, rel=1e-12)
    without = tmp_path / "without.toml"
    kept = [line for line in preset.read_text().splitlines() if not line.startswith("noise_memory = ")]
    without.write_text("\n".join(kept) + "\n")
    assert "noise_" not in resolved_config(load_scene(without))


def test_the_preset_holds_a_noisy_drive_with_the_key_and_not_without() -> None:
    """The m4f preset (its loop nominal, as a sweep keeps it) on a drive with 1.1 V of noise, the
    scorecard's draw (its drive noise criterion's run 464 and seed): with its learnt noise it
    swings up and holds; without the key (Rn fixed at 3e-4) the link leaves the success test's
    tolerance in the last second."""
    from preset_runs import with_and_without

    draw = (("actuator.noise", 1.1), ("sensors.seed", 3497196701))
    results = with_and_without("noise_memory", "drive_noise", draw, rn="preset")
    assert results["with"].outcome == "pass", results["with"].reason
    assert results["without"].outcome == "fail", results["without"].reason
