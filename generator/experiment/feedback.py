"""The feedback of a scene's [controller]: its LQR gain (`control.lqr`) or the gain it gives, in
the scene's coordinates and units of u (the table's keys and rules: `scene.controller`)."""

from __future__ import annotations

from typing import Any

from ipgen.control.controller import Controller
from ipgen.model.pendulum import Pendulum


class GainError(Exception):
    """No LQR gain for this scene (the message says why)."""


def controller(table: Any, p: Pendulum) -> Controller:
    """The controller of a validated [controller] table for the scene's pendulum `p`, with its LQR
    gain or the gain it gives (raises `GainError`).

    In the rig's coordinates (`p.coordinates`) the weights, an equilibrium given as angles, the
    gain and the equilibrium returned are in them; "upright" and "hanging" name the same physical
    state in any convention (its angles there follow the map, docs/model.md). K is in the units
    of u (`p.actuator`: volts for a dc_motor, m/s² or rad/s² for an acceleration input)."""
    import numpy as np

    from ipgen.control.linear import equilibrium_state

    frame = p.coordinates
    gain = table.gain if table.kind == "gain" else _lqr_gain(table, p)
    x_eq = equilibrium_state(p.links, table.equilibrium)  # angles as written: the rig's
    if isinstance(table.equilibrium, str) and not frame.is_canonical:
        x_eq = frame.to_user(x_eq, p.links)  # a named state, mapped
    return Controller(
        kind=table.kind,
        gain=tuple(float(k) for k in np.ravel(gain)),  # K is 1 x 2(n+1)
        equilibrium=tuple(float(x) for x in x_eq),
        saturation=None if table.saturation is None else float(table.saturation),
        period=None if table.period is None else float(table.period),
        unit=_unit(p),
    )


def _lqr_gain(table: Any, p: Pendulum) -> Any:
    """K by `control.lqr` from the table's weights (default: identity)."""
    from ipgen.control.linear import ControlError, lqr

    weights = table.q if table.q is not None else [1.0] * (2 * p.dof)
    try:
        return lqr(p, weights, float(table.r), equilibrium=table.equilibrium)
    except ControlError as exc:
        raise GainError(f"controller: no LQR gain: {exc}") from None


def _unit(p: Pendulum) -> str:
    """What u is when it is not the force or torque ("" then)."""
    if p.actuator.is_motor:
        return "motor voltage [V]"
    if p.actuator.is_acceleration:
        return "base acceleration [rad/s^2]" if p.is_rotary else "base acceleration [m/s^2]"
    return ""
