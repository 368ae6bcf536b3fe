"""Fast exact algebra for the derivation: polynomials in parameters, velocities and trig terms.

Every quantity in these equations is a polynomial in the parameters (m, l, δ, g), the
velocities θ̇ and a few trigonometric "letters": s_k = sin θk, c_k = cos θk, and
C_jk = cos(θj − θk), S_jk = sin(θj − θk) for j < k. Working in a sparse polynomial ring
(sympy's `PolyElement`, plain dicts underneath) instead of on expression trees makes
expansion, collection and differentiation linear in the number of terms; ∂/∂θi is the
chain rule over the letters that depend on θi.
"""

from __future__ import annotations

import copy
from collections.abc import Iterable
from dataclasses import dataclass
from fractions import Fraction

import sympy as sp
from sympy.polys.domains import QQ
from sympy.polys.rings import PolyElement, PolyRing

from generator.model import Symbols


@dataclass(frozen=True)
class _Letter:
    """A trig generator, what it means, and its derivatives: {angle index: (sign, letter)}."""

    name: str
    expr: sp.Expr
    derivatives: dict[int, tuple[int, str]]


class Algebra:
    """The polynomial ring of one system, with conversions to and from sympy expressions."""

    def __init__(self, sym: Symbols, named: dict[sp.Symbol, sp.Expr] | None = None) -> None:
        """`named`: intermediate quantities (symbol -> definition, in definition order) that
        stay symbols in every result; derivatives go through their definitions."""
        named = named or {}
        self.sym = sym
        q = sym.q
        n = len(q)
        letters: list[_Letter] = []
        for k in range(n):
            letters.append(_Letter(f"s{k}", sp.sin(q[k]), {k: (1, f"c{k}")}))
            letters.append(_Letter(f"c{k}", sp.cos(q[k]), {k: (-1, f"s{k}")}))
        for j in range(n):
            for k in range(j + 1, n):
                cjk, sjk = f"C{j}_{k}", f"S{j}_{k}"
                letters.append(_Letter(cjk, sp.cos(q[j] - q[k]), {j: (-1, sjk), k: (1, sjk)}))
                letters.append(_Letter(sjk, sp.sin(q[j] - q[k]), {j: (1, cjk), k: (-1, cjk)}))
        self.parameters: tuple[sp.Symbol, ...] = sym.parameters
        self.velocities: tuple[sp.Symbol, ...] = (*sym.qd, *sym.qdd)  # θ̇ and θ̈
        trig_symbols = [sp.Symbol(letter.name) for letter in letters]
        gens = [*self.parameters, *self.velocities, *trig_symbols, *named]
        self.ring = PolyRing(gens, QQ)
        self.gens: dict[sp.Symbol, PolyElement] = dict(zip(gens, self.ring.gens, strict=True))
        self._index = {s: i for i, s in enumerate(gens)}
        self.n_parameters = len(self.parameters)
        first_letter = len(self.parameters) + len(self.velocities)
        self._letter_gen = {letter.name: self.ring.gens[first_letter + i] for i, letter in enumerate(letters)}
        self._letter_index = {letter.name: first_letter + i for i, letter in enumerate(letters)}
        # Back to sympy: each generator's meaning.
        letter_meanings = [t.expr for t in letters]
        self._meaning: list[sp.Expr] = [*self.parameters, *self.velocities, *letter_meanings, *named]
        self._plain: list[sp.Expr] = gens  # the same, with trig letters as plain symbols (for code)
        self.letters: dict[sp.Symbol, sp.Expr] = {sp.Symbol(t.name): t.expr for t in letters}
        # For ∂/∂θi: the letters that depend on θi (generator index), sign, derivative letter.
        self._by_angle: dict[int, list[tuple[int, int, PolyElement]]] = {}
        for letter in letters:
            for angle, (sign, target) in letter.derivatives.items():
                self._by_angle.setdefault(angle, []).append(
                    (self._letter_index[letter.name], sign, self._letter_gen[target])
                )

        # Named quantities: their definitions as polynomials, the angles they depend on, and
        # their meaning in θ (for sympy results).
        self._expr_cache: dict[tuple[int, bool], tuple[PolyElement, sp.Expr]] = {}
        self.named: dict[sp.Symbol, PolyElement] = {}
        self._named_angles: dict[int, set[int]] = {}
        self._named_derivative: dict[tuple[int, int], PolyElement] = {}
        for symbol, definition in named.items():
            poly = self.from_expr(definition)
            index = self._index[symbol]
            self.named[symbol] = poly
            self._named_angles[index] = {i for i in range(n) if self.depends_on_angle(poly, i)}
            self._meaning[index] = self.to_expr(poly)

    def folded(self, values: dict[int, Fraction]) -> Algebra:
        """A copy in which the parameter generators `values` (index -> value) are constants."""
        folded = copy.copy(self)
        folded.named = {s: Algebra.substitute(p, values) for s, p in self.named.items()}
        folded._expr_cache = {}
        folded._named_derivative = {}
        folded._meaning = list(self._meaning)
        for symbol, poly in folded.named.items():
            folded._meaning[self._index[symbol]] = folded.to_expr(poly)
        return folded

    @staticmethod
    def substitute(p: PolyElement, values: dict[int, Fraction]) -> PolyElement:
        """p with generators (by index) replaced by exact constants; the ring is unchanged."""
        result = p.ring.zero.copy()
        domain = p.ring.domain
        for monomial, coefficient in p.iterterms():
            exponents = list(monomial)
            for index, value in values.items():
                if exponents[index]:
                    coefficient *= domain(value.numerator, value.denominator) ** exponents[index]
                    exponents[index] = 0
            key = tuple(exponents)
            total = result.get(key, domain.zero) + coefficient
            if total:
                result[key] = total
            else:
                result.pop(key, None)
        return result

    # -- building -------------------------------------------------------------------------
    def zero(self) -> PolyElement:
        return self.ring.zero

    def one(self) -> PolyElement:
        return self.ring.one

    def symbol(self, s: sp.Symbol) -> PolyElement:
        return self.gens[s]

    def sin(self, k: int) -> PolyElement:
        return self._letter_gen[f"s{k}"]

    def cos(self, k: int) -> PolyElement:
        return self._letter_gen[f"c{k}"]

    def cos_difference(self, j: int | None, k: int | None) -> PolyElement:
        """cos(θj − θk); `None` stands for the angle 0 (the base's own direction)."""
        if j == k:
            return self.ring.one
        if j is None or k is None:
            return self.cos(k if j is None else j)  # type: ignore[arg-type]
        a, b = min(j, k), max(j, k)
        return self._letter_gen[f"C{a}_{b}"]

    def from_expr(self, expr: sp.Expr) -> PolyElement:
        """Convert a sympy polynomial in parameters, velocities and sin/cos of single angles."""
        q_index = {s: k for k, s in enumerate(self.sym.q)}
        replace: dict[sp.Expr, sp.Symbol] = {}
        for atom in expr.atoms(sp.sin, sp.cos):
            k = q_index[atom.args[0]]
            replace[atom] = sp.Symbol(f"s{k}" if isinstance(atom, sp.sin) else f"c{k}")
        return self.ring(sp.expand(expr.xreplace(replace)))

    # -- calculus -------------------------------------------------------------------------
    def diff_angle(self, p: PolyElement, i: int) -> PolyElement:
        """∂p/∂θi by the chain rule over the trig letters."""
        result = self.ring.zero
        for index, sign, derivative in self._by_angle.get(i, ()):
            d = self._diff_index(p, index)
            if d:
                result += d * derivative if sign > 0 else -(d * derivative)
        for index, angles in self._named_angles.items():
            if i in angles:
                d = self._diff_index(p, index)
                if d:
                    result += d * self._named_derivative_of(index, i)
        return result

    def _named_derivative_of(self, index: int, i: int) -> PolyElement:
        key = (index, i)
        if key not in self._named_derivative:
            self._named_derivative[key] = self.diff_angle(self.named[self._plain[index]], i)
        return self._named_derivative[key]

    def depends_on_angle(self, p: PolyElement, i: int) -> bool:
        indices = [index for index, _, _ in self._by_angle.get(i, ())]
        indices += [index for index, angles in self._named_angles.items() if i in angles]
        return any(monomial[index] for monomial in p.itermonoms() for index in indices)

    def diff_symbol(self, p: PolyElement, s: sp.Symbol) -> PolyElement:
        return self._diff_index(p, self._index[s])

    def times_symbol(self, p: PolyElement, s: sp.Symbol) -> PolyElement:
        """p · s for a generator s: a shift of exponents, much cheaper than a general product."""
        index = self._index[s]
        result = self.ring.zero.copy()
        for monomial, coefficient in p.iterterms():
            result[(*monomial[:index], monomial[index] + 1, *monomial[index + 1 :])] = coefficient
        return result

    def _diff_index(self, p: PolyElement, index: int) -> PolyElement:
        """∂p/∂(generator number `index`); sympy's own `diff` looks the generator up slowly."""
        result = self.ring.zero.copy()
        for monomial, coefficient in p.iterterms():
            e = monomial[index]
            if e:
                lowered = (*monomial[:index], e - 1, *monomial[index + 1 :])
                result[lowered] = result.get(lowered, 0) + coefficient * e
        return result

    # -- back to sympy ----------------------------------------------------------------------
    def to_expr(self, p: PolyElement, letters: bool = False) -> sp.Expr:
        """A readable sympy expression: each state monomial times its factored parameter part.

        With `letters`, sin/cos stay plain symbols (s1, c1, C1_2, S1_2: see `letters`), which is
        what code generation wants: each is computed once in the generated code.
        """
        key = (id(p), letters)
        cached = self._expr_cache.get(key)
        if cached is not None and cached[0] is p:
            return cached[1]
        meaning = self._plain if letters else self._meaning
        groups: dict[tuple[int, ...], list[tuple[tuple[int, ...], object]]] = {}
        cut = self.n_parameters
        for monomial, coefficient in sorted(p.terms()):
            groups.setdefault(monomial[cut:], []).append((monomial[:cut], coefficient))
        terms = []
        for state, parts in groups.items():
            terms.append(self._parameter_factor(parts) * self._monomial(state, cut, meaning))
        expr = sp.Add(*terms)
        self._expr_cache[key] = (p, expr)  # keeps p alive, so its id stays unique
        return expr

    def _monomial(
        self, exponents: Iterable[int], offset: int, meaning: list[sp.Expr] | None = None
    ) -> sp.Expr:
        meaning = meaning or self._meaning
        return sp.Mul(*(meaning[offset + i] ** e for i, e in enumerate(exponents) if e))

    def _parameter_factor(self, parts: list[tuple[tuple[int, ...], object]]) -> sp.Expr:
        """Σ c·monomial with the common monomial, sign and |c| pulled out: −l1*(m1/2 + m2)."""
        common = tuple(min(e) for e in zip(*(m for m, _ in parts), strict=True))
        coefficients = [sp.Rational(int(c.numerator), int(c.denominator)) for _, c in parts]
        scale = sp.S.One
        if len(coefficients) > 1:
            if len({abs(c) for c in coefficients}) == 1:
                scale = abs(coefficients[0])
            if all(c < 0 for c in coefficients):
                scale = -scale
            coefficients = [c / scale for c in coefficients]
        inner = sp.Add(
            *(
                c * self._monomial(tuple(a - b for a, b in zip(m, common, strict=True)), 0)
                for (m, _), c in zip(parts, coefficients, strict=True)
            )
        )
        return scale * self._monomial(common, 0) * inner
