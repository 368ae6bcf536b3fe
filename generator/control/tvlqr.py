"""Tracking a swing-up plan: a discrete time-varying LQR at the controller period, then LQR hold.

The controller samples the state every `period` seconds (t_k = k·period) and holds u until the
next sample, as ipgen's sampled-data loop does. Along the plan, the nominal state is the plan's
x(t_k) and the nominal input ū_k the plan's mean input over [t_k, t_k+1). The discretised
linearisation

    x_k+1 − x̄_k+1 ≈ A_k (x_k − x̄_k) + B_k (u_k − ū_k),   A_k = ∂F/∂x, B_k = ∂F/∂u at (x̄_k, ū_k),

takes the exact Jacobians (CasADi's automatic differentiation) of the flow map F over one period
(RK4 on ipgen's exact model, `CasadiModel.flow_map`). The gains come from the backward Riccati
recursion

    K_k = (R + B_kᵀ P_k+1 B_k)⁻¹ B_kᵀ P_k+1 A_k,   P_k = Q + A_kᵀ P_k+1 (A_k − B_k K_k),

started from P_K = the discrete algebraic Riccati solution at the target (scipy's
`solve_discrete_are` on the same flow map's Jacobians, u = 0): the schedule thus ends exactly in
the hold gain, the discrete LQR u = −K_hold (x − x_target) that keeps the pendulum upright after
the plan. (A scene's `[controller]` uses `ipgen.lqr`'s continuous gain held over the period; for
the hold after a swing-up the discrete gain is the one that is optimal for the held input, and it
differs from the continuous one by O(period).)
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from ipgen.control.casadi_model import Plant, casadi_model, rk4_substeps, rk4_unstable_mode
from ipgen.control.linear import ControlError, discrete_lqr_gain, linearize, weights
from ipgen.control.trajectory import Plan, PlanError, finite_number

if TYPE_CHECKING:
    import numpy as np

__all__ = ["GainSchedule", "discrete_lqr", "riccati_recursion", "track", "whole_periods"]


@dataclass(frozen=True)
class GainSchedule:
    """Nominal states, inputs and gains at the sampling instants t_k = k·period, k = 0..K−1,
    and the hold gain after them. u_k = ū_k − K_k (x_k − x̄_k) for k < K, then
    u = −K_hold (x − x_target); both clipped to |u| ≤ u_max."""

    period: float
    states: np.ndarray  # K+1 × 2·dof: x̄_0..x̄_K (x̄_K the target)
    inputs: np.ndarray  # K: ū_k
    gains: np.ndarray  # K × 2·dof
    hold_gain: np.ndarray  # 2·dof
    terminal_cost: np.ndarray  # P_K (the DARE solution at the target)
    u_max: float
    a: np.ndarray  # K × 2·dof × 2·dof: A_k
    b: np.ndarray  # K × 2·dof: B_k

    @property
    def steps(self) -> int:
        return len(self.inputs)

    @property
    def target(self) -> np.ndarray:
        return self.states[-1]

    def control(self, k: int, x: np.ndarray) -> tuple[float, str]:
        """(u, phase) at sampling instant k from the measured state x; phase "track" or "hold"."""
        import numpy as np

        if k < self.steps:
            u = self.inputs[k] - float(self.gains[k] @ (np.asarray(x, float) - self.states[k]))
            phase = "track"
        else:
            u = -float(self.hold_gain @ (np.asarray(x, float) - self.target))
            phase = "hold"
        return float(np.clip(u, -self.u_max, self.u_max)), phase


def riccati_recursion(
    a: np.ndarray, b: np.ndarray, q: np.ndarray, r: np.ndarray, terminal: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """(K_0..K_K−1, P_0) of the backward Riccati recursion for x_k+1 = A_k x_k + B_k u_k
    minimising Σ x_kᵀ Q x_k + u_kᵀ R u_k + x_Kᵀ P_K x_K; `a` is K × n × n, `b` K × n × m."""
    import numpy as np

    steps = a.shape[0]
    p = np.asarray(terminal, float)
    gains = np.zeros((steps, b.shape[2], a.shape[1]))
    for k in range(steps - 1, -1, -1):
        ak, bk = a[k], b[k]
        pb = p @ bk
        gain = np.linalg.solve(r + bk.T @ pb, pb.T @ ak)
        gains[k] = gain
        p = q + ak.T @ p @ (ak - bk @ gain)
        p = 0.5 * (p + p.T)
    return gains, p


def _flow_jacobians_at_rest(plant: Plant, period: float, target: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(A_d, B_d) of `CasadiModel.flow_map(period)` at `target`, u = 0.

    At an equilibrium every RK4 stage is evaluated at the target itself, so the Jacobian of the
    RK4 flow is RK4 applied to the linear model (A, B): per substep Φ = Σ_{k≤4} (hA)^k/k! and
    Γ = h Σ_{k≤3} (hA)^k/(k+1)! B. That is the same map as differentiating the unrolled flow,
    in matrix products instead of a graph whose size grows with period/1 ms (a 3 s period took
    12 s to build). Away from an equilibrium the unrolled flow is differentiated as before."""
    import numpy as np

    model = casadi_model(plant)
    xdot, a_c, b_c = model.state_jacobians()(target, 0.0)
    if np.max(np.abs(np.asarray(xdot, dtype=float))) > 1e-12:
        _, ad, bd = model.flow_jacobians(period)(target, 0.0)
        return np.asarray(ad, dtype=float), np.asarray(bd, dtype=float).reshape(-1, 1)
    substeps = rk4_substeps(period)
    h = period / substeps
    ha = h * np.asarray(a_c, dtype=float)
    eye = np.eye(ha.shape[0])
    phi = eye + ha @ (eye + ha @ (eye / 2 + ha @ (eye / 6 + ha / 24)))
    gamma = (
        h * (eye + ha @ (eye / 2 + ha @ (eye / 6 + ha / 24))) @ np.asarray(b_c, dtype=float).reshape(-1, 1)
    )
    ad, bd = eye, np.zeros_like(gamma)
    for _ in range(substeps):
        ad, bd = phi @ ad, phi @ bd + gamma
    return ad, bd


def _check_rk4_stable(a: np.ndarray, period: float) -> None:
    """A ControlError unless the planner's RK4 steps over `period` (`rk4_substeps`) keep every
    mode of the linear model `a` that does not grow from growing: a stiff one (heavy damping on a
    light body) made the sampled model grow 1e195-fold where the rig's grows 46-fold."""
    step = period / rk4_substeps(period)
    worst = rk4_unstable_mode(a, step)
    if worst is not None:
        raise ControlError(
            f"the model's mode at s = {worst:.4g} 1/s is too fast for the planner's RK4 steps of {step:g} s "
            "(RK4 needs |h s| below about 2.8): check the parameters' units (a link of micrometres, or "
            "damping far beyond a light body's inertia)"
        )


def discrete_lqr(
    plant: Plant, period: float, q: np.ndarray, r: np.ndarray, target: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(K, P, A_d, B_d): the discrete LQR about the upright `target` at rest, u held over `period`
    (A_d, B_d the exact Jacobians of the one-period flow map; P from scipy's DARE)."""
    import numpy as np

    # The continuous linear model at the target (the links as built): the RK4 steps' stability,
    # then stabilisability and detectability are checked on it.
    dof = plant.dof
    system = plant.system
    links: dict[str, Any] = plant.links_as_built  # Any: the keywords of linearize's overloads differ
    a_c, b_c = linearize(
        system.type, system.links, plant.m, plant.l, plant.delta, plant.g, system.inertia,
        q=target[:dof], qd=target[dof:], **links,
    )  # fmt: skip
    _check_rk4_stable(a_c, period)
    ad, bd = _flow_jacobians_at_rest(plant, period, target)
    if not (np.all(np.isfinite(ad)) and np.all(np.isfinite(bd))):
        raise ControlError(
            f"the sampled linear model over {period:g} s overflows a double: check the parameters' units"
        )
    gain, p = discrete_lqr_gain((ad, bd), (a_c, b_c), q, r, period)
    return gain.reshape(-1), p, ad, bd


def whole_periods(duration: float, period: float) -> int:
    """The number of `period`s in `duration`; a PlanError unless it is a whole number >= 1 (to a
    relative 1e-6), as a plan tracked every period must be."""
    steps_f = duration / period
    steps = round(steps_f)
    if steps < 1 or abs(steps_f - steps) > 1e-6 * max(1.0, steps_f):
        raise PlanError(
            f"duration {duration:g} s is not a whole multiple of period = {period:g} s; "
            "choose a duration of k·period"
        )
    return steps


def track(
    plan: Plan,
    period: float = 0.01,
    q: np.ndarray | list[float] | None = None,
    r: float = 1e-4,
) -> GainSchedule:
    """The time-varying LQR that tracks `plan` sampled every `period` seconds, and its hold gain.

    `q` (2·dof diagonal weights or a matrix, default all ones) and `r` (weight of u², default
    1e-4: tight tracking, the plan already spends the input) weight the deviation from the plan
    and the input correction, as in `ipgen.lqr`; the hold gain uses the same weights. The plan's
    duration must be a whole multiple of `period`.
    """
    import numpy as np

    period_ = finite_number("period", period)
    if period_ <= 0:
        raise PlanError(f"period = {period_}: expected a sampling period > 0 s (e.g. 0.01)")
    steps = whole_periods(plan.duration, period_)
    dof = plan.plant.dof
    weights_q, weights_r = weights(np.ones(2 * dof) if q is None else q, r, 2 * dof)
    target = plan.states[-1]
    hold_gain, terminal, _, _ = discrete_lqr(plan.plant, period_, weights_q, weights_r, target)
    times = np.arange(steps + 1) * period_
    states = np.array([plan.state(t) for t in times])
    states[-1] = target
    inputs = np.array([plan.input_average(times[k], times[k + 1]) for k in range(steps)])
    jac = casadi_model(plan.plant).flow_jacobians(period_).map(steps)
    _, a_all, b_all = jac(states[:-1].T, inputs.reshape(1, -1))
    n = 2 * dof
    a = np.asarray(a_all, dtype=float).reshape(n, steps, n).transpose(1, 0, 2)
    b = np.asarray(b_all, dtype=float).reshape(n, steps, 1).transpose(1, 0, 2)
    gains, _ = riccati_recursion(a, b, weights_q, weights_r, terminal)
    return GainSchedule(
        period=period_,
        states=states,
        inputs=inputs,
        gains=gains[:, 0, :],
        hold_gain=hold_gain,
        terminal_cost=terminal,
        u_max=plan.u_max,
        a=a,
        b=b[:, :, 0],
    )
