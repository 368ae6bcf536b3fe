"""The fixed-pivot chain's energy ledger, integrated independently (scipy's DOP853 on the sympy
model `FixedModel`): the reference the simulator with m inputs is to be compared with (issue 46).

With x = [q; q̇] and the ledger's states W (the inputs' work, ∫ uᵀ Bᵀ q̇ dt: input k's torque times
its joint's relative rate) and E (the dissipated energy, ∫ (2D + F_cᵀ q̇) dt: viscous damping and
Coulomb friction), T + V − W + E is constant along every motion: checked for the pendubot (joint
1), the acrobot (joint 2) and the fully actuated double pendulum, in ipgen's coordinates and in
DFKI's (relative, hanging, counterclockwise), with rotors, damping and Coulomb friction; and a
free-swinging chain (no damping, friction or input) keeps T + V.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from ipgen.model.fixed import FixedPendulum
from ipgen.model.fixed_equations import angle_map
from ipgen.model.fixed_numeric import FixedModel

TOLERANCE = 1e-8  # of the energy scale, with rtol 1e-11 and atol 1e-12


def _potential(model: FixedModel) -> Callable[[list[float]], float]:
    import sympy as sp

    e = model.equations
    numbers = model.pendulum.numbers()
    values = {s: numbers[s.name] for s in e.potential_energy.free_symbols if s.name in numbers}
    return sp.lambdify([list(e.q)], e.potential_energy.xreplace(values), modules="numpy")


def integrate(
    model: FixedModel, x0: np.ndarray, inputs: Callable[[float], np.ndarray], t_end: float
) -> tuple[np.ndarray, np.ndarray]:
    """(t, rows [q, q̇, W, E]) of the chain driven by `inputs(t)` (m torques)."""
    pendulum = model.pendulum
    n = pendulum.links
    delta = np.array(pendulum.delta)
    rotation, _ = angle_map(pendulum.coordinates, n)  # θ̇ = R q̇

    def f(t: float, y: np.ndarray) -> np.ndarray:
        q, qd = y[:n], y[n : 2 * n]
        u = np.asarray(inputs(t), dtype=float)
        qdd = model.forward_dynamics(q, qd, u)
        power_in = float(u @ (model.B.T @ qd))
        absolute = rotation @ qd
        relative = np.concatenate([absolute[:1], np.diff(absolute)])  # each joint's rate
        lost = float(delta @ relative**2) + float(model.friction(q, qd) @ qd)  # 2D + F_cᵀ q̇
        return np.concatenate([qd, qdd, [power_in, lost]])

    y0 = np.concatenate([x0, [0.0, 0.0]])
    times = np.linspace(0.0, t_end, 201)
    solution = solve_ivp(f, (0.0, t_end), y0, method="DOP853", t_eval=times, rtol=1e-11, atol=1e-12)
    assert solution.success, solution.message
    return solution.t, solution.y.T


def _chain(joints: tuple[int, ...], coordinates: tuple[str, str, str], free: bool = False) -> FixedPendulum:
    angles, zero, positive = coordinates
    return FixedPendulum(
        2,
        m=[0.6, 0.4],
        l=[0.3, 0.25],
        delta=[0.0, 0.0] if free else [0.02, 0.01],
        com=[0.15, 0.1],
        J=[0.004, 0.002],
        coulomb=None if free else [0.05, 0.03],
        coulomb_law="atan",
        joints=joints,
        Ir=None if free else [2e-4] * len(joints),
        gr=None if free else [6.0] * len(joints),
        angles=angles,
        zero=zero,
        positive=positive,
    )


CANONICAL = ("absolute", "upright", "clockwise")
DFKI = ("relative", "hanging", "counterclockwise")


@pytest.mark.parametrize("coordinates", [CANONICAL, DFKI], ids=["ipgen", "dfki"])
@pytest.mark.parametrize("joints", [(1,), (2,), (1, 2)], ids=["pendubot", "acrobot", "both"])
def test_energy_balance_with_inputs(joints: tuple[int, ...], coordinates: tuple[str, str, str]) -> None:
    model = FixedModel(_chain(joints, coordinates))
    potential = _potential(model)
    amplitudes = np.array([0.8, -0.5][: len(joints)])

    def inputs(t: float) -> np.ndarray:
        return amplitudes * np.sin(3.0 * t)

    _, rows = integrate(model, np.array([0.3, -0.2, 0.0, 0.5]), inputs, 4.0)
    ledger = []
    for row in rows:
        q, qd, work, lost = row[:2], row[2:4], row[4], row[5]
        kinetic = 0.5 * qd @ model.mass_matrix(q) @ qd
        ledger.append(kinetic + float(potential(list(q))) - work + lost)
    assert np.max(np.abs(rows[:, 4])) > 0.05  # the inputs did work
    assert np.max(np.abs(np.array(ledger) - ledger[0])) < TOLERANCE * max(1.0, np.max(np.abs(rows[:, 4])))


def test_free_chain_keeps_its_energy() -> None:
    model = FixedModel(_chain((1,), CANONICAL, free=True))
    potential = _potential(model)
    _, rows = integrate(model, np.array([2.5, -1.0, 0.0, 3.0]), lambda t: np.zeros(1), 5.0)
    energy = [0.5 * r[2:4] @ model.mass_matrix(r[:2]) @ r[2:4] + float(potential(list(r[:2]))) for r in rows]
    assert np.max(np.abs(rows[:, 4:])) == 0.0
    assert np.max(np.abs(np.array(energy) - energy[0])) < TOLERANCE * abs(energy[0])
