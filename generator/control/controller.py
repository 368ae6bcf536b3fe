"""A feedback controller attached to a model: data only (how it is computed lives in control.py).

u = −K (x − x_eq), x = [θ; θ̇], optionally clipped to |u| ≤ saturation and held over sampling
periods. Scenes carry one (`[controller]`); the emit targets may print it (the C header's
`ipgen_<name>_control`).
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Controller:
    kind: str  # "lqr" (K designed by ipgen) or "gain" (K given in the scene)
    gain: tuple[float, ...]  # K, 2·dof entries, in the order of x = [θ0..θn, θ̇0..θ̇n]
    equilibrium: tuple[float, ...]  # x_eq, 2·dof entries
    saturation: float | None = None  # |u| ≤ saturation [N or N m, or `unit`]; None: unbounded
    period: float | None = None  # sampling period [s]; None: continuous
    unit: str = ""  # what u is, for comments ("" = the direct input: force [N] or torque [N m])
