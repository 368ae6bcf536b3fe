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

Each `step` runs cpp/include/ipgen_loop.h (ipgen_loop_difference, _filter, _kalman_update,
_ekf_update) through ctypes (`ipgen.common.loop_runtime`): the code the firmware header and the
simulator run. Python holds the design (the gains, the covariances, the model) and the state
between samples; the EKF's model is the Python `VectorField`, called back from C.
"""

from __future__ import annotations

import ctypes
import math
import numbers
from abc import ABC, abstractmethod
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

from ipgen.common.loop_runtime import FIELD, EkfFilter, KalmanFilter, Measurement, address, ekf_work, library
from ipgen.common.safetext import abbreviate
from ipgen.estimation.checks import covariance_matrix, measured_indices, sampling_period
from ipgen.estimation.covariance import NOISE_CEILING, NOISE_MARGIN, RN_FLOOR
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

        try:
            values = np.asarray(y, dtype=float).reshape(-1)
        except (TypeError, ValueError):
            raise EstimationError(
                f"y = {abbreviate(repr(y))}: expected numbers, one per measured coordinate"
            ) from None
        if values.size != len(self.measured):
            raise EstimationError(
                f"y has {values.size} entries, expected {len(self.measured)} "
                f"(measured = {list(self.measured)})"
            )
        if not np.isfinite(values).all():  # refused before the filter sees it: it stays as it was
            raise EstimationError(f"y = {abbreviate(repr(y))} is not finite: an encoder's reading failed?")
        return values


def _input(u: Any) -> float:
    """ū_{k−1} as a finite float, or the EstimationError saying so (the filter is left as it was)."""
    try:
        value = float(u)
    except (TypeError, ValueError):
        value = math.nan
    if not math.isfinite(value):
        raise EstimationError(f"u = {abbreviate(repr(u))}: expected a finite number (the input held)")
    return value


def _doubles(values: Any, shape: tuple[int, ...]) -> np.ndarray:
    """`values` as a new C-contiguous float64 array of `shape` (owned by the estimator: C reads it)."""
    import numpy as np

    return np.ascontiguousarray(np.array(values, dtype=np.float64).reshape(shape))


def _noise_memory(memory: Any, margin: Any, period: float, rn: np.ndarray) -> float:
    """The learnt noise's memory [s] (0: Rn fixed), checked with its margin: at least one period
    (the mean's weight T / memory at most 1), and Rn diagonal (only its diagonal is learnt)."""
    import numpy as np

    for name, value in (("noise_memory", memory), ("noise_margin", margin)):
        if isinstance(value, bool | str) or not isinstance(value, numbers.Real) or not math.isfinite(value):
            raise EstimationError(f"{name} = {value!r}: expected a finite number")
        if value < 0 or (name == "noise_margin" and value <= 0):
            bound = "> 0" if name == "noise_margin" else ">= 0"
            raise EstimationError(f"{name} = {value!r}: must be {bound}")
    if 0 < memory < period:
        raise EstimationError(
            f"noise_memory = {memory!r} s is shorter than the period {period!r} s: give at least one period"
        )
    if memory > 0 and np.count_nonzero(rn - np.diag(np.diag(rn))):
        raise EstimationError("noise_memory needs a diagonal Rn (only its diagonal is learnt)")
    return float(memory)


def _variances(name: str, value: Any, default: np.ndarray) -> np.ndarray:
    """`value` (None: `default`), one variance or one per entry of `default`, each a finite
    number > 0; else one EstimationError line."""
    import numpy as np

    if value is None:
        return default.copy()
    entries = list(value) if isinstance(value, Sequence | np.ndarray) else [value]
    numeric = all(isinstance(v, numbers.Real) and not isinstance(v, bool) for v in entries)
    fine = numeric and len(entries) in (1, len(default)) and all(math.isfinite(v) and v > 0 for v in entries)
    if not fine:
        shown = value.tolist() if isinstance(value, np.ndarray) else value
        raise EstimationError(
            f"{name} = {shown!r}: expected a finite variance > 0, one or one per measured coordinate"
        )
    return np.broadcast_to(np.array(entries, dtype=float), default.shape).copy()


def _noise_bounds(floor: Any, ceiling: Any, rn_diagonal: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The learnt noise's floor and ceiling per measured coordinate (defaults RN_FLOOR and
    NOISE_CEILING times Rn's diagonal, at least the floor), checked: 0 < floor <= ceiling."""
    import numpy as np

    low = _variances("noise_floor", floor, np.full(len(rn_diagonal), RN_FLOOR))
    high = _variances("noise_ceiling", ceiling, NOISE_CEILING * rn_diagonal)
    if ceiling is not None and np.any(high < low):
        raise EstimationError(f"noise_ceiling = {high.tolist()!r} is below noise_floor = {low.tolist()!r}")
    return low, np.maximum(high, low)


def _measurement_of(dof: int, measured: tuple[int, ...], x_eq: np.ndarray) -> tuple[Measurement, list[Any]]:
    """The ipgen_loop_measurement of the Kalman filters, and the arrays it points into (to keep)."""
    import numpy as np

    indices = np.array(measured, dtype=np.int32)
    equilibrium = _doubles(x_eq, (2 * dof,))
    return Measurement(dof, len(measured), address(indices), address(equilibrium)), [indices, equilibrium]


class _Runtime(Estimator):
    """What the estimators running ipgen_loop.h share: the sample count k, the estimate x (2·dof)
    C updates in place and the measured values' buffer y, each with its address."""

    def _start(self) -> None:
        import numpy as np

        self._k = 0
        self._x = np.zeros(2 * self.dof)
        self._y = np.zeros(len(self.measured))
        self._x_at, self._y_at = address(self._x), address(self._y)

    def _take(self, y: Any) -> int:
        """Copy y_k into the buffer (checked), return k and count the sample."""
        self._y[:] = self._measurement(y)
        k, self._k = self._k, self._k + 1
        return k


class _Rates(_Runtime):
    """An estimator of the rates from successive measurements (every coordinate measured): it
    keeps y_{k−1}."""

    def __init__(self, period: float, dof: int) -> None:
        self.period = sampling_period(period)
        if isinstance(dof, bool) or not isinstance(dof, numbers.Integral) or not 1 <= dof <= 2**16:
            raise EstimationError(f"dof = {abbreviate(repr(dof))}: expected a whole number >= 1")
        self.dof = int(dof)
        self.measured = tuple(range(self.dof))

    def reset(self) -> None:
        import numpy as np

        self._start()
        self._previous = np.zeros(self.dof)
        self._previous_at = address(self._previous)


class Difference(_Rates):
    """The backward difference of the measured angles (every coordinate measured).

    Parameters
    ----------
    period : float
        The sampling period T [s].
    dof : int
        The coordinates, all measured.
    """

    def __init__(self, period: float, dof: int) -> None:
        super().__init__(period, dof)
        self.reset()

    def step(self, y: Sequence[float] | np.ndarray, u: float = 0.0) -> np.ndarray:
        """x̂_k = [y_k; (y_k − y_{k−1}) / T] (rates 0 at k = 0); `u` is ignored.

        Parameters
        ----------
        y : array_like
            y_k, dof entries.
        u : float, optional
            Ignored (no model).

        Returns
        -------
        numpy.ndarray
            x̂_k (2·dof), a new array.
        """
        k = self._take(y)
        library().ipgen_loop_difference(self.dof, self.period, k, self._y_at, self._previous_at, self._x_at)
        return self._x.copy()


class DerivativeFilter(_Rates):
    """The first-order derivative filter ωc s / (s + ωc), discretised as Quanser's rigs do.

    Parameters
    ----------
    period : float
        The sampling period T [s].
    dof : int
        The coordinates, all measured.
    cutoff : float, optional
        ωc [rad/s], at most the Nyquist frequency π / T (default 50).
    """

    def __init__(self, period: float, dof: int, cutoff: float = 50.0) -> None:
        super().__init__(period, dof)
        try:
            cutoff_ = math.nan if isinstance(cutoff, str | bytes) else float(cutoff)
        except (TypeError, ValueError):
            cutoff_ = math.nan
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

    def step(self, y: Sequence[float] | np.ndarray, u: float = 0.0) -> np.ndarray:
        """x̂_k = [y_k; v_k], v_k = a v_{k−1} + ωc (y_k − y_{k−1}), v_0 = 0; `u` is ignored.

        Parameters
        ----------
        y : array_like
            y_k, dof entries.
        u : float, optional
            Ignored (no model).

        Returns
        -------
        numpy.ndarray
            x̂_k (2·dof), a new array.
        """
        k = self._take(y)
        library().ipgen_loop_filter(
            self.dof, self.pole, self.cutoff, k, self._y_at, self._previous_at, self._x_at
        )
        return self._x.copy()


class SteadyStateKalman(_Runtime):
    """The steady-state Kalman filter `design` (from `ipgen.kalman`) in its current form.

    Parameters
    ----------
    design : Kalman
        The filter's discrete model, gains and equilibrium (`ipgen.kalman`).
    """

    def __init__(self, design: Kalman) -> None:
        import numpy as np

        self.design = design
        self.period = design.period
        self.dof = design.A.shape[0] // 2
        self.measured = design.measured
        self._x_eq = np.asarray(design.equilibrium, dtype=float)
        size, count = 2 * self.dof, len(self.measured)
        measurement, kept = _measurement_of(self.dof, self.measured, self._x_eq)
        a, b = _doubles(design.A, (size, size)), _doubles(design.B[:, 0], (size,))
        m = _doubles(design.M, (size, count))
        self._kept = [*kept, a, b, m]  # the arrays the struct points into
        self._filter = KalmanFilter(measurement, address(a), address(b), address(m), float(design.u_eq))
        self._work = np.zeros(size + count)
        self.reset()

    def reset(self) -> None:
        self._start()

    def step(self, y: Sequence[float] | np.ndarray, u: float = 0.0) -> np.ndarray:
        """x̂_{k|k} from y_k and ū_{k−1} (module docstring; ū ignored at k = 0).

        Parameters
        ----------
        y : array_like
            y_k, one entry per measured coordinate.
        u : float, optional
            ū_{k−1}, the input held over the last period.

        Returns
        -------
        numpy.ndarray
            x̂_{k|k} (2·dof), a new array.
        """
        held = _input(u)
        k = self._take(y)
        library().ipgen_loop_kalman_update(
            ctypes.byref(self._filter), k, self._y_at, held, self._x_at, address(self._work)
        )
        return self._x.copy()


class ExtendedKalman(_Runtime):
    """The extended Kalman filter on ipgen's exact nonlinear model (module docstring).

    Parameters
    ----------
    pendulum : Pendulum, mapping or VectorField
        The model, as for `ipgen.kalman`.
    period : float
        The sampling period T [s].
    Qn, Rn : array_like
        The process (2·dof) and measurement (one per measured coordinate) noise covariances,
        as for `ipgen.kalman`.
    measured : sequence of int, optional
        The measured coordinates (default all).
    equilibrium : sequence of float or str, optional
        Where the unmeasured coordinates start (default upright).
    gain_spread : float, optional
        > 0: the filter also learns the input gain of the plant over the model's, ρ (`gain`),
        starting from ρ = 1 with this standard deviation (default 0: not learnt).
    gain_drift : float, optional
        With `gain_spread`: ρ's random walk, its standard deviation's growth per √s (default 0:
        ρ constant; a scene's `[estimator] gain_drift` defaults to 0.003). Both at most 1; a
        drift without `gain_spread` is refused.
    noise_memory : float, optional
        > 0: the filter learns each measured coordinate's noise variance from its innovations,
        an exponential mean over this memory [s] (weight T / memory a sample, so at least one
        period) of innovation² − (C P⁻ Cᵀ)_rr from Rn's diagonal / `noise_margin`, and uses
        `noise_margin` times it within [`noise_floor`, `noise_ceiling`] (`noise_used`; default 0:
        Rn fixed). Rn must be diagonal then.
    noise_floor, noise_ceiling : float or sequence of float, optional
        With `noise_memory`: the lowest and highest variance used, one or one per measured
        coordinate (defaults: 1e-12, and 10 times Rn's diagonal).
    noise_margin : float, optional
        With `noise_memory`: the multiple of the learnt variance used (default 10).

    Notes
    -----
    A sample whose model fails (the `VectorField` raises) or whose innovation covariance
    C P⁻ Cᵀ + Rn is not positive definite (a diverged or non-finite estimate or measurement)
    raises `EstimationError`; the filter's state is then that of the sample before.
    """

    def __init__(
        self,
        pendulum: Any,
        period: float,
        Qn: Any,
        Rn: Any,
        *,
        measured: Sequence[int] | None = None,
        equilibrium: Sequence[float] | str | None = None,
        gain_spread: float = 0.0,
        gain_drift: float = 0.0,
        noise_memory: float = 0.0,
        noise_floor: float | Sequence[float] | None = None,
        noise_ceiling: float | Sequence[float] | None = None,
        noise_margin: float = NOISE_MARGIN,
    ) -> None:
        import numpy as np

        for name, value in (("gain_spread", gain_spread), ("gain_drift", gain_drift)):
            if isinstance(value, bool) or not (isinstance(value, int | float) and 0 <= value <= 1):
                raise EstimationError(
                    f"{name} = {value!r}: expected a number from 0 to 1 (0: the gain not learnt)"
                )
        if gain_drift > 0 and gain_spread == 0:
            raise EstimationError(
                f"gain_drift = {gain_drift!r} without gain_spread: the drift is of a learnt gain; "
                "give gain_spread > 0 too, or leave gain_drift at 0"
            )
        self.gain_spread, self.gain_drift = float(gain_spread), float(gain_drift)
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
        count = len(self.measured)
        measurement, kept = _measurement_of(self.dof, self.measured, self._x_eq)
        qn, rn = _doubles(self.Qn, (size, size)), _doubles(self.Rn, (count, count))
        self._failure: BaseException | None = None
        self._field = FIELD(self._model_field)  # kept: C calls it back
        self.noise_memory = _noise_memory(noise_memory, noise_margin, self.period, self.Rn)
        self.noise_margin = float(noise_margin)
        self.noise_floor, self.noise_ceiling = _noise_bounds(noise_floor, noise_ceiling, np.diag(self.Rn))
        floor, ceiling = _doubles(self.noise_floor, (count,)), _doubles(self.noise_ceiling, (count,))
        self._noise = np.zeros(count)  # the learnt variances (noise)
        self._kept = [*kept, qn, rn, floor, ceiling, self._noise]
        weight = self.period / self.noise_memory if self.noise_memory > 0 else 0.0
        # gain 1: the VectorField's u is the input itself (a motor's b folded in)
        self._filter = EkfFilter(
            measurement, self.period, 1.0, address(qn), address(rn), self._field, None,
            self.gain_spread, self.gain_drift,
            weight, self.noise_margin, address(floor), address(ceiling), address(self._noise),
        )  # fmt: skip
        self._states = size + (1 if self.gain_spread > 0 else 0)  # IPGEN_LOOP_EKF_STATES
        self._work = np.zeros(ekf_work(self._states, count))
        self.reset()

    def reset(self) -> None:
        import numpy as np

        self._start()
        self._x = np.zeros(self._states)  # the estimate, and ρ when the gain is learnt
        self._x[2 * self.dof :] = 1.0  # ρ before the first sample
        self._x_at = address(self._x)
        self._p = np.zeros((self._states, self._states))  # P_{k−1|k−1}

    def _model_field(self, context: Any, x: Any, u: float, f: Any, a: Any) -> int:
        """ipgen_loop_field on the `VectorField`: f(x, u) and, when `a` is not NULL, ∂f/∂x."""
        import numpy as np

        try:
            size = 2 * self.dof
            state = np.ctypeslib.as_array(x, shape=(size,)).copy()
            if a:
                rate, jacobian, _ = self.model.jacobians(state, u)
                np.ctypeslib.as_array(a, shape=(size * size,))[:] = np.asarray(jacobian).reshape(-1)
            else:
                rate = self.model.f(state, u)
            np.ctypeslib.as_array(f, shape=(size,))[:] = rate
        except Exception as exc:  # reported by step, after C returns
            self._failure = exc
            return 1
        return 0

    def initial_covariance(self) -> np.ndarray:
        """P_{0|−1}: Rn's diagonal for the measured coordinates, 1 for the rest.

        Returns
        -------
        numpy.ndarray
            2·dof × 2·dof, diagonal.
        """
        import numpy as np

        diagonal = np.ones(2 * self.dof)
        diagonal[list(self.measured)] = np.diag(self.Rn)
        return np.diag(diagonal)

    def step(self, y: Sequence[float] | np.ndarray, u: float = 0.0) -> np.ndarray:
        """x̂_{k|k} from y_k and ū_{k−1} (module docstring; ū ignored at k = 0).

        Parameters
        ----------
        y : array_like
            y_k, one entry per measured coordinate.
        u : float, optional
            ū_{k−1}, the input held over the last period.

        Returns
        -------
        numpy.ndarray
            x̂_{k|k} (2·dof), a new array.

        Raises
        ------
        EstimationError
            The model failed, or C P⁻ Cᵀ + Rn is not positive definite (the class's Notes).
        """
        held = _input(u)
        k = self._take(y)
        self._failure = None
        code = library().ipgen_loop_ekf_update(
            ctypes.byref(self._filter), k, self._y_at, held, self._x_at, address(self._p),
            address(self._work),
        )  # fmt: skip
        if code != 0:
            self._k = k  # the sample did not happen
            if code == 1:
                raise EstimationError(
                    f"extended Kalman filter, sample {k}: the model fails at the estimate: {self._failure}"
                ) from self._failure
            raise EstimationError(
                f"extended Kalman filter, sample {k}: the innovation covariance C P⁻ Cᵀ + Rn is not "
                "positive definite (a diverged or non-finite estimate, input or measurement)"
            )
        return self._x[: 2 * self.dof].copy()

    @property
    def gain(self) -> float:
        """ρ, the plant's input gain over the model's as learnt (1 when not learnt or before the
        first sample; kept within [1/2, 2])."""
        return float(self._x[-1]) if self._states > 2 * self.dof and self._k > 0 else 1.0

    @property
    def noise_used(self) -> np.ndarray:
        """The variances the filter uses for the measured coordinates now: Rn's diagonal, or with
        `noise_memory` the learnt ones times `noise_margin` within their bounds (Rn's diagonal
        before the second sample)."""
        import numpy as np

        if self.noise_memory <= 0 or self._k < 2:
            return np.diag(self.Rn).copy()
        return np.clip(self.noise_margin * self._noise, self.noise_floor, self.noise_ceiling)

    @property
    def covariance(self) -> np.ndarray | None:
        """P_{k|k} after the last step (None before the first); with the gain learnt, ρ's row
        and column last."""
        return None if self._k == 0 else self._p.copy()
