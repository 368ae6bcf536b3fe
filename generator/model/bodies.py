"""The kinematics of every body of a system, as polynomials (docs/model.md in code).

Every quantity is an element of the FLINT polynomial ring (`fmpq_mpoly`) of the system's
`Algebra`, in its generators: parameters, velocities and trig letters. Link i is a homogeneous
rod of mass m_i and length l_i with its centre of gravity (CoG) at l_i/2.
"""

from __future__ import annotations

from dataclasses import dataclass

from ipgen.model.polynomial import Algebra, Poly
from ipgen.model.system import System
from ipgen.model.vectors import PlanarVector


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
