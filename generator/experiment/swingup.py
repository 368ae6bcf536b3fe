"""The swing-up of a scene's [swingup]: the energy law set up, or the trajectory planned, and the
gains computed (`control.swingup`; the table's keys and rules: `scene.swingup`)."""

from __future__ import annotations

from typing import Any

from ipgen.control.swingup import SwingUpLaw
from ipgen.model.actuator import DIRECT
from ipgen.model.pendulum import Pendulum
from ipgen.scene.fields import format_number
from ipgen.scene.swingup import ENERGY_KEYS


class SwingUpError(Exception):
    """No swing-up for this scene (the message says what to relax)."""


def law(table: Any, p: Pendulum, start: tuple[float, ...]) -> SwingUpLaw:
    """The swing-up of a validated [swingup] table for the scene's pendulum `p` from state `start`
    (ipgen's coordinates; raises `SwingUpError`).

    The law is designed on the direct model in ipgen's coordinates: with a dc_motor the folded one
    (`p.folded()`), in force units (u_max · b, b = `p.gain` the force or torque per volt), and
    returned in volts (`in_volts`); its messages then state the limits in volts (delta[0] includes
    the back-EMF, which the energy law's `design_speed` takes off a_max). With an acceleration
    input u is the base's acceleration (energy method only). The hold weights q are in the scene's
    coordinates (Q in ipgen's = Pᵀ Q P), r in the input's units (R / b² in force units)."""
    from ipgen.control.swingup import in_volts

    acceleration = p.actuator.is_acceleration
    if acceleration and table.method != "energy":
        raise SwingUpError(
            'swingup: method "trajectory" plans a force or torque, not yet an acceleration input: '
            'use method "energy" or [actuator] kind "direct"'
        )
    gain = p.gain if p.actuator.is_motor else 1.0
    direct = (p.folded() if p.actuator.is_motor else p.replace(actuator=DIRECT)).canonical()
    designed = _law(table, p, direct, start, float(table.u_max) * gain, gain)
    return designed if gain == 1.0 else in_volts(designed, gain)


def _law(
    table: Any, p: Pendulum, direct: Pendulum, start: tuple[float, ...], u_max: float, gain: float
) -> SwingUpLaw:
    from ipgen.control.casadi_model import plant
    from ipgen.control.energy import energy_swingup
    from ipgen.control.linear import ControlError
    from ipgen.control.swingup import energy_law, schedule_law, trajectory_swingup

    period, hold = float(table.period), float(table.hold)
    try:
        model = plant(direct)
        if table.method == "energy":
            keys = {key: getattr(table, key) for key in ENERGY_KEYS if getattr(table, key) is not None}
            constants: dict[str, Any] = {
                key: value if key in ("law", "q") else float(value) for key, value in keys.items()
            }
            if "q" in constants:
                import numpy as np

                weights = np.asarray(constants["q"], dtype=float)
                weights = np.diag(weights) if weights.ndim == 1 else weights
                to_canonical, _ = p.coordinates.matrices(p.links)
                weights = to_canonical.T @ weights @ to_canonical
                constants["q"] = weights
            if "r" in constants:
                constants["r"] /= gain**2
            planned = energy_swingup(
                model, u_max=u_max, period=period, acceleration=p.actuator.is_acceleration, **constants
            )
            return energy_law(planned, hold)
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
    return schedule_law(plan, schedule, hold, table.tracking or "lqr")
