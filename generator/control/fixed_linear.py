"""`linearize` and `lqr` of a fixed-pivot chain (`FixedPendulum`): m inputs, B 2n × m, K m × 2n.

Everything is in the chain's own coordinates (its `angles`, `zero`, `positive`): the equations
are derived in them (`model.fixed_equations`), so A, B, K, Q and an equilibrium given as angles
are too. Coulomb friction is not linearised (as for the other systems).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from ipgen.common.arrays import float_array
from ipgen.common.safetext import abbreviate
from ipgen.control.linear import ControlError, checked_vector, continuous_lqr_gain, weights
from ipgen.model.coordinates import rests
from ipgen.model.fixed import FixedPendulum
from ipgen.model.fixed_equations import angle_map, state_map
from ipgen.model.fixed_numeric import FixedModel


def linearize_fixed(
    p: FixedPendulum,
    q: Sequence[float] | None = None,
    qd: Sequence[float] | None = None,
    u: Sequence[float] | float | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """(A, B) of ẋ = f(x, u), x = [q; q̇] in p's coordinates: A 2n × 2n, B 2n × m.

    Examples
    --------
    >>> p = FixedPendulum(2, m=[1, 1], l=[1, 1], delta=[0, 0], joints=[2])
    >>> [m.shape for m in linearize_fixed(p)]
    [(4, 4), (4, 1)]
    """
    n, inputs = p.links, p.inputs
    angles = checked_vector("q", q, n, "one angle per link")
    rates = checked_vector("qd", qd, n, "one rate per link")
    given = None if u is None else np.atleast_1d(u)
    torques = checked_vector("u", given, inputs, "one torque per actuated joint")
    a, b = FixedModel(p).linearize(angles, rates, torques)
    if not (np.all(np.isfinite(a)) and np.all(np.isfinite(b))):
        raise ControlError("the linear model overflows: check the parameters' units")
    return a, b


def fixed_equilibrium(p: FixedPendulum, equilibrium: Sequence[float] | str | None) -> np.ndarray:
    """The equilibrium's angles in p's coordinates: "upright" (default), "hanging" or n angles
    (each link's absolute angle a multiple of π)."""
    n = p.links
    matrix, zero = angle_map(p.coordinates, n)
    if equilibrium is None or isinstance(equilibrium, str):
        if equilibrium not in (None, "upright", "hanging"):
            raise ControlError(f"equilibrium {equilibrium!r}: expected 'upright', 'hanging' or {n} angles")
        theta = np.full(n, math.pi if equilibrium == "hanging" else 0.0)
        return np.linalg.solve(matrix, theta - zero)
    angles = checked_vector("equilibrium", equilibrium, n, "one angle per link, in the chain's coordinates")
    theta = matrix @ angles + zero
    for i, angle in enumerate(theta):
        if not rests(angle):
            raise ControlError(
                f"equilibrium: link {i + 1} at {angle:g} rad from upright is not an equilibrium without "
                "torque: each link upright or hanging"
            )
    return angles


def lqr_fixed(
    p: FixedPendulum,
    Q: np.ndarray | Sequence,
    R: float | Sequence[float] | np.ndarray,
    equilibrium: Sequence[float] | str | None = None,
) -> np.ndarray:
    """K (m × 2n) of u = −K (x − x_eq), python-control's convention, about an equilibrium.

    R is one number (R·I), m diagonal weights or an m × m positive definite matrix.

    Examples
    --------
    >>> p = FixedPendulum(2, m=[1, 1], l=[1, 1], delta=[0, 0], joints=[1, 2])
    >>> lqr_fixed(p, Q=[1, 1, 1, 1], R=1.0).shape
    (2, 4)
    """
    n, inputs = p.links, p.inputs
    angles = fixed_equilibrium(p, equilibrium)
    a, b = linearize_fixed(p, angles, None, None)
    q, _ = weights(Q, 1.0, 2 * n)
    r = _input_weights(R, inputs)
    return continuous_lqr_gain(a, b, q, r)


def _input_weights(R: float | Sequence[float] | np.ndarray, inputs: int) -> np.ndarray:
    """R as an inputs × inputs symmetric positive definite matrix (one number, a diagonal or a
    matrix), or a one-line ControlError naming R."""
    try:
        r = float_array(R)
    except (TypeError, ValueError):
        raise ControlError(
            f"R = {abbreviate(repr(R))}: expected one number, {inputs} weights or a {inputs} × {inputs} "
            "matrix"
        ) from None
    if r.ndim == 0 or r.size == 1:
        r = np.eye(inputs) * float(r.reshape(-1)[0])
    elif r.ndim == 1:
        if r.size != inputs:
            raise ControlError(f"R has {r.size} entries, expected {inputs} (one per input) or one number")
        r = np.diag(r)
    if r.shape != (inputs, inputs) or not np.all(np.isfinite(r)):
        raise ControlError(f"R must be one number, {inputs} weights or a {inputs} × {inputs} matrix")
    if not np.allclose(r, r.T) or float(np.min(np.linalg.eigvalsh(0.5 * (r + r.T)))) <= 0:
        raise ControlError("R must be symmetric positive definite (every input weighted > 0)")
    return 0.5 * (r + r.T)


def canonical_states(p: FixedPendulum, rows: np.ndarray) -> np.ndarray:
    """States [q; q̇] in the chain's coordinates (one a row) in ipgen's canonical [θ; θ̇]: with
    x_user = P x + c (`fixed_equations.state_map`), x = P⁻¹ (x_user − c)."""
    matrix, offset = state_map(p.coordinates, p.links)
    return np.linalg.solve(matrix, (np.atleast_2d(rows) - offset).T).T


def canonical_gains(p: FixedPendulum, rows: np.ndarray) -> np.ndarray:
    """Gains K_user (one row per input: u_user = −K_user (x_user − x̄_user)) in ipgen's canonical
    coordinates: the rig's torque is s u (`Coordinates.sign`), so u = −s K_user P (x − x̄) and
    K = s K_user P."""
    matrix, _ = state_map(p.coordinates, p.links)
    return p.coordinates.sign * np.atleast_2d(rows) @ matrix
