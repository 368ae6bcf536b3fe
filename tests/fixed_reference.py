"""Two references for the fixed-pivot chain that share nothing with ipgen's derivation.

- `mechanics_model`: sympy.physics.mechanics (Kane's bookkeeping of frames and points, Lagrange's
  method), links as rigid bodies in a plane, rotors as massless rigid bodies spinning on the
  preceding body, damping, Coulomb friction and the motors' torques as torques between bodies.
- `dfki_closed_form`: DFKI's closed form transcribed from symbolic_plant.py ("UnderactuatedLecture",
  github:dfki-ric-underactuated-lab/double_pendulum, BSD-3-Clause) in numpy.
"""

from __future__ import annotations

import numpy as np
import sympy as sp
from sympy.physics import mechanics as me


def mechanics_model(links: int, joints: tuple[int, ...], matrix: np.ndarray, zero: float, clockwise: bool):
    """(M(q), forcing(q, q̇, u), parameters) of the chain in the rig's coordinates q, where the
    absolute angle of link i measured counterclockwise from hanging is ψ = π − zero − R q (R =
    `matrix`: ipgen's θ = R q + zero, clockwise from upright), and u_k the torque of the motor at
    joint `joints[k]` in the rig's positive sense. Returns lambdified functions of
    (q, q̇, u, values) with values keyed by parameter name."""
    q = me.dynamicsymbols(f"q1:{links + 1}")
    qd = [me.dynamicsymbols(f"q{i}", 1) for i in range(1, links + 1)]
    m = sp.symbols(f"m1:{links + 1}")
    length = sp.symbols(f"l1:{links + 1}")
    com = sp.symbols(f"com1:{links + 1}")
    inertia = sp.symbols(f"J1:{links + 1}")
    delta = sp.symbols(f"delta1:{links + 1}")
    cf = sp.symbols(f"cf1:{links + 1}")
    g, rate = sp.symbols("g coulomb_rate")
    u = sp.symbols(f"u1:{len(joints) + 1}")
    rotor = sp.symbols(f"Ir1:{len(joints) + 1}")
    ratio = sp.symbols(f"gr1:{len(joints) + 1}")
    sense = -1 if clockwise else 1  # a positive rig torque about N.z

    ground = me.ReferenceFrame("N")
    origin = me.Point("O")
    origin.set_vel(ground, 0)
    psi = [sp.pi - zero - sum(int(matrix[i, k]) * q[k] for k in range(links)) for i in range(links)]
    frames, bodies, forces = [ground], [], []
    pivot = origin
    for i in range(links):
        frame = ground.orientnew(f"A{i + 1}", "Axis", (psi[i], ground.z))
        centre = pivot.locatenew(f"G{i + 1}", -com[i] * frame.y)
        centre.v2pt_theory(pivot, ground, frame)
        body = me.RigidBody(f"L{i + 1}", centre, frame, m[i], (me.inertia(frame, 0, 0, inertia[i]), centre))
        body.potential_energy = m[i] * g * centre.pos_from(origin).dot(ground.y)
        bodies.append(body)
        frames.append(frame)
        far = pivot.locatenew(f"P{i + 2}", -length[i] * frame.y)
        far.v2pt_theory(pivot, ground, frame)
        pivot = far
    for j in range(1, links + 1):  # joint j: between frames[j-1] and frames[j]
        relative = psi[j - 1] - (psi[j - 2] if j >= 2 else 0)
        relative_rate = sp.diff(relative, me.dynamicsymbols._t)
        torque = -delta[j - 1] * relative_rate - cf[j - 1] * sp.atan(rate * relative_rate)
        for k, joint in enumerate(joints):
            if joint == j:
                torque += sense * u[k]
                housing = frames[j - 1]
                spin = housing.orientnew(f"R{k + 1}", "Axis", (ratio[k] * relative, housing.z))
                centre = me.Point(f"C{k + 1}")
                centre.set_vel(ground, 0)
                bodies.append(
                    me.RigidBody(f"rotor{k + 1}", centre, spin, 0, (me.inertia(spin, 0, 0, rotor[k]), centre))
                )
        forces.append((frames[j], torque * ground.z))
        if j >= 2:
            forces.append((frames[j - 1], -torque * ground.z))
    lagrangian = me.Lagrangian(ground, *bodies)
    method = me.LagrangesMethod(lagrangian, q, forcelist=forces, frame=ground)
    method.form_lagranges_equations()
    qs, qds = sp.symbols(f"x1:{links + 1}"), sp.symbols(f"v1:{links + 1}")
    plain = {**dict(zip(qd, qds, strict=True)), **dict(zip(q, qs, strict=True))}
    mass = method.mass_matrix.subs(plain)
    forcing = method.forcing.subs(plain)
    names = (*m, *length, *com, *inertia, *delta, *cf, g, rate, *rotor, *ratio)
    mass_f = sp.lambdify((qs, names), mass, "numpy")
    forcing_f = sp.lambdify((qs, qds, u, names), forcing, "numpy")

    def values_of(values: dict[str, float]) -> list[float]:
        return [values.get(str(s), 0.0) for s in names]

    return (
        lambda x, values: np.array(mass_f(list(x), values_of(values)), dtype=float),
        lambda x, v, w, values: np.array(
            forcing_f(list(x), list(v), list(w), values_of(values)), dtype=float
        ).reshape(-1),
    )


def dfki_closed_form(
    values: dict[str, float], q: np.ndarray, qd: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """(M, C q̇ − G + F) of DFKI's closed form at (q, q̇), with DFKI's parameter names."""
    m1, m2, l1, r1, r2 = (values[k] for k in ("m1", "m2", "l1", "r1", "r2"))
    i1, i2, ir, gr, g = (values[k] for k in ("I1", "I2", "Ir", "gr", "g"))
    c2, s2 = np.cos(q[1]), np.sin(q[1])
    m11 = i1 + i2 + m2 * l1**2 + 2 * m2 * l1 * r2 * c2 + gr**2 * ir + ir
    m12 = i2 + m2 * l1 * r2 * c2 - gr * ir
    m22 = i2 + gr**2 * ir
    mass = np.array([[m11, m12], [m12, m22]])
    coriolis = np.array(
        [
            [-2 * m2 * l1 * r2 * s2 * qd[1], -m2 * l1 * r2 * s2 * qd[1]],
            [m2 * l1 * r2 * s2 * qd[0], 0.0],
        ]
    )
    gravity = np.array(
        [
            -m1 * g * r1 * np.sin(q[0]) - m2 * g * (l1 * np.sin(q[0]) + r2 * np.sin(q[0] + q[1])),
            -m2 * g * r2 * np.sin(q[0] + q[1]),
        ]
    )
    friction = np.array(
        [
            values["b1"] * qd[0] + values["cf1"] * np.arctan(100 * qd[0]),
            values["b2"] * qd[1] + values["cf2"] * np.arctan(100 * qd[1]),
        ]
    )
    return mass, coriolis @ qd - gravity + friction
