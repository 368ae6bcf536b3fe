"""The physical model: which system, and the kinematics of every body (docs/model.md in code).

This module says *what* the system is; `derive.py` turns it into equations of motion without
knowing whether the base is a cart or an arm. Every quantity is a polynomial, an element of
the FLINT polynomial ring (`fmpq_mpoly`) of the system's `Algebra`, in its generators:
parameters, velocities and trig letters.

Coordinates: θ0 is the cart position [m] or the arm angle [rad]; θ1..θn are absolute link
angles [rad] from the upright vertical, clockwise positive. Link i is a homogeneous rod of
mass m_i and length l_i with its centre of gravity (CoG) at l_i/2.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Literal

from ipgen.polynomial import Algebra, Poly
from ipgen.vectors import PlanarVector

if TYPE_CHECKING:
    import sympy as sp

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

    @property
    def default_name(self) -> str:
        """The model name when none is given: "<type><links>", e.g. rotary3."""
        return f"{self.type}{self.links}"


# Parameters: the arrays m, l, delta (index 0 the base, 1..n the links) and g, named m0, l1,
# delta2, g in scenes, --fix and the generated code (and by `polynomial.Algebra`).
PARAMETER_GROUPS: tuple[str, ...] = ("m", "l", "delta")


def parameter_names(links: int) -> tuple[str, ...]:
    """m0..mn, l0..ln, delta0..deltan, g (n = `links`), in this order."""
    indices = range(links + 1)
    return (*(f"{group}{i}" for group in PARAMETER_GROUPS for i in indices), "g")


def parameter_range(links: int) -> str:
    """The names `parameter_names(links)` as messages show them: "m0..m2, ..., delta0..delta2 or g"."""
    return f"m0..m{links}, l0..l{links}, delta0..delta{links} or g"


def split_parameter(name: str) -> tuple[str, int | None]:
    """ "delta2" -> ("delta", 2), "g" -> ("g", None); KeyError if `name` is no parameter name."""
    if name == "g":
        return "g", None
    group = name.rstrip("0123456789")
    if group not in PARAMETER_GROUPS or group == name:
        raise KeyError(f"unknown parameter {name!r}")
    return group, int(name[len(group) :])


def unused_parameter(system_type: str, name: str) -> str | None:
    """Why the model of a `system_type` system has no parameter `name` (one of its
    `parameter_names`), or None if it has: a cart has no length l0."""
    if system_type == "classical" and name == "l0":
        return "a cart has no length l0"
    return None


@dataclass(frozen=True)
class Symbols:
    """The sympy symbols of one system, index 0 the base, 1..n the links (sympy views only)."""

    q: tuple[sp.Symbol, ...]  # θ_i
    qd: tuple[sp.Symbol, ...]  # θ̇_i
    qdd: tuple[sp.Symbol, ...]  # θ̈_i (for derivatives of M θ̈ at a known θ̈)
    m: tuple[sp.Symbol, ...]
    l: tuple[sp.Symbol, ...]  # noqa: E741 (the paper's name)
    delta: tuple[sp.Symbol, ...]
    g: sp.Symbol
    u: sp.Symbol  # force on the cart [N] or torque on the arm [N m]

    @classmethod
    def for_dof(cls, dof: int) -> Symbols:
        import sympy as sp

        idx = range(dof)
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

    mass: Poly
    height: Poly
    jacobian: tuple[PlanarVector, ...]
    rotational: dict[tuple[int, int], Poly]


def algebra_for(system: System) -> Algebra:
    """The system's generators, with its named quantities defined."""
    algebra = Algebra(system.dof, named_quantity_names(system))
    named_quantities(system, algebra)
    return algebra


def named_quantity_names(system: System) -> tuple[str, ...]:
    """The names `named_quantities` defines, in order: r1, rho1, r2, ..., rn (rotary only)."""
    if not system.is_rotary:
        return ()
    names: list[str] = []
    for i in range(1, system.dof):
        names.append(f"r{i}")
        if i < system.links:
            names.append(f"rho{i}")
    return tuple(names)


def rod_lever(alg: Algebra, body: int, joint: int) -> Poly:
    """Distance along link `joint` from its pivot to the point of link `body` we follow.

    The CoG of link i lies beyond the full length of every earlier link and half of its own.
    """
    if joint < body:
        return alg.l(joint)
    if joint == body:
        return alg.l(joint) / 2
    return alg.zero


def named_quantities(system: System, alg: Algebra) -> None:
    """Intermediate quantities that the equations share, defined in `alg` in order.

    Rotary: `rho_k`, the horizontal reach of joint k + 1 from the arm tip (perpendicular to
    the arm), and `r_i`, that of link i's CoG. Built recursively, they are computed once
    each in the generated code instead of being expanded into every entry that uses them.
    """
    if not system.is_rotary:
        return
    reach_of_joint = alg.zero
    for i in range(1, system.dof):
        alg.define(f"r{i}", reach_of_joint + alg.l(i) / 2 * alg.sin(i))
        if i < system.links:
            reach_of_joint = alg.define(f"rho{i}", reach_of_joint + alg.l(i) * alg.sin(i))


def bodies(system: System, alg: Algebra) -> list[Body]:
    """Kinematics of the links, in the coordinates described in the module docstring.

    `alg` must have the system's named quantities (`algebra_for`).
    """
    n = system.links
    result = []
    for i in range(1, n + 1):
        levers = {k: rod_lever(alg, i, k) for k in range(1, n + 1)}  # joint k -> lever (k >= 1)
        height = alg.total(levers[k] * alg.cos(k) for k in range(1, i + 1))
        # d/dt (l sin θ, l cos θ) = l θ̇ (cos θ, −sin θ): each link turns the point along the
        # unit direction at angle θ_k in the plane of the links.
        link_columns = [PlanarVector.along(levers[k], k) for k in range(1, n + 1)]
        j_spin = alg.m(i) * alg.l(i) ** 2 / 12
        rotational = {(i, i): j_spin}
        if system.is_rotary:
            # In the arm's rotating frame (e_arm, e_perp, e_z) the CoG is at
            # l0 e_arm + r_i e_perp + z_i e_z, so ∂v/∂θ̇0 = l0 e_perp − r_i e_arm.
            reach = alg.gen(f"r{i}")  # see named_quantities
            base_column = PlanarVector.along(alg.l(0), None, normal=-reach)
            if system.inertia == "full":
                # The rod also turns about the vertical with the arm: ½ J_T (θ̇0 sin θ_i)².
                rotational[(0, 0)] = j_spin * alg.sin(i) ** 2
        else:
            base_column = PlanarVector.along(alg.one, None)  # the cart moves along x
        result.append(Body(alg.m(i), height, (base_column, *link_columns), rotational))
    return result


def base_inertia(system: System, alg: Algebra) -> Poly:
    """M_00 contribution of the base alone: cart mass, or the arm's J0 = m0 l0²/3."""
    if system.is_rotary:
        return alg.m(0) * alg.l(0) ** 2 / 3
    return alg.m(0)


def rayleigh_dissipation(system: System, alg: Algebra) -> Poly:
    """D = ½δ0θ̇0² + ½δ1θ̇1² + Σ_{i≥2} ½δ_i(θ̇_i − θ̇_{i−1})² (docs/model.md: link 1 uses its absolute rate)."""
    rate = [alg.gens[alg.qd(i)] for i in range(system.dof)]
    terms = [alg.delta(0) * rate[0] ** 2, alg.delta(1) * rate[1] ** 2]
    terms += [alg.delta(i) * (rate[i] - rate[i - 1]) ** 2 for i in range(2, system.dof)]
    return alg.total(terms) / 2
