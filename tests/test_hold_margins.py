"""bench/hold_margins.py's loop matrices against an independent construction.

The bench builds each sampled loop on the controller's period T: a delay as past inputs
(u_k applied from t_k + d), a lag as a state, drive noise as a sum over the period. The reference
here steps the loop every h = 1 ms instead: the state measured d earlier (a buffer of past states,
u_k applied at t_k: the same loop with the time origin moved by d), the lag and the noise held
per step, the controller acting every T / h steps. Both must give the same spectral radius and
the same stationary covariance.
"""

from __future__ import annotations

import functools
import sys
from pathlib import Path

import numpy as np
import pytest
import scipy.linalg

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))  # the repository: bench/

from bench.hold_margins import delayed_radius, lagged_radius, lqr_gain, mpc_model, spread_per_volt, zoh

H = 0.001  # s: the reference's step


@functools.lru_cache(maxsize=1)
def _plant() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    import ipgen

    pendulum = ipgen.Pendulum.preset("qube_servo2_mpc_swingup_m4f")
    a, b = ipgen.linearize(pendulum)
    gain = np.array([[-1.334, -22.71, -0.805, -1.853]])  # a stabilising hold (q = [1, 10, 0.1, 0.1], r = 0.3)
    return a, b, gain


def _fine_loop(
    a: np.ndarray, b: np.ndarray, gain: np.ndarray, period: float, delay: float = 0.0, tau: float = 0.0
) -> tuple[np.ndarray, np.ndarray]:
    """(monodromy over one period, noise covariance added over it per V²) of the loop stepped every H."""
    n = a.shape[0]
    if tau > 0:
        a = np.block([[a, b], [np.zeros((1, n)), -np.ones((1, 1)) / tau]])
        b = np.vstack([np.zeros((n, 1)), np.ones((1, 1)) / tau])
    s = a.shape[0]
    step, drive = zoh(a, b, H)
    past = round(delay / H)
    size = s + 1 + n * past  # plant, the held input, the measured states of the last `past` steps
    monodromy, noise = np.eye(size), np.zeros((size, size))
    kick = np.zeros((size, 1))
    kick[:s] = drive
    for j in range(round(period / H)):
        held = np.zeros((1, size))
        if j == 0:
            measured = slice(0, n) if past == 0 else slice(s + 1 + n * (past - 1), size)
            held[0, measured] = -gain[0]
        else:
            held[0, s] = 1.0
        m = np.zeros((size, size))
        m[:s, :s] = step
        m[:s] += drive @ held
        m[s] = held[0]
        if past:
            m[s + 1 : s + 1 + n, :n] = np.eye(n)
            for i in range(1, past):
                m[s + 1 + n * i : s + 1 + n * (i + 1), s + 1 + n * (i - 1) : s + 1 + n * i] = np.eye(n)
        monodromy = m @ monodromy
        noise = m @ noise @ m.T + kick @ kick.T
    return monodromy, noise


def _radius(m: np.ndarray) -> float:
    return max(abs(np.linalg.eigvals(m)))


@pytest.mark.parametrize(
    ("period", "delay"),
    [(0.01, d) for d in (0.0, 0.002, 0.006, 0.012, 0.02, 0.034)]
    + [(0.002, d) for d in (0.0, 0.001, 0.003, 0.011, 0.02)],
)
def test_a_delayed_loop_has_the_spectral_radius_of_the_loop_stepped_every_millisecond(
    period: float, delay: float
):
    a, b, gain = _plant()
    reference = _radius(_fine_loop(a, b, gain, period, delay=delay)[0])
    assert delayed_radius(a, b, gain, period, delay) == pytest.approx(reference, rel=1e-9)


@pytest.mark.parametrize("period", [0.01, 0.002])
@pytest.mark.parametrize("tau", [0.0, 0.0025, 0.02, 0.05])
def test_a_lagged_loop_has_the_spectral_radius_of_the_loop_stepped_every_millisecond(
    period: float, tau: float
):
    a, b, gain = _plant()
    reference = _radius(_fine_loop(a, b, gain, period, tau=tau)[0])
    assert lagged_radius(a, b, gain, period, tau) == pytest.approx(reference, rel=1e-9)


@pytest.mark.parametrize("period", [0.01, 0.005, 0.001])
def test_the_spread_under_drive_noise_is_the_fine_loops(period: float):
    a, b, gain = _plant()
    monodromy, noise = _fine_loop(a, b, gain, period)
    covariance = scipy.linalg.solve_discrete_lyapunov(monodromy, noise)
    expected = np.sqrt(covariance[0, 0]), np.sqrt(covariance[3, 3])  # the arm's angle, the link's rate
    assert spread_per_volt(a, b, gain, period) == pytest.approx(expected, rel=1e-9)


def test_delay_and_lag_both_end_the_hold_and_the_bench_sees_it():
    a, b, gain = _plant()
    assert delayed_radius(a, b, gain, 0.01, 0.0) < 1
    assert delayed_radius(a, b, gain, 0.01, 0.04) > 1
    assert lagged_radius(a, b, gain, 0.01, 0.05) > 1
    unstable = spread_per_volt(a, b, np.zeros_like(gain), 0.01)  # the open loop
    assert unstable == (float("inf"), float("inf"))


def test_the_held_step_is_scipys_zero_order_hold():
    """zoh, which both constructions above share, against scipy.signal.cont2discrete."""
    import scipy.signal

    a, b, _ = _plant()
    for t in (0.001, 0.0037, 0.01):
        phi, gamma, *_ = scipy.signal.cont2discrete((a, b, np.eye(4), np.zeros((4, 1))), t, method="zoh")
        mine = zoh(a, b, t)
        assert np.allclose(mine[0], phi, rtol=1e-10, atol=1e-12)
        assert np.allclose(mine[1], gamma, rtol=1e-10, atol=1e-14)


def test_the_converged_mpc_near_upright_is_the_lqr_the_bench_analyses():
    """The bench's premise: without an active bound the MPC's optimum is −K x, K the discrete LQR
    of its own model with its Q, R (its terminal weight is that LQR's Riccati matrix)."""
    import ipgen

    pendulum = ipgen.Pendulum.preset("qube_servo2_mpc_swingup_m4f")
    controller = ipgen.mpc(pendulum, u_max=10.0, period=0.01, Q=[1, 10, 0.1, 0.1], R=0.3)
    gain = lqr_gain(*mpc_model(pendulum, 0.01), (1.0, 10.0, 0.1, 0.1), 0.3)
    # Small states: the nonlinear terms grow with the state (4e-4 of u with the link at 0.02 rad,
    # 4e-8 at 2e-4).
    for x in ([1e-4, 2e-4, 0.0, 0.0], [-2e-4, 1e-4, 5e-4, -1e-3]):
        expected = float(-(gain @ np.array(x))[0])
        assert controller.solve(x) == pytest.approx(expected, rel=1e-6)
