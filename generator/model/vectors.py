"""Vectors built from unit directions in the plane of the links.

Every velocity in these systems is a sum of `coefficient × u(angle)` with
u(φ) = (cos φ, −sin φ) in the plane the links swing in, plus (rotary only) a component
along the axis normal to that plane. Since u(α)·u(β) = cos(α − β), dot products come out
as cos(θi − θj) by construction: no trigonometric simplification is ever needed.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from ipgen.model.polynomial import Algebra, Poly


@dataclass(frozen=True)
class PlanarVector:
    """Σ coefficient·u(θ_angle) in the links' plane, plus `normal` along the plane's normal.

    An angle is the index k of θk, or None for the angle 0 (the base's own direction).
    """

    terms: tuple[tuple[Poly, int | None], ...]  # (coefficient, angle)
    normal: Poly  # the component along the normal (the ring's zero if none)

    @classmethod
    def along(cls, coefficient: Poly, angle: int | None, normal: Poly | None = None) -> PlanarVector:
        """coefficient·u(θ_angle) + normal·e_normal; no `normal`: in the plane."""
        terms = ((coefficient, angle),) if coefficient else ()
        return cls(terms, coefficient.context().constant(0) if normal is None else normal)

    def dot(self, other: PlanarVector, alg: Algebra) -> Poly:
        total = [
            a * b * alg.cos_difference(alpha, beta) for a, alpha in self.terms for b, beta in other.terms
        ]
        total.append(self.normal * other.normal)
        return alg.total(total)
