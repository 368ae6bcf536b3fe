"""The `[swingup]` table of a scene: its value rules, and the plan and gains it needs.

    [swingup]  method = "energy" (a single link: Åström–Furuta energy control, then LQR catch)
                        | "trajectory" (any n: a plan on the exact model, tracked by TVLQR);
               u_max = the input limit [N or N m], > 0 (required);
               x_max = cart travel [m] or arm angle [rad] limit of the plan (trajectory only);
               duration = the manoeuvre's time [s] (trajectory only, required there);
               period = controller sampling [s] (default 0.01), commensurate with sample;
               hold = s upright after arrival, then the run ends (default 2).

The scene's initial state is where the swing-up starts (no [initial] table: every link hanging
at rest). The keys are declared in `schema.SwingupTable`; `relations` checks what a type cannot
say; `law` plans (trajectory) or sets up the energy law, and computes the gains
(`control.swingup`). Every problem is one line naming the key and the fix.
"""

from __future__ import annotations

import math
from typing import Any

from ipgen.control.swingup import SwingUpLaw
from ipgen.scene.controller import periods_within
from ipgen.scene.fields import format_number
from ipgen.scene.values import refuse

METHODS: tuple[str, ...] = ("energy", "trajectory")
LAWS: tuple[str, ...] = ("energy", "proportional")  # = control.energy.LAWS (checked by a test)
# The energy law's constants, each a key of [swingup] (method "energy" only) and an argument of
# control.energy.energy_swingup; absent = that function's default (docs/swingup.md).
ENERGY_KEYS: tuple[str, ...] = (
    "law",
    "gain_energy",
    "accel_max",
    "design_speed",
    "energy_target",
    "catch_angle",
    "catch_rate",
    "gain_position",
    "gain_velocity",
    "q",
    "r",
)
DEFAULT_PERIOD = 0.01
DEFAULT_HOLD = 2.0
COMMENSURATE_TOLERANCE = 1e-9


class SwingUpError(Exception):
    """No swing-up for this scene (the message says what to relax)."""


def relations(table: Any, context: dict[str, Any]) -> None:
    """Keys by method, no [controller] or driving [input], the period against t_end and sample."""
    if context.get("controller"):
        refuse(
            "a swing-up scene has its own controller (the hold LQR); remove the [controller] table",
            key="method",
            value=table.method,
        )
    input_kind = context.get("input_kind", "zero")
    if input_kind != "zero":
        refuse(
            f'the swing-up sets u, but [input] kind "{input_kind}" drives it too; remove [input]',
            key="method",
            value=table.method,
        )
    if table.method == "energy":
        if context.get("links", 1) != 1:
            refuse(
                f"energy control swings up a single link, this system has {context['links']}; "
                'use method = "trajectory"',
                key="method",
                value=table.method,
            )
        for key in ("duration", "x_max", "margin"):
            if getattr(table, key) is not None:
                refuse('is for method = "trajectory" only; remove it', key=key, value=getattr(table, key))
    else:
        for key in ENERGY_KEYS:
            if getattr(table, key) is not None:
                refuse('is for method = "energy" only; remove it', key=key, value=getattr(table, key))
    if table.method == "trajectory" and table.duration is None:
        refuse(
            'method = "trajectory" needs duration = the manoeuvre\'s time in s',
            key="method",
            value=table.method,
        )
    t_end, sample = context.get("t_end", math.inf), context.get("sample", DEFAULT_PERIOD)
    period = float(table.period)
    if not period <= t_end:
        refuse(f"must be <= t_end ({format_number(t_end)} s)", key="period", value=table.period)
    periods_within(table.period, t_end)
    ratio = max(period, sample) / min(period, sample)
    if abs(ratio - round(ratio)) > COMMENSURATE_TOLERANCE * ratio:
        refuse(
            f"must be a whole multiple or a whole fraction of simulation.sample ({format_number(sample)} s)",
            key="period",
            value=table.period,
        )
    if table.duration is not None and float(table.duration) > t_end:
        refuse(
            f"the manoeuvre must fit in t_end ({format_number(t_end)} s): "
            "a longer t_end or a shorter duration",
            key="duration",
            value=table.duration,
        )
    if table.duration is not None and float(table.duration) / period > 20_000:
        refuse(
            "is more than 20000 controller periods: a shorter duration or a longer period",
            key="duration",
            value=table.duration,
        )


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
