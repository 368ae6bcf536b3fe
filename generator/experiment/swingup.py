"""The swing-up of a scene's [swingup]: the energy law set up, or the trajectory planned, and the
gains computed (`control.swingup`; the table's keys and rules: `scene.swingup`)."""

from __future__ import annotations

from typing import Any

from ipgen.control.swingup import SwingUpLaw
from ipgen.scene.fields import format_number
from ipgen.scene.swingup import ENERGY_KEYS


class SwingUpError(Exception):
    """No swing-up for this scene (the message says what to relax)."""


def law(
    table: Any,
    system: Any,
    params: Any,
    start: tuple[float, ...],
    gain: float = 1.0,
    acceleration: bool = False,
    coordinates: Any = None,
) -> SwingUpLaw:
    """The swing-up of a validated [swingup] table from state `start` (raises `SwingUpError`).
    `gain`: a dc_motor's force or torque per volt b, `params` then the motor-folded ones; the
    law is designed in force units (u_max b) and returned in volts (`in_volts`); its messages
    state the limits in volts (`params.delta[0]` then includes the back-EMF, which the energy
    law's `design_speed` takes off a_max).
    `acceleration`: u is the base's acceleration (energy method only).
    `coordinates`: the scene's (`model.coordinates.Coordinates`, default ipgen's): the hold
    weights q are in them (Q in ipgen's = Pᵀ Q P), r in the input's units (R / b² in force units)."""
    from ipgen.control.swingup import in_volts

    if acceleration and table.method != "energy":
        raise SwingUpError(
            'swingup: method "trajectory" plans a force or torque, not yet an acceleration input: '
            'use method "energy" or [actuator] kind "direct"'
        )
    designed = _law(table, system, params, start, float(table.u_max) * gain, acceleration, gain, coordinates)
    return designed if gain == 1.0 else in_volts(designed, gain)


def _law(
    table: Any,
    system: Any,
    params: Any,
    start: tuple[float, ...],
    u_max: float,
    acceleration: bool,
    gain: float,
    coordinates: Any,
) -> SwingUpLaw:
    from ipgen.control.casadi_model import plant
    from ipgen.control.energy import energy_swingup
    from ipgen.control.linear import ControlError
    from ipgen.control.swingup import energy_law, schedule_law, trajectory_swingup

    period, hold = float(table.period), float(table.hold)
    try:
        model = plant(
            system.type,
            system.links,
            params.m,
            params.l,
            params.delta,
            params.g,
            system.inertia,
            **dict(params.links),
        )
        if table.method == "energy":
            keys = {key: getattr(table, key) for key in ENERGY_KEYS if getattr(table, key) is not None}
            constants: dict[str, Any] = {
                key: value if key in ("law", "q") else float(value) for key, value in keys.items()
            }
            if "q" in constants:
                import numpy as np

                weights = np.asarray(constants["q"], dtype=float)
                weights = np.diag(weights) if weights.ndim == 1 else weights
                if coordinates is not None:
                    p, _ = coordinates.matrices(system.links)
                    weights = p.T @ weights @ p
                constants["q"] = weights
            if "r" in constants:
                constants["r"] /= gain**2
            return energy_law(
                energy_swingup(model, u_max=u_max, period=period, acceleration=acceleration, **constants),
                hold,
            )
        plan, schedule = trajectory_swingup(
            model,
            duration=float(table.duration),
            u_max=u_max,
            x_max=None if table.x_max is None else float(table.x_max),
            period=period,
            start=start,
            margin=1.0 if table.margin is None else float(table.margin),
            input_gain=gain,
        )
    except ControlError as exc:
        raise SwingUpError(f"swingup: {exc}") from None
    except ValueError as exc:  # numpy's LinAlgError: the hold LQR has no solution at this period
        if type(exc).__name__ != "LinAlgError":
            raise
        raise SwingUpError(
            f"swingup: no hold gain at period = {format_number(period)} s "
            f"({' '.join(str(exc).split())[:80]}): use a shorter period or other weights q, r"
        ) from None
    return schedule_law(plan, schedule, hold)
