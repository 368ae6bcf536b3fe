"""Numerical comparison shared by the checks that evaluate equations at sample states."""

from __future__ import annotations

import numpy as np


def assert_close(
    actual: np.ndarray,
    expected: np.ndarray,
    tolerance: float,
    what: str,
    names: tuple[str, str] = ("actual", "expected"),
) -> None:
    """max |actual − expected| ≤ tolerance × max |expected| (entries that cancel are fine).

    Empty arrays compare equal; `names` label the two sides in the failure message.
    """
    actual, expected = np.asarray(actual, float), np.asarray(expected, float)
    assert actual.shape == expected.shape, f"{what}: shape {actual.shape} != {expected.shape}"
    scale = float(np.max(np.abs(expected))) if expected.size else 0.0
    error = float(np.max(np.abs(actual - expected))) if expected.size else 0.0
    width = max(len(name) for name in names) + 1
    assert error <= tolerance * max(scale, 1e-300), (
        f"{what}: max |difference| {error:.3e} > {tolerance:g} × {scale:.3e}\n"
        f"  {names[0] + ':':<{width}} {np.array2string(actual, precision=17)}\n"
        f"  {names[1] + ':':<{width}} {np.array2string(expected, precision=17)}"
    )
