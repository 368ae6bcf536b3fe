"""The feedback of a scene's [controller]: its LQR gain (`control.lqr`) or the gain it gives, in
the scene's coordinates and units of u (the table's keys and rules: `scene.controller`)."""

from __future__ import annotations

from typing import Any

from ipgen.control.controller import Controller
from ipgen.control.coordinates import Coordinates


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
