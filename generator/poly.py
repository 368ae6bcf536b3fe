"""Sparse polynomials with exact rational coefficients: the derivation's only algebra.

A `Poly` maps monomials to integer numerators over one common positive denominator `den`, so
that coefficient arithmetic is on Python integers (a `Fraction` per term costs several times
more). A monomial is a sorted tuple of generator indices in which each generator appears as
often as its exponent: x0² x3 is `(0, 0, 3)`, the constant monomial is `()`. Sparse monomials
keep a product's cost proportional to its degree, whatever the number of generators (an n-link
system has about n² trigonometric generators, and a monomial has a handful of factors).

Polys are values: no operation modifies its operands, and results may share an operand's
storage only when returning that operand itself.
"""

from __future__ import annotations

from bisect import bisect_right
from collections.abc import Iterable, Iterator
from fractions import Fraction
from math import gcd, lcm

Monomial = tuple[int, ...]
Number = int | Fraction


def from_numerators(terms: dict[Monomial, int], den: int) -> Poly:
    """A Poly from numerators over `den` (no zeros among them), in lowest terms; `terms` is
    used as it is, not copied."""
    if den != 1:
        if not terms:
            den = 1
        else:
            common = gcd(den, *terms.values())
            if common != 1:
                den //= common
                terms = {m: c // common for m, c in terms.items()}
    result = Poly.__new__(Poly)
    result.terms = terms
    result.den = den
    return result


def insert(monomial: Monomial, generator: int) -> Monomial:
    """`monomial` times one more factor `generator`."""
    at = bisect_right(monomial, generator)
    return (*monomial[:at], generator, *monomial[at:])


class Poly:
    """Σ (numerator / den) · monomial, with `terms` = {monomial: numerator}; no zero numerators."""

    __slots__ = ("den", "terms")

    terms: dict[Monomial, int]
    den: int

    def __init__(self, terms: dict[Monomial, Number] | None = None) -> None:
        """A Poly from {monomial: rational coefficient}; monomials must be sorted tuples."""
        terms = {m: Fraction(c) for m, c in (terms or {}).items() if c}
        den = lcm(*(c.denominator for c in terms.values())) if terms else 1
        self.terms = {m: c.numerator * (den // c.denominator) for m, c in terms.items()}
        self.den = den

    # -- construction -------------------------------------------------------------------
    @classmethod
    def constant(cls, value: Number) -> Poly:
        value = Fraction(value)
        return from_numerators({(): value.numerator} if value else {}, value.denominator)

    @classmethod
    def generator(cls, index: int) -> Poly:
        return from_numerators({(index,): 1}, 1)

    @classmethod
    def total(cls, polys: Iterable[Poly]) -> Poly:
        """Σ polys, accumulated in place (a chain of `+` would copy the running sum each time)."""
        polys = [p for p in polys if p.terms]
        if not polys:
            return ZERO
        if len(polys) == 1:
            return polys[0]
        den = lcm(*(p.den for p in polys))
        terms: dict[Monomial, int] = {}
        get = terms.get
        for p in polys:
            scale = den // p.den
            if scale == 1:
                for m, c in p.terms.items():
                    terms[m] = get(m, 0) + c
            else:
                for m, c in p.terms.items():
                    terms[m] = get(m, 0) + c * scale
        return from_numerators({m: c for m, c in terms.items() if c}, den)

    # -- inspection ---------------------------------------------------------------------
    def __bool__(self) -> bool:
        return bool(self.terms)

    def __len__(self) -> int:
        return len(self.terms)

    def __eq__(self, other: object) -> bool:
        if isinstance(other, int | Fraction):
            other = Poly.constant(other)
        if not isinstance(other, Poly):
            return NotImplemented
        return self.den == other.den and self.terms == other.terms

    __hash__ = None  # type: ignore[assignment]  # mutable-looking value type: not hashable

    def __repr__(self) -> str:
        shown = " + ".join(f"{c}*x{list(m)}" for m, c in self.items()) or "0"
        return f"Poly({shown})"

    def items(self) -> Iterator[tuple[Monomial, Fraction]]:
        """(monomial, coefficient) in increasing monomial order: deterministic."""
        den = self.den
        for m in sorted(self.terms):
            yield m, Fraction(self.terms[m], den)

    def generators(self) -> set[int]:
        """Every generator that occurs in some monomial."""
        return set().union(*self.terms)

    # -- arithmetic ---------------------------------------------------------------------
    def __neg__(self) -> Poly:
        return from_numerators({m: -c for m, c in self.terms.items()}, self.den)

    def __add__(self, other: Poly | Number) -> Poly:
        if not isinstance(other, Poly):
            other = Poly.constant(other)
        if not other.terms:
            return self
        if not self.terms:
            return other
        return Poly.total((self, other))

    __radd__ = __add__

    def __sub__(self, other: Poly | Number) -> Poly:
        if not isinstance(other, Poly):
            other = Poly.constant(other)
        return self + (-other)

    def __rsub__(self, other: Number) -> Poly:
        return Poly.constant(other) - self

    def __mul__(self, other: Poly | Number) -> Poly:
        if not isinstance(other, Poly):
            return self.scale(other)
        if not self.terms or not other.terms:
            return ZERO
        a, b = (self, other) if len(self.terms) >= len(other.terms) else (other, self)
        terms: dict[Monomial, int] = {}
        get = terms.get
        for mb, cb in b.terms.items():
            if not mb:
                for ma, ca in a.terms.items():
                    terms[ma] = get(ma, 0) + ca * cb
            elif len(mb) == 1:
                g = mb[0]
                for ma, ca in a.terms.items():
                    m = insert(ma, g)
                    terms[m] = get(m, 0) + ca * cb
            else:
                for ma, ca in a.terms.items():
                    m = tuple(sorted(ma + mb))
                    terms[m] = get(m, 0) + ca * cb
        return from_numerators({m: c for m, c in terms.items() if c}, a.den * b.den)

    __rmul__ = __mul__

    def __truediv__(self, other: Number) -> Poly:
        return self.scale(1 / Fraction(other))

    def __pow__(self, exponent: int) -> Poly:
        result = ONE
        for _ in range(exponent):
            result = result * self
        return result

    def scale(self, factor: Number) -> Poly:
        factor = Fraction(factor)
        if not factor:
            return ZERO
        num = factor.numerator
        terms = self.terms if num == 1 else {m: c * num for m, c in self.terms.items()}
        return from_numerators(terms, self.den * factor.denominator)

    def times_generator(self, index: int) -> Poly:
        """p · x_index: a shift of every monomial, much cheaper than a general product."""
        return from_numerators({insert(m, index): c for m, c in self.terms.items()}, self.den)

    def diff(self, index: int) -> Poly:
        """∂p/∂x_index."""
        terms: dict[Monomial, int] = {}
        for m, c in self.terms.items():
            if index in m:
                at = m.index(index)
                # Removing one factor is injective on monomials that have it: no collisions.
                terms[(*m[:at], *m[at + 1 :])] = c * m.count(index)
        return from_numerators(terms, self.den)

    def substitute(self, values: dict[int, Fraction]) -> Poly:
        """p with the generators `values` (index -> exact value) replaced by constants."""
        if not self.terms:
            return self
        exact = {g: (v.numerator, v.denominator) for g, v in values.items()}
        # Each term's numerator times its values' numerators, over their denominators' product.
        scaled: list[tuple[Monomial, int, int]] = []
        for m, c in self.terms.items():
            den = 1
            if any(g in exact for g in m):
                kept = []
                for g in m:
                    value = exact.get(g)
                    if value is None:
                        kept.append(g)
                    else:
                        c *= value[0]
                        den *= value[1]
                m = tuple(kept)
            scaled.append((m, c, den))
        common = lcm(*(den for _, _, den in scaled))
        terms: dict[Monomial, int] = {}
        get = terms.get
        for m, c, den in scaled:
            terms[m] = get(m, 0) + c * (common // den)
        return from_numerators({m: c for m, c in terms.items() if c}, self.den * common)


ZERO = Poly()
ONE = Poly.constant(1)
