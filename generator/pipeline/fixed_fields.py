"""A fixed scene's checked values for `ipgen run` (pipeline/fixed_run.py, fixed_mpc.py): numbers
and arrays as one line each, the controller's sampling period, and the state feedback a fixed
scene's [controller] resolves to."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ipgen.common.arrays import float_or_inf
from ipgen.control.controller import MpcDesign
from ipgen.scene.fields import Reader


@dataclass(frozen=True)
class FixedController:
    """A fixed chain's state feedback u = −K (x − x_eq): K m × 2n, x_eq, saturations (m), period,
    all in the chain's coordinates and its inputs' positive sense."""

    kind: str
    gain: np.ndarray
    equilibrium: np.ndarray
    saturation: tuple[float, ...] | None
    period: float | None
    mpc: MpcDesign | None = None  # kind = "mpc": the problem, in ipgen's coordinates


def numbers(reader: Reader, key: str, value: Any, sizes: tuple[int, ...], what: str) -> np.ndarray:
    import math
    from decimal import Decimal

    items = value if isinstance(value, list) else [value]
    flat: list[Any] = []
    for item in items:
        flat.extend(item if isinstance(item, list) else [item])
    if any(isinstance(x, bool) or not isinstance(x, int | float | Decimal) for x in flat):
        reader.bad(key, value, f"expected {what}")
    numbers = np.array([float_or_inf(x) for x in flat])
    if numbers.size not in sizes or not all(math.isfinite(x) for x in numbers):
        reader.bad(key, value, f"expected {what}")
    return numbers


def scalar(reader: Reader, key: str, value: Any, what: str) -> float:
    """One finite number (not an array of one), or one line naming `key`."""
    if isinstance(value, list):
        reader.bad(key, value, f"expected {what}")
    return float(numbers(reader, key, value, (1,), what)[0])


def controller_period(reader: Reader, table: Any, settings: dict[str, Any]) -> float | None:
    """controller.period [s]: > 0, <= t_end, a whole multiple or fraction of the sample."""
    if "period" not in table:
        return None
    period = float(numbers(reader, "controller.period", table["period"], (1,), "a number > 0 [s]")[0])
    t_end, sample = float(settings.get("t_end") or 0.0), float(settings.get("sample") or 0.0)
    ratio = max(period, sample) / min(period, sample) if period > 0 and sample > 0 else 0.0
    if period <= 0 or (t_end and period > t_end) or abs(ratio - round(ratio)) > 1e-9 * ratio:
        reader.bad(
            "controller.period",
            table["period"],
            "expected > 0 s, <= t_end, a whole multiple or fraction of sample",
        )
    return period


def weight_matrix(reader: Reader, key: str, value: Any, size: int) -> np.ndarray:
    """A size × size weight: `size` diagonal weights, or a matrix of `size` rows of `size` (a
    nested list of another shape is refused, not flattened into weights)."""
    what = f"{size} weights or a {size} × {size} matrix"
    matrix = isinstance(value, list) and any(isinstance(row, list) for row in value)
    if matrix and (len(value) != size or any(not isinstance(row, list) or len(row) != size for row in value)):
        reader.bad(key, value, f"expected {what}")
    values = numbers(reader, key, value, (size, size * size), what)
    return np.diag(values) if values.size == size else values.reshape(size, size)
