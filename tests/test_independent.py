"""An independent derivation with sympy.physics.mechanics (Kane's method) against ipgen.

The geometry is built here from first principles, sharing nothing with generator/model.py:
rigid bodies in rotating reference frames, gravity as forces on the centres of gravity,
viscous friction as forces and torques between the bodies, the input as a force on the cart
or a torque on the arm. Kane's equations give M(θ) θ̈ = forcing(θ, θ̇, u); with the
generalized speeds θ̇i, ipgen must have M equal and bias = B u − forcing, compared
numerically at random states and positive parameters to 1e-12 relative.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import cache

import numpy as np
import pytest
import sympy as sp
from sympy.physics import mechanics as me

from generator.derive import Equations, derive
from generator.model import System

RELATIVE = 1e-12
STATES = 5


@dataclass(frozen=True)
class Reference:
    """Numerical functions of (angles, rates, input, parameters) from the mechanics model."""

    mass_matrix: Callable[..., np.ndarray]
    forcing: Callable[..., np.ndarray]
    kinetic: Callable[..., float]
    potential: Callable[..., float]


def rod_inertia(frame: me.ReferenceFrame, about_y: sp.Expr, about_x: sp.Expr) -> me.Dyadic:
    """Central inertia dyadic of a thin rod along `frame.z` (nothing about its own axis)."""
    return me.inertia(frame, about_x, about_y, 0)


@cache
def reference(kind: str, links: int, inertia: str) -> Reference:
    """Kane's equations of the pendulum, from frames, points and rigid bodies.

    Classical: N.x along the rail, N.z up; link i's frame is N turned by θi about N.y, so
    its axis Li.z = sin θi N.x + cos θi N.z (θ clockwise from upright, seen from −N.y).
    Rotary: N.z up; the arm frame A is N turned by −θ0 about N.z so that the arm A.y =
    (sin θ0, cos θ0, 0) and A.x = (cos θ0, −sin θ0, 0) (eq. 25); link i's frame is A turned
    by θi about the arm axis A.y, so Li.z = sin θi A.x + cos θi N.z.
    """
    size = links + 1
    q = me.dynamicsymbols(f"q0:{size}")
    w = me.dynamicsymbols(f"w0:{size}")
    m = sp.symbols(f"m0:{size}", positive=True)
    lengths = sp.symbols(f"l0:{size}", positive=True)
    delta = sp.symbols(f"delta0:{size}", nonnegative=True)
    g, u = sp.symbols("g u")

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
        frame = base_frame.orientnew(f"L{i}", "Axis", [q[i], links_axis])
        frame.set_ang_vel(base_frame, w[i] * links_axis)
        cog = pivot.locatenew(f"G{i}", lengths[i] / 2 * frame.z)
        cog.v2pt_theory(pivot, ground, frame)
        j_t = m[i] * lengths[i] ** 2 / 12
        if kind == "rotary" and inertia == "pivot":
            dyadic = rod_inertia(frame, j_t, 0)  # J_T about the pivot axis only
        else:
            dyadic = rod_inertia(frame, j_t, j_t)  # complete thin rod: J_T (I − z z)
        bodies.append(me.RigidBody(f"link{i}", cog, frame, m[i], (dyadic, cog)))
        loads.append((cog, -m[i] * g * ground.z))
        # Joint damping: link 1 against the base, link i against link i − 1 (MODEL.md);
        # equal and opposite torques on the two bodies the joint connects.
        other = base_frame if i == 1 else previous_frame
        relative = frame.ang_vel_in(ground) - other.ang_vel_in(ground)
        loads.append((frame, -delta[i] * relative))
        loads.append((other, delta[i] * relative))
        tip = pivot.locatenew(f"P{i + 1}", lengths[i] * frame.z)
        tip.v2pt_theory(pivot, ground, frame)
        previous_frame, pivot = frame, tip

    kane = me.KanesMethod(ground, q_ind=q, u_ind=w, kd_eqs=[q[k].diff() - w[k] for k in range(size)])
    kane.kanes_equations(bodies, loads)
    kinetic = sum(body.kinetic_energy(ground) for body in bodies)
    potential = sum(m[i] * g * bodies[i].masscenter.pos_from(origin).dot(ground.z) for i in range(1, size))

    angles = sp.symbols(f"a0:{size}")
    rates = sp.symbols(f"r0:{size}")
    plain = dict(zip(w, rates, strict=True)) | dict(zip(q, angles, strict=True))
    arguments = (angles, rates, u, (m, lengths, delta, g))

    def numeric(expr: sp.Expr | sp.Matrix) -> Callable[..., np.ndarray]:
        return sp.lambdify(arguments, sp.sympify(expr).xreplace(plain), "numpy")

    return Reference(
        numeric(kane.mass_matrix),
        numeric(kane.forcing),
        numeric(kinetic),
        numeric(potential),
    )


@dataclass(frozen=True)
class Ipgen:
    """ipgen's equations as numerical functions with the same argument layout."""

    mass_matrix: Callable[..., np.ndarray]
    bias: Callable[..., np.ndarray]
    kinetic: Callable[..., float]
    potential: Callable[..., float]


@cache
def ipgen(kind: str, links: int, inertia: str) -> Ipgen:
    eqs: Equations = derive(System(kind, links, inertia))  # type: ignore[arg-type]
    sym = eqs.symbols
    arguments = (sym.q, sym.qd, sym.u, (sym.m, sym.l, sym.delta, sym.g))

    def numeric(expr: sp.Expr | sp.Matrix) -> Callable[..., np.ndarray]:
        return sp.lambdify(arguments, expr, "numpy")

    return Ipgen(
        numeric(eqs.mass_matrix),
        numeric(eqs.bias),
        numeric(eqs.kinetic_energy),
        numeric(eqs.potential_energy),
    )


CASES = [
    ("classical", 1, "pivot"),
    ("classical", 2, "pivot"),
    ("classical", 3, "pivot"),
    ("rotary", 1, "pivot"),
    ("rotary", 1, "full"),
    ("rotary", 2, "pivot"),
    ("rotary", 2, "full"),
]


def case_id(case: tuple[str, int, str]) -> str:
    kind, links, inertia = case
    return f"{kind}{links}" + (f"-{inertia}" if kind == "rotary" else "")


def random_case(rng: np.random.Generator, size: int) -> tuple:
    angles = tuple(rng.uniform(-np.pi, np.pi, size))
    rates = tuple(rng.uniform(-3.0, 3.0, size))
    torque = float(rng.uniform(-2.0, 2.0))
    params = (
        tuple(rng.uniform(0.1, 2.0, size)),
        tuple(rng.uniform(0.2, 1.5, size)),
        tuple(rng.uniform(0.0, 0.5, size)),
        float(rng.uniform(1.0, 20.0)),
    )
    return angles, rates, torque, params


def assert_close(actual: np.ndarray, expected: np.ndarray, what: str) -> None:
    actual = np.asarray(actual, dtype=float)
    expected = np.asarray(expected, dtype=float)
    scale = max(float(np.max(np.abs(expected))), 1e-300)
    error = float(np.max(np.abs(actual - expected)))
    assert error <= RELATIVE * scale, (
        f"{what}: max |difference| {error:.3e} > {RELATIVE:g} × {scale:.3e}\n"
        f"  ipgen:     {np.array2string(actual, precision=17)}\n"
        f"  mechanics: {np.array2string(expected, precision=17)}"
    )


@pytest.mark.parametrize("case", CASES, ids=case_id)
def test_matches_kanes_method(case: tuple[str, int, str]) -> None:
    kind, links, inertia = case
    size = links + 1
    ref = reference(kind, links, inertia)
    ours = ipgen(kind, links, inertia)
    rng = np.random.default_rng(20130 + 10 * links + (kind == "rotary") + 2 * (inertia == "full"))
    input_map = np.zeros(size)
    input_map[0] = 1.0
    for k in range(STATES):
        args = random_case(rng, size)
        torque = args[2]
        where = f"{case_id(case)}, state {k}: θ={np.round(args[0], 4)}, θ̇={np.round(args[1], 4)}"
        mass = ours.mass_matrix(*args)
        assert_close(mass, ref.mass_matrix(*args), f"{where}: M")
        bias = np.ravel(ours.bias(*args))
        expected_bias = torque * input_map - np.ravel(ref.forcing(*args))
        assert_close(bias, expected_bias, f"{where}: bias (= B u − Kane's forcing)")
        assert_close(ours.kinetic(*args), ref.kinetic(*args), f"{where}: T")
        assert_close(ours.potential(*args), ref.potential(*args), f"{where}: V")
