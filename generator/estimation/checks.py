"""Checks of the estimators' arguments: the period, the measured coordinates, a covariance."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

from ipgen.estimation.measurement import LARGEST, Sensors
from ipgen.estimation.pendulum import EstimationError

if TYPE_CHECKING:
    import numpy as np


def sampling_period(period: Any) -> float:
    try:
        value = float(period)
    except (TypeError, ValueError):
        value = math.nan
    if not (math.isfinite(value) and value > 0):
        raise EstimationError(f"period = {period!r}: expected a sampling period > 0 s (e.g. 0.001)")
    return value


def measured_indices(measured: Sequence[int] | None, dof: int) -> tuple[int, ...]:
    """The measured coordinates (default: every angle: all dof coordinates)."""
    import numpy as np

    listed = isinstance(measured, Sequence | np.ndarray) and not isinstance(measured, str | bytes)
    if measured is not None and not listed:
        raise EstimationError(f"measured = {measured!r}: expected a list of coordinate indices, e.g. [0, 1]")
    return Sensors.of(dof, measured).measured


def covariance_matrix(name: str, value: Any, size: int, what: str, *, definite: bool) -> np.ndarray:
    """A symmetric covariance from a scalar (·I), `size` diagonal entries or a full matrix."""
    import numpy as np

    try:
        array = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise EstimationError(f"{name}: expected numbers ({what})") from None
    if array.ndim == 0:
        array = np.eye(size) * float(array)
    elif array.ndim == 1:
        if array.size != size:
            raise EstimationError(f"{name} has {array.size} diagonal entries, expected {size} ({what})")
        array = np.diag(array)
    if array.shape != (size, size):
        raise EstimationError(f"{name} has shape {array.shape}, expected ({size}, {size}) ({what})")
    if not np.all(np.isfinite(array)):
        raise EstimationError(f"{name} must be finite")
    if np.max(np.abs(array), initial=0.0) > LARGEST:
        raise EstimationError(
            f"{name} has an entry above {LARGEST:g}: only its ratio to the other covariance matters, "
            "scale both down"
        )
    scale = max(1e-300, float(np.max(np.abs(array))))
    if not np.allclose(array, array.T, rtol=0, atol=1e-12 * scale):
        raise EstimationError(f"{name} must be symmetric")
    array = 0.5 * (array + array.T)
    smallest = float(np.min(np.linalg.eigvalsh(array)))
    if definite and smallest <= 0:
        raise EstimationError(f"{name} must be positive definite (its smallest eigenvalue is {smallest:.3g})")
    if not definite and smallest < -1e-12 * scale:
        raise EstimationError(f"{name} must be positive semidefinite (an eigenvalue is {smallest:.3g})")
    return array
