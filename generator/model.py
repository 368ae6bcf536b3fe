"""The physical model: which system, its symbols, and the kinematics of every body.

This module says *what* the system is (MODEL.md, in code); `derive.py` turns it into
equations of motion without knowing whether the base is a cart or an arm.

Coordinates: θ0 is the cart position [m] or the arm angle [rad]; θ1..θn are absolute link
angles [rad] from the upright vertical, clockwise positive. Link i is a homogeneous rod of
mass m_i and length l_i with its centre of gravity (CoG) at l_i/2.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import sympy as sp

from generator.vectors import PlanarVector

SystemType = Literal["classical", "rotary"]
Inertia = Literal["pivot", "full"]
SYSTEM_TYPES: tuple[str, ...] = ("classical", "rotary")
INERTIA_VARIANTS: tuple[str, ...] = ("pivot", "full")


@dataclass(frozen=True)
class System:
    """A classical (cart) or rotary (Furuta arm) base carrying a chain of `links` rods."""

    type: SystemType
    links: int
    inertia: Inertia = "pivot"  # rotary only: "pivot" (published model) or "full" thin rod

    def __post_init__(self) -> None:
        if self.type not in SYSTEM_TYPES:
            raise ValueError(f"unknown system type {self.type!r}")
        if self.links < 1:
            raise ValueError("a system needs at least one link")
        if self.inertia not in INERTIA_VARIANTS:
            raise ValueError(f"unknown inertia variant {self.inertia!r}")

    @property
    def dof(self) -> int:
        return self.links + 1

    @property
    def is_rotary(self) -> bool:
        return self.type == "rotary"


@dataclass(frozen=True)
class Symbols:
    """The sympy symbols of one system; index 0 is the base, 1..n the links."""

    q: tuple[sp.Symbol, ...]  # θ_i
    qd: tuple[sp.Symbol, ...]  # θ̇_i
    qdd: tuple[sp.Symbol, ...]  # θ̈_i (for derivatives of M θ̈ at a known θ̈)
    m: tuple[sp.Symbol, ...]
    l: tuple[sp.Symbol, ...]  # noqa: E741 (the paper's name)
    delta: tuple[sp.Symbol, ...]
    g: sp.Symbol
    u: sp.Symbol  # force on the cart [N] or torque on the arm [N m]

    @classmethod
    def for_system(cls, system: System) -> Symbols:
        idx = range(system.dof)
        return cls(
            q=tuple(sp.Symbol(f"theta{i}", real=True) for i in idx),
            qd=tuple(sp.Symbol(f"dtheta{i}", real=True) for i in idx),
            qdd=tuple(sp.Symbol(f"ddtheta{i}", real=True) for i in idx),
            m=tuple(sp.Symbol(f"m{i}", positive=True) for i in idx),
            l=tuple(sp.Symbol(f"l{i}", positive=True) for i in idx),
            delta=tuple(sp.Symbol(f"delta{i}", nonnegative=True) for i in idx),
            g=sp.Symbol("g", positive=True),
            u=sp.Symbol("u", real=True),
        )

    @property
    def parameters(self) -> tuple[sp.Symbol, ...]:
        return (*self.m, *self.l, *self.delta, self.g)


@dataclass(frozen=True)
class Body:
    """One link: mass, CoG height, the CoG velocity Jacobian and its own rotational inertia.

    `jacobian[k]` is ∂v_CoG/∂θ̇_k, expressed in a frame where it is a `PlanarVector`
    (classical: the fixed x-z plane; rotary: the arm's rotating frame).
    `rotational[j, k]` is the body's spin contribution to the mass matrix.
    """

    mass: sp.Expr
    height: sp.Expr
    jacobian: tuple[PlanarVector, ...]
    rotational: dict[tuple[int, int], sp.Expr]


def rod_lever(sym: Symbols, body: int, joint: int) -> sp.Expr:
    """Distance along link `joint` from its pivot to the point of link `body` we follow.

    The CoG of link i lies beyond the full length of every earlier link and half of its own.
    """
    if joint < body:
        return sym.l[joint]
    if joint == body:
        return sym.l[joint] / 2
    return sp.S.Zero


def named_quantities(system: System, sym: Symbols) -> dict[sp.Symbol, sp.Expr]:
    """Intermediate quantities that the equations share, in definition order.

    Rotary: `rho_k`, the horizontal reach of joint k + 1 from the arm tip (perpendicular to
    the arm), and `r_i`, that of link i's CoG. Built recursively, they are computed once
    each in the generated code instead of being expanded into every entry that uses them.
    """
    if not system.is_rotary:
        return {}
    named: dict[sp.Symbol, sp.Expr] = {}
    reach_of_joint: sp.Expr = sp.S.Zero
    for i in range(1, system.dof):
        r_i = sp.Symbol(f"r{i}", real=True)
        named[r_i] = reach_of_joint + sym.l[i] / 2 * sp.sin(sym.q[i])
        if i < system.links:
            rho = sp.Symbol(f"rho{i}", real=True)
            named[rho] = reach_of_joint + sym.l[i] * sp.sin(sym.q[i])
            reach_of_joint = rho
    return named


def bodies(system: System, sym: Symbols) -> list[Body]:
    """Kinematics of the links, in the coordinates described in the module docstring."""
    n = system.links
    result = []
    for i in range(1, n + 1):
        levers = [rod_lever(sym, i, k) for k in range(n + 1)]
        height = sp.Add(*(levers[k] * sp.cos(sym.q[k]) for k in range(1, i + 1)))
        # d/dt (l sin θ, l cos θ) = l θ̇ (cos θ, −sin θ): each link turns the point along the
        # unit direction at angle θ_k in the plane of the links.
        link_columns = [PlanarVector.along(levers[k], sym.q[k]) for k in range(1, n + 1)]
        j_spin = sym.m[i] * sym.l[i] ** 2 / 12
        rotational = {(i, i): j_spin}
        if system.is_rotary:
            # In the arm's rotating frame (e_arm, e_perp, e_z) the CoG is at
            # l0 e_arm + r_i e_perp + z_i e_z, so ∂v/∂θ̇0 = l0 e_perp − r_i e_arm.
            reach = sp.Symbol(f"r{i}", real=True)  # see named_quantities
            base_column = PlanarVector.along(sym.l[0], sp.S.Zero, normal=-reach)
            if system.inertia == "full":
                # The rod also turns about the vertical with the arm: ½ J_T (θ̇0 sin θ_i)².
                rotational[(0, 0)] = j_spin * sp.sin(sym.q[i]) ** 2
        else:
            base_column = PlanarVector.along(sp.S.One, sp.S.Zero)  # the cart moves along x
        result.append(Body(sym.m[i], height, (base_column, *link_columns), rotational))
    return result


def base_inertia(system: System, sym: Symbols) -> sp.Expr:
    """M_00 contribution of the base alone: cart mass, or the arm's J0 = m0 l0²/3."""
    if system.is_rotary:
        return sym.m[0] * sym.l[0] ** 2 / 3
    return sym.m[0]


def rayleigh_dissipation(system: System, sym: Symbols) -> sp.Expr:
    """D = ½δ0θ̇0² + ½δ1θ̇1² + Σ_{i≥2} ½δ_i(θ̇_i − θ̇_{i−1})² (MODEL.md: link 1 uses its absolute rate)."""
    qd, delta = sym.qd, sym.delta
    terms = [delta[0] * qd[0] ** 2, delta[1] * qd[1] ** 2]
    terms += [delta[i] * (qd[i] - qd[i - 1]) ** 2 for i in range(2, system.dof)]
    return sp.Add(*terms) / 2
