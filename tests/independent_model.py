"""The pendulums built independently with sympy.physics.mechanics (Kane's method).

The geometry is built here from first principles, sharing nothing with generator/model.py:
rigid bodies in rotating reference frames, gravity as forces on the centres of gravity,
viscous friction as forces and torques between the bodies, the input as a force on the cart
or a torque on the arm. Kane's equations give M(θ) θ̈ = forcing(θ, θ̇, u).

Used by tests/test_independent.py (against ipgen's equations), tools/make_golden.py (an
independent integration that checks the simulator's golden trajectories) and
bench/references.py (the derivations ipgen's generation time is compared with).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import cache
from typing import TYPE_CHECKING

import sympy as sp
from sympy.physics import mechanics as me

if TYPE_CHECKING:  # numpy only in annotations: the benchmark times derivations in a numpy-free process
    import numpy as np


@dataclass(frozen=True)
class Reference:
    """Numerical functions of (angles, rates, input, parameters) from the mechanics model."""

    mass_matrix: Callable[..., np.ndarray]
    forcing: Callable[..., np.ndarray]
    kinetic: Callable[..., float]
    potential: Callable[..., float]

    def accelerations(self, *args: object) -> np.ndarray:
        """θ̈ = M⁻¹ forcing at the same arguments as `mass_matrix`."""
        import numpy as np

        mass = np.asarray(self.mass_matrix(*args), dtype=float)
        return np.linalg.solve(mass, np.asarray(self.forcing(*args), dtype=float).ravel())


def rod_inertia(frame: me.ReferenceFrame, about_y: sp.Expr, about_x: sp.Expr) -> me.Dyadic:
    """Central inertia dyadic of a thin rod along `frame.z` (nothing about its own axis)."""
    return me.inertia(frame, about_x, about_y, 0)


@dataclass
class Pendulum:
    """What a method of sympy.physics.mechanics needs: frames, coordinates, bodies and loads."""

    ground: me.ReferenceFrame
    origin: me.Point
    q: list[sp.Function]
    speeds: list[sp.Expr]  # the rates the velocities are written in
    bodies: list[me.RigidBody | me.Particle]
    loads: list[tuple]
    parameters: dict[str, tuple[sp.Symbol, ...]]  # m, l, delta: one per body; g, u: one each


def pendulum(
    kind: str, links: int, inertia: str = "pivot", speeds: list[sp.Expr] | None = None, general: bool = False
) -> Pendulum:
    """The n-link pendulum on a cart (classical) or on a horizontal arm (rotary).

    `general`: the links as built (docs/model.md): link i's CoG at com_i along it, inertia J_i
    about the CoG (perpendicular; J_axial_i about its own axis, counted with inertia "full"), a
    particle tip_i at its far end; the arm a body on the vertical axis with inertia J0 about it.
    Otherwise the paper's homogeneous rods (and a rod arm).

    `speeds` are the rates the velocities are written in: generalized speeds for Kane's method,
    or None for the time derivatives of the coordinates (Lagrange's method).

    Classical: N.x along the rail, N.z up; link i's frame is N turned by θi about N.y, so
    its axis Li.z = sin θi N.x + cos θi N.z (θ clockwise from upright, seen from −N.y).
    Rotary: N.z up; the arm frame A is N turned by −θ0 about N.z so that the arm A.y =
    (sin θ0, cos θ0, 0) and A.x = (cos θ0, −sin θ0, 0) (eq. 25); link i's frame is A turned
    by θi about the arm axis A.y, so Li.z = sin θi A.x + cos θi N.z.
    """
    size = links + 1
    q = list(me.dynamicsymbols(f"q0:{size}"))
    w = speeds if speeds is not None else [qi.diff() for qi in q]
    m = sp.symbols(f"m0:{size}", positive=True)
    lengths = sp.symbols(f"l0:{size}", positive=True)
    delta = sp.symbols(f"delta0:{size}", nonnegative=True)
    g, u = sp.symbols("g u")
    com = sp.symbols(f"com0:{size}", real=True)
    inertia_cog = sp.symbols(f"J0:{size}", nonnegative=True)
    axial = sp.symbols(f"J_axial0:{size}", nonnegative=True)
    tips = sp.symbols(f"tip0:{size}", nonnegative=True)

    ground = me.ReferenceFrame("N")
    origin = me.Point("O")
    origin.set_vel(ground, 0)
    bodies: list[me.RigidBody | me.Particle] = []
    loads: list[tuple] = []

    if kind == "classical":
        base_frame = ground  # the cart translates: it does not rotate
        attach = origin.locatenew("cart", q[0] * ground.x)
        attach.set_vel(ground, w[0] * ground.x)
        bodies.append(me.Particle("cart", attach, m[0]))
        loads.append((attach, (u - delta[0] * w[0]) * ground.x))
        links_axis = ground.y
    else:
        base_frame = ground.orientnew("A", "Axis", [-q[0], ground.z])
        base_frame.set_ang_vel(ground, -w[0] * ground.z)
        if general:
            # The arm (hub and rotor included) as one body on the axis: J0 about the vertical.
            arm_cog = origin.locatenew("arm_cog", 0 * base_frame.y)
            arm_cog.set_vel(ground, 0)
            arm_inertia = me.inertia(base_frame, 0, 0, inertia_cog[0])
        else:
            arm_cog = origin.locatenew("arm_cog", lengths[0] / 2 * base_frame.y)
            arm_cog.v2pt_theory(origin, ground, base_frame)
            # A thin rod along A.y: m0 l0²/12 about A.x and A.z through its centre of gravity.
            rod = m[0] * lengths[0] ** 2 / 12
            arm_inertia = me.inertia(base_frame, rod, 0, rod)
        bodies.append(me.RigidBody("arm", arm_cog, base_frame, m[0], (arm_inertia, arm_cog)))
        turning = -ground.z  # the direction θ0 increases about
        loads.append((base_frame, (u - delta[0] * w[0]) * turning))
        attach = origin.locatenew("tip", lengths[0] * base_frame.y)
        attach.v2pt_theory(origin, ground, base_frame)
        links_axis = base_frame.y

    previous_frame, pivot = base_frame, attach
    for i in range(1, size):
        # Absolute angle: the link frame is turned from the base frame, not from link i − 1.
        frame = base_frame.orientnew(f"L{i}", "Axis", [q[i], links_axis])
        frame.set_ang_vel(base_frame, w[i] * links_axis)
        cog = pivot.locatenew(f"G{i}", (com[i] if general else lengths[i] / 2) * frame.z)
        cog.v2pt_theory(pivot, ground, frame)
        j_t = inertia_cog[i] if general else m[i] * lengths[i] ** 2 / 12
        if kind == "rotary" and inertia == "pivot":
            dyadic = rod_inertia(frame, j_t, 0)  # J_T about the pivot axis only
        elif general:
            dyadic = me.inertia(frame, j_t, j_t, axial[i])  # axisymmetric: J_axial about Li.z
        else:
            dyadic = rod_inertia(frame, j_t, j_t)  # complete thin rod: J_T (I − z z)
        bodies.append(me.RigidBody(f"link{i}", cog, frame, m[i], (dyadic, cog)))
        loads.append((cog, -m[i] * g * ground.z))
        # Joint damping: link 1 against the base, link i against link i − 1 (docs/model.md);
        # equal and opposite torques on the two bodies the joint connects.
        relative = frame.ang_vel_in(ground) - previous_frame.ang_vel_in(ground)
        loads.append((frame, -delta[i] * relative))
        loads.append((previous_frame, delta[i] * relative))
        tip = pivot.locatenew(f"P{i + 1}", lengths[i] * frame.z)
        tip.v2pt_theory(pivot, ground, frame)
        if general:  # a point mass at the far end (hinge, encoder, weight)
            bodies.append(me.Particle(f"tip{i}", tip, tips[i]))
            loads.append((tip, -tips[i] * g * ground.z))
        previous_frame, pivot = frame, tip
    parameters = {"m": m, "l": lengths, "delta": delta, "g": (g,), "u": (u,)}
    if general:
        parameters |= {"com": com, "J": inertia_cog, "J_axial": axial, "tip": tips}
    return Pendulum(ground, origin, q, w, bodies, loads, parameters)


@cache
def reference(kind: str, links: int, inertia: str, general: bool = False) -> Reference:
    """Kane's equations of the pendulum (see `pendulum` for the frames), as numeric functions
    of (angles, rates, u, (m, l, delta, g)), or with `general` of
    (angles, rates, u, (m, l, delta, g, com, J, J_axial, tip))."""
    size = links + 1
    w = list(me.dynamicsymbols(f"w0:{size}"))
    system = pendulum(kind, links, inertia, w, general)
    q, ground, bodies = system.q, system.ground, system.bodies
    m, lengths, delta = (system.parameters[key] for key in ("m", "l", "delta"))
    (g,), (u,) = system.parameters["g"], system.parameters["u"]

    kane = me.KanesMethod(ground, q_ind=q, u_ind=w, kd_eqs=[q[k].diff() - w[k] for k in range(size)])
    kane.kanes_equations(bodies, system.loads)
    kinetic = sum(body.kinetic_energy(ground) for body in bodies)
    heights = [body.masscenter.pos_from(system.origin).dot(ground.z) for body in bodies]
    # Every body at its height above the base's pivot (the base itself stays at height 0).
    potential = sum(body.mass * g * height for body, height in zip(bodies, heights, strict=True))

    angles = sp.symbols(f"a0:{size}")
    rates = sp.symbols(f"r0:{size}")
    plain = dict(zip(w, rates, strict=True)) | dict(zip(q, angles, strict=True))
    arguments: tuple = (angles, rates, u, (m, lengths, delta, g))
    if general:
        links_as_built = tuple(system.parameters[key] for key in ("com", "J", "J_axial", "tip"))
        arguments = (angles, rates, u, (m, lengths, delta, g, *links_as_built))

    def numeric(expr: sp.Expr | sp.Matrix) -> Callable[..., np.ndarray]:
        return sp.lambdify(arguments, sp.sympify(expr).xreplace(plain), "numpy")

    return Reference(
        numeric(kane.mass_matrix),
        numeric(kane.forcing),
        numeric(kinetic),
        numeric(potential),
    )
