"""An [estimator] table's numbers, computed once: what the simulator, the C header and the
Python estimators share (the shared spec of issue 32).

`design(pendulum, kind, period, sensors, ...)` checks the combination and fixes every number the
estimator needs: the measured coordinates, the filter's cutoff, Qn and Rn (the defaults of
`covariance` unless given), and for "kalman" the steady-state gains (`kalman.kalman`). `build`
gives the Python estimator of a design.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from ipgen.estimation.checks import covariance_matrix, sampling_period
from ipgen.estimation.covariance import measurement_covariance, process_covariance
from ipgen.estimation.estimators import (
    DerivativeFilter,
    Difference,
    Estimator,
    ExtendedKalman,
    SteadyStateKalman,
)
from ipgen.estimation.kalman import Kalman, kalman, linear_model
from ipgen.estimation.measurement import Sensors
from ipgen.estimation.pendulum import EstimationError, as_model, equilibrium_of

if TYPE_CHECKING:
    import numpy as np

KINDS: tuple[str, ...] = ("exact", "difference", "filter", "kalman", "ekf")
DEFAULT_CUTOFF = 50.0  # rad/s: Quanser's courseware's 50 s / (s + 50)


@dataclass(frozen=True)
class EstimatorDesign:
    """Every number of one estimator (module docstring); `Qn`, `Rn` for kalman and ekf only,
    `gains` for kalman only; `equilibrium` is where unmeasured coordinates start (and the
    Kalman filter's linearisation point)."""

    kind: str
    period: float
    dof: int
    measured: tuple[int, ...]
    equilibrium: np.ndarray
    cutoff: float | None = None
    Qn: np.ndarray | None = None
    Rn: np.ndarray | None = None
    gains: Kalman | None = None

    def build(self, pendulum: Any = None) -> Estimator | None:
        """The Python estimator (None for "exact"); the EKF needs the `pendulum` again."""
        if self.kind == "difference":
            return Difference(self.period, self.dof)
        if self.kind == "filter":
            return DerivativeFilter(self.period, self.dof, self.cutoff or DEFAULT_CUTOFF)
        if self.kind == "kalman" and self.gains is not None:
            return SteadyStateKalman(self.gains)
        if self.kind == "ekf":
            if pendulum is None:
                raise EstimationError("an EKF needs the pendulum: build(pendulum)")
            return ExtendedKalman(
                pendulum, self.period, self.Qn, self.Rn, measured=self.measured, equilibrium=self.equilibrium
            )
        return None


def design(
    pendulum: Any,
    kind: str,
    period: float,
    sensors: Sensors,
    *,
    cutoff: float | None = None,
    process_noise: Any = None,
    measurement_noise: Any = None,
    input_noise: float = 0.0,
    u_scale: float | None = None,
    equilibrium: Sequence[float] | str | None = None,
) -> EstimatorDesign:
    """The design of an estimator of `kind` (KINDS) for `pendulum` sampled every `period` with
    `sensors`; `u_scale`: the input's limit (None: 1 unit), for the default Qn.

    Raises `EstimationError` (one line) for a combination that cannot work: a difference or
    filter without every coordinate measured, a cutoff on another kind, covariances on a kind
    without a model, a Kalman filter that does not converge."""
    if kind not in KINDS:
        raise EstimationError(f"estimator kind {kind!r}: expected one of {', '.join(map(repr, KINDS))}")
    model = as_model(pendulum)
    period_ = sampling_period(period)
    dof = model.dof
    x_eq = equilibrium_of(model, equilibrium)
    if sensors.measured and max(sensors.measured) >= dof:
        raise EstimationError(f"measured: coordinate {max(sensors.measured)} does not exist (0..{dof - 1})")
    cart = model.pendulum.system.type == "classical"
    if sensors.cart != cart:  # a cart's position encoder counts metres, 1 / resolution a count, not 2π / it
        sensors = dataclasses.replace(sensors, cart=cart)
    if cutoff is not None and kind != "filter":
        raise EstimationError(f'cutoff applies to kind "filter" only, not {kind!r}: remove it')
    if (process_noise is not None or measurement_noise is not None) and kind not in ("kalman", "ekf"):
        raise EstimationError(
            f'process_noise and measurement_noise apply to kinds "kalman" and "ekf" only, not {kind!r}'
        )
    common = {"kind": kind, "period": period_, "dof": dof, "measured": sensors.measured, "equilibrium": x_eq}
    if kind in ("difference", "filter") and sensors.measured != tuple(range(dof)):
        raise EstimationError(
            f'estimator kind "{kind}" needs every coordinate measured (measured = {list(sensors.measured)}); '
            'use "kalman" or "ekf" to estimate the others'
        )
    if kind == "filter":
        probe = DerivativeFilter(period_, dof, DEFAULT_CUTOFF if cutoff is None else cutoff)
        return EstimatorDesign(**common, cutoff=probe.cutoff)
    if kind in ("exact", "difference"):
        return EstimatorDesign(**common)
    size = 2 * dof
    if process_noise is None:
        _, b = linear_model(model, period_, x_eq)
        qn = process_covariance(
            b, period_, input_noise=input_noise, u_scale=1.0 if u_scale is None else u_scale
        )
    else:
        qn = covariance_matrix("process_noise", process_noise, size, "one per state", definite=False)
    if measurement_noise is None:
        rn = measurement_covariance(sensors)
    else:
        rn = covariance_matrix(
            "measurement_noise", measurement_noise, len(sensors.measured), "one per measured", definite=True
        )
    gains = (
        kalman(model, period_, qn, rn, measured=sensors.measured, equilibrium=x_eq)
        if kind == "kalman"
        else None
    )
    return EstimatorDesign(**common, Qn=qn, Rn=rn, gains=gains)
