"""The `[controller]` table of a scene: validated, and its LQR gain computed (`control.lqr`).

    [controller]  kind = "lqr" (required in the table);
                  q = 2·(links + 1) diagonal weights, or a symmetric positive semidefinite
                      2·(links + 1) × 2·(links + 1) matrix (default: identity), in the order of
                      x = [θ0..θn, θ̇0..θ̇n];
                  r = weight of u² (> 0, default 1);
                  equilibrium = "upright" (default) | "hanging" | [θ0, θ1, ..., θn] (links at 0
                      or π; velocities zero);
                  saturation = u_max > 0: |u| ≤ u_max (default: unbounded);
                  period = sampling period in s (> 0; default: continuous feedback). The input
                      is computed at t = k·period and held in between; period and
                      [simulation] sample must be whole multiples of one another.

The controller sets u, so it cannot be combined with an `[input]` other than zero. Every problem
is one line naming the file and the key (`_Reader.fail`), like the other tables.
"""

from __future__ import annotations

import math
from decimal import Decimal
from typing import TYPE_CHECKING, Any

from ipgen.control.controller import Controller
from ipgen.scene import schema

if TYPE_CHECKING:
    from ipgen.scene.fields import _Section


def read_controller(
    section: _Section,
    system: Any,  # scene._System: type, links, inertia
    params: Any,  # scene._Parameters: m, l, delta, g
    input_kind: str,
    sample: float,
    t_end: float,
) -> Controller:
    """The controller of a scene's [controller] table (present, possibly empty), with its gain."""
    from ipgen.scene.fields import _one_of, _type_name, format_number

    kind = section.choice("kind", schema.CONTROLLER_KINDS)
    if input_kind != "zero":
        section.bad(
            "kind",
            kind,
            f'the controller sets u, but [input] kind "{input_kind}" drives it too; '
            'remove [input] (or set kind = "zero")',
        )
    size = 2 * (system.links + 1)
    weights = _read_q(section, size, _type_name)
    r = section.number("r", "the weight of u², > 0", default=schema.DEFAULT_R)
    if r <= 0:
        section.bad("r", r, "the weight of u² must be > 0")
    equilibrium = _read_equilibrium(section, system.links, _one_of, _type_name)
    saturation = None
    if section.has("saturation"):
        saturation = section.number("saturation", "")
        if saturation <= 0:
            unit = "N" if system.type == "classical" else "N m"
            section.bad("saturation", saturation, f"the largest |u| must be > 0 {unit}")
    period = None
    if section.has("period"):
        period = section.number("period", "")
        if not 0 < period <= t_end:
            section.bad("period", period, f"must be > 0 s and <= t_end ({format_number(t_end)} s)")
        if not _commensurate(period, sample):
            section.bad(
                "period",
                period,
                "must be a whole multiple or a whole fraction of simulation.sample "
                f"({format_number(sample)} s)",
            )

    from ipgen.control.linear import ControlError, lqr

    try:
        gain = lqr(
            system.type,
            system.links,
            params.m,
            params.l,
            params.delta,
            weights,
            r,
            g=params.g,
            inertia=system.inertia,
            equilibrium=equilibrium,
            **dict(params.links),  # the links as built the scene gives (com, J, J_axial, tip)
        )
    except ControlError as exc:
        section.reader.fail(f"controller: no LQR gain: {exc}")
    from ipgen.control.linear import equilibrium_state

    x_eq = equilibrium_state(system.links, equilibrium)
    return Controller(
        kind=kind,
        gain=tuple(float(k) for k in gain),
        equilibrium=tuple(float(x) for x in x_eq),
        saturation=saturation,
        period=period,
    )


def _commensurate(period: float, sample: float) -> bool:
    """True when period / sample or sample / period is a whole number (to a relative 1e-9)."""
    ratio = max(period, sample) / min(period, sample)
    return abs(ratio - round(ratio)) <= schema.COMMENSURATE_TOLERANCE * ratio


def _read_q(section: _Section, size: int, type_name: Any) -> list[list[float]] | list[float]:
    """Diagonal weights (size numbers >= 0) or a symmetric positive semidefinite size × size matrix."""
    if not section.has("q"):
        return [1.0] * size
    value = section.data["q"]
    layout = f"2 · (links + 1) = {size}: θ0.. then θ̇0.."
    if not isinstance(value, list):
        section.bad("q", value, f"expected an array of {size} weights or a {size} × {size} matrix")
    if len(value) != size:
        section.reader.fail(f"{section.key('q')} has {len(value)} entries, expected {size} ({layout})")
    if all(isinstance(row, list) for row in value) and value:
        return _read_matrix(section, value, size)
    weights = []
    for i, item in enumerate(value):
        number = _finite(section, f"q[{i}]", item, type_name)
        if number < 0:
            section.bad(f"q[{i}]", item, "weights must be >= 0")
        weights.append(number)
    return weights


def _read_matrix(section: _Section, rows: list[Any], size: int) -> list[list[float]]:
    from ipgen.scene.fields import _type_name

    matrix: list[list[float]] = []
    for i, row in enumerate(rows):
        if len(row) != size:
            section.reader.fail(
                f"{section.key(f'q[{i}]')} has {len(row)} entries, expected {size} (a {size} × {size} matrix)"
            )
        matrix.append([_finite(section, f"q[{i}][{j}]", item, _type_name) for j, item in enumerate(row)])
    scale = max(1.0, max(abs(x) for row in matrix for x in row))
    for i in range(size):
        for j in range(i):
            if abs(matrix[i][j] - matrix[j][i]) > 1e-12 * scale:
                section.reader.fail(
                    f"{section.key(f'q[{i}][{j}]')} = {matrix[i][j]:g} differs from q[{j}][{i}] = "
                    f"{matrix[j][i]:g}: Q must be symmetric"
                )
    import numpy as np

    smallest = float(np.min(np.linalg.eigvalsh(np.array(matrix))))
    if smallest < -1e-12 * scale:
        section.reader.fail(
            f"{section.key('q')}: Q must be positive semidefinite, its smallest eigenvalue is {smallest:.3g}"
        )
    return matrix


def _finite(section: _Section, key: str, item: Any, type_name: Any) -> float:
    if isinstance(item, bool) or not isinstance(item, (int, Decimal)):
        section.bad(key, item, f"expected a number, got {type_name(item)}")
    try:
        number = float(item)
    except OverflowError:
        number = math.inf
    if not math.isfinite(number):
        section.bad(key, item, "must be a finite number")
    return number


def _read_equilibrium(section: _Section, links: int, one_of: Any, type_name: Any) -> str | list[float]:
    """ "upright", "hanging" or the dof angles [θ0, θ1, ...], each link at a multiple of π."""
    if not section.has("equilibrium"):
        return schema.DEFAULT_EQUILIBRIUM
    value = section.data["equilibrium"]
    dof = links + 1
    expected = f"{one_of(schema.EQUILIBRIA)}, or an array of {dof} angles [θ0, θ1, ...]"
    if isinstance(value, str):
        if value not in schema.EQUILIBRIA:
            section.bad("equilibrium", value, f"expected {expected}")
        return value
    if not isinstance(value, list):
        section.bad("equilibrium", value, f"expected {expected}, got {type_name(value)}")
    if len(value) != dof:
        section.reader.fail(
            f"{section.key('equilibrium')} has {len(value)} entries, "
            f"expected {dof} (θ0 and one angle per link)"
        )
    angles = [_finite(section, f"equilibrium[{i}]", item, type_name) for i, item in enumerate(value)]
    for i, angle in enumerate(angles[1:], start=1):
        if abs(math.remainder(angle, math.pi)) > 1e-9:
            section.bad(
                f"equilibrium[{i}]",
                value[i],
                "a link rests only upright (0) or hanging (π = 3.141592653589793, or any multiple of π)",
            )
    return angles
