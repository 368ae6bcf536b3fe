"""`ipgen.linearize` and `ipgen.lqr`: the cart's and the arm's (`control.linear`) or, for a
`FixedPendulum`, the fixed-pivot chain's (`control.fixed_linear`), chosen by the first argument."""

from __future__ import annotations

import functools
from typing import Any

import numpy as np

from ipgen.control import fixed_linear, linear
from ipgen.model.fixed import FixedPendulum


def _is_fixed(args: tuple, kwargs: dict) -> bool:
    return bool(args and isinstance(args[0], FixedPendulum)) or isinstance(kwargs.get("p"), FixedPendulum)


@functools.wraps(linear.linearize)
def linearize(*args: Any, **kwargs: Any) -> tuple[np.ndarray, np.ndarray]:
    if _is_fixed(args, kwargs):
        return linear.called("linearize", fixed_linear.linearize_fixed, *args, **kwargs)
    return linear.linearize(*args, **kwargs)


@functools.wraps(linear.lqr)
def lqr(*args: Any, **kwargs: Any) -> np.ndarray:
    if _is_fixed(args, kwargs):
        return linear.called("lqr", fixed_linear.lqr_fixed, *args, **kwargs)
    return linear.lqr(*args, **kwargs)
