"""Reference derivations with sympy.physics.mechanics, for the generation benchmark.

The same pendulum as ipgen (MODEL.md): rods with the centre of gravity at l/2 and inertia
m l²/12, absolute link angles (clockwise from upright), viscous damping of the base, of link 1
against the base and of link i against link i − 1, the input on the base. Rotary links use the
"pivot" inertia (the published model, ipgen's default): J_T about the pivot axis only.

Run as `python -m bench.references METHOD TYPE LINKS`: imports first, then times the derivation
alone (frames, bodies, loads, the equations, M and the forcing vector; no code generation) and
prints it as JSON on stdout. A fresh process each time, so no cache is shared between runs.
"""

from __future__ import annotations

import json
import sys
import time
from dataclasses import dataclass

import sympy as sp
from sympy.physics import mechanics as me

METHODS = ("kane", "lagrange")


@dataclass
class Pendulum:
    """Everything a method needs: the ground frame, coordinates, their rates, bodies and loads."""

    ground: me.ReferenceFrame
    q: list[sp.Function]
    speeds: list[sp.Expr]
    bodies: list[me.RigidBody | me.Particle]
    loads: list[tuple]
    parameters: dict[str, tuple[sp.Symbol, ...]]  # m, l, delta: one per body; g, u: one each


def pendulum(kind: str, links: int, speeds: list[sp.Expr] | None = None) -> Pendulum:
    """The n-link pendulum on a cart (classical) or on a horizontal arm (rotary).

    `speeds` are the rates the velocities are written in: generalized speeds for Kane's method,
    or None for the time derivatives of the coordinates (Lagrange's method).
    """
    size = links + 1
    q = list(me.dynamicsymbols(f"q0:{size}"))
    rates = speeds if speeds is not None else [qi.diff() for qi in q]
    m = sp.symbols(f"m0:{size}", positive=True)
    lengths = sp.symbols(f"l0:{size}", positive=True)
    delta = sp.symbols(f"delta0:{size}", nonnegative=True)
    g, force = sp.symbols("g u")

    ground = me.ReferenceFrame("N")
    origin = me.Point("O")
    origin.set_vel(ground, 0)
    bodies: list[me.RigidBody | me.Particle] = []
    loads: list[tuple] = []

    if kind == "classical":
        base = ground  # the cart slides along N.x without turning
        pivot = origin.locatenew("C", q[0] * ground.x)
        pivot.set_vel(ground, rates[0] * ground.x)
        bodies.append(me.Particle("cart", pivot, m[0]))
        loads.append((pivot, (force - delta[0] * rates[0]) * ground.x))
        swing = ground.y
    else:
        # The arm turns by θ0 clockwise seen from above: its axis A.y = (sin θ0, cos θ0, 0).
        base = ground.orientnew("A", "Axis", [-q[0], ground.z])
        base.set_ang_vel(ground, -rates[0] * ground.z)
        arm_cog = origin.locatenew("Ga", lengths[0] / 2 * base.y)
        arm_cog.v2pt_theory(origin, ground, base)
        across = m[0] * lengths[0] ** 2 / 12  # thin rod along A.y: m0 l0²/3 about the pivot
        arm = me.RigidBody("arm", arm_cog, base, m[0], (me.inertia(base, across, 0, across), arm_cog))
        bodies.append(arm)
        loads.append((base, -(force - delta[0] * rates[0]) * ground.z))
        pivot = origin.locatenew("C", lengths[0] * base.y)
        pivot.v2pt_theory(origin, ground, base)
        swing = base.y

    previous = base
    for i in range(1, size):
        # Absolute angle: the link frame is turned from the base frame, not from link i − 1.
        frame = base.orientnew(f"L{i}", "Axis", [q[i], swing])
        frame.set_ang_vel(base, rates[i] * swing)
        cog = pivot.locatenew(f"G{i}", lengths[i] / 2 * frame.z)
        cog.v2pt_theory(pivot, ground, frame)
        j_t = m[i] * lengths[i] ** 2 / 12
        dyadic = me.inertia(frame, j_t, j_t, 0) if kind == "classical" else me.inertia(frame, 0, j_t, 0)
        bodies.append(me.RigidBody(f"link{i}", cog, frame, m[i], (dyadic, cog)))
        loads.append((cog, -m[i] * g * ground.z))
        torque = -delta[i] * (frame.ang_vel_in(ground) - previous.ang_vel_in(ground))
        loads.append((frame, torque))
        loads.append((previous, -torque))
        tip = pivot.locatenew(f"P{i + 1}", lengths[i] * frame.z)
        tip.v2pt_theory(pivot, ground, frame)
        previous, pivot = frame, tip
    parameters = {"m": m, "l": lengths, "delta": delta, "g": (g,), "u": (force,)}
    return Pendulum(ground, q, rates, bodies, loads, parameters)


def derive(method: str, kind: str, links: int) -> tuple[sp.Matrix, sp.Matrix, Pendulum]:
    """M and the forcing vector of the pendulum by Kane's or Lagrange's method."""
    if method == "kane":
        size = links + 1
        w = list(me.dynamicsymbols(f"w0:{size}"))
        system = pendulum(kind, links, w)
        kinematics = [qi.diff() - wi for qi, wi in zip(system.q, w, strict=True)]
        kane = me.KanesMethod(system.ground, q_ind=system.q, u_ind=w, kd_eqs=kinematics)
        kane.kanes_equations(system.bodies, system.loads)
        return kane.mass_matrix, kane.forcing, system
    system = pendulum(kind, links)
    lagrangian = me.Lagrangian(system.ground, *system.bodies)
    lagrange = me.LagrangesMethod(lagrangian, system.q, forcelist=system.loads, frame=system.ground)
    lagrange.form_lagranges_equations()
    return lagrange.mass_matrix, lagrange.forcing, system


def agrees_with_ipgen(method: str, kind: str, links: int = 2, seed: int = 0) -> float:
    """Largest relative difference from ipgen's M and B u − bias at a random state (~1e-15)."""
    import numpy as np

    from generator.derive import derive as ipgen_derive
    from generator.model import System

    mass, forcing, system = derive(method, kind, links)
    equations = ipgen_derive(System(kind, links, "pivot"))  # type: ignore[arg-type]
    ipgen = equations.symbols
    random = np.random.default_rng(seed)
    size = links + 1
    values = {
        "q": random.uniform(-3, 3, size),
        "qd": random.uniform(-3, 3, size),
        "m": random.uniform(0.1, 2, size),
        "l": random.uniform(0.2, 1.5, size),
        "delta": random.uniform(0, 0.5, size),
        "g": [9.81],
        "u": [0.7],
    }
    theirs = {"q": system.q, "qd": system.speeds, **system.parameters}
    ours = {"q": ipgen.q, "qd": ipgen.qd, "m": ipgen.m, "l": ipgen.l, "delta": ipgen.delta, "g": (ipgen.g,)}

    def at(symbols: dict) -> dict:
        # Rates first: substituting q(t) would otherwise turn q'(t) into a derivative of a number.
        names = ("qd", "q", "m", "l", "delta", "g", "u")
        return {k: v for name in names for k, v in zip(symbols.get(name, ()), values[name], strict=False)}

    def number(matrix: sp.Matrix, symbols: dict) -> np.ndarray:
        return np.array(matrix.subs(list(at(symbols).items())).evalf(), dtype=float)

    wanted_mass = number(equations.mass_matrix, ours)
    wanted_forcing = -number(equations.bias, ours).ravel()
    wanted_forcing[0] += values["u"][0]
    got_mass, got_forcing = number(mass, theirs), number(forcing, theirs).ravel()
    return float(
        max(
            np.abs(got_mass - wanted_mass).max() / np.abs(wanted_mass).max(),
            np.abs(got_forcing - wanted_forcing).max() / np.abs(wanted_forcing).max(),
        )
    )


def main(argv: list[str]) -> None:
    method, kind, links = argv[0], argv[1], int(argv[2])
    start, start_cpu = time.perf_counter(), time.process_time()
    derive(method, kind, links)
    wall, cpu = time.perf_counter() - start, time.process_time() - start_cpu
    print(json.dumps({"derive_s": wall, "derive_cpu_s": cpu}))


if __name__ == "__main__":
    main(sys.argv[1:])
