"""The pendulum an estimator models: ẋ = f(x, u) with its exact Jacobians (`VectorField`).

A pendulum is given as an `ipgen.Pendulum`, as ipgen's keyword description (a mapping of the
arguments of `ipgen.linearize` without the point: type, links, m, l, delta, g, inertia, com, J,
J_axial, tip, actuator, angles, zero, positive), or as a ready `VectorField`.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any

from ipgen.control.linear import ControlError, VectorField, equilibrium_state, vector_field
from ipgen.errors import Error
from ipgen.model.coordinates import rests
from ipgen.model.pendulum import Pendulum

if TYPE_CHECKING:
    import numpy as np

# The keywords of `vector_field` (those of `ipgen.linearize` without q, qd, u).
KEYWORDS: tuple[str, ...] = (
    "type", "links", "m", "l", "delta", "g", "inertia", "com", "J", "J_axial", "tip",
    "actuator", "angles", "zero", "positive",
)  # fmt: skip


class EstimationError(Error, ValueError):
    """An estimator that cannot be built (bad covariances, an undetectable pair, ...)."""


def as_model(pendulum: Any) -> VectorField:
    """The `VectorField` of `pendulum` (module docstring); bad input raises `EstimationError`."""
    if isinstance(pendulum, VectorField):
        return pendulum
    if isinstance(pendulum, Mapping):
        unknown = sorted(set(pendulum) - set(KEYWORDS))
        if unknown:
            raise EstimationError(
                f"pendulum: unknown key {unknown[0]!r}; expected the keywords of ipgen.linearize: "
                + ", ".join(KEYWORDS)
            )
        try:
            return vector_field(**pendulum)
        except ControlError as exc:
            raise EstimationError(f"pendulum: {exc}") from None
        except TypeError as exc:
            raise EstimationError(f"pendulum: {exc} (type, links, m, l and delta are required)") from None
    if isinstance(pendulum, Pendulum):
        return vector_field(pendulum)
    raise EstimationError(
        f"pendulum: expected a mapping of ipgen.linearize's keywords or an ipgen.Pendulum, "
        f"got {type(pendulum).__name__}"
    )


def equilibrium_of(model: VectorField, equilibrium: Sequence[float] | str | None) -> np.ndarray:
    """x_eq (2·dof) in the model's coordinates: "upright" (default), "hanging" (the physical
    states, mapped into the rig's coordinates), dof angles in the rig's coordinates (rates zero,
    as `ipgen.lqr` reads them), or a full state of 2·dof entries (rates must be zero)."""
    import numpy as np

    dof = model.dof
    links = model.system.links
    frame_p, frame_c = model.transform, model.offset
    if equilibrium is None or isinstance(equilibrium, str):
        try:
            x = equilibrium_state(links, equilibrium)
        except ControlError as exc:
            raise EstimationError(str(exc)) from None
        return frame_p @ x + frame_c
    try:
        values = np.asarray(equilibrium, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        values = np.full(1, np.nan)  # refused below
    if values.size == 2 * dof:
        if np.any(values[dof:] != 0):
            raise EstimationError("equilibrium: the rates (its last dof entries) must be zero")
        values = values[:dof]
    if values.size != dof or not np.all(np.isfinite(values)):
        raise EstimationError(
            f"equilibrium: expected 'upright', 'hanging', {dof} finite angles or a state of {2 * dof} entries"
        )
    x = np.concatenate([values, np.zeros(dof)])
    canonical = np.linalg.solve(frame_p, x - frame_c)
    for i, angle in enumerate(canonical[1:dof], start=1):
        if not rests(angle):
            raise EstimationError(
                f"equilibrium[{i}] is not an equilibrium angle: links rest upright or hanging"
            )
    return x
