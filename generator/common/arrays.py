"""Numbers from what a user passes: numpy converts text ("1", b"1", ["0.5"]) and booleans to
numbers, which ipgen's arguments refuse as it refuses them anywhere a number is asked for."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    import numpy as np


def float_array(value: Any) -> np.ndarray:
    """`value` as float64 numbers (its own shape); ValueError for text or booleans, ValueError or
    TypeError for what numpy cannot convert (a ragged list, a mapping, None)."""
    import numpy as np

    kind = np.asarray(value).dtype.kind
    if kind in "US":
        raise ValueError(f"{value!r} is text, not numbers")
    if kind == "b":
        raise ValueError(f"{value!r} holds booleans, not numbers")
    try:
        return np.asarray(value, dtype=np.float64)
    except OverflowError:  # an integer beyond a double
        raise ValueError(f"{value!r} holds a number beyond a double") from None


def float_or_inf(value: Any) -> float:
    """`value` (an int, float or Decimal) as a float; inf for an integer beyond a double's range,
    which float() refuses with an OverflowError (the caller's finiteness check then names it)."""
    try:
        return float(value)
    except OverflowError:
        return float("inf")
