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
from typing import TYPE_CHECKING

from ipgen.control.casadi_model import Plant
from ipgen.control.trajectory import Plan, PlanError, finite_number, plan_swingup
from ipgen.control.tvlqr import GainSchedule, track

if TYPE_CHECKING:
    import numpy as np

__all__ = ["trajectory_swingup"]


def trajectory_swingup(
    plant: Plant,
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
) -> tuple[Plan, GainSchedule]:
    """(plan, gain schedule) of a swing-up from `start` (default hanging at rest) to upright at
    rest in `duration` s, planned within |u| ≤ margin·u_max (0 < margin ≤ 1) and |θ0| ≤ x_max,
    tracked every `period` s with |u| ≤ u_max. Raises `PlanError` (an `ipgen.Error`)."""
    margin_ = finite_number("margin", margin)
    if not 0 < margin_ <= 1:
        raise PlanError(f"margin = {margin!r}: expected a fraction of u_max in (0, 1]")
    u_limit = finite_number("u_max", u_max)
    plan = plan_swingup(
        plant,
        duration=duration,
        u_max=u_limit * margin_,
        x_max=x_max,
        start=start,
        intervals=intervals,
    )
    plan = dataclasses.replace(plan, u_max=u_limit)
    return plan, track(plan, period, q=q, r=r)
