"""scipy's `solve_ivp` (DOP853 and LSODA) on a right-hand side lambdified from the generator's
own sympy equations (`ipgen.model.derivation.derive`): M(θ) and the bias with the scene's parameter
values substituted, θ̈ = M⁻¹(B u − bias) by `numpy.linalg.solve`.

Like ipsim, the integration is restarted at every input jump (the pulse edges) and reports the
states at the sample times (scipy interpolates them with its dense output).
"""

from __future__ import annotations

import itertools
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import sympy as sp
from scipy.integrate import solve_ivp

from ipgen.experiment.scene import Scene
from ipgen.model.derivation import derive


@dataclass
class Run:
    method: str
    rtol: float
    states: np.ndarray  # samples x 2·dof
    wall_per_second: float  # median wall time per simulated second [s]
    repeats: int
    rhs_evals: int
    failed: str = ""


def right_hand_side(scene: Scene) -> Callable[[float, np.ndarray, float], np.ndarray]:
    """f(t, x, u) for x = [θ; θ̇] from lambdified M and bias (parameters substituted)."""
    equations = derive(scene.system).rod()
    sym = equations.symbols
    values = {symbol: scene.value(str(symbol)) for symbol in sym.parameters}
    state = (*sym.q, *sym.qd)
    mass = sp.lambdify(state, equations.mass_matrix.subs(values), "numpy", cse=True)
    bias = sp.lambdify(state, equations.bias.subs(values), "numpy", cse=True)
    n = scene.links + 1

    def f(_t: float, x: np.ndarray, u: float) -> np.ndarray:
        force = -np.asarray(bias(*x), dtype=float).reshape(n)
        force[0] += u
        acceleration = np.linalg.solve(np.asarray(mass(*x), dtype=float), force)
        return np.concatenate((x[n:], acceleration))

    return f


class ScipyPendulum:
    def __init__(self, scene: Scene) -> None:
        self.scene = scene
        self.f = right_hand_side(scene)

    def _integrate(self, method: str, rtol: float, sample: float) -> tuple[np.ndarray, int]:
        scene = self.scene
        samples = np.arange(round(scene.t_end / sample) + 1) * sample
        edges = [t for t in scene.input.breakpoints() if 0 < t < scene.t_end]
        bounds = [0.0, *edges, scene.t_end]
        x = np.array([*scene.theta, *scene.dtheta], dtype=float)
        rows = [x]
        evals = 0
        for a, b in itertools.pairwise(bounds):
            u = scene.input.value(0.5 * (a + b))
            inside = samples[(samples > a + 1e-12) & (samples <= b + 1e-12)]
            done = solve_ivp(
                self.f, (a, b), x, method=method, t_eval=inside, rtol=rtol, atol=rtol * 1e-2, args=(u,)
            )
            if done.status != 0:
                raise RuntimeError(done.message)
            evals += done.nfev
            rows.extend(done.y.T)
            x = done.y[:, -1] if inside.size and abs(inside[-1] - b) < 1e-12 else done.sol(b)
        return np.array(rows), evals

    def run(self, method: str, rtol: float, sample: float, repeat_seconds: float = 0.5) -> Run:
        walls: list[float] = []
        spent = 0.0
        states, evals = np.empty(0), 0
        try:
            while len(walls) < 1 or (spent < repeat_seconds and len(walls) < 3):
                start = time.perf_counter()
                states, evals = self._integrate(method, rtol, sample)
                walls.append(time.perf_counter() - start)
                spent += walls[-1]
        except RuntimeError as failure:
            return Run(method, rtol, np.empty(0), float("nan"), 0, 0, str(failure))
        return Run(method, rtol, states, float(np.median(walls)) / self.scene.t_end, len(walls), evals)
