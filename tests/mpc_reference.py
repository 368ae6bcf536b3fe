"""The MPC's optimal-control problem written independently in CasADi and solved by IPOPT, the
reference of tests/test_mpc.py: the same RK4 discretisation (built here from the exact model's
CasADi expressions, `ipgen.control.casadi_model`), weights, bounds and soft penalty as an
`ipgen.control.mpc.Mpc`, as a multiple-shooting NLP (states and inputs the variables, soft
violations as slack variables)."""

from __future__ import annotations

from typing import Any

import numpy as np

from ipgen.control.casadi_model import Plant, casadi_model, import_casadi
from ipgen.control.mpc import Mpc


class IpoptReference:
    """The NLP of `controller`'s problem with x_0 a parameter; `solve(x0)` returns (u_0, inputs)."""

    def __init__(self, controller: Mpc) -> None:
        ca = import_casadi()
        c = controller
        model = casadi_model(Plant(c.pendulum.folded()))
        dof, nx, N = c.pendulum.dof, c.nx, c.N
        gain = float(c.pendulum.gain)
        x, u = ca.SX.sym("x", nx), ca.SX.sym("u")

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
        F = ca.Function("F", [x, u], [state])
        self.F = F
        opti = ca.Opti()
        X, U = opti.variable(nx, N + 1), opti.variable(1, N)
        x0 = opti.parameter(nx)
        Q, R, P, xr = (ca.DM(np.asarray(v, float)) for v in (c.Q, c.R, c.P, c.x_ref))
        cost = 0
        for k in range(N):
            e = X[:, k] - xr
            cost += ca.mtimes([e.T, Q, e]) + R[0, 0] * U[0, k] ** 2
            opti.subject_to(X[:, k + 1] == F(X[:, k], U[0, k]))
        e = X[:, N] - xr
        cost += ca.mtimes([e.T, P, e])
        opti.subject_to(X[:, 0] == x0)
        opti.subject_to(opti.bounded(c.u_min, U, c.u_max))
        for index, lo, hi in c.hard:
            opti.subject_to(opti.bounded(lo, X[index, 1:], hi))
        rho1, rho2 = c.soft_penalty
        for index, lo, hi in c.soft:
            above, below = opti.variable(1, N), opti.variable(1, N)
            opti.subject_to(X[index, 1:] - above <= hi)
            opti.subject_to(X[index, 1:] + below >= lo)
            opti.subject_to(above >= 0)
            opti.subject_to(below >= 0)
            cost += rho1 * (ca.sum2(above) + ca.sum2(below)) + rho2 * (ca.sumsqr(above) + ca.sumsqr(below))
        opti.minimize(cost)
        options = {"print_time": False, "ipopt.print_level": 0, "ipopt.sb": "yes", "ipopt.tol": 1e-12,
                   "ipopt.constr_viol_tol": 1e-12, "ipopt.max_iter": 500}  # fmt: skip
        opti.solver("ipopt", options)
        self.opti, self.X, self.U, self.x0 = opti, X, U, x0
        self.nx, self.N = nx, N

    def solve(self, x0: np.ndarray) -> tuple[float, np.ndarray]:
        """(u_0, every u_k) of the problem from x0, IPOPT started from x_k = x0, u_k = 0."""
        opti = self.opti
        opti.set_value(self.x0, np.asarray(x0, float))
        opti.set_initial(self.X, np.tile(np.asarray(x0, float).reshape(-1, 1), (1, self.N + 1)))
        opti.set_initial(self.U, np.zeros((1, self.N)))
        solution = opti.solve()
        inputs = np.asarray(solution.value(self.U), float).reshape(-1)
        return float(inputs[0]), inputs
