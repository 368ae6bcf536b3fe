"""The estimators a sampled loop runs, one `step` per sample (the shared spec of issue 32).

Every estimator takes, at sample k, the measured values y_k (the measured coordinates, in the
order of `measured`) and the input ū_{k−1} the model saw over the last period [t_{k−1}, t_k)
(the saturated command applied on it; ignored at the first sample and by the estimators without
a model), and returns x̂_k = x̂_{k|k}, the state estimate (2·dof: θ0..θn, θ̇0..θ̇n) the
controller uses at t_k. `reset()` starts again.

- `Difference`: θ̂ = y_k, θ̇̂_k = (y_k − y_{k−1}) / T, θ̇̂_0 = 0 (all coordinates measured).
- `DerivativeFilter`: θ̂ = y_k, v_k = a v_{k−1} + ωc (y_k − y_{k−1}), a = e^{−ωc T}, v_0 = 0:
  Quanser's ωc (z − 1) / (z − e^{−ωc T}), whose gain at low frequency is ωc T / (1 − e^{−ωc T})
  (1.0252 at 50 rad/s and 1 ms).
- `SteadyStateKalman`: the current form of `kalman.Kalman` in deviations from (x_eq, u_eq):
  predict x̂_{k|k−1} = A x̂_{k−1|k−1} + B ū_{k−1}, update x̂_{k|k} = x̂_{k|k−1} + M (y_k − C x̂_{k|k−1}).
- `ExtendedKalman`: predict with one RK4 step of length T of the nonlinear ẋ = f(x, ū_{k−1}),
  F = I + T A_c + (T A_c)²/2 with A_c = ∂f/∂x at (x̂_{k−1|k−1}, ū_{k−1}) (`VectorField`: the exact
  Jacobian of ipgen's derivation), P⁻ = F P Fᵀ + Qn; update with K = P⁻Cᵀ(C P⁻Cᵀ + Rn)⁻¹ and the
  Joseph form P = (I − KC) P⁻ (I − KC)ᵀ + K Rn Kᵀ.

The Kalman filters start at x̂_{0|−1}: measured coordinates y_0, the others at x_eq, rates 0;
the EKF with P_{0|−1} = diag(Rn's diagonal for the measured coordinates, 1 rad² (m²) for the
others, 1 (unit/s)² for the rates).
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

from ipgen.estimation.checks import covariance_matrix, measured_indices, sampling_period
from ipgen.estimation.kalman import Kalman
from ipgen.estimation.measurement import cutoff_problem
from ipgen.estimation.pendulum import EstimationError, as_model, equilibrium_of

if TYPE_CHECKING:
    import numpy as np

__all__ = ["DerivativeFilter", "Difference", "Estimator", "ExtendedKalman", "SteadyStateKalman"]


class Estimator(ABC):
    """An estimator of the state from the sampled measurements (module docstring)."""

    period: float
    dof: int
    measured: tuple[int, ...]

    @abstractmethod
    def reset(self) -> None:
        """Forget every sample: the next `step` is sample 0."""

    @abstractmethod
    def step(self, y: Sequence[float] | np.ndarray, u: float = 0.0) -> np.ndarray:
        """x̂_{k|k} from y_k and the input ū_{k−1} held over the last period."""

    def _measurement(self, y: Any) -> np.ndarray:
        import numpy as np

        values = np.asarray(y, dtype=float).reshape(-1)
        if values.size != len(self.measured):
            raise EstimationError(
                f"y has {values.size} entries, expected {len(self.measured)} "
                f"(measured = {list(self.measured)})"
            )
        return values


class Difference(Estimator):
    """The backward difference of the measured angles (every coordinate measured)."""

    def __init__(self, period: float, dof: int) -> None:
        self.period = sampling_period(period)
        self.dof = int(dof)
        self.measured = tuple(range(self.dof))
        self.reset()

    def reset(self) -> None:
        self._last: np.ndarray | None = None

    def step(self, y: Sequence[float] | np.ndarray, u: float = 0.0) -> np.ndarray:
        import numpy as np

        values = self._measurement(y)
        rates = np.zeros(self.dof) if self._last is None else (values - self._last) / self.period
        self._last = values.copy()
        return np.concatenate([values, rates])


class DerivativeFilter(Estimator):
    """The first-order derivative filter ωc s / (s + ωc), discretised as Quanser's rigs do."""

    def __init__(self, period: float, dof: int, cutoff: float = 50.0) -> None:
        self.period = sampling_period(period)
        self.dof = int(dof)
        self.measured = tuple(range(self.dof))
        cutoff_ = float(cutoff)
        if not (math.isfinite(cutoff_) and cutoff_ > 0):
            raise EstimationError(f"cutoff = {cutoff!r}: expected a frequency > 0 rad/s (e.g. 50)")
        problem = cutoff_problem(cutoff_, self.period)
        if problem:
            raise EstimationError(f"cutoff = {cutoff!r}: {problem}")
        self.cutoff = cutoff_
        self.pole = math.exp(-cutoff_ * self.period)  # a = e^{−ωc T}
        self.reset()

    @property
    def dc_gain(self) -> float:
        """The discrete filter's gain at low frequency relative to s: ωc T / (1 − e^{−ωc T})."""
        return self.cutoff * self.period / (1.0 - self.pole)

    def reset(self) -> None:
        import numpy as np

        self._last: np.ndarray | None = None
        self._rates = np.zeros(self.dof)

    def step(self, y: Sequence[float] | np.ndarray, u: float = 0.0) -> np.ndarray:
        import numpy as np

        values = self._measurement(y)
        if self._last is not None:
            self._rates = self.pole * self._rates + self.cutoff * (values - self._last)
        self._last = values.copy()
        return np.concatenate([values, self._rates])


def _initial_state(dof: int, measured: tuple[int, ...], y: np.ndarray, x_eq: np.ndarray) -> np.ndarray:
    """x̂_{0|−1}: the measured coordinates y_0, the others x_eq, rates 0."""
    import numpy as np

    x = np.concatenate([x_eq[:dof], np.zeros(dof)])
    x[list(measured)] = y
    return x


class SteadyStateKalman(Estimator):
    """The steady-state Kalman filter `design` (from `ipgen.kalman`) in its current form."""

    def __init__(self, design: Kalman) -> None:
        import numpy as np

        self.design = design
        self.period = design.period
        self.dof = design.A.shape[0] // 2
        self.measured = design.measured
        self._x_eq = np.asarray(design.equilibrium, dtype=float)
        self.reset()

    def reset(self) -> None:
        self._x: np.ndarray | None = None  # x̂_{k−1|k−1}

    def step(self, y: Sequence[float] | np.ndarray, u: float = 0.0) -> np.ndarray:
        values = self._measurement(y)
        d = self.design
        if self._x is None:
            prior = _initial_state(self.dof, self.measured, values, self._x_eq)
        else:
            deviation = self._x - self._x_eq
            prior = self._x_eq + d.A @ deviation + d.B[:, 0] * (float(u) - d.u_eq)
        self._x = prior + d.M @ (values - d.C @ prior)
        return self._x.copy()


class ExtendedKalman(Estimator):
    """The extended Kalman filter on ipgen's exact nonlinear model (module docstring).

    `pendulum`: as for `ipgen.kalman`; `Qn`, `Rn`: covariances as there; `equilibrium`: where
    the unmeasured coordinates start (default upright)."""

    def __init__(
        self,
        pendulum: Any,
        period: float,
        Qn: Any,
        Rn: Any,
        *,
        measured: Sequence[int] | None = None,
        equilibrium: Sequence[float] | str | None = None,
    ) -> None:
        import numpy as np

        self.model = as_model(pendulum)
        self.period = sampling_period(period)
        self.dof = self.model.dof
        self.measured = measured_indices(measured, self.dof)
        size = 2 * self.dof
        self.Qn = covariance_matrix("Qn", Qn, size, "one per state θ0..θn, θ̇0..θ̇n", definite=False)
        self.Rn = covariance_matrix(
            "Rn", Rn, len(self.measured), "one per measured coordinate", definite=True
        )
        self.C = np.zeros((len(self.measured), size))
        for row, index in enumerate(self.measured):
            self.C[row, index] = 1.0
        self._x_eq = equilibrium_of(self.model, equilibrium)
        self.reset()

    def reset(self) -> None:
        self._x: np.ndarray | None = None  # x̂_{k−1|k−1}
        self._p: np.ndarray | None = None  # P_{k−1|k−1}

    def initial_covariance(self) -> np.ndarray:
        """P_{0|−1}: Rn's diagonal for the measured coordinates, 1 for the rest."""
        import numpy as np

        diagonal = np.ones(2 * self.dof)
        diagonal[list(self.measured)] = np.diag(self.Rn)
        return np.diag(diagonal)

    def predict(self, x: np.ndarray, p: np.ndarray, u: float) -> tuple[np.ndarray, np.ndarray]:
        """(x̂_{k+1|k}, P_{k+1|k}) from (x̂_{k|k}, P_{k|k}) with ū_k = u held over the period."""
        import numpy as np

        t = self.period
        f = self.model.f
        _, a_c, _ = self.model.jacobians(x, u)
        k1 = f(x, u)
        k2 = f(x + 0.5 * t * k1, u)
        k3 = f(x + 0.5 * t * k2, u)
        k4 = f(x + t * k3, u)
        x_next = x + t / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
        ta = t * a_c
        transition = np.eye(x.size) + ta + 0.5 * ta @ ta
        p_next = transition @ p @ transition.T + self.Qn
        return x_next, 0.5 * (p_next + p_next.T)

    def update(self, x: np.ndarray, p: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(x̂_{k|k}, P_{k|k}) from the prediction and y_k (Joseph form)."""
        import numpy as np

        c = self.C
        s = c @ p @ c.T + self.Rn
        k = np.linalg.solve(s, c @ p).T
        x_new = x + k @ (y - c @ x)
        i_kc = np.eye(x.size) - k @ c
        p_new = i_kc @ p @ i_kc.T + k @ self.Rn @ k.T
        return x_new, 0.5 * (p_new + p_new.T)

    def step(self, y: Sequence[float] | np.ndarray, u: float = 0.0) -> np.ndarray:
        values = self._measurement(y)
        if self._x is None or self._p is None:
            x, p = _initial_state(self.dof, self.measured, values, self._x_eq), self.initial_covariance()
        else:
            x, p = self.predict(self._x, self._p, float(u))
        self._x, self._p = self.update(x, p, values)
        return self._x.copy()

    @property
    def covariance(self) -> np.ndarray | None:
        """P_{k|k} after the last step (None before the first)."""
        return None if self._p is None else self._p.copy()
