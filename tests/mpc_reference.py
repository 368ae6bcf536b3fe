"""The MPC's optimal-control problem written independently in CasADi and solved by IPOPT, the
reference of tests/test_mpc.py: the same RK4 discretisation (built here from the exact model's
CasADi expressions, `ipgen.control.casadi_model`; a fixed chain's from model/fixed_equations'
Lagrange equations, control/fixed_swingup's CasADi dynamics), weights, bounds and soft penalty as an
`ipgen.control.mpc.Mpc`, as a multiple-shooting NLP (states and inputs the variables, soft
violations as slack variables; SX graphs, `nlpsol`)."""

from __future__ import annotations

from typing import Any

import numpy as np

from ipgen.control.casadi_model import Plant, casadi_model, import_casadi
from ipgen.control.fixed_swingup import casadi_dynamics
from ipgen.control.mpc import Mpc
from ipgen.model.fixed import FixedPendulum


def flow(controller: Mpc) -> Any:
    """F(x, u): `controller`'s sample of RK4 (`substeps` steps over `period`, u held) on the exact
    model's CasADi expressions (the motor folded in: force or torque gain · u), an SX function."""
    ca = import_casadi()
    c = controller
    dof, nx = c.pendulum.dof, c.nx
    x, u = ca.SX.sym("x", nx), ca.SX.sym("u")
    if isinstance(
        c.pendulum, FixedPendulum
    ):  # Lagrange's equations of model/fixed_equations, ipgen's coordinates
        chain = casadi_dynamics(c.pendulum.canonical())

        def f(state: Any) -> Any:
            return chain(state, u)
    else:
        model = casadi_model(Plant(c.pendulum.folded()))
        gain = float(c.pendulum.gain)

        def f(state: Any) -> Any:
            return ca.vertcat(state[dof:], model.acceleration(state[:dof], state[dof:], gain * u))

    h = c.period / c.substeps
    state = x
    for _ in range(c.substeps):
        k1 = f(state)
        k2 = f(state + h / 2 * k1)
        k3 = f(state + h / 2 * k2)
        k4 = f(state + h * k3)
        state = state + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    return ca.Function("F", [x, u], [state])


class IpoptReference:
    """The NLP of `controller`'s problem with x_0 and the reference per stage parameters.
    `solve(x0, reference)` returns (u_0, the inputs); `states` then holds the states (nx × (N + 1))
    and `objective` the cost. `F` is the RK4 map (CasADi). With `barrier` κ > 0 the cost has
    −κ log(distance) of every inequality added (u's bounds at k = 0..N−1; the hard and the soft
    state bounds at k = 1..N, a soft bound's slacks >= 0): the problem ipgen_mpc_method's
    barrier solves."""

    def __init__(self, controller: Mpc, barrier: float = 0.0) -> None:
        ca = import_casadi()
        c = controller
        nx, N = c.nx, c.N
        self.F = flow(c)
        X, U, x0 = ca.SX.sym("X", nx, N + 1), ca.SX.sym("U", 1, N), ca.SX.sym("x0", nx)
        XR, UR = ca.SX.sym("XR", nx, N + 1), ca.SX.sym("UR", 1, N)  # x_ref_k, u_ref_k
        ns = len(c.soft)
        above, below = ca.SX.sym("above", ns, N), ca.SX.sym("below", ns, N)
        Q, R, P = (ca.DM(np.asarray(v, float)) for v in (c.Q, c.R, c.P))
        cost = 0
        constraints, lower, upper = [X[:, 0] - x0], [np.zeros(nx)], [np.zeros(nx)]
        for k in range(N):
            e = X[:, k] - XR[:, k]
            cost += ca.mtimes([e.T, Q, e]) + R[0, 0] * (U[0, k] - UR[0, k]) ** 2
            constraints.append(self.F(X[:, k], U[0, k]) - X[:, k + 1])
            lower.append(np.zeros(nx))
            upper.append(np.zeros(nx))
        e = X[:, N] - XR[:, N]
        cost += ca.mtimes([e.T, P, e])
        rho1, rho2 = c.soft_penalty
        for j, (index, lo, hi) in enumerate(c.soft):
            constraints += [(X[index, 1:] - above[j, :]).T, (X[index, 1:] + below[j, :]).T]
            lower += [np.full(N, -np.inf), np.full(N, lo)]
            upper += [np.full(N, hi), np.full(N, np.inf)]
            cost += rho1 * (ca.sum2(above[j, :]) + ca.sum2(below[j, :]))
            cost += rho2 * (ca.sumsqr(above[j, :]) + ca.sumsqr(below[j, :]))
            if barrier > 0:
                distances = (
                    hi + above[j, :] - X[index, 1:],
                    X[index, 1:] + below[j, :] - lo,
                    above[j, :],
                    below[j, :],
                )
                cost -= barrier * sum(ca.sum2(ca.log(d)) for d in distances)
        if barrier > 0:
            cost -= barrier * (ca.sum2(ca.log(c.u_max - U)) + ca.sum2(ca.log(U - c.u_min)))
            for index, lo, hi in c.hard:
                cost -= barrier * (ca.sum2(ca.log(hi - X[index, 1:])) + ca.sum2(ca.log(X[index, 1:] - lo)))
        # variable bounds: u, the hard state bounds (x_1..x_N), the slacks >= 0
        x_lo, x_hi = np.full((nx, N + 1), -np.inf), np.full((nx, N + 1), np.inf)
        for index, lo, hi in c.hard:
            x_lo[index, 1:], x_hi[index, 1:] = lo, hi
        variables = ca.vertcat(ca.vec(X), ca.vec(U), ca.vec(above), ca.vec(below))
        self.lbx = np.concatenate([x_lo.T.reshape(-1), np.full(N, c.u_min), np.zeros(2 * ns * N)])
        self.ubx = np.concatenate([x_hi.T.reshape(-1), np.full(N, c.u_max), np.full(2 * ns * N, np.inf)])
        self.lbg, self.ubg = np.concatenate(lower), np.concatenate(upper)
        parameters = ca.vertcat(x0, ca.vec(XR), ca.vec(UR))
        g = ca.vertcat(*[ca.vec(g) for g in constraints])
        problem = {"x": variables, "p": parameters, "f": cost, "g": g}
        options = {"print_time": False, "ipopt.print_level": 0, "ipopt.sb": "yes", "ipopt.tol": 1e-12,
                   "ipopt.constr_viol_tol": 1e-12, "ipopt.max_iter": 500}  # fmt: skip
        if barrier > 0:  # the logarithms' arguments stay positive: no relaxed bounds; 1e-10 (1e-12
            # stalls on the logarithms' rounding: "search direction becomes too small")
            options.update({"ipopt.bound_relax_factor": 0.0, "ipopt.tol": 1e-10})
        self.solver = ca.nlpsol("reference", "ipopt", problem, options)
        self.nx, self.N, self.ns, self.barrier = nx, N, ns, barrier
        self.x_ref, self.u_ref = np.asarray(c.x_ref, float), np.asarray(c.u_ref, float)
        self.states = np.zeros((nx, N + 1))

    def solve(self, x0: np.ndarray, reference: Any = None, warm: Any = None) -> tuple[float, np.ndarray]:
        """(u_0, every u_k) of the problem from x0 about the controller's x_ref, u_ref, IPOPT
        started from x_k = x0, u_k = 0, or from `warm` ((N + 1) × nx states, N inputs: a warm
        start); or about a reference per stage ((N + 1) × nx states, N inputs), IPOPT started
        from it (x_k, u_k its rows, u clipped to its bounds: where ipgen_mpc_track starts cold, so
        that both find the same local minimum of a nonconvex problem)."""
        nx, N = self.nx, self.N
        if reference is None:
            xs, us = np.tile(self.x_ref, (N + 1, 1)), np.full(N, self.u_ref[0])
            guess = np.concatenate([np.tile(np.asarray(x0, float), N + 1), np.zeros(N)])
            if warm is not None:
                guess = np.concatenate([np.asarray(part, float).reshape(-1) for part in warm])
        else:
            xs, us = (np.asarray(v, float) for v in reference)
            u_lo, u_hi = self.lbx[nx * (N + 1)], self.ubx[nx * (N + 1)]
            guess = np.concatenate([xs.reshape(-1), np.clip(us.reshape(-1), u_lo, u_hi)])
        parameters = np.concatenate([np.asarray(x0, float), xs.reshape(-1), us.reshape(-1)])
        slack = 1.0 if self.barrier > 0 else 0.0  # inside the barrier's logarithms
        start = np.concatenate([guess, np.full(2 * self.ns * N, slack)])
        result = self.solver(x0=start, p=parameters, lbx=self.lbx, ubx=self.ubx, lbg=self.lbg, ubg=self.ubg)
        if not self.solver.stats()["success"]:
            raise RuntimeError(f"IPOPT failed from {x0}: {self.solver.stats()['return_status']}")
        self.objective = float(result["f"])
        w = np.asarray(result["x"], float).reshape(-1)
        self.states = w[: nx * (N + 1)].reshape(N + 1, nx).T
        inputs = w[nx * (N + 1) : nx * (N + 1) + N]
        return float(inputs[0]), inputs
