"""A reference closed-loop simulator for the swing-up tests and bench (not ipgen's simulator).

scipy's `solve_ivp` (DOP853) integrates the exact model of `ipgen.control.linear.dynamics` (the
sympy derivation lambdified onto numpy: independent of the CasADi expressions the planner and
the gains use) between sampling instants t_k = k·period; a controller is asked for u at every
t_k from the state there and u is held until t_k+1 (zero-order hold), as a sampled controller on
a rig would run.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from scipy.integrate import solve_ivp

from ipgen.control.casadi_model import Plant
from ipgen.control.linear import dynamics

Controller = Callable[[int, np.ndarray], tuple[float, str]]


@dataclass(frozen=True)
class Run:
    """Samples at t_k: states (K+1 × 2·dof), the inputs held from t_k (K+1, the last repeated)
    and the phase names."""

    t: np.ndarray
    x: np.ndarray
    u: np.ndarray
    phase: tuple[str, ...]

    def write_csv(self, path: str) -> None:
        """The simulator's CSV columns (t, theta0.., dtheta0..) plus u and phase."""
        dof = self.x.shape[1] // 2
        header = ["t", *(f"theta{i}" for i in range(dof)), *(f"dtheta{i}" for i in range(dof)), "u", "phase"]
        with open(path, "w") as out:
            out.write(",".join(header) + "\n")
            for t, x, u, phase in zip(self.t, self.x, self.u, self.phase, strict=True):
                row = [repr(float(t)), *(repr(float(v)) for v in x), repr(float(u)), phase]
                out.write(",".join(row) + "\n")


def simulate(
    plant: Plant,
    controller: Controller,
    x0: Sequence[float],
    t_end: float,
    period: float,
    rtol: float = 1e-9,
    atol: float = 1e-10,
) -> Run:
    """The sampled closed loop of `controller` (called as controller(k, x) → (u, phase)) on
    `plant` from x0 for t_end seconds."""
    dyn = dynamics(plant.system)
    dof = plant.dof
    params = list(plant.params)
    steps = round(t_end / period)
    x = np.asarray(x0, dtype=float).copy()
    xs, us, phases = [x.copy()], [], []
    for k in range(steps):
        u, phase = controller(k, x)

        def rhs(_t: float, state: np.ndarray, u: float = u) -> np.ndarray:
            return np.concatenate([state[dof:], dyn.forward_dynamics(state[:dof], state[dof:], u, params)])

        sol = solve_ivp(rhs, (k * period, (k + 1) * period), x, method="DOP853", rtol=rtol, atol=atol)
        if not sol.success:
            raise RuntimeError(f"solve_ivp failed at t = {k * period:g}: {sol.message}")
        x = sol.y[:, -1].copy()
        xs.append(x.copy())
        us.append(u)
        phases.append(phase)
    us.append(us[-1] if us else 0.0)
    phases.append(phases[-1] if phases else "")
    return Run(np.arange(steps + 1) * period, np.array(xs), np.array(us), tuple(phases))
