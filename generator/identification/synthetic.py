"""Synthetic experiments: a known model simulated and measured with noise (tests, demo, bench).

The simulation is independent of the fit's CasADi model: θ̈ from `control.linear.dynamics`
(numpy lambdified from the derivation), the motor folded by `Pendulum.folded` (b, c, the
reflected inertia), the simulator's Coulomb law, integrated by scipy's
`solve_ivp` (DOP853, tight tolerances) and sampled at the requested times.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

from ipgen.control.linear import dynamics
from ipgen.identification.data import Measurements
from ipgen.identification.model import Setup

if TYPE_CHECKING:
    import numpy as np

__all__ = ["folded_parameters", "measure", "multisine", "simulate", "write_csv"]


def folded_parameters(setup: Setup) -> tuple[list[float], float]:
    """(flat, b): `Dynamics`' flat parameters of the setup's direct model and the input gain.

    Parameters
    ----------
    setup : Setup

    Returns
    -------
    (list of float, float)
        `Pendulum.flat` of `setup.pendulum()`, a dc_motor folded in (`Pendulum.folded`), and b
        (1 without a motor).

    Raises
    ------
    PendulumError
        Setup values no system has.

    Examples
    --------
    >>> from ipgen.model.pendulum import Pendulum
    >>> setup = Setup.from_pendulum(Pendulum("classical", 1, [1.0, 0.1], [0.0, 0.5], [0.1, 0.0]))
    >>> folded_parameters(setup)[1]
    1.0
    """
    pendulum = setup.pendulum()
    folded = pendulum.folded() if pendulum.actuator.is_motor else pendulum
    return folded.flat(), pendulum.gain


def simulate(setup: Setup, t: np.ndarray, input_fn: Callable[[float], float], x0: np.ndarray) -> np.ndarray:
    """The true state [θ, θ̇] (len(t) × 2 dof) of `setup` driven by u = input_fn(t) from x0."""
    import numpy as np
    from scipy.integrate import solve_ivp

    system = setup.system
    dof = system.dof
    model = dynamics(system)
    params, b = folded_parameters(setup)
    speed = setup.coulomb_speed
    values = dict(setup.values)
    coulomb = [values.get(f"coulomb{i}", 0.0) for i in range(dof)] if setup.friction else [0.0] * dof

    def rhs(time: float, x: np.ndarray) -> np.ndarray:
        q, qd = x[:dof], x[dof:]
        force = np.zeros(dof)
        for i in range(dof):
            if coulomb[i]:
                w = qd[i] - qd[i - 1] if i >= 2 else qd[i]
                f = coulomb[i] * np.tanh(w / speed)
                force[i] -= f
                if i >= 2:
                    force[i - 1] += f
        # the friction enters as a generalised force: add M⁻¹ Q to θ̈ of the input alone
        qdd = model.forward_dynamics(q, qd, b * input_fn(time), params)
        if np.any(force):
            mass = model.mass_matrix(q, params)
            qdd = qdd + np.linalg.solve(mass, force)
        return np.concatenate([qd, qdd])

    solution = solve_ivp(rhs, (t[0], t[-1]), x0, t_eval=t, method="DOP853", rtol=1e-9, atol=1e-10)
    if not solution.success:  # pragma: no cover - a bad test model
        raise RuntimeError(solution.message)
    return solution.y.T


def measure(
    setup: Setup,
    t: np.ndarray,
    input_fn: Callable[[float], float],
    x0: np.ndarray,
    noise: float,
    rng: np.random.Generator,
    *,
    rates: bool = False,
    record_u: bool = True,
) -> Measurements:
    """`simulate`, then angles (and, with `rates`, rates) with white Gaussian noise of standard
    deviation `noise` [m or rad], and u as applied."""
    import numpy as np

    state = simulate(setup, t, input_fn, x0)
    dof = setup.system.dof
    theta = state[:, :dof] + noise * rng.standard_normal((len(t), dof))
    dtheta = state[:, dof:] + 10 * noise * rng.standard_normal((len(t), dof)) if rates else None
    u = np.array([input_fn(float(x)) for x in t]) if record_u else None
    return Measurements(t=np.asarray(t, dtype=float), theta=theta, dtheta=dtheta, u=u, source="synthetic")


def multisine(t: float) -> float:
    """±2.5 V at most: four sines between 0.4 and 3 Hz (the pendulum hangs at ~1.5 Hz)."""
    return (
        0.9 * math.sin(2 * math.pi * 0.4 * t)
        + 0.6 * math.sin(2 * math.pi * 1.1 * t + 1.0)
        + 0.5 * math.sin(2 * math.pi * 1.9 * t + 2.0)
        + 0.4 * math.sin(2 * math.pi * 3.0 * t + 0.5)
    )


def write_csv(path: Path, t: np.ndarray, theta: np.ndarray, u: np.ndarray) -> None:
    """The measurements in the simulator's CSV format, without rates (encoders measure angles)."""
    import numpy as np

    header = "t," + ",".join(f"theta{i}" for i in range(theta.shape[1])) + ",u"
    table = np.column_stack([t, theta, u])
    np.savetxt(path, table, delimiter=",", header=header, comments="", fmt="%.9g")
