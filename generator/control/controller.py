"""A feedback controller attached to a model: data only (how it is computed lives in control.py).

u = −K (x − x_eq), x = [θ; θ̇], optionally clipped to |u| ≤ saturation and held over sampling
periods; or (kind "mpc") the constrained nonlinear MPC of `mpc` (docs/mpc.md), its problem
resolved to numbers (`MpcDesign`). Scenes carry one (`[controller]`); the emit targets may print
it (the C header's `ipgen_<name>_control`).
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class MpcDesign:
    """A [controller] kind = "mpc" resolved: every number the C step (ipgen_mpc.h) takes, in
    ipgen's coordinates and the scene's unit of u (volts with a dc_motor). Matrices row-major."""

    horizon: int  # N
    substeps: int  # RK4 steps a sample
    Q: tuple[float, ...]  # nx², row-major
    R: float
    P: tuple[float, ...]  # nx², row-major (default: the discrete LQR's Riccati matrix)
    reference: tuple[float, ...]  # x_ref (nx)
    u_min: float
    u_max: float
    bounds: tuple[tuple[int, float, float], ...]  # hard: (state index, min, max)
    soft_bounds: tuple[tuple[int, float, float], ...]  # soft: (state index, min, max)
    soft_penalty: tuple[float, float]  # ρ1, ρ2
    mode: str  # "rti" | "converged"
    sqp_iterations: int
    cold_iterations: int
    qp_iterations: int
    sqp_tolerance: float
    qp_tolerance: float
    # The model the step predicts with (the C header prints them): the parameters the design used,
    # a motor folded in (`Pendulum.folded().params()`: m, l, delta, g, com, J, J_axial, tip), and
    # the force or torque on the base per unit of u (a dc_motor's gain; 1 otherwise).
    params: tuple[tuple[str, tuple[float, ...] | float], ...] = ()
    input_gain: float = 1.0
    barrier: float = 0.0  # > 0: each QP Newton steps on its log-barrier problem at this weight
    # "frozen": the Jacobians at each stage's start, discretised; "shifted": most kept from the last sample
    sensitivities: str = "exact"


@dataclass(frozen=True)
class Controller:
    kind: str  # "lqr" (K designed by ipgen), "gain" (K given in the scene) or "mpc"
    gain: tuple[float, ...]  # K, 2·dof entries, in the order of x = [θ0..θn, θ̇0..θ̇n]
    equilibrium: tuple[float, ...]  # x_eq, 2·dof entries
    saturation: float | None = None  # |u| ≤ saturation [N or N m, or `unit`]; None: unbounded
    period: float | None = None  # sampling period [s]; None: continuous
    unit: str = ""  # what u is, for comments ("" = the direct input: force [N] or torque [N m])
    # kind "mpc": the problem (in ipgen's coordinates); gain is then the discrete LQR's at the
    # reference with the same Q, R (what the unconstrained MPC is near it), saturation u_max,
    # equilibrium the reference, both in the scene's coordinates as for LQR.
    mpc: MpcDesign | None = None
