"""Swing-up by trajectory: plan on the exact model, then track with time-varying LQR and hold.

`trajectory_swingup` chains `plan_swingup` (trajectory.py: CasADi + IPOPT collocation) and
`track` (tvlqr.py: discrete time-varying LQR at the controller period, then the discrete LQR
hold). The plan may be asked to keep a fraction `margin` of the input limit in reserve, so that
the feedback has authority left where the plan saturates; the controller clips to the full limit.
Energy control for single links is `energy.energy_swingup`.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

from ipgen.control.casadi_model import Plant
from ipgen.control.energy import EnergySwingUp, link_constants
from ipgen.control.trajectory import Plan, PlanError, finite_number, plan_swingup
from ipgen.control.tvlqr import GainSchedule, track, whole_periods
from ipgen.model.pendulum import Pendulum

if TYPE_CHECKING:
    import numpy as np

__all__ = ["SwingUpLaw", "energy_law", "in_volts", "schedule_law", "trajectory_swingup"]


def trajectory_swingup(
    plant: Plant | Pendulum,
    *,
    duration: float,
    u_max: float,
    x_max: float | None = None,
    period: float = 0.01,
    start: Sequence[float] | None = None,
    margin: float = 1.0,
    q: np.ndarray | Sequence[float] | None = None,
    r: float = 1e-4,
    intervals: int | None = None,
    input_gain: float = 1.0,
) -> tuple[Plan, GainSchedule]:
    """(plan, gain schedule) of a swing-up from `start` (default hanging at rest) to upright at
    rest in `duration` s, planned within |u| ≤ margin·u_max (0 < margin ≤ 1) and |θ0| ≤ margin·x_max,
    tracked every `period` s with |u| ≤ u_max. Raises `PlanError` (an `ipgen.Error`).
    `input_gain`: force or torque per unit of the rig's input (a dc_motor's b): messages state
    the input limit in the rig's units (u_max / input_gain, volts)."""
    margin_ = finite_number("margin", margin)
    if not 0 < margin_ <= 1:
        raise PlanError(f"margin = {margin!r}: expected a fraction of u_max in (0, 1]")
    u_limit = finite_number("u_max", u_max)
    duration_, period_ = finite_number("duration", duration), finite_number("period", period)
    if duration_ > 0 and period_ > 0:  # planning takes seconds: refuse what track would, first
        whole_periods(duration_, period_)
    try:
        plan = plan_swingup(
            plant,
            duration=duration,
            u_max=u_limit * margin_,
            x_max=None if x_max is None else finite_number("x_max", x_max) * margin_,
            start=start,
            intervals=intervals,
            input_gain=input_gain,
        )
    except PlanError as exc:
        if margin_ < 1:  # its limits are margin · u_max and margin · x_max, not the ones given
            raise PlanError(f"{exc} (planned within margin = {margin_:g} of u_max and x_max)") from None
        raise
    plan = dataclasses.replace(plan, u_max=u_limit)
    return plan, track(plan, period, q=q, r=r)


@dataclass(frozen=True)
class SwingUpLaw:
    """What a simulator or a C controller needs to run a swing-up scene (data only).

    Both methods sample every `period` s (zero-order hold) and clip to |u| ≤ u_max; the hold
    phase is the discrete LQR u = −hold_gain (x − target), stopped `hold` s after it begins.

    method "energy" (`energy.EnergySwingUp`): `energy` holds k_E, k_x, k_v, a_max, the catch
    angle and rate, E0 and the link energy's constants J = `energy_inertia` (about the pivot) and
    w = `energy_weight` (E = ½ J θ̇1² + w (cos θ1 − 1); energy.link_constants).
    method "trajectory" (`tvlqr.GainSchedule`): `inputs` ū_k (K), `states` x̄_k ((K+1) × 2·dof,
    flattened row by row), `gains` K_k (K × 2·dof, flattened); target = x̄_K.
    """

    method: str  # "energy" | "trajectory"
    u_max: float
    period: float
    hold: float  # s in the hold phase before the run ends
    hold_gain: tuple[float, ...]
    target: tuple[float, ...]
    energy: tuple[tuple[str, float], ...] = ()
    inputs: tuple[float, ...] = ()
    states: tuple[float, ...] = ()
    gains: tuple[float, ...] = ()
    plan_iterations: int = 0
    plan_time: float = 0.0  # s, IPOPT wall clock
    # The force or torque per unit of u: 1, or a dc_motor's b [N m/V or N/V] (`in_volts`): then
    # u_max, hold_gain, inputs and gains are in volts, and the energy law's force is divided by it.
    input_gain: float = 1.0
    # u is the base's acceleration ([actuator] kind "acceleration"): the energy law's a is u.
    base_acceleration: bool = False
    # rad: a hold that lets link 1 fall this far gives it back to the energy law (0: never)
    release_angle: float = 0.0
    # trajectory: what tracks the plan, "lqr" (the gains) or "mpc" (the scene's MPC, the plan its
    # reference per stage: ipgen_loop.h's track_law)
    tracking: str = "lqr"

    @property
    def steps(self) -> int:
        return len(self.inputs)


def energy_law(law: EnergySwingUp, hold: float) -> SwingUpLaw:
    """The `SwingUpLaw` of an energy controller (catch about θ1 = 0)."""
    plant = law.plant
    dof = plant.dof
    inertia, weight = link_constants(plant)
    constants = (
        ("gain_energy", law.gain_energy),
        ("gain_position", law.gain_position),
        ("gain_velocity", law.gain_velocity),
        ("accel_max", law.accel_max),
        ("catch_angle", law.catch_angle),
        ("catch_rate", law.catch_rate),
        ("energy_target", law.energy_target),
        ("energy_inertia", inertia),
        ("energy_weight", weight),
        # absent unless learning: the .cfg of a scene without it unchanged
        *((("energy_step", law.energy_step),) if law.energy_step > 0 else ()),
        *((("catch_deficit", law.catch_deficit),) if law.catch_deficit > 0 else ()),
        *((("catch_base", law.catch_base),) if law.catch_base > 0 else ()),
    )
    return SwingUpLaw(
        method="energy",
        u_max=law.u_max,
        period=law.period,
        hold=hold,
        hold_gain=tuple(float(k) for k in law.hold_gain.ravel()),
        target=(0.0,) * (2 * dof),
        energy=tuple((name, float(value)) for name, value in constants),
        base_acceleration=law.acceleration,
        release_angle=law.release_angle,
    )


def schedule_law(plan: Plan, schedule: GainSchedule, hold: float, tracking: str = "lqr") -> SwingUpLaw:
    """The `SwingUpLaw` of a planned swing-up tracked by `schedule` (`tracking` "lqr"), or by the
    scene's MPC with the plan as its reference ("mpc": the schedule's gains then unused)."""
    return SwingUpLaw(
        method="trajectory",
        u_max=schedule.u_max,
        period=schedule.period,
        hold=hold,
        hold_gain=tuple(float(k) for k in schedule.hold_gain.ravel()),
        target=tuple(float(v) for v in schedule.target),
        inputs=tuple(float(u) for u in schedule.inputs),
        states=tuple(float(v) for v in schedule.states.ravel()),
        gains=tuple(float(v) for v in schedule.gains.ravel()),
        plan_iterations=plan.iterations,
        plan_time=plan.solve_time,
        tracking=tracking,
    )


def in_volts(law: SwingUpLaw, gain: float) -> SwingUpLaw:
    """`law`, designed on the motor-folded model in force or torque units, with every u-valued
    number (u_max, hold gain, planned inputs, gain schedule) divided by the motor's gain b, so
    that u is the motor voltage (docs/model.md, "A DC motor on the base")."""
    return dataclasses.replace(
        law,
        u_max=law.u_max / gain,
        hold_gain=tuple(k / gain for k in law.hold_gain),
        inputs=tuple(u / gain for u in law.inputs),
        gains=tuple(k / gain for k in law.gains),
        input_gain=gain,
    )
