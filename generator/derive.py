"""Lagrange's equations with Rayleigh dissipation, from energies to M θ̈ + bias = B u.

The structure keeps the derivation polynomial in size (no `simplify` anywhere):
- M = Σ m_i J_iᵀ J_i + spin terms, with J_i the CoG velocity Jacobians (`model.py`);
- C from the Christoffel symbols of M (so Ṁ − 2C is skew-symmetric), differentiating only
  the entries that actually depend on the angle;
- P = ∂V/∂θ, damping = ∂²D/∂θ̇²;
- every entry is tidied by `tidy`: expanded once and grouped by its state-dependent factor.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass

import sympy as sp

from generator.model import Symbols, System, base_inertia, bodies, rayleigh_dissipation

ProgressCallback = Callable[[str], None]


@dataclass(frozen=True)
class Equations:
    """M(θ) θ̈ + C(θ, θ̇) θ̇ + D θ̇ + P(θ) = B u, with every piece as a sympy expression."""

    system: System
    symbols: Symbols
    mass_matrix: sp.Matrix  # M, symmetric positive definite
    coriolis: sp.Matrix  # C, Christoffel symbols of the first kind contracted with θ̇
    damping: sp.Matrix  # constant: ∂D/∂θ̇ = damping · θ̇
    gravity: sp.Matrix  # P = ∂V/∂θ (column)
    bias: sp.Matrix  # C θ̇ + damping θ̇ + P (column)
    input_map: sp.Matrix  # B: the input acts on θ0 only
    kinetic_energy: sp.Expr
    potential_energy: sp.Expr
    dissipation: sp.Expr  # Rayleigh D; the power it removes is 2D

    @property
    def n_matrix(self) -> sp.Matrix:
        """One valid N of eq. 29: N θ̇ + P is the bias."""
        return self.coriolis + self.damping


def tidy(expr: sp.Expr, state: Iterable[sp.Symbol]) -> sp.Expr:
    """Expand once, then collect the parameter coefficient of each state-dependent factor.

    Cheap (linear in the number of terms) and enough here: with absolute angles every
    entry is a sum of products of per-entry trig factors and velocities.
    """
    state = tuple(state)
    groups: dict[sp.Expr, list[sp.Expr]] = {}
    for term in sp.Add.make_args(sp.expand(expr)):
        coefficient, factor = term.as_independent(*state, as_Add=False)
        groups.setdefault(factor, []).append(coefficient)
    return sp.Add(*(sp.factor_terms(sp.Add(*c)) * f for f, c in groups.items()))


def _mass_matrix(system: System, sym: Symbols, state: tuple[sp.Symbol, ...]) -> sp.Matrix:
    links = bodies(system, sym)
    size = system.dof
    mass = sp.zeros(size, size)
    for j in range(size):
        for k in range(j, size):
            terms = [body.mass * body.jacobian[j].dot(body.jacobian[k]) for body in links]
            terms += [body.rotational.get((j, k), sp.S.Zero) for body in links]
            if j == k == 0:
                terms.append(base_inertia(system, sym))
            mass[j, k] = mass[k, j] = tidy(sp.Add(*terms), state)
    return mass


def _coriolis(mass: sp.Matrix, sym: Symbols, state: tuple[sp.Symbol, ...]) -> sp.Matrix:
    """C_kj = Σ_i ½(∂M_kj/∂θi + ∂M_ki/∂θj − ∂M_ij/∂θk) θ̇i."""
    size = mass.rows
    q, qd = sym.q, sym.qd
    # ∂M_jk/∂θ_i, only where M_jk depends on θ_i (most entries depend on two angles at most).
    partial: dict[tuple[int, int, int], sp.Expr] = {}
    for j in range(size):
        for k in range(j, size):
            for i in range(size):
                if q[i] in mass[j, k].free_symbols:
                    partial[i, j, k] = partial[i, k, j] = sp.diff(mass[j, k], q[i])

    def dm(i: int, j: int, k: int) -> sp.Expr:
        return partial.get((i, j, k), sp.S.Zero)

    coriolis = sp.zeros(size, size)
    for k in range(size):
        for j in range(size):
            terms = [(dm(i, k, j) + dm(j, k, i) - dm(k, i, j)) * qd[i] for i in range(size)]
            coriolis[k, j] = tidy(sp.Add(*terms) / 2, state)
    return coriolis


def derive(system: System, progress: ProgressCallback | None = None) -> Equations:
    """Derive the equations of motion of `system` (see MODEL.md for the conventions)."""
    report = progress or (lambda step: None)
    sym = Symbols.for_system(system)
    state = (*sym.q, *sym.qd)
    size = system.dof

    report("mass matrix")
    mass = _mass_matrix(system, sym, state)

    report("potential energy and gravity")
    potential = tidy(sp.Add(*(b.mass * sym.g * b.height for b in bodies(system, sym))), state)
    gravity = sp.Matrix([tidy(sp.diff(potential, q), state) for q in sym.q])

    report("dissipation")
    dissipation = rayleigh_dissipation(system, sym)
    damping = sp.Matrix(size, size, lambda j, k: sp.diff(dissipation, sym.qd[j], sym.qd[k]))

    report("Coriolis matrix")
    coriolis = _coriolis(mass, sym, state)

    report("bias vector")
    qd = sp.Matrix(sym.qd)
    velocity_terms = (coriolis + damping) * qd
    bias = sp.Matrix([tidy(velocity_terms[k] + gravity[k], state) for k in range(size)])

    kinetic = tidy((qd.T * mass * qd)[0, 0] / 2, state)
    input_map = sp.Matrix([1] + [0] * system.links)
    return Equations(
        system=system,
        symbols=sym,
        mass_matrix=mass,
        coriolis=coriolis,
        damping=damping,
        gravity=gravity,
        bias=bias,
        input_map=input_map,
        kinetic_energy=kinetic,
        potential_energy=potential,
        dissipation=dissipation,
    )
