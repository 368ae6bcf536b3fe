"""The estimators' formulas against hand-computed samples and independent implementations:
the backward difference by hand, the derivative filter as scipy.signal.lfilter of Quanser's
discrete transfer function, the steady-state Kalman filter against dlqe's predictor form, the
EKF against a reference written here (Kane's equations from tests/independent_model.py,
central-difference Jacobians), and `replay` over a CSV against stepping by hand."""

from __future__ import annotations

import csv
import math

import numpy as np
import pytest
from estimation_cases import QUBE, RDIP, RSIP
from independent_model import reference
from numeric import assert_close

import ipgen
from ipgen.estimation import (
    DerivativeFilter,
    Difference,
    EstimationError,
    ExtendedKalman,
    SteadyStateKalman,
    replay,
)


def test_backward_difference_by_hand() -> None:
    est = Difference(0.01, 2)
    samples = [(0.0, 1.0), (0.02, 0.97), (0.05, 0.90)]
    out = [est.step(y) for y in samples]
    assert np.array_equal(out[0], [0.0, 1.0, 0.0, 0.0])
    assert_close(out[1], [0.02, 0.97, 2.0, -3.0], 1e-13, "k = 1")
    assert_close(out[2], [0.05, 0.90, 3.0, -7.0], 1e-13, "k = 2")
    est.reset()
    assert np.array_equal(est.step((0.3, 0.3))[2:], [0.0, 0.0])


def test_derivative_filter_is_quanser_discretisation() -> None:
    from scipy.signal import lfilter

    period, cutoff = 1e-3, 50.0
    est = DerivativeFilter(period, 2, cutoff)
    # ωc T / (1 − e^{−ωc T}) = 0.05 / 0.0487706 = 1.02521 (the spec's 1.0254 is a rounding slip)
    assert est.dc_gain == pytest.approx(1.02521, abs=1e-5)
    rng = np.random.default_rng(3)
    y = np.cumsum(rng.normal(size=(300, 2)) * 1e-3, axis=0)
    out = np.array([est.step(row) for row in y])
    pole = math.exp(-cutoff * period)
    # ωc (1 − z⁻¹) / (1 − a z⁻¹) on y − y_0 (the filter starts at rest: v_0 = 0)
    expected = lfilter([cutoff, -cutoff], [1.0, -pole], y - y[0], axis=0)
    assert_close(out[:, 2:], expected, 1e-12, "rates")
    assert np.array_equal(out[:, :2], y)
    # a ramp of slope 1: the rate settles at the discrete filter's dc gain
    ramp = DerivativeFilter(period, 2, cutoff)
    last = [ramp.step((k * period, 0.0)) for k in range(2000)][-1]
    assert last[2] == pytest.approx(ramp.dc_gain, rel=1e-9)


def _linear_data(k, steps, seed):
    """Inputs and noisy measurements of the discrete model (A, B, C) about x_eq."""
    rng = np.random.default_rng(seed)
    n = k.A.shape[0]
    x = np.zeros(n)
    x[1] = 0.05
    us = rng.normal(size=steps) * 0.5
    ys = []
    for j in range(steps):
        ys.append(k.C @ x + rng.normal(size=k.C.shape[0]) * 1e-3 + k.C @ k.equilibrium)
        x = k.A @ x + k.B[:, 0] * us[j]
    return us, np.array(ys)


@pytest.mark.parametrize(("name", "pendulum", "measured"), [("qube", QUBE, None), ("rdip", RDIP, [0, 2])])
def test_steady_state_kalman_is_dlqe_predictor_form(name, pendulum, measured) -> None:
    """x̂_{k|k} of the current form, propagated (A x̂ + B u), is the predictor form's
    x̂_{k+1|k} = A x̂ + B u + L (y − C x̂) with dlqe's L: the two forms are one filter."""
    dof = pendulum["links"] + 1
    k = ipgen.kalman(pendulum, 2e-3, 1e-4 * np.eye(2 * dof), 1e-6, measured=measured)
    us, ys = _linear_data(k, 400, 11)
    est = SteadyStateKalman(k)
    current = np.array([est.step(ys[0])] + [est.step(ys[j], us[j - 1]) for j in range(1, len(ys))])
    predictor = np.zeros(2 * dof)
    predictor[list(k.measured)] = ys[0]  # x̂_{0|−1}
    x_eq = k.equilibrium
    for j in range(len(ys)):
        dev = predictor - x_eq
        filtered = dev + k.M @ (ys[j] - k.C @ predictor)
        assert_close(current[j] - x_eq, filtered, 1e-9, f"{name}: x̂_{{{j}|{j}}}")
        predictor = x_eq + k.A @ dev + k.B[:, 0] * us[j] + k.L @ (ys[j] - k.C @ predictor)
        assert_close(
            predictor - x_eq,
            k.A @ (current[j] - x_eq) + k.B[:, 0] * us[j],
            1e-9,
            f"{name}: x̂_{{{j + 1}|{j}}}",
        )


class ReferenceEKF:
    """The EKF of the shared spec written from scratch: Kane's f, central-difference A_c."""

    def __init__(self, pendulum, period, qn, rn, measured):
        links = pendulum["links"]
        self.ref = reference(pendulum["type"], links, "pivot")
        self.params = (tuple(pendulum["m"]), tuple(pendulum["l"]), tuple(pendulum["delta"]), 9.81)
        self.dof, self.t, self.qn, self.rn = links + 1, period, qn, rn
        self.c = np.eye(2 * self.dof)[measured]
        self.measured = measured

    def f(self, x, u):
        q, qd = tuple(x[: self.dof]), tuple(x[self.dof :])
        return np.concatenate([x[self.dof :], self.ref.accelerations(q, qd, u, self.params)])

    def run(self, ys, us):
        n, h = 2 * self.dof, 1e-6
        x = np.zeros(n)
        x[self.measured] = ys[0]
        p = np.eye(n)
        p[self.measured, self.measured] = np.diag(self.rn)
        out = []
        for j, y in enumerate(ys):
            if j > 0:
                u = us[j - 1]
                a = np.column_stack(
                    [(self.f(x + h * e, u) - self.f(x - h * e, u)) / (2 * h) for e in np.eye(n)]
                )
                t = self.t
                k1 = self.f(x, u)
                k2 = self.f(x + t / 2 * k1, u)
                k3 = self.f(x + t / 2 * k2, u)
                k4 = self.f(x + t * k3, u)
                x = x + t * (k1 + 2 * k2 + 2 * k3 + k4) / 6
                big_f = np.eye(n) + t * a + (t * a) @ (t * a) / 2
                p = big_f @ p @ big_f.T + self.qn
            s = self.c @ p @ self.c.T + self.rn
            gain = p @ self.c.T @ np.linalg.inv(s)
            x = x + gain @ (y - self.c @ x)
            i_kc = np.eye(n) - gain @ self.c
            p = i_kc @ p @ i_kc.T + gain @ self.rn @ gain.T
            out.append(x.copy())
        return np.array(out), p


@pytest.mark.parametrize(
    ("name", "pendulum", "measured"), [("rsip", RSIP, [0, 1]), ("rdip", RDIP, [0, 1, 2])]
)
def test_ekf_against_an_independent_reference(name, pendulum, measured) -> None:
    """A swinging pendulum (far from any linearisation) measured with noise: both EKFs agree
    to the central differences' accuracy."""
    dof = pendulum["links"] + 1
    period = 5e-3
    rng = np.random.default_rng(7)
    ekf_ref = ReferenceEKF(pendulum, period, np.eye(2 * dof) * 1e-5, np.eye(len(measured)) * 1e-6, measured)
    x = np.zeros(2 * dof)
    x[1:dof] = 0.8  # tilted 0.8 rad: falls and swings
    us = 0.3 * np.sin(np.arange(120) * 0.1)
    ys = []
    for u in us:
        ys.append(x[measured] + rng.normal(size=len(measured)) * 1e-3)
        for _ in range(10):  # the "truth": 10 RK4 substeps of the reference model
            h = period / 10
            k1 = ekf_ref.f(x, u)
            k2 = ekf_ref.f(x + h / 2 * k1, u)
            k3 = ekf_ref.f(x + h / 2 * k2, u)
            k4 = ekf_ref.f(x + h * k3, u)
            x = x + h * (k1 + 2 * k2 + 2 * k3 + k4) / 6
    expected, p_expected = ekf_ref.run(np.array(ys), us)
    ekf = ExtendedKalman(pendulum, period, ekf_ref.qn, ekf_ref.rn, measured=measured)
    got = np.array([ekf.step(ys[0])] + [ekf.step(ys[j], us[j - 1]) for j in range(1, len(ys))])
    assert_close(got, expected, 1e-7, f"{name}: EKF estimates")
    assert_close(ekf.covariance, p_expected, 1e-6, f"{name}: EKF covariance")
    # and it tracks the truth's angles to within the noise
    assert np.max(np.abs(got[-1][measured] - ys[-1])) < 1e-2


def test_replay_over_a_csv_is_stepping_by_hand(tmp_path) -> None:
    period = 1e-3
    k = ipgen.kalman(QUBE, period, 1e-4 * np.eye(4), 1e-6)
    us, ys = _linear_data(k, 50, 2)
    path = tmp_path / "run.csv"
    with open(path, "w", newline="") as handle:
        writer = csv.writer(handle)
        writer.writerow(["t", "theta0", "theta1", "u", "y_theta0", "y_theta1"])
        for j in range(len(ys)):  # two rows per sample: the replay takes those at k·T
            writer.writerow(
                [repr(j * period), 0, 0, repr(float(us[j])), repr(float(ys[j][0])), repr(float(ys[j][1]))]
            )
            writer.writerow([repr((j + 0.5) * period), 0, 0, repr(float(us[j])), 9, 9])
    got = replay(SteadyStateKalman(k), path)
    by_hand = SteadyStateKalman(k)
    expected = [by_hand.step(ys[0])] + [by_hand.step(ys[j], us[j - 1]) for j in range(1, len(ys))]
    assert np.array_equal(got.estimate, np.array(expected))
    assert np.array_equal(got.y, ys)
    with pytest.raises(EstimationError, match=r"no column .nope."):
        replay(SteadyStateKalman(k), path, measured=["y_theta0", "nope"])


@pytest.mark.parametrize("bad", ["y", "u"])
@pytest.mark.parametrize("value", [math.nan, math.inf, -math.inf, "x"])
def test_a_reading_that_is_not_a_number_is_refused_and_the_filter_goes_on(bad: str, value: object) -> None:
    """A non-finite (or non-numeric) measurement or input: an EstimationError, and the filter stays
    at the sample before, as docs/estimation.md says (the EKF took the NaN and failed on every
    sample after; the steady-state filter returned NaN without a word). Its next good sample equals
    that of a twin that never saw the bad one."""
    rng = np.random.default_rng(3)
    samples = [(rng.normal(0, 0.05, 2), float(rng.normal())) for _ in range(6)]
    for make in (
        lambda: ExtendedKalman(QUBE, 1e-3, 1e-6 * np.eye(4), 1e-6),
        lambda: SteadyStateKalman(ipgen.kalman(QUBE, 1e-3, 1e-6 * np.eye(4), 1e-6)),
    ):
        filtered, twin = make(), make()
        for k, (y, u) in enumerate(samples):
            if k == 3:
                wrong = ([value, y[1]], u) if bad == "y" else (y, value)
                with pytest.raises(EstimationError, match=r"not finite|expected"):
                    filtered.step(*wrong)
            assert np.array_equal(filtered.step(y, u), twin.step(y, u))
