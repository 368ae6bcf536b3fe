"""The microcontroller's method of the MPC step (ipgen_mpc_method, docs/mpc.md "One factorisation a
sample"): a fixed log-barrier weight with Newton steps warm-started on its central path, and
frozen sensitivities.

- The barrier problem: `solve` (iterated to convergence with the barrier's Newton steps) gives
  IPOPT's first input on the same problem with −κ log(distance) of every inequality added
  (tests/mpc_reference.py, written independently), within 1e-6 at seeded random states, with and
  without soft bounds; the bounds active at some of them.
- Frozen sensitivities: A, B are the fourth-order Taylor polynomials (what RK4 does to a linear
  model) of CasADi's Jacobians of the exact model at the stage's start, F the exact path's; with
  substeps, Φ^s and Σ Φ^i Γ.
- One Newton step a sample on frozen sensitivities in closed loop (the exact model by solve_ivp):
  |u| within its bound, the arm within its travel, upright at the end; its cost within 1 % of the
  interior point's real-time iteration from the same start; float follows double.
- Bad methods: one line in Python; IPGEN_MPC_BAD_SETTINGS from the C step.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from mpc_reference import IpoptReference
from test_mpc import FLOAT_INPUT, RTI_TRAVEL, closed_loop, qube, qube_soft

from ipgen.common.limits import MAX_MPC_BARRIER
from ipgen.control.casadi_model import Plant, casadi_model
from ipgen.control.mpc import Mpc, MpcError

pytest.importorskip("casadi")

AGREEMENT = 1e-6  # the first input against IPOPT's on the barrier problem [V]
FAST = {"barrier": 1e-3, "qp_iterations": 1, "sensitivities": "frozen"}  # the microcontroller's method


@pytest.mark.parametrize("make", [qube, qube_soft], ids=["qube", "qube-soft"])
def test_the_barrier_problem_equals_ipopt(make: object) -> None:
    kappa = 1e-2  # large enough that the barrier moves the solution well beyond the agreement
    controller = make(barrier=kappa)  # type: ignore[operator]
    plain = make()  # type: ignore[operator]
    reference = IpoptReference(controller, barrier=kappa)
    rng = np.random.default_rng(11)
    near_bound = moved = 0
    for _ in range(12):
        x = rng.uniform([-0.9, -0.25, -1, -1], [0.9, 0.25, 1, 1])
        u = controller.solve(x)
        # "SQP budget reached": Gauss-Newton's linear rate, as in test_mpc (its first input is right)
        assert controller.info is not None and controller.info.status in ("ok", "SQP budget reached"), x
        u_ref, inputs = reference.solve(x)
        assert abs(u - u_ref) <= AGREEMENT, (x, u, u_ref)
        near_bound += bool(np.max(np.abs(inputs)) > controller.u_max - 0.05)
        near_bound += bool(np.max(np.abs(reference.states[0])) > 0.95)  # the arm near its travel
        moved += abs(u - plain.solve(x)) > 100 * AGREEMENT  # the barrier's problem is another one
    assert near_bound >= 2 and moved >= 6, (near_bound, moved)


def _taylor(a: np.ndarray, b: np.ndarray, h: float) -> tuple[np.ndarray, np.ndarray]:
    """One RK4 step of x' = a x + b u: (I + M + M²/2 + M³/6 + M⁴/24, h (I + M/2 + M²/6 + M³/24) b)."""
    m, eye = h * a, np.eye(len(a))
    phi = eye + m + m @ m / 2 + m @ m @ m / 6 + m @ m @ m @ m / 24
    gamma = h * (eye + m / 2 + m @ m / 6 + m @ m @ m / 24) @ b
    return phi, gamma


@pytest.mark.parametrize("substeps", [1, 3])
def test_frozen_sensitivities_are_rk4_of_the_models_jacobians(substeps: int) -> None:
    import casadi as ca

    frozen, exact = qube(sensitivities="frozen", substeps=substeps), qube(substeps=substeps)
    model = casadi_model(Plant(frozen.pendulum.folded()))
    x, u = ca.SX.sym("x", 4), ca.SX.sym("u")
    f = ca.vertcat(x[2:], model.acceleration(x[:2], x[2:], float(frozen.pendulum.gain) * u))
    jacobians = ca.Function("J", [x, u], [ca.jacobian(f, x), ca.jacobian(f, u)])
    h = frozen.period / substeps
    rng = np.random.default_rng(5)
    for _ in range(5):
        state, drive = rng.uniform(-1, 1, 4), float(rng.uniform(-10, 10))
        a_c, b_c = (np.asarray(v, float) for v in jacobians(state, drive))
        phi, gamma = _taylor(a_c, b_c, h)
        a_ref, b_ref = np.eye(4), np.zeros((4, 1))
        for _ in range(substeps):
            a_ref, b_ref = phi @ a_ref, phi @ b_ref + gamma
        xn, a, b = frozen.linearisation(state, drive)
        assert np.abs(a - a_ref).max() <= 1e-12 * max(1.0, np.abs(a_ref).max())
        assert np.abs(b - b_ref).max() <= 1e-12 * max(1.0, np.abs(b_ref).max())
        xn_exact, a_exact, _ = exact.rk4(state, drive)
        assert np.allclose(xn, xn_exact, rtol=1e-14, atol=1e-15)  # the defects stay exact
        assert np.array_equal(frozen.rk4(state, drive)[1], a_exact)  # rk4 stays exact
        # an approximation: up to 16 % of A's largest entry at these states (±10 V, rates ±1 rad/s)
        assert 1e-8 < np.abs(a - a_exact).max() < 0.2 * np.abs(a_exact).max()


def test_one_newton_step_a_sample_keeps_the_bounds_near_the_interior_points_cost() -> None:
    fast, interior = qube(**FAST), qube()
    costs = []
    for controller in (fast, interior):
        states, inputs = closed_loop([controller], [0.5, 0.15, 1.0, 0.0], 3.0)
        assert np.all(np.abs(inputs) <= controller.u_max)
        assert np.max(np.abs(states[:, 0])) <= 1.0 + RTI_TRAVEL
        assert np.max(np.abs(inputs)) >= controller.u_max - 0.05  # the bound mattered
        assert np.max(np.abs(states[-1])) <= 5e-2, states[-1]  # upright, near rest
        if controller is fast:
            assert controller.info is not None and controller.info.qp_iterations == 1
        x, u = states[:-1], inputs[:, 0]
        costs.append(float(np.einsum("ki,ij,kj->", x, controller.Q, x) + controller.R[0, 0] * u @ u))
    assert abs(costs[0] - costs[1]) <= 0.01 * costs[1], costs


def test_soft_bounds_keep_their_place_in_the_carried_over_slacks() -> None:
    """qube_soft (the arm beyond ±0.7 rad and the link's rate beyond ±8 rad/s cost s + 100 s²,
    the arm's hard ±1 rad besides): the slacks and multipliers of every block of inequalities
    (u's, the hard, the soft bounds', their slacks') shifted with the trajectory; the cost within
    1 % of the interior point's, the bounds kept."""
    costs = []
    for controller in (qube_soft(**FAST), qube_soft()):
        states, inputs = closed_loop([controller], [0.5, 0.15, 1.0, 0.0], 3.0)
        assert np.all(np.abs(inputs) <= controller.u_max)
        assert np.max(np.abs(states[:, 0])) <= 1.0 + RTI_TRAVEL
        assert np.max(np.abs(states[:, 0])) > 0.7  # the soft bound was violated, so it mattered
        assert np.max(np.abs(states[-1])) <= 5e-2, states[-1]
        x, u = states[:-1], inputs[:, 0]
        rho1, rho2 = controller.soft_penalty
        excess = [np.maximum(np.maximum(x[:, i] - hi, lo - x[:, i]), 0.0) for i, lo, hi in controller.soft]
        penalty = sum(float(np.sum(rho1 * e + rho2 * e**2)) for e in excess)
        quadratic = float(np.einsum("ki,ij,kj->", x, controller.Q, x) + controller.R[0, 0] * u @ u)
        costs.append(quadratic + penalty)
    assert abs(costs[0] - costs[1]) <= 0.01 * costs[1], costs


def test_the_first_stage_keeps_the_exact_sensitivities() -> None:
    """A cold step of one SQP iteration linearises every stage at (x, u_ref = 0): the workspace's
    A_0, B_0 are RK4's exact sensitivities there, A_1 .. A_{N-1} the frozen ones."""
    x = np.array([0.3, 0.2, 1.0, -0.5])
    controller = qube(**FAST, cold_iterations=1)
    controller.step(x)
    N = controller.N
    A, B, _, _ = _last_qp(controller)
    _, a_exact, b_exact = controller.rk4(x, 0.0)
    _, a_frozen, b_frozen = controller.linearisation(x, 0.0)
    assert np.abs(a_exact - a_frozen).max() > 1e-6  # they differ here, so the test can tell
    assert np.array_equal(A[0], a_exact) and np.array_equal(B[0], b_exact)
    assert all(np.array_equal(A[k], a_frozen) and np.array_equal(B[k], b_frozen) for k in range(1, N))


def _last_qp(controller: Mpc) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """A, B, the defects d and the step z of the last QP, copied from the workspace (ipgen_mpc_carve's
    order: the warm flag, the trajectory, A, B, d, z; nu = 1)."""
    nx, N = controller.nx, controller.N
    sizes = {"A": N * nx * nx, "B": N * nx, "d": N * nx, "z": (N + 1) * nx + N}
    start, parts = 1 + sizes["z"], {}
    for name, size in sizes.items():
        parts[name] = controller.work[start : start + size].copy()
        start += size
    return parts["A"].reshape(N, nx, nx), parts["B"].reshape(N, nx, 1), parts["d"].reshape(N, nx), parts["z"]


def test_shifted_sensitivities_keep_the_last_samples_and_compute_two() -> None:
    """A warm step with shifted sensitivities linearises about the last solution moved by one
    sample: stages 1 .. N-2 take the last QP's A, B of stages 2 .. N-1 as they were, stage 0 RK4's
    exact sensitivities and stage N-1 the frozen ones at the guess, and every defect is new,
    F(x_k, u_k) - x_{k+1} at the guess (`rk4`, to a few ulps of F). The frozen method's step
    computes those stages at the guess instead (and differs: so the test can tell)."""
    x0, x1 = np.array([0.3, 0.2, 1.0, -0.5]), np.array([0.31, 0.19, 0.9, -0.6])
    method = {"barrier": 0.1, "qp_iterations": 2}
    shifted, frozen = qube(**method, sensitivities="shifted"), qube(**method, sensitivities="frozen")
    N = shifted.N
    assert shifted.step(x0) == frozen.step(x0)  # a cold step computes every stage: the same
    A0, B0, _, _ = _last_qp(shifted)
    pairs = zip(_last_qp(shifted)[:3], _last_qp(frozen)[:3], strict=True)
    assert all(np.array_equal(a, b) for a, b in pairs)
    states, inputs = shifted.trajectory()
    guess_x = np.vstack([states[1:], states[-1:]])  # the shift: the last state and input repeated
    guess_u = np.concatenate([inputs[1:, 0], inputs[-1:, 0]])
    shifted.step(x1)
    frozen.step(x1)
    A, B, d, _ = _last_qp(shifted)
    assert np.array_equal(A[1 : N - 1], A0[2:]) and np.array_equal(B[1 : N - 1], B0[2:])
    _, a_exact, b_exact = shifted.rk4(guess_x[0], guess_u[0])
    assert np.array_equal(A[0], a_exact) and np.array_equal(B[0], b_exact)
    _, a_last, b_last = shifted.linearisation(guess_x[N - 1], guess_u[N - 1])
    assert np.array_equal(A[N - 1], a_last) and np.array_equal(B[N - 1], b_last)
    for k in range(N):  # to rounding: a kept stage evaluates F alone, rk4 with its sensitivities
        f_k = shifted.rk4(guess_x[k], guess_u[k])[0]  # (libm's sin and sincos may differ by an ulp)
        ulps = 4 * np.finfo(float).eps * max(1.0, np.abs(f_k).max())
        assert np.abs(d[k] - (f_k - guess_x[k + 1])).max() <= ulps
    A_frozen = _last_qp(frozen)[0]
    for k in (1, N // 2, N - 2):
        assert np.array_equal(A_frozen[k], frozen.linearisation(guess_x[k], guess_u[k])[1])
        assert np.abs(A_frozen[k] - A[k]).max() > 1e-9


def test_a_later_sqp_iteration_computes_every_stage_again() -> None:
    """With two SQP iterations a sample only the first keeps the last sample's stages: the second
    linearises every stage at its own guess, the solution minus its last step (z, after d in the
    workspace; full steps in the real-time iteration): stage 0 by `rk4`, the others by
    `linearisation` there, none the kept one."""
    controller = qube(barrier=0.1, qp_iterations=2, sensitivities="shifted", sqp_iterations=2)
    nx, N = controller.nx, controller.N
    controller.step([0.3, 0.2, 1.0, -0.5])
    kept = _last_qp(controller)[0][2:]
    controller.step([0.31, 0.19, 0.9, -0.6])
    A, _, _, z = _last_qp(controller)
    states, inputs = controller.trajectory()
    x, u = states - z[: (N + 1) * nx].reshape(N + 1, nx), inputs[:, 0] - z[(N + 1) * nx :]
    assert np.allclose(A[0], controller.rk4(x[0], u[0])[1], rtol=0, atol=1e-9)
    for k in range(1, N):
        assert np.allclose(A[k], controller.linearisation(x[k], u[k])[1], rtol=0, atol=1e-9), k
    assert np.abs(A[1 : N - 1] - kept).max() > 1e-8


def test_after_an_infeasible_step_the_next_keeps_that_steps_stages() -> None:
    """The arm past its hard travel: the step reports "QP infeasible" and keeps its guess (and the
    A, B it linearised it with); the next, warm step keeps those stages shifted, computes stage 0
    and N-1 anew and, the arm back inside, solves."""
    controller = qube(sensitivities="shifted")
    N = controller.N
    controller.step([1.05, 0.0, 0.0, 0.0])
    assert controller.info is not None and controller.info.status == "QP infeasible"
    A0 = _last_qp(controller)[0]
    states, inputs = controller.trajectory()
    controller.step([0.9, 0.0, -1.0, 0.0])
    assert controller.info.status == "ok"
    A = _last_qp(controller)[0]
    assert np.array_equal(A[1 : N - 1], A0[2:])
    assert np.array_equal(A[0], controller.rk4(states[1], inputs[1, 0])[1])
    assert np.array_equal(A[N - 1], controller.linearisation(states[N], inputs[N - 1, 0])[1])


def test_shifted_sensitivities_hold_the_qube_within_its_travel() -> None:
    """In closed loop (the exact model) from the arm swinging: the arm within its travel, upright
    at the end, as with the frozen ones."""
    controller = qube(barrier=0.1, qp_iterations=2, sensitivities="shifted")
    states, inputs = closed_loop([controller], [0.5, 0.15, 1.0, 0.0], 3.0)
    assert np.max(np.abs(states[:, 0])) <= 1.0 + RTI_TRAVEL
    assert np.max(np.abs(inputs)) <= controller.u_max and np.max(np.abs(states[-1])) <= 5e-2, states[-1]


def test_more_sqp_iterations_carry_the_slacks_and_multipliers_over() -> None:
    """Two and three SQP iterations a sample, each one Newton step: a step's later QPs continue
    from the one before (not from their central path), so the arm keeps its travel as with one."""
    for iterations in (2, 3):
        controller = qube(**FAST, sqp_iterations=iterations)
        states, _ = closed_loop([controller], [0.5, 0.15, 1.0, 0.0], 3.0)
        assert np.max(np.abs(states[:, 0])) <= 1.0 + RTI_TRAVEL, iterations
        assert np.max(np.abs(states[-1])) <= 5e-2, states[-1]


def test_float_follows_double_with_the_microcontrollers_method() -> None:
    double, single = qube(**FAST), qube(precision="float", **FAST)
    _, inputs = closed_loop([double, single], [0.5, 0.15, 1.0, 0.0], 2.0)
    assert np.max(np.abs(inputs[:, 1] - inputs[:, 0])) <= FLOAT_INPUT * double.u_max


@settings(max_examples=40, deadline=None)
@given(
    barrier=st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.text(max_size=3), st.booleans()),
    sensitivities=st.one_of(
        st.sampled_from(["exact", "frozen", "shifted"]), st.text(max_size=8), st.integers(), st.none()
    ),
    mode=st.sampled_from(["rti", "converged"]),
)
def test_any_method_is_a_design_or_one_line(barrier: object, sensitivities: object, mode: str) -> None:
    try:
        controller = qube(barrier=barrier, sensitivities=sensitivities, mode=mode)
    except MpcError as error:
        assert "\n" not in str(error) and ("barrier" in str(error) or "sensitivities" in str(error))
        return
    assert isinstance(barrier, float) and 0 <= barrier <= MAX_MPC_BARRIER
    assert sensitivities in ("exact", "frozen", "shifted")
    assert mode == "rti" or (barrier == 0 and sensitivities == "exact")
    assert isinstance(controller, Mpc)


@pytest.mark.parametrize(
    ("barrier", "sensitivities", "exact_hessian"),
    [
        *((bad, 0, 0) for bad in (-1.0, float("nan"), float("inf"))),
        *((0.0, bad, 0) for bad in (3, -1)),  # IPGEN_MPC_EXACT, _FROZEN, _SHIFTED are 0, 1, 2
        *((0.0, inexact, 1) for inexact in (1, 2)),  # the exact Hessian needs exact sensitivities
    ],
)
def test_the_c_step_refuses_a_bad_method(barrier: float, sensitivities: int, exact_hessian: int) -> None:
    controller = qube()
    controller._method.barrier, controller._method.sensitivities = barrier, sensitivities
    controller._settings.exact_hessian = exact_hessian
    u = controller.step([0.1, 0.05, 0.0, 0.0])
    assert controller.info is not None and controller.info.status == "bad settings" and u == 0.0
