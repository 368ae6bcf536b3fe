"""Vectors built from unit directions in the plane of the links.

Every velocity in these systems is a sum of `coefficient × u(angle)` with
u(φ) = (cos φ, −sin φ) in the plane the links swing in, plus (rotary only) a component
along the axis normal to that plane. Since u(α)·u(β) = cos(α − β), dot products come out
as cos(θi − θj) by construction: no trigonometric simplification is ever needed.
"""

from __future__ import annotations

from dataclasses import dataclass

import sympy as sp


@dataclass(frozen=True)
class PlanarVector:
    """Σ coefficient·u(angle) in the links' plane, plus `normal` along the plane's normal."""

    terms: tuple[tuple[sp.Expr, sp.Expr], ...]  # (coefficient, angle)
    normal: sp.Expr = sp.S.Zero

    @classmethod
    def along(cls, coefficient: sp.Expr, angle: sp.Expr, normal: sp.Expr = sp.S.Zero) -> PlanarVector:
        terms = () if coefficient == 0 else ((sp.sympify(coefficient), sp.sympify(angle)),)
        return cls(terms, sp.sympify(normal))

    def dot(self, other: PlanarVector) -> sp.Expr:
        total = [a * b * sp.cos(alpha - beta) for a, alpha in self.terms for b, beta in other.terms]
        total.append(self.normal * other.normal)
        return sp.Add(*total)
