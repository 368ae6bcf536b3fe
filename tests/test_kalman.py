"""ipgen.kalman against python-control's dlqe and an independent Riccati iteration; the ZOH
discretisation against scipy.signal; the default covariances against hand-computed values;
the QUBE-Servo 2 preset balanced by LQR on the default Kalman filter (2048 counts)."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
from estimation_cases import CDIP, QUBE, QUBE_LQR, QUBE_SATURATION, RDIP, RSIP
from numeric import assert_close

import ipgen
from ipgen.estimation import EstimationError, Sensors, SteadyStateKalman, design
from ipgen.estimation.covariance import INPUT_FRACTION, Q_RATE, RN_FLOOR, measurement_covariance
from ipgen.estimation.loop import closed_loop
from ipgen.estimation.pendulum import as_model

control = pytest.importorskip("control")  # the [test] extra

CASES = [
    ("qube", QUBE, 1e-3, None, "upright"),
    ("qube-500Hz", QUBE, 2e-3, None, "upright"),
    ("rsip", RSIP, 1e-3, None, "upright"),
    ("rdip", RDIP, 2e-3, None, "upright"),
    ("rdip-hanging", RDIP, 5e-3, None, "hanging"),
    ("cdip-base-and-link2", CDIP, 1e-3, [0, 2], "upright"),
]


def _covariances(rng: np.random.Generator, size: int, measured: int) -> tuple[np.ndarray, np.ndarray]:
    """A random positive semidefinite Qn (rank deficient: G = I with correlated noise) and Rn > 0."""
    g = rng.normal(size=(size, size - 1)) * 1e-3
    r = rng.normal(size=(measured, measured)) * 1e-3
    return g @ g.T, r @ r.T + 1e-6 * np.eye(measured)


def _riccati_iteration(a, c, q, r, iterations=200000, tolerance=1e-15):
    """P ← A P Aᵀ − A P Cᵀ (C P Cᵀ + R)⁻¹ C P Aᵀ + Q from P = Q + I until it stops moving."""
    p = q + np.eye(a.shape[0])
    for _ in range(iterations):
        s = c @ p @ c.T + r
        nxt = a @ p @ a.T - a @ p @ c.T @ np.linalg.solve(s, c @ p @ a.T) + q
        nxt = 0.5 * (nxt + nxt.T)
        if np.max(np.abs(nxt - p)) <= tolerance * np.max(np.abs(nxt)):
            return nxt
        p = nxt
    raise AssertionError("the Riccati iteration did not converge")


@pytest.mark.parametrize(
    ("name", "pendulum", "period", "measured", "equilibrium"), CASES, ids=[c[0] for c in CASES]
)
def test_gains_match_dlqe_and_a_riccati_iteration(name, pendulum, period, measured, equilibrium) -> None:
    rng = np.random.default_rng(sum(map(ord, name)))
    dof = pendulum["links"] + 1
    count = dof if measured is None else len(measured)
    qn, rn = _covariances(rng, 2 * dof, count)
    k = ipgen.kalman(pendulum, period, qn, rn, measured=measured, equilibrium=equilibrium)
    gain, p, _ = control.dlqe(k.A, np.eye(2 * dof), k.C, qn, rn)
    assert_close(k.L, np.asarray(gain), 1e-7, f"{name}: L against control.dlqe")
    assert_close(k.P, np.asarray(p), 1e-7, f"{name}: P against control.dlqe")
    iterated = _riccati_iteration(k.A, k.C, qn, rn)
    assert_close(k.P, iterated, 1e-7, f"{name}: P against the Riccati iteration")
    s = k.C @ iterated @ k.C.T + rn
    assert_close(k.M, iterated @ k.C.T @ np.linalg.inv(s), 1e-7, f"{name}: M = P Cᵀ S⁻¹")
    assert_close(k.L, k.A @ k.M, 1e-12, f"{name}: L = A M")
    assert np.max(np.abs(k.poles())) < 1.0


@pytest.mark.parametrize(("name", "pendulum"), [("qube", QUBE), ("rdip", RDIP), ("cdip", CDIP)])
def test_zoh_model_is_scipy_cont2discrete_of_linearize(name, pendulum) -> None:
    from scipy.signal import cont2discrete

    period = 2e-3
    dof = pendulum["links"] + 1
    a_c, b_c = ipgen.linearize(**pendulum)
    a, b, *_ = cont2discrete((a_c, b_c, np.eye(2 * dof), np.zeros((2 * dof, 1))), period, method="zoh")
    k = ipgen.kalman(pendulum, period, np.eye(2 * dof) * 1e-6, 1e-6)
    assert_close(k.A, a, 1e-12, f"{name}: A")
    assert_close(k.B, b, 1e-12, f"{name}: B")
    assert k.C.shape == (dof, 2 * dof) and np.array_equal(k.C[:, :dof], np.eye(dof))


def test_vector_field_jacobians_are_linearize_and_finite_differences() -> None:
    """Away from equilibrium with a motor and the rig's coordinates (linearize with u ≠ 0 and a
    dc_motor used to take u as the torque: it is the voltage)."""
    model = as_model(QUBE)
    x, u = np.array([0.3, -0.4, 1.5, -2.0]), 1.7
    f, a, b = model.jacobians(x, u)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        a_lin, b_lin = ipgen.linearize(q=x[:2], qd=x[2:], u=u, **QUBE)
    assert_close(a, a_lin, 1e-12, "A against linearize")
    assert_close(b, b_lin, 1e-12, "B against linearize")
    h = 1e-6
    a_fd = np.column_stack([(model.f(x + h * e, u) - model.f(x - h * e, u)) / (2 * h) for e in np.eye(4)])
    b_fd = (model.f(x, u + h) - model.f(x, u - h)) / (2 * h)
    assert_close(a, a_fd, 1e-7, "A against central differences")
    assert_close(b[:, 0], b_fd, 1e-7, "B against central differences")
    # f in Quanser's α = −θ1 is ipgen's f mapped: the arm's acceleration is the same
    canonical = as_model({k: v for k, v in QUBE.items() if k != "positive"})
    flip = np.diag([1.0, -1.0, 1.0, -1.0])
    assert_close(f, flip @ canonical.f(flip @ x, u), 1e-14, "f in the rig's coordinates")


def test_default_covariances_by_hand() -> None:
    sensors = Sensors.of(3, [0, 1, 2], resolution=[1000, 2048, 0], noise=[0.0, 1e-3, 0.0], cart=True)
    rn = measurement_covariance(sensors)
    step_cart, step_angle = 1 / 1000, 2 * math.pi / 2048
    expected = np.diag([step_cart**2 / 12, 1e-6 + step_angle**2 / 12, RN_FLOOR])
    assert_close(rn, expected, 1e-15, "Rn")
    period = 1e-3
    d = design(QUBE, "kalman", period, Sensors.of(2, None, 2048), u_scale=QUBE_SATURATION, input_noise=0.2)
    b = d.gains.B
    expected_qn = b @ b.T * (0.2**2 + (INPUT_FRACTION * QUBE_SATURATION) ** 2)
    expected_qn[2:, 2:] += period * Q_RATE * np.eye(2)
    assert_close(d.Qn, expected_qn, 1e-14, "Qn")
    assert np.array_equal(d.Rn, measurement_covariance(Sensors.of(2, None, 2048)))


def test_quantisation_by_hand() -> None:
    sensors = Sensors.of(2, None, resolution=[4, 0])  # Δ = π/2 on the arm, the link exact
    got = [sensors.quantise(np.array([v, 0.123])) for v in (0.78, 0.79, -0.79, 2.0)]
    assert [g[0] for g in got] == [0.0, math.pi / 2, -math.pi / 2, math.pi / 2]
    assert all(g[1] == 0.123 for g in got)
    rng1, rng2 = np.random.default_rng(5), np.random.default_rng(5)
    noisy = Sensors.of(2, None, 0, noise=[0.0, 0.5])
    draws = rng2.standard_normal(2)
    assert np.array_equal(noisy.sample(np.array([0.1, 0.2]), rng1), np.array([0.1, 0.2 + 0.5 * draws[1]]))


@pytest.mark.parametrize("period", [1e-3, 2e-3])
def test_qube_balances_on_the_default_kalman_filter(period) -> None:
    """The default Qn (u_scale = the 10 V limit, q_rate = 1) and Rn (2048 counts) balance the
    preset's LQR from a 0.2 rad tilt, and the estimate's rate error is small."""
    sensors = Sensors.of(2, None, 2048)
    d = design(QUBE, "kalman", period, sensors, u_scale=QUBE_SATURATION)
    gain = ipgen.lqr(**QUBE, **QUBE_LQR)
    run = closed_loop(
        as_model(QUBE), gain, np.zeros(4), SteadyStateKalman(d.gains), sensors, period, 2.5,
        [0.0, 0.2, 0.0, 0.0], saturation=QUBE_SATURATION, seed=1,
    )  # fmt: skip
    assert run.balanced, f"fell or did not settle: final state {run.x[-1]}"
    rms = run.rms_error()
    assert rms[0] < 2e-3 and rms[1] < 2e-3, rms  # about the encoder's 3.07 mrad count / √12
    assert rms[2] < 0.2 and rms[3] < 0.2, rms  # rad/s
    # the backward difference makes the same loop chatter against the 10 V limit
    from ipgen.estimation import Difference

    rough = closed_loop(
        as_model(QUBE), gain, np.zeros(4), Difference(period, 2), sensors, period, 2.5,
        [0.0, 0.2, 0.0, 0.0], saturation=QUBE_SATURATION, seed=1,
    )  # fmt: skip
    assert rough.rms_error()[3] > 2 * rms[3]


def test_an_undetectable_choice_is_refused() -> None:
    """A rotary pendulum's arm angle is not detectable from the link angle alone."""
    with pytest.raises(EstimationError, match="measure more coordinates"):
        ipgen.kalman(RSIP, 1e-3, 1e-6, 1e-6, measured=[1])


def test_difference_and_filter_need_every_coordinate() -> None:
    with pytest.raises(EstimationError, match="needs every coordinate measured"):
        design(RSIP, "filter", 1e-3, Sensors.of(2, [1]))


def test_a_pendulum_and_its_keywords_give_the_same_filter() -> None:
    """ipgen.Pendulum.from_scene of the QUBE preset and the keyword description agree."""
    from pathlib import Path

    scene = Path(__file__).resolve().parent.parent / "scenes" / "rigs" / "qube_servo2.toml"
    pendulum = ipgen.Pendulum.from_scene(scene)
    a = ipgen.kalman(pendulum, 1e-3, 1e-6 * np.eye(4), 1e-6)
    b = ipgen.kalman(QUBE, 1e-3, 1e-6 * np.eye(4), 1e-6)
    for name in ("A", "B", "C", "L", "P", "M"):
        assert_close(getattr(a, name), getattr(b, name), 1e-12, name)


@pytest.mark.parametrize("told", [False, True])
@pytest.mark.parametrize("kind", ["kalman", "ekf"])
def test_a_carts_position_encoder_counts_metres_whatever_the_sensors_say(kind: str, told: bool) -> None:
    """The default Rn of a cart's position encoder: Δ = 1 / resolution [m], (Δ² / 12); of an
    angle's, 2π / resolution. `design` takes the cart from the model (Sensors.of's `cart` left at
    its default gave the cart a Δ 2π times too large: Rn 4π² ≈ 39.5 times)."""
    ip02 = ipgen.Pendulum.preset("ip02_sip")
    sensors = Sensors.of(2, resolution=[100000, 4096], cart=told)
    rn = design(ip02, kind, 1e-3, sensors, u_scale=10.0).Rn
    assert rn[0, 0] == pytest.approx((1 / 100000) ** 2 / 12, rel=1e-12)
    assert rn[1, 1] == pytest.approx((2 * math.pi / 4096) ** 2 / 12, rel=1e-12)
    arm = design(QUBE, kind, 1e-3, Sensors.of(2, resolution=[2048, 2048], cart=told), u_scale=10.0).Rn
    assert arm[0, 0] == pytest.approx((2 * math.pi / 2048) ** 2 / 12, rel=1e-12)
