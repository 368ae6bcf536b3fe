"""Symbolic checks of the derived equations against docs/model.md, written out by hand here.

- eq. 30 (classical, n = 2) and eq. 31 (rotary, n = 1, pivot inertia, and the 'full'
  variant with 1/3 for eq. 31's 1/4): M, P and the bias N θ̇ + P entry by entry;
- the energies and the Rayleigh function equal docs/model.md's formulas, and Lagrange's equation
  from those energies (differentiated here, independently of derive.py) gives both
  M θ̈ + N θ̇ + P and M θ̈ + bias;
- M = ∂²T/∂θ̇² (hence symmetric), damping = ∂²D/∂θ̇², P = ∂V/∂θ, all with docs/model.md's
  T, V, D; Ṁ − 2C skew-symmetric.

Zero tests are exact: sin/cos of every angle become polynomial variables and the result
is reduced modulo sin² + cos² = 1 (a canonical form), so no heuristic `simplify` is needed.
"""

from __future__ import annotations

from collections.abc import Sequence
from functools import cache

import pytest
import sympy as sp
from cases import CASES, case_id

from ipgen.model.derivation import Equations, derive
from ipgen.model.symbols import Symbols
from ipgen.model.system import System

# --------------------------------------------------------------------------- helpers


def trig_normal_form(expr: sp.Expr, angles: Sequence[sp.Symbol]) -> sp.Expr:
    """A canonical polynomial form of `expr` in sin θi, cos θi modulo sin² θi + cos² θi = 1."""
    expr = sp.expand(sp.expand_trig(sp.expand(expr)))
    sines = [sp.Dummy(f"s{k}") for k in range(len(angles))]
    cosines = [sp.Dummy(f"c{k}") for k in range(len(angles))]
    replace: dict[sp.Expr, sp.Expr] = {}
    for angle, s, c in zip(angles, sines, cosines, strict=True):
        replace[sp.sin(angle)] = s
        replace[sp.cos(angle)] = c
    poly_expr = sp.expand(expr.xreplace(replace))
    leftover = poly_expr.atoms(sp.sin, sp.cos)
    assert not leftover, f"trigonometric terms left after expansion: {leftover}"
    for s, c in zip(sines, cosines, strict=True):
        # Division by c² + s² − 1 in c leaves a remainder of degree ≤ 1 in c: unique.
        poly_expr = sp.expand(sp.rem(poly_expr, c**2 + s**2 - 1, c))
    return poly_expr


def assert_identical(actual: sp.Expr, expected: sp.Expr, angles: Sequence[sp.Symbol], what: str) -> None:
    difference = trig_normal_form(actual - expected, angles)
    assert difference == 0, (
        f"{what}:\n  ipgen:    {actual}\n  expected: {expected}\n  difference (normal form): {difference}"
    )


def assert_matrix_identical(
    actual: sp.Matrix, expected: sp.Matrix, angles: Sequence[sp.Symbol], what: str
) -> None:
    assert actual.shape == expected.shape, f"{what}: shape {actual.shape} != {expected.shape}"
    for r in range(actual.rows):
        for c in range(actual.cols):
            assert_identical(actual[r, c], expected[r, c], angles, f"{what}[{r}, {c}]")


@cache
def equations(kind: str, links: int, inertia: str = "pivot") -> Equations:
    return derive(System(kind, links, inertia)).rod()  # type: ignore[arg-type]


def column(values: Sequence[sp.Expr]) -> sp.Matrix:
    return sp.Matrix(list(values))


# --------------------------------------------------------------------------- eq. 30


def eq30(sym: Symbols) -> tuple[sp.Matrix, sp.Matrix, sp.Matrix]:
    """M, N, P of the classical double pendulum, transcribed from docs/model.md."""
    _, t1, t2 = sym.q
    _, d1, d2 = sym.qd
    m0, m1, m2 = sym.m
    _, l1, l2 = sym.l
    de0, de1, de2 = sym.delta
    g = sym.g
    a = (m1 / 2 + m2) * l1
    b = m2 * l2 / 2
    e = m2 * l1 * l2 / 2
    j1 = m1 * l1**2 / 3
    j2 = m2 * l2**2 / 3
    c12 = sp.cos(t1 - t2)
    s12 = sp.sin(t1 - t2)
    mass = sp.Matrix(
        [
            [m0 + m1 + m2, a * sp.cos(t1), b * sp.cos(t2)],
            [a * sp.cos(t1), j1 + m2 * l1**2, e * c12],
            [b * sp.cos(t2), e * c12, j2],
        ]
    )
    n_matrix = sp.Matrix(
        [
            [de0, -a * d1 * sp.sin(t1), -b * d2 * sp.sin(t2)],
            [0, de1 + de2, -de2 + e * d2 * s12],
            [0, -de2 - e * d1 * s12, de2],
        ]
    )
    gravity = column([0, -(m1 / 2 + m2) * g * l1 * sp.sin(t1), -(m2 / 2) * g * l2 * sp.sin(t2)])
    return mass, n_matrix, gravity


def test_eq30_classical_double() -> None:
    eqs = equations("classical", 2)
    sym = eqs.symbols
    mass, n_matrix, gravity = eq30(sym)
    assert_matrix_identical(eqs.mass_matrix, mass, sym.q, "classical 2: M vs eq. 30")
    assert_matrix_identical(eqs.gravity, gravity, sym.q, "classical 2: P vs eq. 30")
    bias = n_matrix * column(sym.qd) + gravity
    assert_matrix_identical(eqs.bias, bias, sym.q, "classical 2: bias vs eq. 30's N θ̇ + P")


# --------------------------------------------------------------------------- eq. 31


def eq31(sym: Symbols, spin: sp.Expr) -> tuple[sp.Matrix, sp.Matrix, sp.Matrix]:
    """M, N, P of the rotary single pendulum; `spin` is the sin²θ1 coefficient of M00 / (m1 l1²).

    docs/model.md's eq. 31 is the pivot variant, spin = 1/4: N00 = δ0 + ¼ m1 l1² θ̇1 sin 2θ1 and
    N10 = −⅛ m1 l1² θ̇0 sin 2θ1. Both come from M00's θ1-dependence alone, ∂M00/∂θ1 =
    spin m1 l1² sin 2θ1: d/dt (M00 θ̇0) gives N00 = δ0 + spin m1 l1² θ̇1 sin 2θ1 and −½ θ̇0²
    ∂M00/∂θ1 gives N10 = −(spin/2) m1 l1² θ̇0 sin 2θ1, so the 'full' variant (spin = 1/3)
    changes these two entries as well as M00.
    """
    _, t1 = sym.q
    d0, d1 = sym.qd
    m0, m1 = sym.m
    l0, l1 = sym.l
    de0, de1 = sym.delta
    g = sym.g
    j0 = m0 * l0**2 / 3
    j1 = m1 * l1**2 / 3
    s1, c1 = sp.sin(t1), sp.cos(t1)
    mass = sp.Matrix(
        [
            [j0 + m1 * l0**2 + spin * m1 * l1**2 * s1**2, m1 * l0 * l1 * c1 / 2],
            [m1 * l0 * l1 * c1 / 2, j1],
        ]
    )
    n_matrix = sp.Matrix(
        [
            [de0 + spin * m1 * l1**2 * d1 * sp.sin(2 * t1), -m1 * l0 * l1 * d1 * s1 / 2],
            [-spin / 2 * m1 * l1**2 * d0 * sp.sin(2 * t1), de1],
        ]
    )
    gravity = column([0, -m1 * g * l1 * s1 / 2])
    return mass, n_matrix, gravity


@pytest.mark.parametrize(
    ("inertia", "spin"), [("pivot", sp.Rational(1, 4)), ("full", sp.Rational(1, 3))], ids=["pivot", "full"]
)
def test_eq31_rotary_single(inertia: str, spin: sp.Expr) -> None:
    """Eq. 31 (pivot, ¼ in M00) and its 'full' variant (1/3): M, P and the bias N θ̇ + P."""
    eqs = equations("rotary", 1, inertia)
    sym = eqs.symbols
    mass, n_matrix, gravity = eq31(sym, spin)
    name = f"rotary 1 {inertia}"
    assert_matrix_identical(eqs.mass_matrix, mass, sym.q, f"{name}: M vs eq. 31 (M00 with {spin})")
    assert_matrix_identical(eqs.gravity, gravity, sym.q, f"{name}: P vs eq. 31")
    bias = n_matrix * column(sym.qd) + gravity
    assert_matrix_identical(eqs.bias, bias, sym.q, f"{name}: bias vs eq. 31's N θ̇ + P (spin {spin})")


def test_rotary_single_full_minus_pivot_is_the_rod_spin() -> None:
    """The variants differ only in M00, by J_T sin²θ1 = m1 l1²/12 sin²θ1."""
    eqs = equations("rotary", 1, "full")
    sym = eqs.symbols
    pivot = equations("rotary", 1, "pivot").mass_matrix
    extra = sym.m[1] * sym.l[1] ** 2 / 12 * sp.sin(sym.q[1]) ** 2
    expected = pivot + sp.Matrix([[extra, 0], [0, 0]])
    assert_matrix_identical(eqs.mass_matrix, expected, sym.q, "rotary 1: full − pivot")


# --------------------------------------------------------------------------- energies and Lagrange


def model_energies(system: System, sym: Symbols) -> tuple[sp.Expr, sp.Expr, sp.Expr]:
    """T, V, D exactly as docs/model.md's "Energies" section states them (positions, then |v|²)."""
    q, qd, m, length, delta = sym.q, sym.qd, sym.m, sym.l, sym.delta
    n = system.links
    t = sp.Symbol("t")
    path = {q[k]: sp.Function(f"path{k}")(t) for k in range(n + 1)}
    rates = {sp.Derivative(path[q[k]], t): qd[k] for k in range(n + 1)}

    def velocity(point: list[sp.Expr]) -> list[sp.Expr]:
        moving = [coord.xreplace(path) for coord in point]
        values = [sp.diff(coord, t).subs(rates) for coord in moving]
        back = {v: k for k, v in path.items()}
        return [v.xreplace(back) for v in values]

    base_inertia = m[0] * length[0] ** 2 / 3 if system.is_rotary else m[0]  # J0 or the cart mass
    kinetic = base_inertia * qd[0] ** 2 / 2
    potential = sp.S.Zero
    for i in range(1, n + 1):
        r = sum(length[k] * sp.sin(q[k]) for k in range(1, i + 1)) - length[i] / 2 * sp.sin(q[i])
        z = sum(length[k] * sp.cos(q[k]) for k in range(1, i + 1)) - length[i] / 2 * sp.cos(q[i])
        if system.is_rotary:
            cog = [
                length[0] * sp.sin(q[0]) + r * sp.cos(q[0]),
                length[0] * sp.cos(q[0]) - r * sp.sin(q[0]),
                z,
            ]
        else:
            cog = [q[0] + r, z]
        j_t = m[i] * length[i] ** 2 / 12
        speed2 = sum(v**2 for v in velocity(cog))
        kinetic += m[i] * speed2 / 2 + j_t * qd[i] ** 2 / 2
        if system.is_rotary and system.inertia == "full":
            kinetic += j_t * (qd[0] * sp.sin(q[i])) ** 2 / 2
        potential += m[i] * sym.g * z
    dissipation = delta[0] * qd[0] ** 2 / 2 + delta[1] * qd[1] ** 2 / 2
    dissipation += sum(delta[i] * (qd[i] - qd[i - 1]) ** 2 / 2 for i in range(2, n + 1))
    return kinetic, potential, dissipation


STRUCTURE_CASES = [*CASES, ("classical", 4, "pivot"), ("rotary", 3, "pivot"), ("rotary", 3, "full")]


@cache
def energies(kind: str, links: int, inertia: str = "pivot") -> tuple[sp.Expr, sp.Expr, sp.Expr]:
    """docs/model.md's T, V, D for the case, in the symbols of ipgen's equations."""
    eqs = equations(kind, links, inertia)
    return model_energies(eqs.system, eqs.symbols)


@pytest.mark.parametrize("case", CASES, ids=case_id)
def test_energies_match_model(case: tuple[str, int, str]) -> None:
    eqs = equations(*case)
    sym = eqs.symbols
    kinetic, potential, dissipation = energies(*case)
    name = case_id(case)
    assert_identical(eqs.kinetic_energy, kinetic, sym.q, f"{name}: T")
    assert_identical(eqs.potential_energy, potential, sym.q, f"{name}: V")
    assert_identical(eqs.dissipation, dissipation, sym.q, f"{name}: D")


@pytest.mark.parametrize("case", STRUCTURE_CASES, ids=case_id)
def test_lagrange_from_model_energies(case: tuple[str, int, str]) -> None:
    """d/dt ∂L/∂θ̇ − ∂L/∂θ + ∂D/∂θ̇ = M θ̈ + N θ̇ + P = M θ̈ + bias, with L, D from docs/model.md.

    N θ̇ + P and the bias are each compared with the model's equation (so N θ̇ + P = bias
    follows from two independent checks, not from how derive.py assembles the bias).
    """
    eqs = equations(*case)
    sym = eqs.symbols
    kinetic, potential, dissipation = energies(*case)
    lagrangian = kinetic - potential
    size = eqs.system.dof
    acc = [sp.Symbol(f"ddtheta{k}") for k in range(size)]
    name = case_id(case)
    n_rates_gravity = eqs.n_matrix * column(sym.qd) + eqs.gravity

    def time_derivative(expr: sp.Expr) -> sp.Expr:
        return sum(
            sp.diff(expr, sym.q[k]) * sym.qd[k] + sp.diff(expr, sym.qd[k]) * acc[k] for k in range(size)
        )

    for k in range(size):
        momentum = sp.diff(lagrangian, sym.qd[k])
        generalized = time_derivative(momentum) - sp.diff(lagrangian, sym.q[k])
        generalized += sp.diff(dissipation, sym.qd[k])
        inertial = sum(eqs.mass_matrix[k, j] * acc[j] for j in range(size))
        assert_identical(
            inertial + n_rates_gravity[k],
            generalized,
            sym.q,
            f"{name}: Lagrange's equation {k}, M θ̈ + N θ̇ + P",
        )
        assert_identical(
            inertial + eqs.bias[k], generalized, sym.q, f"{name}: Lagrange's equation {k}, M θ̈ + bias"
        )


# --------------------------------------------------------------------------- structure


@pytest.mark.parametrize("case", STRUCTURE_CASES, ids=case_id)
def test_mass_matrix_is_hessian_of_model_kinetic_energy(case: tuple[str, int, str]) -> None:
    """M = ∂²T/∂θ̇² with docs/model.md's T: entry by entry, so M is also symmetric."""
    eqs = equations(*case)
    sym = eqs.symbols
    kinetic, _, _ = energies(*case)
    hessian = sp.hessian(kinetic, sym.qd)
    assert_matrix_identical(eqs.mass_matrix, hessian, sym.q, f"{case_id(case)}: M vs ∂²T/∂θ̇² (model.md T)")


@pytest.mark.parametrize("case", STRUCTURE_CASES, ids=case_id)
def test_damping_and_gravity_are_derivatives(case: tuple[str, int, str]) -> None:
    """damping = ∂²D/∂θ̇², P = ∂V/∂θ, T = ½ θ̇ᵀ M θ̇, with T, V, D from docs/model.md."""
    eqs = equations(*case)
    sym = eqs.symbols
    kinetic, potential, dissipation = energies(*case)
    name = case_id(case)
    hessian = sp.hessian(dissipation, sym.qd)
    assert_matrix_identical(eqs.damping, hessian, sym.q, f"{name}: damping vs ∂²D/∂θ̇² (docs/model.md's D)")
    grad = column([sp.diff(potential, a) for a in sym.q])
    assert_matrix_identical(eqs.gravity, grad, sym.q, f"{name}: P vs ∂V/∂θ (docs/model.md's V)")
    qd = column(sym.qd)
    quadratic = (qd.T * eqs.mass_matrix * qd)[0, 0] / 2
    assert_identical(quadratic, kinetic, sym.q, f"{name}: ½ θ̇ᵀ M θ̇ vs docs/model.md's T")
    assert_identical(eqs.kinetic_energy, kinetic, sym.q, f"{name}: T vs docs/model.md's T")


@pytest.mark.parametrize(
    "case", [("classical", 2, "pivot"), ("rotary", 2, "pivot"), ("rotary", 2, "full")], ids=case_id
)
def test_mdot_minus_two_c_is_skew_symmetric(case: tuple[str, int, str]) -> None:
    eqs = equations(*case)
    sym = eqs.symbols
    mass = eqs.mass_matrix
    mdot = sp.zeros(*mass.shape)
    for angle, rate in zip(sym.q, sym.qd, strict=True):
        mdot += sp.diff(mass, angle) * rate
    skew = mdot - 2 * eqs.coriolis
    assert_matrix_identical(
        skew + skew.T, sp.zeros(*mass.shape), sym.q, f"{case_id(case)}: (Ṁ − 2C) + (Ṁ − 2C)ᵀ"
    )
    # C must be linear in θ̇ and free of damping: C(θ, 0) = 0.
    at_rest = eqs.coriolis.xreplace(dict.fromkeys(sym.qd, 0))
    assert at_rest == sp.zeros(*mass.shape), f"{case_id(case)}: C(θ, 0) = {at_rest}"
