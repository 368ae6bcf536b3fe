"""The gym options' error and the number tests every option goes through."""

from __future__ import annotations

import math

from ipgen.errors import Error


class GymError(Error, ValueError):
    """An environment that cannot be made as asked; the message names the option and the fix."""


def is_number(value: object) -> bool:
    """A real number that is not NaN (int or float, not bool); infinities pass."""
    return isinstance(value, int | float) and not isinstance(value, bool) and not math.isnan(value)


def is_integer(value: object) -> bool:
    """An int (not bool)."""
    return isinstance(value, int) and not isinstance(value, bool)
