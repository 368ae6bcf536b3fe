"""Lagrange's equations with Rayleigh dissipation, from energies to M θ̈ + bias = B u.

The structure keeps the derivation polynomial in size (no `simplify` anywhere):
- M = Σ m_i J_iᵀ J_i + spin terms, with J_i the CoG velocity Jacobians (`model.py`);
- C from the Christoffel symbols of M (so Ṁ − 2C is skew-symmetric), differentiating only
  the entries that actually depend on the angle;
- P = ∂V/∂θ, damping = ∂²D/∂θ̇²;
- all of it in a sparse polynomial ring (`polynomial.py`), where expanding and collecting
  are free, then turned into readable sympy expressions once, at the end.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import cached_property

import sympy as sp
from sympy.polys.rings import PolyElement

from generator.model import Symbols, System, base_inertia, bodies, named_quantities, rayleigh_dissipation
from generator.polynomial import Algebra
from generator.vectors import PlanarVector

ProgressCallback = Callable[[str], None]
PolyMatrix = list[list[PolyElement]]


@dataclass(frozen=True)
class Equations:
    """M(θ) θ̈ + C(θ, θ̇) θ̇ + D θ̇ + P(θ) = B u.

    Each piece is kept as polynomials (`poly`, what code generation reads) and offered as
    sympy expressions in θ, θ̇ and the parameters (computed on first use).
    """

    system: System
    symbols: Symbols
    algebra: Algebra
    poly: dict[str, PolyMatrix]  # name -> matrix of ring elements (vectors: one column)

    def _matrix(self, name: str) -> sp.Matrix:
        return sp.Matrix([[self.algebra.to_expr(e) for e in row] for row in self.poly[name]])

    @cached_property
    def mass_matrix(self) -> sp.Matrix:
        """M, symmetric positive definite."""
        return self._matrix("mass_matrix")

    @cached_property
    def coriolis(self) -> sp.Matrix:
        """C, from the Christoffel symbols of M: Ṁ − 2C is skew-symmetric."""
        return self._matrix("coriolis")

    @cached_property
    def damping(self) -> sp.Matrix:
        """Constant damping matrix: ∂D/∂θ̇ = damping · θ̇."""
        return self._matrix("damping")

    @cached_property
    def gravity(self) -> sp.Matrix:
        """P = ∂V/∂θ (column)."""
        return self._matrix("gravity")

    @cached_property
    def bias(self) -> sp.Matrix:
        """C θ̇ + damping θ̇ + P (column)."""
        return self._matrix("bias")

    @cached_property
    def n_matrix(self) -> sp.Matrix:
        """One valid N of eq. 29 (C + damping): N θ̇ + P is the bias."""
        return self._matrix("n_matrix")

    @property
    def input_map(self) -> sp.Matrix:
        """B: the input acts on θ0 only."""
        return sp.Matrix([1] + [0] * self.system.links)

    @cached_property
    def kinetic_energy(self) -> sp.Expr:
        return self.algebra.to_expr(self.poly["kinetic_energy"][0][0])

    @cached_property
    def potential_energy(self) -> sp.Expr:
        return self.algebra.to_expr(self.poly["potential_energy"][0][0])

    @cached_property
    def dissipation(self) -> sp.Expr:
        """Rayleigh D; the power it removes is 2D."""
        return self.algebra.to_expr(self.poly["dissipation"][0][0])


class _RingVector:
    """A `PlanarVector` with ring coefficients and angle indices (None: the base direction)."""

    def __init__(self, vector: PlanarVector, algebra: Algebra, angle_index: dict[sp.Expr, int]) -> None:
        self.terms = [(algebra.from_expr(c), angle_index.get(a)) for c, a in vector.terms]
        self.normal = algebra.from_expr(vector.normal)
        self.algebra = algebra

    def dot(self, other: _RingVector) -> PolyElement:
        total = self.normal * other.normal
        for a, alpha in self.terms:
            for b, beta in other.terms:
                total += a * b * self.algebra.cos_difference(alpha, beta)
        return total


def _mass_matrix(system: System, algebra: Algebra) -> PolyMatrix:
    sym = algebra.sym
    angle_index = {q: k for k, q in enumerate(sym.q)}
    size = system.dof
    mass = [[algebra.zero() for _ in range(size)] for _ in range(size)]
    mass[0][0] = algebra.from_expr(base_inertia(system, sym))
    for body in bodies(system, sym):
        m = algebra.from_expr(body.mass)
        columns = [_RingVector(v, algebra, angle_index) for v in body.jacobian]
        for j in range(size):
            for k in range(j, size):
                mass[j][k] += m * columns[j].dot(columns[k])
        for (j, k), spin in body.rotational.items():
            mass[j][k] += algebra.from_expr(spin)
    for j in range(size):
        for k in range(j):
            mass[j][k] = mass[k][j]
    return mass


MassPartials = dict[tuple[int, int, int], PolyElement]


def _mass_partials(mass: PolyMatrix, algebra: Algebra) -> MassPartials:
    """∂M_jk/∂θ_i keyed (i, j, k), only where M_jk depends on θ_i (most depend on two angles)."""
    size = len(mass)
    partial: MassPartials = {}
    for j in range(size):
        for k in range(j, size):
            for i in range(size):
                if algebra.depends_on_angle(mass[j][k], i):
                    partial[i, j, k] = partial[i, k, j] = algebra.diff_angle(mass[j][k], i)
    return partial


def _coriolis(partial: MassPartials, size: int, algebra: Algebra) -> PolyMatrix:
    """C_kj = Σ_i ½(∂M_kj/∂θi + ∂M_ki/∂θj − ∂M_ij/∂θk) θ̇i."""
    qd = algebra.sym.qd
    zero = algebra.zero()

    def dm(i: int, j: int, k: int) -> PolyElement:
        return partial.get((i, j, k), zero)

    half = algebra.one() / 2
    return [
        [
            sum(
                (algebra.times_symbol(dm(i, k, j) + dm(j, k, i) - dm(k, i, j), qd[i]) for i in range(size)),
                zero,
            )
            * half
            for j in range(size)
        ]
        for k in range(size)
    ]


def _dynamics_partials(
    partial: MassPartials, bias: list[PolyElement], algebra: Algebra
) -> tuple[PolyMatrix, PolyMatrix]:
    """Partial derivatives of r(θ, θ̇, θ̈) = M(θ) θ̈ + b(θ, θ̇), the residual of M θ̈ + b = B u.

    Returns (∂r/∂θ, ∂r/∂θ̇) = (∂M/∂θ_i θ̈ + ∂b/∂θ_i, ∂b/∂θ̇_i) column by column. Differentiating
    M θ̈ + b = B u implicitly gives ∂θ̈/∂x = −M⁻¹ ∂r/∂x and ∂θ̈/∂u = M⁻¹ B: no symbolic inverse.
    """
    size = len(bias)
    sym = algebra.sym
    by_angle = [
        [
            sum(
                (
                    algebra.times_symbol(partial[i, k, j], sym.qdd[j])
                    for j in range(size)
                    if (i, k, j) in partial
                ),
                algebra.diff_angle(bias[k], i),
            )
            for i in range(size)
        ]
        for k in range(size)
    ]
    by_rate = [[algebra.diff_symbol(bias[k], sym.qd[i]) for i in range(size)] for k in range(size)]
    return by_angle, by_rate


def derive(system: System, progress: ProgressCallback | None = None) -> Equations:
    """Derive the equations of motion of `system` (see MODEL.md for the conventions)."""
    report = progress or (lambda step: None)
    sym = Symbols.for_system(system)
    algebra = Algebra(sym, named_quantities(system, sym))
    size = system.dof
    qd = sym.qd
    zero = algebra.zero()

    report("mass matrix")
    mass = _mass_matrix(system, algebra)

    report("potential energy and gravity")
    heights = [algebra.from_expr(b.mass * sym.g * b.height) for b in bodies(system, sym)]
    potential = sum(heights, algebra.zero())
    gravity = [algebra.diff_angle(potential, k) for k in range(size)]

    report("dissipation")
    dissipation = algebra.from_expr(rayleigh_dissipation(system, sym))
    damping = [
        [algebra.diff_symbol(algebra.diff_symbol(dissipation, sym.qd[j]), sym.qd[k]) for k in range(size)]
        for j in range(size)
    ]

    report("Coriolis matrix")
    partial = _mass_partials(mass, algebra)
    coriolis = _coriolis(partial, size, algebra)

    report("bias vector")
    bias = [
        sum((algebra.times_symbol(coriolis[k][j] + damping[k][j], qd[j]) for j in range(size)), gravity[k])
        for k in range(size)
    ]
    momentum = [
        sum((algebra.times_symbol(mass[j][k], qd[k]) for k in range(size)), zero) for j in range(size)
    ]
    kinetic = sum((algebra.times_symbol(momentum[j], qd[j]) for j in range(size)), zero) / 2

    n_matrix = [[coriolis[k][j] + damping[k][j] for j in range(size)] for k in range(size)]
    report("derivatives of the dynamics")
    residual_dq, residual_dqd = _dynamics_partials(partial, bias, algebra)
    return Equations(
        system=system,
        symbols=sym,
        algebra=algebra,
        poly={
            "mass_matrix": mass,
            "coriolis": coriolis,
            "damping": damping,
            "n_matrix": n_matrix,
            "gravity": [[g] for g in gravity],
            "bias": [[b] for b in bias],
            "kinetic_energy": [[kinetic]],
            "potential_energy": [[potential]],
            "dissipation": [[dissipation]],
            "residual_dq": residual_dq,
            "residual_dqd": residual_dqd,
        },
    )
