"""Swing-up: the CasADi model against the sympy one, the plan's defects by re-integration, the
time-varying LQR against independent Riccati solutions, and closed loops ending upright.

Independent references: `ipgen.control.linear.dynamics` (sympy lambdified onto numpy) for the
model, scipy's `solve_ivp` for every re-integration, scipy's `expm` and `solve_discrete_are` and a
batch least-squares solution for the gains. The closed loops run on `swingup_reference.simulate`
(solve_ivp on the sympy model, zero-order hold at the controller period).
"""

from __future__ import annotations

import math
from functools import cache

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.linalg import expm, solve_discrete_are
from swingup_reference import simulate

pytest.importorskip("casadi")

from ipgen.control.casadi_model import casadi_model, plant
from ipgen.control.energy import energy_swingup, link_energy
from ipgen.control.linear import dynamics, linearize
from ipgen.control.swingup import trajectory_swingup
from ipgen.control.trajectory import plan_swingup
from ipgen.control.tvlqr import riccati_recursion, track

# Upright and at rest: link angles within ANGLE of a multiple of 2π, base within BASE, rates within RATE.
ANGLE, BASE, RATE = 1e-2, 5e-2, 5e-2

# (type, links, duration [s], u_max, x_max) of the paper's rigs extended with equal links.
CASES = {
    "classical1": ("classical", 1, 2.0, 20.0, 1.0),
    "rotary1": ("rotary", 1, 2.0, 5.0, None),
    "classical2": ("classical", 2, 3.0, 50.0, 1.0),
    "rotary2": ("rotary", 2, 3.0, 10.0, None),
    "classical3": ("classical", 3, 3.5, 50.0, 1.0),
}


def paper_plant(kind: str, links: int):
    """CDIP (classical) / RSIP (rotary) parameters of the paper, extended with equal links."""
    if kind == "classical":
        return plant(kind, links, [0.3] + [0.275] * links, [0.0] + [0.5] * links, [0.3] + [0.1] * links)
    return plant(kind, links, [0.5] + [0.275] * links, [0.6] + [0.5] * links, [0.3] + [0.011458] * links)


def hanging(links: int) -> np.ndarray:
    x = np.zeros(2 * (links + 1))
    x[1 : links + 1] = math.pi
    return x


def assert_upright_at_rest(x: np.ndarray) -> None:
    dof = x.size // 2
    links = np.array([math.remainder(a, 2 * math.pi) for a in x[1:dof]])
    assert abs(x[0]) <= BASE, f"base at {x[0]:.3g}"
    assert np.all(np.abs(links) <= ANGLE), f"links at {links}"
    assert np.all(np.abs(x[dof:]) <= RATE), f"rates {x[dof:]}"


@pytest.mark.parametrize(("kind", "links", "inertia"), [("classical", 2, "pivot"), ("rotary", 2, "full")])
def test_casadi_model_matches_the_sympy_model(kind: str, links: int, inertia: str) -> None:
    p = plant(kind, links, [0.4, 0.3, 0.2], [0.6, 0.5, 0.4], [0.3, 0.05, 0.02], inertia=inertia)
    model = casadi_model(p)
    reference = dynamics(p.system)
    rng = np.random.default_rng(1)
    for _ in range(5):
        q, qd, u = rng.normal(size=3), rng.normal(size=3), float(rng.normal())
        qdd = np.asarray(model.acceleration(q, qd, u), float).reshape(-1)
        np.testing.assert_allclose(
            qdd, reference.forward_dynamics(q, qd, u, p.params), rtol=1e-10, atol=1e-10
        )
        residual = np.asarray(model.residual(q, qd, qdd, u), float)
        assert np.max(np.abs(residual)) < 1e-10


def test_flow_map_jacobians_match_the_exact_zero_order_hold_discretisation() -> None:
    """At upright the discretised map's Jacobians are e^{Ah} and ∫e^{As} ds B of ipgen.linearize."""
    p = paper_plant("rotary", 2)
    h = 0.01
    a, b = linearize("rotary", 2, p.m, p.l, p.delta)
    n = a.shape[0]
    augmented = np.zeros((n + 1, n + 1))
    augmented[:n, :n], augmented[:n, n:] = a * h, b * h
    exact = expm(augmented)
    _, ad, bd = casadi_model(p).flow_jacobians(h)(np.zeros(n), 0.0)
    np.testing.assert_allclose(np.asarray(ad), exact[:n, :n], atol=1e-9)
    np.testing.assert_allclose(np.asarray(bd).reshape(-1), exact[:n, n], atol=1e-9)


@pytest.mark.parametrize(
    "kind, links, period", [("rotary", 2, 0.01), ("classical", 2, 0.0237), ("rotary", 1, 0.2)]
)
def test_hold_jacobians_at_rest_equal_the_unrolled_flows(kind: str, links: int, period: float) -> None:
    """discrete_lqr's shortcut at an equilibrium (RK4 of the linear model, matrix products) is
    the Jacobian of the unrolled RK4 flow that CasADi differentiates, to rounding."""
    from ipgen.control.tvlqr import _flow_jacobians_at_rest

    p = paper_plant(kind, links)
    n = 2 * p.dof
    ad, bd = _flow_jacobians_at_rest(p, period, np.zeros(n))
    _, ad0, bd0 = casadi_model(p).flow_jacobians(period)(np.zeros(n), 0.0)
    np.testing.assert_allclose(ad, np.asarray(ad0), rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(bd, np.asarray(bd0).reshape(-1, 1), rtol=1e-12, atol=1e-12)


@pytest.fixture(scope="module")
def rotary1_plan():
    kind, links, duration, u_max, x_max = CASES["rotary1"]
    return plan_swingup(paper_plant(kind, links), duration=duration, u_max=u_max, x_max=x_max)


def _largest_defect(plan) -> float:
    """Re-integrate every interval from its start knot with the plan's input (sympy model,
    DOP853) and return the largest distance to the next knot."""
    p = plan.plant
    dof = p.dof
    reference = dynamics(p.system)
    worst = 0.0
    for k in range(plan.intervals):
        t0, t1 = plan.times[k], plan.times[k + 1]

        def rhs(t: float, x: np.ndarray, t0: float = t0, t1: float = t1) -> np.ndarray:
            u = plan.input(min(max(t, t0), t1 - 1e-12))
            return np.concatenate([x[dof:], reference.forward_dynamics(x[:dof], x[dof:], u, p.params)])

        end = solve_ivp(rhs, (t0, t1), plan.states[k], method="DOP853", rtol=1e-10, atol=1e-12).y[:, -1]
        worst = max(worst, float(np.max(np.abs(end - plan.states[k + 1]))))
    return worst


@pytest.mark.parametrize("case", ["classical1", "rotary1"])
def test_plan_meets_its_limits_and_its_dynamics_by_reintegration(case: str) -> None:
    """Defects are small and shrink like Hermite–Simpson's truncation error (≥ 6x per halving
    of h; a wrong term in the model would leave an O(1) defect that refinement cannot remove)."""
    kind, links, duration, u_max, x_max = CASES[case]
    p = paper_plant(kind, links)
    plan = plan_swingup(p, duration=duration, u_max=u_max, x_max=x_max, intervals=40)
    dof = links + 1
    np.testing.assert_allclose(plan.states[0], hanging(links), atol=1e-9)
    np.testing.assert_allclose(plan.states[-1], np.zeros(2 * dof), atol=1e-9)
    assert np.max(np.abs(np.r_[plan.inputs, plan.mid_inputs])) <= u_max * (1 + 1e-6)
    assert x_max is None or np.max(np.abs(plan.states[:, 0])) <= x_max * (1 + 1e-6)
    worst = _largest_defect(plan)
    scale = float(np.max(np.abs(plan.states)))
    assert worst <= 2e-3 * scale, f"largest defect {worst:.3g} against states up to {scale:.3g}"
    finer = _largest_defect(plan_swingup(p, duration=duration, u_max=u_max, x_max=x_max, intervals=80))
    assert finer <= worst / 6, f"defect {worst:.3g} at 40 intervals, {finer:.3g} at 80"


def test_riccati_recursion_converges_to_scipys_discrete_are() -> None:
    """Time-invariant: the backward recursion at upright tends to solve_discrete_are's P."""
    p = paper_plant("classical", 2)
    h = 0.01
    _, ad, bd = casadi_model(p).flow_jacobians(h)(np.zeros(6), 0.0)
    ad, bd = np.asarray(ad), np.asarray(bd).reshape(6, 1)
    q, r = np.eye(6), np.eye(1)
    steps = 4000
    gains, p0 = riccati_recursion(np.repeat(ad[None], steps, 0), np.repeat(bd[None], steps, 0), q, r, q)
    exact = solve_discrete_are(ad, bd, q, r)
    np.testing.assert_allclose(p0, exact, rtol=1e-6, atol=1e-6 * np.max(np.abs(exact)))
    k_exact = np.linalg.solve(r + bd.T @ exact @ bd, bd.T @ exact @ ad)
    np.testing.assert_allclose(gains[0], k_exact, rtol=1e-6, atol=1e-8)


def test_schedule_gains_solve_the_finite_horizon_problem_by_batch_least_squares(rotary1_plan) -> None:
    """The first gain of the last H steps equals the optimal linear feedback of the stacked
    finite-horizon LQ problem, solved as one least-squares problem (no Riccati recursion)."""
    schedule = track(rotary1_plan, 0.01, r=1e-2)
    q, r, terminal = np.eye(4), 1e-2, schedule.terminal_cost
    horizon = 25
    first = schedule.steps - horizon
    a, b = schedule.a[first:], schedule.b[first:]
    n = 4
    # x_k = Φ_k x_0 + Γ_k u, u = (u_0..u_H−1); cost = Σ |Q^½ x_k|² + r |u|² + |P^½ x_H|².
    phi = [np.eye(n)]
    gamma = [np.zeros((n, horizon))]
    for k in range(horizon):
        phi.append(a[k] @ phi[-1])
        g = a[k] @ gamma[-1]
        g[:, k] += b[k]
        gamma.append(g)
    weights = [np.linalg.cholesky(q).T] * (horizon - 1) + [np.linalg.cholesky(terminal).T]  # x_1..x_H
    rows_u = np.vstack([w @ gamma[k + 1] for k, w in enumerate(weights)] + [math.sqrt(r) * np.eye(horizon)])
    rows_x = np.vstack([w @ phi[k + 1] for k, w in enumerate(weights)] + [np.zeros((horizon, n))])
    # u* = −pinv(rows_u) rows_x x_0 (the x_0ᵀ Q x_0 term does not depend on u)
    feedback = -np.linalg.lstsq(rows_u, rows_x, rcond=None)[0]
    np.testing.assert_allclose(-feedback[0], schedule.gains[first], rtol=1e-6, atol=1e-8)


def test_schedule_jacobians_match_finite_differences_of_the_sympy_flow(rotary1_plan) -> None:
    schedule = track(rotary1_plan, 0.01)
    p = rotary1_plan.plant
    reference = dynamics(p.system)

    def flow(x: np.ndarray, u: float) -> np.ndarray:
        def rhs(_t: float, y: np.ndarray) -> np.ndarray:
            return np.concatenate([y[2:], reference.forward_dynamics(y[:2], y[2:], u, p.params)])

        return solve_ivp(rhs, (0, 0.01), x, method="DOP853", rtol=1e-12, atol=1e-13).y[:, -1]

    for k in (10, 90, 170):
        x, u = schedule.states[k], schedule.inputs[k]
        eps = 1e-6
        a_fd = np.column_stack([(flow(x + eps * e, u) - flow(x - eps * e, u)) / (2 * eps) for e in np.eye(4)])
        b_fd = (flow(x, u + eps) - flow(x, u - eps)) / (2 * eps)
        np.testing.assert_allclose(schedule.a[k], a_fd, atol=1e-6)
        np.testing.assert_allclose(schedule.b[k], b_fd, atol=1e-6)


@cache
def _schedule(case: str):
    """The case's swing-up designed on the paper's plant, once per process: the mass factors of
    `_closed_loop` perturb only the simulated plant, so they track the same plan and gains (the
    design is deterministic; the schedule is frozen and its control law has no state)."""
    kind, links, duration, u_max, x_max = CASES[case]
    p = paper_plant(kind, links)
    return trajectory_swingup(p, duration=duration, u_max=u_max, x_max=x_max, period=0.01)[1]


def _closed_loop(case: str, mass_factor: float) -> None:
    kind, links, duration, u_max, _ = CASES[case]
    p = paper_plant(kind, links)
    schedule = _schedule(case)
    m = list(p.m)
    m[links] *= mass_factor  # the outermost link, the hardest to get right
    run = simulate(p.with_params(m=m), schedule.control, hanging(links), duration + 4.0, 0.01)
    assert np.max(np.abs(run.u)) <= u_max
    assert run.phase[0] == "track" and run.phase[-1] == "hold"
    assert_upright_at_rest(run.x[-1])


@pytest.mark.parametrize("case", ["classical1", "rotary1", "classical2", "rotary2"])
@pytest.mark.parametrize("mass_factor", [1.0, 1.05])
def test_trajectory_swingup_ends_upright_and_at_rest(case: str, mass_factor: float) -> None:
    _closed_loop(case, mass_factor)


@pytest.mark.slow
@pytest.mark.parametrize("mass_factor", [1.0, 1.05])
def test_trajectory_swingup_classical_triple(mass_factor: float) -> None:
    _closed_loop("classical3", mass_factor)


@pytest.mark.parametrize(("kind", "u_max"), [("rotary", 5.0), ("classical", 20.0)])
def test_energy_control_swings_up_and_catches(kind: str, u_max: float) -> None:
    p = paper_plant(kind, 1)
    controller = energy_swingup(p, u_max=u_max, period=0.01)
    run = simulate(p, controller.control, hanging(1), 8.0, 0.01)
    phases = list(run.phase)
    assert "swing" in phases and phases[-1] == "hold"
    caught = phases.index("hold")
    assert run.t[caught] < 4.0
    # While swinging, the link's energy deficit shrinks (sampled every 0.2 s: damping wobbles).
    energy = [link_energy(p, x) for x in run.x[: caught + 1 : 20]]
    assert energy[-1] > energy[0] + 0.8 * abs(energy[0])
    assert np.max(np.abs(run.u)) <= u_max
    assert_upright_at_rest(run.x[-1])


def test_hold_gain_tends_to_the_continuous_lqr_gain_for_fast_sampling() -> None:
    """The discrete hold gain is ipgen.lqr's continuous gain up to O(period)."""
    from ipgen.control.linear import lqr
    from ipgen.control.tvlqr import discrete_lqr

    p = paper_plant("rotary", 1)
    continuous = lqr("rotary", 1, p.m, p.l, p.delta, np.ones(4), 1.0)
    errors = []
    for h in (1e-2, 1e-3, 1e-4):
        k, _, _, _ = discrete_lqr(p, h, np.eye(4), np.eye(1), np.zeros(4))
        errors.append(np.max(np.abs(k - continuous)) / np.max(np.abs(continuous)))
    assert errors[2] < 2e-3
    assert errors[1] < errors[0] / 5 and errors[2] < errors[1] / 5  # first order in h


def test_fallback_homotopy_runs_when_the_first_solve_fails(monkeypatch: pytest.MonkeyPatch) -> None:
    """The first IPOPT call is made to report a failure: the homotopy in the limits (×4, ×2, ×1.4,
    ×1, warm-started) must then find the plan, within the original limits."""
    from ipgen.control import trajectory

    real = trajectory._solve
    calls = []

    def failing_first(*args, **kwargs):
        result, status, iterations, elapsed = real(*args, **kwargs)
        calls.append(status)
        return result, ("Maximum_Iterations_Exceeded" if len(calls) == 1 else status), iterations, elapsed

    monkeypatch.setattr(trajectory, "_solve", failing_first)
    kind, links, duration, u_max, x_max = CASES["classical1"]
    plan = plan_swingup(paper_plant(kind, links), duration=duration, u_max=u_max, x_max=x_max)
    assert len(plan.attempts) == 5 and plan.attempts[0].startswith("linear guess: Maximum_Iterations")
    assert plan.attempts[-1].startswith("homotopy ×1: Solve_Succeeded")
    assert np.max(np.abs(plan.inputs)) <= u_max * (1 + 1e-6)
    assert np.max(np.abs(plan.states[:, 0])) <= x_max * (1 + 1e-6)
