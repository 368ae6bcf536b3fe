"""The `[controller]` table of a scene: its own value rules, and its gain (`control.lqr`, or given).

    [controller]  kind = "lqr" | "gain" (required in the table): the gain K of u = −K (x − x_eq)
                      by LQR from q and r, or as given in `gain`;
                  gain = the 2·(links + 1) entries of K (kind = "gain" only, required there), in
                      the scene's coordinates and units of u (volts per rad with a dc_motor), e.g.
                      a policy trained with ipgen.gym (docs/gym.md);
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

The keys are declared in `schema.ControllerTable`; the checks a type cannot say are here
(`weights`, `equilibrium`, `relations`). The controller sets u, so it cannot be combined with
an `[input]` other than zero. Every problem is one line naming the file and the key.
"""

from __future__ import annotations

import math
from typing import Any

from pydantic import ValidationInfo

from ipgen.common import limits
from ipgen.control.controller import Controller
from ipgen.control.coordinates import Coordinates
from ipgen.scene.fields import format_number, one_of, type_name
from ipgen.scene.values import at, check_count, context_of, number, refuse, refuse_key

# Feedback controllers ([controller] kind) and the named equilibria they stabilise.
CONTROLLER_KINDS: tuple[str, ...] = ("lqr", "gain")
EQUILIBRIA: tuple[str, ...] = ("upright", "hanging")
DEFAULT_EQUILIBRIUM = "upright"
DEFAULT_R = 1.0  # LQR weight of u²; the default Q is the identity
# A sampling period and the output interval must be whole multiples of one another, to this
# relative tolerance, so that every sampling instant or every sample is a stop of the other.
COMMENSURATE_TOLERANCE = 1e-9

WEIGHTS_SCHEMA: dict[str, Any] = {
    "oneOf": [
        {"type": "array", "items": {"type": "number", "minimum": 0}, "minItems": 4},
        {"type": "array", "items": {"type": "array", "items": {"type": "number"}}, "minItems": 4},
    ]
}
EQUILIBRIUM_SCHEMA: dict[str, Any] = {
    "oneOf": [
        {"type": "string", "enum": list(EQUILIBRIA)},
        {"type": "array", "items": {"type": "number"}, "minItems": 2},
    ]
}


def _per_state(value: Any, info: ValidationInfo, expected: str) -> dict[str, Any] | None:
    """The context once `value` is an array of 2·(links + 1) entries (θ0.. then θ̇0..), or None
    before [system] is known; `expected` (with {size}) is the message for a non-array."""
    context = context_of(info, "count")
    if context is None:
        return None
    size = 2 * context["count"]
    if not isinstance(value, list):
        refuse(expected.format(size=size, type=type_name(value)))
    check_count(value, size, f"2 · (links + 1) = {size}: θ0.. then θ̇0..")
    return context


def weights(value: Any, info: ValidationInfo) -> list[list[float]] | list[float] | None:
    """q: diagonal weights (size numbers >= 0) or a symmetric positive semidefinite matrix."""
    context = _per_state(value, info, "expected an array of {size} weights or a {size} × {size} matrix")
    if context is None:
        return None
    if all(isinstance(row, list) for row in value) and value:
        return _matrix(value, len(value), context)
    return [at(i, _weight, item, context) for i, item in enumerate(value)]


def _weight(item: Any, context: dict[str, Any]) -> float:
    weight = number(item)
    if weight < 0:
        refuse("weights must be >= 0")
    return weight


def _matrix(rows: list[Any], size: int, context: dict[str, Any]) -> list[list[float]]:
    def row_of(row: list[Any], _: dict[str, Any]) -> list[float]:
        check_count(row, size, f"a {size} × {size} matrix")
        return [at(j, number, item, context) for j, item in enumerate(row)]

    matrix = [at(i, row_of, row, context) for i, row in enumerate(rows)]
    scale = max(1.0, max(abs(x) for row in matrix for x in row))
    for i in range(size):
        for j in range(i):
            if abs(matrix[i][j] - matrix[j][i]) > 1e-12 * scale:
                refuse_key(
                    f" = {matrix[i][j]:g} differs from q[{j}][{i}] = {matrix[j][i]:g}: Q must be symmetric",
                    index=(i, j),
                )
    import numpy as np

    smallest = float(np.min(np.linalg.eigvalsh(np.array(matrix))))
    if smallest < -1e-12 * scale:
        refuse_key(f": Q must be positive semidefinite, its smallest eigenvalue is {smallest:.3g}")
    return matrix


def gain_values(value: Any, info: ValidationInfo) -> list[float] | None:
    """gain: the 2·(links + 1) finite entries of K."""
    expected = "expected an array of the {size} entries of K (θ0.. then θ̇0..), got {type}"
    context = _per_state(value, info, expected)
    if context is None:
        return None
    return [at(i, number, item, context) for i, item in enumerate(value)]


def equilibrium(value: Any, info: ValidationInfo) -> str | list[float]:
    """ "upright", "hanging" or the dof angles [θ0, θ1, ...], each link at a multiple of π."""
    context = context_of(info, "count")
    if context is None:
        return "upright"
    dof = context["count"]
    expected = f"{one_of(EQUILIBRIA)}, or an array of {dof} angles [θ0, θ1, ...]"
    if isinstance(value, str):
        if value not in EQUILIBRIA:
            refuse(f"expected {expected}")
        return value
    if not isinstance(value, list):
        refuse(f"expected {expected}, got {type_name(value)}")
    check_count(value, dof, "θ0 and one angle per link")
    angles = [at(i, number, item, context) for i, item in enumerate(value)]
    for i, angle in enumerate(angles[1:], start=1):
        if abs(math.remainder(angle, math.pi)) > 1e-9:
            refuse(
                "a link rests only upright (0) or hanging (π = 3.141592653589793, or any multiple of π)",
                key="equilibrium",
                index=(i,),
                value=value[i],
            )
    return angles


def relations(table: Any, context: dict[str, Any]) -> None:
    """A gain given exactly for kind "gain"; no other input than zero; a period in (0, t_end],
    commensurate with the output sample."""
    given = table.model_fields_set
    if table.kind == "gain":
        if table.gain is None:
            refuse(
                'kind = "gain" runs the gain K you give: add gain = [...] (2 · (links + 1) entries)',
                key="kind",
                value=table.kind,
            )
        for key in ("q", "r") if given & {"q", "r"} else ():
            if key in given:
                refuse(
                    'weights the LQR design; kind = "gain" takes K as given: remove it',
                    key=key,
                    value=getattr(table, key),
                )
    elif "gain" in given:
        refuse(
            'is for kind = "gain"; kind = "lqr" computes K from q and r: remove gain or set kind = "gain"',
            key="gain",
            value=table.gain,
        )
    input_kind = context["input_kind"]
    if input_kind != "zero":
        refuse(
            f'the controller sets u, but [input] kind "{input_kind}" drives it too; '
            'remove [input] (or set kind = "zero")',
            key="kind",
            value=table.kind,
        )
    if table.period is None:
        return
    period, t_end, sample = float(table.period), context["t_end"], context["sample"]
    if not 0 < period <= t_end:
        refuse(f"must be > 0 s and <= t_end ({format_number(t_end)} s)", key="period", value=table.period)
    periods_within(table.period, t_end)
    if not _commensurate(period, sample):
        refuse(
            f"must be a whole multiple or a whole fraction of simulation.sample ({format_number(sample)} s)",
            key="period",
            value=table.period,
        )


def periods_within(period: Any, t_end: float, key: str = "period") -> None:
    """At most `limits.MAX_SAMPLES` controller periods in t_end (each is a stop of the integrator)."""
    if t_end / float(period) > limits.MAX_SAMPLES:
        refuse(
            f"t_end / period = {t_end / float(period):.3g} controller periods, more than the "
            f"{limits.MAX_SAMPLES:.0e} the simulator accepts: a longer period or a shorter t_end",
            key=key,
            value=period,
        )


def _commensurate(period: float, sample: float) -> bool:
    """True when period / sample or sample / period is a whole number (to a relative 1e-9)."""
    ratio = max(period, sample) / min(period, sample)
    return abs(ratio - round(ratio)) <= COMMENSURATE_TOLERANCE * ratio


class GainError(Exception):
    """No LQR gain for this scene (the message says why)."""


def controller(
    table: Any, system: Any, params: Any, actuator: Any = None, coordinates: Coordinates | None = None
) -> Controller:
    """The controller of a validated [controller] table, with its LQR gain or the gain it gives
    (raises `GainError`).

    In the rig's `coordinates` (default: ipgen's) the weights, an equilibrium given as angles,
    the gain and the equilibrium returned are in them; "upright" and "hanging" name the same
    physical state in any convention (its angles there follow the map, docs/model.md)."""
    import numpy as np

    from ipgen.control.linear import equilibrium_state

    frame = coordinates if coordinates is not None else Coordinates()
    gain = table.gain if table.kind == "gain" else _lqr_gain(table, system, params, actuator, frame)
    x_eq = equilibrium_state(system.links, table.equilibrium)  # angles as written: the rig's
    if isinstance(table.equilibrium, str) and not frame.is_canonical:
        x_eq = frame.to_user(x_eq, system.links)  # a named state, mapped
    return Controller(
        kind=table.kind,
        gain=tuple(float(k) for k in np.ravel(gain)),  # K is 1 x 2(n+1)
        equilibrium=tuple(float(x) for x in x_eq),
        saturation=None if table.saturation is None else float(table.saturation),
        period=None if table.period is None else float(table.period),
        unit=_unit(system, actuator),
    )


def _lqr_gain(table: Any, system: Any, params: Any, actuator: Any, frame: Coordinates) -> Any:
    """K by `control.lqr` from the table's weights, in the scene's coordinates and units of u."""
    from ipgen.control.linear import ControlError, lqr

    weights_ = table.q if table.q is not None else [1.0] * (2 * (system.links + 1))
    try:
        gain = lqr(
            system.type,
            system.links,
            params.m,
            params.l,
            params.delta,
            weights_,
            float(table.r),
            g=params.g,
            inertia=system.inertia,
            equilibrium=table.equilibrium,
            **dict(params.links),  # the links as built the scene gives (com, J, J_axial, tip)
            actuator=actuator,  # [actuator]: K in volts (dc_motor) or m/s², rad/s² (acceleration)
            angles=frame.angles,
            zero=frame.zero,
            positive=frame.positive,
        )
    except ControlError as exc:
        raise GainError(f"controller: no LQR gain: {exc}") from None
    return gain


def _unit(system: Any, actuator: Any) -> str:
    """What u is when it is not the force or torque ("" then)."""
    if actuator is not None and actuator.is_motor:
        return "motor voltage [V]"
    if actuator is not None and actuator.is_acceleration:
        return "base acceleration [rad/s^2]" if system.type == "rotary" else "base acceleration [m/s^2]"
    return ""
