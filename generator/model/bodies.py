"""The kinematics and energies of a system, as polynomials (docs/model.md in code).

Every quantity is an element of the FLINT polynomial ring (`fmpq_mpoly`) of the system's
`Algebra`, in its generators: parameters, velocities, trig letters and named quantities.

Link i (1..n) is built as it is (docs/model.md, "Links as built"): mass m_i with its centre of
gravity (CoG) at com_i from the pivot, inertia J_i about the CoG (perpendicular to the link),
J_axial_i about its own axis, and a point mass tip_i at its far end, l_i from the pivot. The
rotary arm has inertia J0 about the vertical. The paper's rods are the defaults com_i = l_i/2,
J_i = m_i l_i²/12, J0 = m0 l0²/3, tip_i = J_axial_i = 0 (`rod_defaults`).

The mass matrix and the potential energy depend on the links only through a few per-link
combinations, named quantities computed once per call in the generated code:

    w_i = tip_i + Σ_{k>i} (m_k + tip_k)      mass beyond the far end of link i (w_n = tip_n)
    a_i = m_i com_i + w_i l_i                first mass moment about pivot i (every body the
                                             link carries)
    I_i = J_i + m_i com_i² + w_i l_i²        inertia about pivot i (link i and the point masses
                                             at its far end)

With them (c_i = cos θi, c_ij = cos(θi − θj), i < j):
M_0i = a_i c_i (cart) or l0 a_i c_i (arm), M_ii = I_i, M_ij = l_i a_j c_ij, V = g Σ a_i c_i;
M_00 = m0 + m_1 + w_1 (cart), or, for the arm, J0 + l0² (m_1 + w_1) + Q with
Q = Σ_i m_i r_i² + tip_i ρ_i² (r_i, ρ_i: horizontal reach of the CoG and of the far end of link i
from the arm's tip, themselves named quantities; `_reaches`) plus, with the full inertia,
Σ_i J_i sin²θi + J_axial_i cos²θi.
"""

from __future__ import annotations

from ipgen.model.polynomial import Algebra, Poly
from ipgen.model.system import System

# What each family of named quantities is, for the comments of the generated code.
NAMED_MEANING: dict[str, str] = {
    "w": "mass beyond the far end of link {i} [kg]",
    "h": "mass moment of link {i} alone about its pivot [kg m]",
    "x": "mass moment of the masses beyond link {i} about its pivot [kg m]",
    "a": "mass moment of link {i} and all it carries about its pivot [kg m]",
    "I": "inertia of link {i} and the masses at its far end about its pivot [kg m^2]",
    "r": "horizontal reach of link {i}'s CoG from the arm's tip [m]",
    "rho": "horizontal reach of link {i}'s far end from the arm's tip [m]",
    "y": "sum of mass x reach of the masses beyond link {i}'s far end [kg m]",
    "R": "sum of mass x reach of links {i}..n and their tip masses [kg m]",
    "G": "sum of mass x lever about pivot {i} x reach, over all link {i} carries [kg m^2]",
    "Q": "sum of mass x reach^2 of every mass on the arm (dQ/dq_k = 2 cos q_k G_k) [kg m^2]",
}


def algebra_for(system: System) -> Algebra:
    """The system's generators, with its named quantities defined."""
    algebra = Algebra(system.dof, named_quantity_names(system))
    named_quantities(system, algebra)
    return algebra


def named_quantity_names(system: System) -> tuple[str, ...]:
    """The names `named_quantities` defines, in the order of their definitions (each uses only
    earlier ones): w_{n−1}..w_1, then h_i, x_i, a_i, I_i per link, then (rotary) r_i, ρ_i, and
    y_i, G_i, R_i from the last link down, and Q."""
    n = system.links
    names = [f"w{i}" for i in range(n - 1, 0, -1)]
    for i in range(1, n + 1):
        names += [f"h{i}", f"x{i}", f"a{i}", f"I{i}"]
    if system.is_rotary:
        for i in range(1, n + 1):
            names += [f"r{i}", f"rho{i}"]
        for i in range(n, 0, -1):
            names += [f"y{i}", f"G{i}"] + ([f"R{i}"] if i > 1 else [])
        names.append("Q")
    return tuple(names)


def named_meaning(name: str) -> str:
    """What the named quantity `name` (a1, rho2, Q) is, for a comment of the generated code."""
    family = name.rstrip("0123456789")
    return NAMED_MEANING[family].format(i=name[len(family) :])


def beyond(alg: Algebra, i: int, links: int) -> Poly:
    """w_i: the mass beyond the far end of link i (its tip mass and the links after it)."""
    return alg.tip(links) if i == links else alg.gen(f"w{i}")


def named_quantities(system: System, alg: Algebra) -> None:
    """Define the named quantities of the module docstring in `alg`, in order.

    The per-link combinations depend on parameters only: h_i = m_i com_i and x_i = w_i l_i (the
    moments of the link itself and of what it carries), a_i = h_i + x_i, I_i = J_i + com_i h_i +
    l_i x_i. Each is computed once in the generated code instead of being expanded into every
    entry that uses it.
    """
    n = system.links
    for i in range(n - 1, 0, -1):
        alg.define(f"w{i}", alg.tip(i) + alg.m(i + 1) + beyond(alg, i + 1, n))
    for i in range(1, n + 1):
        own = alg.define(f"h{i}", alg.m(i) * alg.com(i))
        carried = alg.define(f"x{i}", beyond(alg, i, n) * alg.l(i))
        alg.define(f"a{i}", own + carried)
        alg.define(f"I{i}", alg.J(i) + alg.com(i) * own + alg.l(i) * carried)
    if system.is_rotary:
        _reaches(system, alg)


def _reaches(system: System, alg: Algebra) -> None:
    """The rotary reaches and Q = Σ_b m_b r_b² (b: every link and tip mass, r_b its reach), the
    part of M_00 that depends on the angles (plus, with the full inertia, Σ_k (J_k − J_axial_k)
    sin²θk).

    Reaches, recursively: ρ_0 = 0, r_i = ρ_{i−1} + com_i sin θi, ρ_i = ρ_{i−1} + l_i sin θi.
    Since r_b = Σ_k lever_k(b) sin θk, with G_k = Σ_b m_b lever_k(b) r_b: Q = Σ_k sin θk G_k and
    ∂Q/∂θk = 2 cos θk G_k, given to the algebra as Q's gradient so that the Coriolis terms read
    2 cos θk G_k instead of the chain rule's expansion. G_k = h_k r_k + l_k y_k with
    y_k = tip_k ρ_k + R_{k+1} and R_k = m_k r_k + y_k (R_{n+1} = 0).
    """
    n = system.links
    reach_of_joint = alg.zero
    for i in range(1, n + 1):
        alg.define(f"r{i}", reach_of_joint + alg.com(i) * alg.sin(i))
        reach_of_joint = alg.define(f"rho{i}", reach_of_joint + alg.l(i) * alg.sin(i))
    carried = alg.zero  # R_{k+1}
    lever_moment: dict[int, Poly] = {}
    for k in range(n, 0, -1):
        reach, far_end = alg.gen(f"r{k}"), alg.gen(f"rho{k}")
        beyond_far_end = alg.define(f"y{k}", alg.tip(k) * far_end + carried)
        moment_k = alg.gen(f"h{k}") * reach + alg.l(k) * beyond_far_end
        if system.inertia == "full":
            # The link turns about the vertical with the arm: ½ (J_k sin²θk + J_axial_k cos²θk) θ̇0²,
            # = ½ J_axial_k θ̇0² (in M_00) + ½ (J_k − J_axial_k) sin²θk θ̇0² (in Q).
            moment_k += (alg.J(k) - alg.J_axial(k)) * alg.sin(k)
        lever_moment[k] = alg.define(f"G{k}", moment_k)
        if k > 1:
            carried = alg.define(f"R{k}", alg.m(k) * reach + beyond_far_end)
    alg.define(
        "Q",
        alg.total(alg.sin(k) * lever_moment[k] for k in range(1, n + 1)),
        gradient={k: 2 * alg.cos(k) * lever_moment[k] for k in range(1, n + 1)},
    )


def moment(alg: Algebra, i: int) -> Poly:
    """a_i, the first mass moment about pivot i of link i and everything it carries."""
    return alg.gen(f"a{i}")


def mass_matrix_entries(system: System, alg: Algebra) -> dict[tuple[int, int], Poly]:
    """The upper triangle of M (j <= k), from the named quantities (module docstring)."""
    n = system.links
    entries: dict[tuple[int, int], Poly] = {}
    total = alg.m(1) + beyond(alg, 1, n)  # every mass the base carries
    if system.is_rotary:
        # In the arm's rotating frame (e_arm, e_perp, e_z) a point at reach r of the chain's
        # plane moves with l0 θ̇0 e_perp − r θ̇0 e_arm from the arm: |.|² = (l0² + r²) θ̇0².
        parts = [alg.J(0), alg.l(0) ** 2 * total, alg.gen("Q")]
        if system.inertia == "full":
            parts += [alg.J_axial(i) for i in range(1, n + 1)]  # see _reaches
        entries[0, 0] = alg.total(parts)
        base_lever = alg.l(0)
    else:
        entries[0, 0] = alg.m(0) + total
        base_lever = alg.one
    for i in range(1, n + 1):
        entries[0, i] = base_lever * moment(alg, i) * alg.cos(i)
        entries[i, i] = alg.gen(f"I{i}")
        for j in range(i + 1, n + 1):
            entries[i, j] = alg.l(i) * moment(alg, j) * alg.cos_difference(i, j)
    return entries


def potential_energy(system: System, alg: Algebra) -> Poly:
    """V = g Σ_i a_i cos θi: every mass at its height above the base's pivot."""
    return alg.g() * alg.total(moment(alg, i) * alg.cos(i) for i in range(1, system.dof))


def rod_defaults(system: System, alg: Algebra) -> dict[int, Poly]:
    """{generator: its value for the paper's rods}: com_i = l_i/2, J_i = m_i l_i²/12, J0 = m0 l0²/3
    (rotary; a cart's J0 is unused: 0), J_axial_i = tip_i = 0."""
    arm = alg.m(0) * alg.l(0) ** 2 / 3 if system.is_rotary else alg.zero
    values: dict[int, Poly] = {alg.index("J0"): arm}
    for i in range(1, system.dof):
        values[alg.index(f"com{i}")] = alg.l(i) / 2
        values[alg.index(f"J{i}")] = alg.m(i) * alg.l(i) ** 2 / 12
        values[alg.index(f"J_axial{i}")] = alg.zero
        values[alg.index(f"tip{i}")] = alg.zero
    return values


def joint_rates(system: System) -> list[dict[int, int]]:
    """The rate each damper i = 0..n acts on, as {coordinate: ±1} (θ̇0 for the base, θ̇1 for link 1,
    θ̇i − θ̇_{i−1} for the joint between links i−1 and i; docs/model.md: link 1 uses its absolute
    rate). Damper i's torque is r_i = δ_i ω_i, and the generalised damping force on coordinate
    k is ∂D/∂θ̇_k = Σ_i r_i ∂ω_i/∂θ̇_k: +r_i on the body it turns, −r_{i+1} from the next joint."""
    return [{0: 1}, {1: 1}, *({i: 1, i - 1: -1} for i in range(2, system.dof))]


def rayleigh_dissipation(system: System, alg: Algebra) -> Poly:
    """D = ½δ0θ̇0² + ½δ1θ̇1² + Σ_{i≥2} ½δ_i(θ̇_i − θ̇_{i−1})² = ½ Σ_i δ_i ω_i² (`joint_rates`)."""
    rates = [alg.total(c * alg.gens[alg.qd(k)] for k, c in rate.items()) for rate in joint_rates(system)]
    return alg.total(alg.delta(i) * rate**2 for i, rate in enumerate(rates)) / 2
