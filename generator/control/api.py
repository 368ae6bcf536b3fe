"""`ipgen.linearize` and `ipgen.lqr`: the cart's and the arm's (`control.linear`) or, for a
`FixedPendulum`, the fixed-pivot chain's (`control.fixed_linear`), chosen by the first argument.

Each form is a `typing.overload` (what type checkers and IDEs show); help() and
`inspect.signature` show the first, the Pendulum's, and the docstring (`control.linear`'s) tells
the others."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any, overload

from ipgen.control import fixed_linear, linear
from ipgen.control.linear import shown_as_first_form
from ipgen.model.fixed import FixedPendulum

if TYPE_CHECKING:
    import numpy as np

    from ipgen.model.actuator import Actuator
    from ipgen.model.pendulum import Pendulum


def _is_fixed(args: tuple, kwargs: dict) -> bool:
    return bool(args and isinstance(args[0], FixedPendulum)) or isinstance(kwargs.get("p"), FixedPendulum)


@overload
def linearize(
    p: Pendulum,
    q: Sequence[float] | np.ndarray | None = None,
    qd: Sequence[float] | np.ndarray | None = None,
    u: float = 0.0,
) -> tuple[np.ndarray, np.ndarray]: ...


@overload
def linearize(
    p: FixedPendulum,
    q: Sequence[float] | np.ndarray | None = None,
    qd: Sequence[float] | np.ndarray | None = None,
    u: Sequence[float] | np.ndarray | float | None = None,
) -> tuple[np.ndarray, np.ndarray]: ...


@overload
def linearize(
    type: str,
    links: int,
    m: Sequence[float],
    l: Sequence[float],  # noqa: E741
    delta: Sequence[float],
    g: float = 9.81,
    inertia: str = "pivot",
    q: Sequence[float] | np.ndarray | None = None,
    qd: Sequence[float] | np.ndarray | None = None,
    u: float = 0.0,
    *,
    com: Sequence[float] | None = None,
    J: Sequence[float] | None = None,
    J_axial: Sequence[float] | None = None,
    tip: Sequence[float] | None = None,
    actuator: Actuator | Mapping[str, object] | None = None,
    angles: str = "absolute",
    zero: str = "upright",
    positive: str = "clockwise",
) -> tuple[np.ndarray, np.ndarray]: ...


@shown_as_first_form
def linearize(*args: Any, **kwargs: Any) -> tuple[np.ndarray, np.ndarray]:
    if _is_fixed(args, kwargs):
        return linear.called("linearize", fixed_linear.linearize_fixed, *args, **kwargs)
    return linear.linearize(*args, **kwargs)


@overload
def lqr(
    p: Pendulum,
    Q: np.ndarray | Sequence,
    R: float | Sequence[float],
    equilibrium: Sequence[float] | str | None = None,
) -> np.ndarray: ...


@overload
def lqr(
    p: FixedPendulum,
    Q: np.ndarray | Sequence,
    R: float | Sequence[float] | np.ndarray,
    equilibrium: Sequence[float] | str | None = None,
) -> np.ndarray: ...


@overload
def lqr(
    type: str,
    links: int,
    m: Sequence[float],
    l: Sequence[float],  # noqa: E741
    delta: Sequence[float],
    Q: np.ndarray | Sequence,
    R: float | Sequence[float],
    g: float = 9.81,
    inertia: str = "pivot",
    equilibrium: Sequence[float] | str | None = None,
    *,
    com: Sequence[float] | None = None,
    J: Sequence[float] | None = None,
    J_axial: Sequence[float] | None = None,
    tip: Sequence[float] | None = None,
    actuator: Actuator | Mapping[str, object] | None = None,
    angles: str = "absolute",
    zero: str = "upright",
    positive: str = "clockwise",
) -> np.ndarray: ...


@shown_as_first_form
def lqr(*args: Any, **kwargs: Any) -> np.ndarray:
    if _is_fixed(args, kwargs):
        return linear.called("lqr", fixed_linear.lqr_fixed, *args, **kwargs)
    return linear.lqr(*args, **kwargs)


# one docstring for each public function and its private forms: control.linear's tells them all
linearize.__doc__ = linear.linearize.__doc__
lqr.__doc__ = linear.lqr.__doc__
