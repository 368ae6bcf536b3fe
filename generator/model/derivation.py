"""Lagrange's equations with Rayleigh dissipation, from energies to M θ̈ + bias = B u.

The structure keeps the derivation polynomial in size (no `simplify` anywhere):
- M and V from a few per-link combinations (mass moments, inertias about the pivots) and the
  rotary reaches, named quantities of the ring (`bodies.py`);
- C from the Christoffel symbols of M (so Ṁ − 2C is skew-symmetric), differentiating only
  the entries that actually depend on the angle;
- P = ∂V/∂θ, damping = ∂²D/∂θ̇²;
- all of it as elements of one polynomial ring over Q (FLINT's `fmpq_mpoly`; generators
  and the chain rule in `polynomial.py`), where expanding and collecting are free. sympy
  expression views of the results are offered for tests and references.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import cached_property
from typing import TYPE_CHECKING

from ipgen.model.bodies import (
    algebra_for,
    mass_matrix_entries,
    potential_energy,
    rayleigh_dissipation,
    rod_defaults,
)
from ipgen.model.polynomial import Algebra, Poly
from ipgen.model.system import System

if TYPE_CHECKING:
    import sympy as sp

    from ipgen.model.actuator import Actuator
    from ipgen.model.symbols import Symbols

ProgressCallback = Callable[[str], None]
PolyMatrix = list[list[Poly]]


@dataclass(frozen=True)
class Equations:
    """M(θ) θ̈ + C(θ, θ̇) θ̇ + D θ̇ + P(θ) = B u, as `ipgen.derive` returns them.

    Each piece is kept as ring elements (`poly`, what code generation reads; `algebra.ring`)
    and offered as sympy expressions in θ, θ̇ and the parameters (computed on first use):
    `mass_matrix`, `coriolis`, `damping`, `gravity`, `bias`, `n_matrix`, `input_matrix`,
    `kinetic_energy`, `potential_energy`, `dissipation`.

    Examples
    --------
    >>> import ipgen
    >>> print(ipgen.derive("classical", 1).mass_matrix)
    Matrix([[m0 + m1, l1*m1*cos(theta1)/2], [l1*m1*cos(theta1)/2, l1**2*m1/3]])
    """

    system: System
    algebra: Algebra
    poly: dict[str, PolyMatrix]  # name -> matrix of polynomials (vectors: one column)
    rod_links: bool = False  # the paper's rods substituted (`rod`): no com, J, J_axial, tip
    # What drives the base (`driven`); None: the paper's direct force or torque. Only the sympy
    # views read it (a dc_motor is folded into them); `poly`, what code generation reads, is the
    # direct model's.
    drive: Actuator | None = None

    @property
    def symbols(self) -> Symbols:
        """The sympy symbols the views are written in."""
        return self.algebra.symbols

    def rod(self) -> Equations:
        """These equations for the paper's homogeneous rods (com_i = l_i/2, J_i = m_i l_i²/12,
        J0 = m0 l0²/3, no tip masses or axial inertia): written in m, l, delta and g only."""
        values = rod_defaults(self.system, self.algebra)
        algebra = self.algebra.composed(values)
        poly = {key: [[algebra.compose(p, values) for p in row] for row in m] for key, m in self.poly.items()}
        return Equations(system=self.system, algebra=algebra, poly=poly, rod_links=True, drive=self.drive)

    def driven(self, actuator: Actuator) -> Equations:
        """These equations with `actuator` driving the base (checked: `ActuatorError`). A
        "dc_motor" is folded into the sympy views exactly (docs/model.md, "A DC motor on the
        base"): M00 + the rotor's reflected inertia, the damping's and N's (0, 0) entry + the
        back-EMF's c, bias0 + c θ̇0, T + ½ I_r θ̇0², D + ½ c θ̇0², and `input_matrix` = (b, 0, …)ᵀ,
        so that M θ̈ + bias = input_matrix · V with V the voltage; the motor constants enter as
        the exact decimals of their values. "direct" and "acceleration" leave the views as they
        are (for "acceleration" see `link_equations`)."""
        import dataclasses

        actuator.check(self.system)
        return dataclasses.replace(self, drive=actuator)

    def _fold(self) -> tuple[sp.Expr, sp.Expr, sp.Expr]:
        """(I_r, c, b) of the drive as exact sympy numbers: the rotor's reflected inertia, the
        back-EMF damping and the input gain ((0, 0, 1) unless a dc_motor drives the base)."""
        import sympy as sp

        drive = self.drive
        if drive is None or not drive.is_motor:
            return sp.Integer(0), sp.Integer(0), sp.Integer(1)

        from ipgen.model.actuator import motor_terms

        constants = {name: sp.Rational(repr(float(value))) for name, value in drive.constants().items()}
        gain, damping, inertia = motor_terms(constants)
        return inertia, damping, gain

    def _matrix(self, name: str) -> sp.Matrix:
        import sympy as sp

        matrix = sp.Matrix([[self.algebra.to_sympy(e) for e in row] for row in self.poly[name]])
        inertia, damping, _ = self._fold()
        if name == "mass_matrix":
            matrix[0, 0] += inertia
        elif name in ("damping", "n_matrix"):
            matrix[0, 0] += damping
        elif name == "bias":
            matrix[0, 0] += damping * self.symbols.qd[0]
        return matrix

    @cached_property
    def input_matrix(self) -> sp.Matrix:
        """B of M θ̈ + bias = B u (column): (1, 0, …, 0)ᵀ for a direct drive (u the force or
        torque; also for "acceleration", where the base force is then τ), (b, 0, …, 0)ᵀ for a
        dc_motor (u the voltage, b the force or torque per volt)."""
        import sympy as sp

        column = sp.zeros(self.system.dof, 1)
        column[0, 0] = self._fold()[2]
        return column

    @cached_property
    def link_equations(self) -> tuple[sp.Matrix, sp.Matrix, sp.Matrix]:
        """(M_LL, M_L0, bias_L): the links' rows of M θ̈ + bias = B u, which for a base that
        follows a commanded acceleration u = θ̈0 ([actuator] kind = "acceleration") are the
        equations of motion: M_LL θ̈_L = −(M_L0 u + bias_L), θ̈_L = (θ̈1, …, θ̈n)
        (docs/model.md, "An acceleration-driven base"). M_LL is n × n, M_L0 and bias_L columns."""
        mass, bias = self.mass_matrix, self.bias
        return mass[1:, 1:], mass[1:, :1], bias[1:, :]

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

    @cached_property
    def kinetic_energy(self) -> sp.Expr:
        rate = self.symbols.qd[0]
        return self.algebra.to_sympy(self.poly["kinetic_energy"][0][0]) + self._fold()[0] * rate**2 / 2

    @cached_property
    def potential_energy(self) -> sp.Expr:
        return self.algebra.to_sympy(self.poly["potential_energy"][0][0])

    @cached_property
    def dissipation(self) -> sp.Expr:
        """Rayleigh D; the power it removes is 2D."""
        rate = self.symbols.qd[0]
        return self.algebra.to_sympy(self.poly["dissipation"][0][0]) + self._fold()[1] * rate**2 / 2


def _mass_matrix(system: System, algebra: Algebra) -> PolyMatrix:
    size = system.dof
    entries = mass_matrix_entries(system, algebra)
    mass = [[algebra.zero] * size for _ in range(size)]
    for (j, k), entry in entries.items():
        mass[j][k] = mass[k][j] = entry
    return mass


MassPartials = dict[tuple[int, int, int], Poly]


def _mass_partials(mass: PolyMatrix, algebra: Algebra) -> MassPartials:
    """∂M_jk/∂θ_i keyed (i, j, k), only where M_jk depends on θ_i (most depend on two angles)."""
    size = len(mass)
    partial: MassPartials = {}
    for j in range(size):
        for k in range(j, size):
            for i, d in algebra.gradient(mass[j][k]).items():
                partial[i, j, k] = partial[i, k, j] = d
    return partial


def _coriolis(partial: MassPartials, size: int, algebra: Algebra) -> PolyMatrix:
    """C_kj = Σ_i ½(∂M_kj/∂θi + ∂M_ki/∂θj − ∂M_ij/∂θk) θ̇i."""

    def christoffel(k: int, j: int) -> Poly:
        parts = []
        for i in range(size):
            rate = algebra.gens[algebra.qd(i)]
            for key, sign in (((i, k, j), 1), ((j, k, i), 1), ((k, i, j), -1)):
                if key in partial:
                    d = partial[key] * rate
                    parts.append(d if sign > 0 else -d)
        return algebra.total(parts) / 2

    return [[christoffel(k, j) for j in range(size)] for k in range(size)]


def _dynamics_partials(
    partial: MassPartials, bias: list[Poly], algebra: Algebra
) -> tuple[PolyMatrix, PolyMatrix]:
    """Partial derivatives of r(θ, θ̇, θ̈) = M(θ) θ̈ + b(θ, θ̇), the residual of M θ̈ + b = B u.

    Returns (∂r/∂θ, ∂r/∂θ̇) = (∂M/∂θ_i θ̈ + ∂b/∂θ_i, ∂b/∂θ̇_i) column by column. Differentiating
    M θ̈ + b = B u implicitly gives ∂θ̈/∂x = −M⁻¹ ∂r/∂x and ∂θ̈/∂u = M⁻¹ B: no symbolic inverse.
    """
    size = len(bias)
    by_angle = []
    for k in range(size):
        gradient = algebra.gradient(bias[k])
        by_angle.append(
            [
                algebra.total(
                    [
                        gradient.get(i, algebra.zero),
                        *(
                            partial[i, k, j] * algebra.gens[algebra.qdd(j)]
                            for j in range(size)
                            if (i, k, j) in partial
                        ),
                    ]
                )
                for i in range(size)
            ]
        )
    by_rate = [[bias[k].derivative(algebra.qd(i)) for i in range(size)] for k in range(size)]
    return by_angle, by_rate


def derive(system: System, progress: ProgressCallback | None = None) -> Equations:
    """Derive the equations of motion of `system` (see docs/model.md for the conventions)."""
    report = progress or (lambda step: None)
    algebra = algebra_for(system)
    size = system.dof
    qd = [algebra.gens[algebra.qd(k)] for k in range(size)]

    report("mass matrix")
    mass = _mass_matrix(system, algebra)

    report("potential energy and gravity")
    potential = potential_energy(system, algebra)
    slope = algebra.gradient(potential)
    gravity = [slope.get(k, algebra.zero) for k in range(size)]

    report("dissipation")
    dissipation = rayleigh_dissipation(system, algebra)
    rate = [algebra.qd(k) for k in range(size)]  # generator indices: `derivative` takes them directly
    damping = [
        [dissipation.derivative(rate[j]).derivative(rate[k]) for k in range(size)] for j in range(size)
    ]

    report("Coriolis matrix")
    partial = _mass_partials(mass, algebra)
    coriolis = _coriolis(partial, size, algebra)

    report("bias vector")
    n_matrix = [[coriolis[k][j] + damping[k][j] for j in range(size)] for k in range(size)]
    bias = [algebra.total([gravity[k], *(n_matrix[k][j] * qd[j] for j in range(size))]) for k in range(size)]
    momentum = [algebra.total(mass[j][k] * qd[k] for k in range(size)) for j in range(size)]
    kinetic = algebra.total(momentum[j] * qd[j] for j in range(size)) / 2

    report("derivatives of the dynamics")
    residual_dq, residual_dqd = _dynamics_partials(partial, bias, algebra)
    return Equations(
        system=system,
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
