"""The steady-state discrete Kalman filter of a pendulum about an equilibrium (`ipgen.kalman`).

The exact linearisation ẋ = A_c (x − x_eq) + B_c (u − u_eq) at the equilibrium (`VectorField`,
u_eq = 0) is discretised with the input held over each period T (zero-order hold):

    A = e^{A_c T},  B = ∫₀ᵀ e^{A_c s} ds B_c      (one matrix exponential of [[A_c, B_c], [0, 0]] T)

and C selects the measured coordinates. With process noise entering every state (G = I) of
covariance Qn and measurement noise Rn, P solves the discrete Riccati equation in
python-control's `dlqe` convention (scipy's `solve_discrete_are` on the dual pair):

    P = A P Aᵀ − A P Cᵀ (C P Cᵀ + Rn)⁻¹ C P Aᵀ + Qn,
    L = A P Cᵀ (C P Cᵀ + Rn)⁻¹          (predictor: x̂⁺ = A x̂ + B u + L (y − C x̂)),
    M = P Cᵀ (C P Cᵀ + Rn)⁻¹            (current form: x̂_{k|k} = x̂_{k|k−1} + M (y_k − C x̂_{k|k−1})),

so that L = A M. The estimators use the current form (`estimators.SteadyStateKalman`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from ipgen.common.limits import MAX_SAMPLE_GROWTH
from ipgen.estimation.checks import covariance_matrix, measured_indices, sampling_period
from ipgen.estimation.covariance import measurement_covariance, process_covariance
from ipgen.estimation.measurement import Sensors
from ipgen.estimation.pendulum import EstimationError, as_model, equilibrium_of

if TYPE_CHECKING:
    import numpy as np

    from ipgen.control.linear import VectorField

__all__ = ["Kalman", "default_covariances", "discretize", "kalman"]


@dataclass(frozen=True)
class Kalman:
    """A steady-state Kalman filter (module docstring): the discrete model (A, B, C) in
    deviations from (x_eq, u_eq), the gains L (predictor, `dlqe`'s) and M (current form), the
    predicted error covariance P and the covariances it was designed for."""

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    L: np.ndarray
    M: np.ndarray
    P: np.ndarray
    Qn: np.ndarray
    Rn: np.ndarray
    period: float
    measured: tuple[int, ...]
    equilibrium: np.ndarray  # x_eq, 2·dof, the model's coordinates
    u_eq: float = 0.0

    def poles(self) -> np.ndarray:
        """Eigenvalues of the estimation error's dynamics A − L C (inside the unit circle)."""
        import numpy as np

        return np.linalg.eigvals(self.A - self.L @ self.C)


def discretize(a: np.ndarray, b: np.ndarray, period: float) -> tuple[np.ndarray, np.ndarray]:
    """(A, B) of the zero-order-hold discretisation of (A_c, B_c) at `period` (expm)."""
    import numpy as np
    from scipy.linalg import expm

    n, m = a.shape[0], b.shape[1]
    block = np.zeros((n + m, n + m))
    block[:n, :n] = a
    block[:n, n:] = b
    flow = expm(block * period)
    return flow[:n, :n], flow[:n, n:]


def linear_model(model: VectorField, period: float, x_eq: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(A, B): the ZOH discretisation of the exact linearisation at (x_eq, u = 0)."""
    import numpy as np

    f, a_c, b_c = model.jacobians(x_eq, 0.0)
    scale = max(1.0, float(np.max(np.abs(a_c))))
    if float(np.max(np.abs(f))) > 1e-9 * scale:
        raise EstimationError("equilibrium: the state is not at rest with u = 0 (ẋ ≠ 0 there)")
    return discretize(a_c, b_c, period)


def kalman(
    pendulum: Any,
    period: float,
    Qn: Any,
    Rn: Any,
    *,
    measured: Sequence[int] | None = None,
    equilibrium: Sequence[float] | str | None = None,
) -> Kalman:
    """The steady-state Kalman filter of `pendulum` sampled every `period` seconds.

    Parameters
    ----------
    pendulum
        An `ipgen.Pendulum`, ipgen's keyword description (a mapping of `ipgen.linearize`'s keywords: type,
        links, m, l, delta, ... actuator, angles, zero, positive) or an `ipgen.control.linear.VectorField`.
    period
        The sampling period T [s]; the input is held over it (ZOH).
    Qn
        Process noise covariance (G = I: it enters every state): a scalar (·I), 2·dof diagonal
        entries or a 2·dof square matrix, symmetric positive semidefinite.
    Rn
        Measurement noise covariance: a scalar, one entry per measured coordinate or a matrix,
        symmetric positive definite.
    measured
        Indices of the measured coordinates (0 = base), increasing; default all angles.
    equilibrium
        "upright" (default), "hanging", or the dof angles in the pendulum's coordinates.

    Returns
    -------
    Kalman
        `.L`, `.P` in `control.dlqe`'s convention, `.M` the current-form gain, `.A`, `.B`, `.C`.

    Raises
    ------
    EstimationError
        Bad arguments, or no stabilising solution (e.g. an unmeasured coordinate that is not
        detectable, such as the arm angle of a rotary pendulum).

    Examples
    --------
    >>> import ipgen
    >>> p = ipgen.Pendulum("rotary", 1, m=[0.1, 0.024], l=[0.085, 0.129], delta=[0.0015, 0.0005])
    >>> estimator = ipgen.kalman(p, 0.002, 1e-3, 1e-6, measured=[0, 1])
    >>> estimator.A.shape, estimator.M.shape  # 4 states, the 2 encoder angles measured
    ((4, 4), (4, 2))
    """
    import numpy as np
    from scipy.linalg import solve_discrete_are

    model = as_model(pendulum)
    period_ = sampling_period(period)
    dof = model.dof
    indices = measured_indices(measured, dof)
    x_eq = equilibrium_of(model, equilibrium)
    with np.errstate(over="ignore", invalid="ignore"):  # e^(A T) may overflow: checked next
        a, b = linear_model(model, period_, x_eq)
    growth = float(np.max(np.abs(np.linalg.eigvals(a)))) if np.all(np.isfinite(a)) else float("inf")
    if not growth < MAX_SAMPLE_GROWTH:  # e^(λ T) far beyond what a Riccati solve takes: the period's fault
        raise EstimationError(
            f"period {period_:g} s: the model's fastest-growing mode grows by {growth:.3g} over one sample, "
            "too much to estimate between two measurements: sample faster (a period well below the time "
            "the upright takes to fall)"
        )
    c = np.zeros((len(indices), 2 * dof))
    for row, index in enumerate(indices):
        c[row, index] = 1.0
    qn = covariance_matrix("Qn", Qn, 2 * dof, "one per state θ0..θn, θ̇0..θ̇n", definite=False)
    rn = covariance_matrix("Rn", Rn, len(indices), "one per measured coordinate", definite=True)
    try:
        p = solve_discrete_are(a.T, c.T, qn, rn)
    except (np.linalg.LinAlgError, ValueError) as exc:
        fast = f"; or sample faster: a mode grows by {growth:.3g} over one sample" if growth > 100 else ""
        raise EstimationError(
            f"no steady-state Kalman filter ({exc}): measure more coordinates (measured = "
            f"{list(indices)}) or give every mode process noise{fast}"
        ) from None
    p = 0.5 * (p + p.T)
    innovation = c @ p @ c.T + rn
    m = np.linalg.solve(innovation, c @ p).T  # P Cᵀ S⁻¹ (S symmetric)
    gain = a @ m
    poles = np.linalg.eigvals(a - gain @ c)
    if not np.all(np.isfinite(gain)) or float(np.max(np.abs(poles))) >= 1.0:
        raise EstimationError(
            f"the Kalman filter is not stable (|poles| up to {np.max(np.abs(poles)):.6g}): "
            f"measure more coordinates (measured = {list(indices)})"
        )
    return Kalman(
        A=a, B=b, C=c, L=gain, M=m, P=p, Qn=qn, Rn=rn,
        period=period_, measured=indices, equilibrium=x_eq,
    )  # fmt: skip


def default_covariances(
    pendulum: Any,
    period: float,
    sensors: Sensors,
    *,
    input_noise: float = 0.0,
    u_scale: float | None = None,
    equilibrium: Sequence[float] | str | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """(Qn, Rn) of `covariance` for `pendulum` at `period` with `sensors` (u_scale: the input
    limit, None for 1 unit)."""
    model = as_model(pendulum)
    x_eq = equilibrium_of(model, equilibrium)
    _, b = linear_model(model, sampling_period(period), x_eq)
    qn = process_covariance(
        b, sampling_period(period), input_noise=input_noise, u_scale=1.0 if u_scale is None else u_scale
    )
    return qn, measurement_covariance(sensors)
