"""A fixed-pivot chain's equations as polynomials, for the headers: the cart's links block.

`fixed_equations.py` derives the chain in sympy (the cart held still, plus rotors, Coulomb
friction and B); the headers print from the polynomial ring of `derivation.py` instead, so that
they share its printer, its common-subexpression elimination and its damping as joint torques
(`codegen/functions.py`). The same observation gives them: the links' rows and columns of the
classical n-link derivation at θ̇0 = θ̈0 = 0, with the cart's parameters that could still reach
them folded to zero (δ0: the cart's damper; the tip masses and J0, J_axial, which a fixed chain
does not have). Generators keep the cart's numbering (link i is m_i, s_i, dq_i), and the
printer's `Syntax.offset` = 1 prints them as entry i − 1 of the chain's arrays.

Not in these polynomials, and added by the headers' templates: the rotors' constant inertia
Ir v vᵀ (v = gr e_j + (1 − gr) e_{j−1}: `rotor_lever`), their kinetic energy ½ Ir (vᵀ θ̇)², and
B u. Coulomb friction is not part of the headers' equations (as for the cart and the arm): the
simulator adds it.
"""

from __future__ import annotations

from dataclasses import replace
from fractions import Fraction
from functools import cache

from ipgen.model.derivation import Equations, derive
from ipgen.model.specialise import Specialisation, specialise
from ipgen.model.system import System

__all__ = ["fixed_poly_equations", "rotor_lever"]


def _held(links: int) -> tuple[tuple[str, Fraction], ...]:
    """The cart's parameters folded to zero: its damper, and what a fixed chain has not."""
    names = [
        "delta0",
        "J0",
        *(f"J_axial{i}" for i in range(1, links + 1)),
        *(f"tip{i}" for i in range(1, links + 1)),
    ]
    return tuple((name, Fraction(0)) for name in names)


@cache
def fixed_poly_equations(links: int) -> Equations:
    """M, bias, gravity, N, the residual's derivatives and the energies of a chain of `links`
    links on a fixed pivot, in ipgen's coordinates (absolute angles from upright, clockwise), as
    `Equations` over the classical n-link algebra (rows and columns: links 1..n)."""
    chain = derive(System("classical", links))
    keys = tuple(chain.poly)
    held = specialise(chain, Specialisation(fixed=_held(links)), keys)
    algebra = held.algebra
    still = {algebra.qd(0): Fraction(0), algebra.qdd(0): Fraction(0)}

    def block(matrix: list[list]) -> list[list]:  # type: ignore[type-arg]
        rows = matrix[1:] if len(matrix) > 1 else matrix
        columns = slice(1, None) if len(matrix[0]) > 1 else slice(None)
        return [[algebra.substitute(p, still) for p in row[columns]] for row in rows]

    poly = {key: block(value) for key, value in held.poly.items()}
    return replace(held, poly=poly)


def rotor_lever(joint: int) -> tuple[tuple[int, str], ...]:
    """(coordinate, factor) of v for the rotor at `joint` (1-based), coordinates 0-based (link 1
    is 0): its absolute rate is vᵀ θ̇ = gr θ̇_j + (1 − gr) θ̇_{j−1} (the ground's 0 for j = 1)."""
    if joint == 1:
        return ((0, "gr"),)
    return ((joint - 1, "gr"), (joint - 2, "1 - gr"))


