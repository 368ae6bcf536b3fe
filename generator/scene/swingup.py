"""The `[swingup]` table's rules that a type cannot say (`relations`); its keys are declared in
`schema.SwingupTable`, its plan designed by `experiment.swingup`. Without an [initial] table the
swing-up starts with every link hanging at rest. Every problem is one line naming the key and the fix.
"""

from __future__ import annotations

import math
from typing import Any

from ipgen.scene.controller import sampling_period
from ipgen.scene.fields import format_number
from ipgen.scene.values import refuse

METHODS: tuple[str, ...] = ("energy", "trajectory")
TRACKINGS: tuple[str, ...] = ("lqr", "mpc")  # what tracks a plan: its gain schedule, or the MPC
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
    "release_angle",
    "energy_step",
    "catch_deficit",
    "catch_base",
    "gain_position",
    "gain_velocity",
    "q",
    "r",
)
DEFAULT_PERIOD = 0.01
DEFAULT_CATCH_ANGLE = 0.3  # rad: = control.energy.energy_swingup's default (checked by a test)
DEFAULT_HOLD = 2.0


def relations(table: Any, context: dict[str, Any]) -> None:
    """Keys by method, no [controller] but an MPC (which then catches and holds, every controller
    period: a whole multiple of the swing-up's) or driving [input], the period against t_end and
    sample."""
    mpc = context.get("controller_kind") == "mpc"
    if context.get("controller") and not mpc:
        refuse(
            "a swing-up scene has its own controller (the hold LQR); remove the [controller] table "
            '(or make it kind = "mpc": the MPC then catches and holds)',
            key="method",
            value=table.method,
        )
    if mpc and context.get("controller_period") is not None:
        controller_period = context["controller_period"]
        ratio = float(controller_period) / float(table.period)
        if not (round(ratio) >= 1 and abs(ratio - round(ratio)) <= 1e-9 * ratio):
            refuse(
                f"must divide the MPC's [controller] period ({format_number(controller_period)} s) "
                "a whole number of times: the MPC holds from the catch on, every controller period",
                key="period",
                value=table.period,
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
        for key in ("duration", "x_max", "margin", "tracking"):
            if getattr(table, key) is not None:
                refuse('is for method = "trajectory" only; remove it', key=key, value=getattr(table, key))
        catch = DEFAULT_CATCH_ANGLE if table.catch_angle is None else float(table.catch_angle)
        if table.release_angle is not None and not float(table.release_angle) > catch:
            refuse(
                f"must be more than catch_angle ({format_number(catch)} rad): the hold would give back "
                "the link it has just caught",
                key="release_angle",
                value=table.release_angle,
            )
    else:
        for key in ENERGY_KEYS:
            if getattr(table, key) is not None:
                refuse('is for method = "energy" only; remove it', key=key, value=getattr(table, key))
    if table.tracking == "mpc" and not mpc:
        refuse(
            'tracking = "mpc" needs a [controller] with kind = "mpc" (the MPC that tracks the plan); '
            'add one or remove tracking',
            key="tracking",
            value=table.tracking,
        )
    if table.method == "trajectory" and table.duration is None:
        refuse(
            'method = "trajectory" needs duration = the manoeuvre\'s time in s',
            key="method",
            value=table.method,
        )
    t_end, sample = context.get("t_end", math.inf), context.get("sample", DEFAULT_PERIOD)
    sampling_period(table.period, t_end, sample)
    period = float(table.period)
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
