"""The generators of one system's polynomials: parameters, velocities and trig letters.

Every quantity in these equations is an element of one polynomial ring over Q: FLINT's sparse
multivariate polynomials with exact rational coefficients (python-flint's `fmpq_mpoly`, in a
`fmpq_mpoly_ctx` with one generator per quantity below; arithmetic and `derivative` in C) in the
parameters (m, l, δ, g), the velocities θ̇ (and accelerations θ̈) and a few trigonometric
"letters": s_k = sin θk, c_k = cos θk, and C_jk = cos(θj − θk), S_jk = sin(θj − θk) for j < k.
Named intermediate quantities (the rotary reaches r_i, rho_k) are generators too, with a
definition: derivatives go through it by the chain rule, and the generated code computes each
once. ∂/∂θi is the chain rule over the letters and named quantities that depend on θi, written
on top of the ring's own `derivative`. sympy is imported only for the expression views
(`Algebra.to_sympy`), never on the generation path.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from fractions import Fraction
from itertools import compress
from math import lcm
from typing import TYPE_CHECKING

from flint import fmpq, fmpq_mpoly, fmpq_mpoly_ctx

from ipgen.model.system import LINK_GROUPS, PARAMETER_GROUPS, group_indices

if TYPE_CHECKING:
    import sympy as sp

    from ipgen.model.symbols import Symbols

Poly = fmpq_mpoly  # an element of `Algebra.ring`
Monomial = tuple[int, ...]  # sparse: generator indices, each repeated as often as its exponent

PARAMETER, VELOCITY, ACCELERATION, LETTER, NAMED = "parameter", "velocity", "acceleration", "letter", "named"


# Rings with at most this many generators (a rotary chain to 5 links, 143) are read from their
# exponent vectors: python-flint 0.9.0's `fmpq_mpoly.str` leaks about 4 kB of native memory a
# call (a process generating headers grew by 40 kB a header), `terms()` does not. Larger rings
# are read from the text: dense vectors of 748 entries (20 links) took ten times as long, a third
# of a second a header.
TERMS_UP_TO = 150


def sparse(p: Poly) -> tuple[dict[Monomial, int], int]:
    """p as ({sparse monomial: numerator}, common denominator), in lowest terms: what code
    generation reads. A sparse monomial lists the generator indices in increasing order, each as
    often as its exponent: x0² x3 is (0, 0, 3).

    Read from p's exponent vectors (`terms`) in a ring of at most `TERMS_UP_TO` generators, else
    from FLINT's own sparse text of p (`fmpq_mpoly.str`: `-3/2*m1*l1^2*s1 + g`, only the
    generators each term uses), whose exponent vectors are dense, one entry per generator.
    """
    if p.is_zero():
        return {}, 1
    return _from_terms(p) if p.context().nvars() <= TERMS_UP_TO else _from_text(p)


def _from_terms(p: Poly) -> tuple[dict[Monomial, int], int]:
    """`sparse` of a nonzero p read from its exponent vectors."""
    return _lowest_terms(
        [
            (tuple(g for g, e in enumerate(exponents) if e for _ in range(e)), int(c.p), int(c.q))
            for exponents, c in p.terms()
        ]
    )


def _from_text(p: Poly) -> tuple[dict[Monomial, int], int]:
    """`sparse` of a nonzero p read from FLINT's text of it."""
    monomials = _monomial_cache(p.context())
    parsed: list[tuple[Monomial, int, int]] = []
    for text in p.str().replace(" - ", " + -").split(" + "):
        term, sign = (text[1:], -1) if text[0] == "-" else (text, 1)
        numerator = denominator = 1
        if term[0].isdigit():  # a coefficient other than 1 (generator names start with a letter)
            coefficient, _, term = term.partition("*")
            top, _, bottom = coefficient.partition("/")
            numerator, denominator = int(top), int(bottom) if bottom else 1
        monomial = monomials.get(term)
        if monomial is None:
            monomial = monomials[term] = _monomial(term, monomials.names)
        parsed.append((monomial, sign * numerator, denominator))
    return _lowest_terms(parsed)


def _lowest_terms(parsed: list[tuple[Monomial, int, int]]) -> tuple[dict[Monomial, int], int]:
    """(monomial, numerator, denominator) terms over their common denominator."""
    den = lcm(*(d for _, _, d in parsed))
    return {m: n * (den // d) for m, n, d in parsed}, den


class _Monomials(dict[str, Monomial]):
    """{FLINT's text of a monomial (`m1*l1^2*s1`): sparse monomial} of one ring, with the ring's
    {generator name: index}: the same monomials recur across the polynomials of a system."""

    def __init__(self, ring: fmpq_mpoly_ctx) -> None:
        super().__init__()
        self.names = {name: g for g, name in enumerate(ring.names())}


_MONOMIALS: dict[fmpq_mpoly_ctx, _Monomials] = {}
_MONOMIALS_KEPT = 500_000  # monomials of earlier rings kept when a new ring comes


def _monomial_cache(ring: fmpq_mpoly_ctx) -> _Monomials:
    cache = _MONOMIALS.get(ring)
    if cache is None:
        if sum(map(len, _MONOMIALS.values())) > _MONOMIALS_KEPT:
            _MONOMIALS.clear()  # earlier systems' monomials: forget them
        cache = _MONOMIALS[ring] = _Monomials(ring)
    return cache


def _monomial(text: str, names: dict[str, int]) -> Monomial:
    """The sparse monomial FLINT writes as `text` (`m1*l1^2*s1`; empty: 1)."""
    if not text:
        return ()
    monomial: list[int] = []
    for factor in text.split("*"):
        name, _, power = factor.partition("^")
        g = names[name]
        monomial.extend((g,) * int(power) if power else (g,))
    return tuple(sorted(monomial))


@dataclass(frozen=True)
class Generator:
    """One generator: its name in C++ (`m1`, `dq0`, `s1`, `c1_2`, `r2`) and what it is."""

    name: str
    kind: str  # PARAMETER, VELOCITY, ACCELERATION, LETTER or NAMED
    index: int = 0  # parameter: the Params entry (m1 -> 1); velocity, acceleration: the angle
    group: str = ""  # parameter: m, l, delta, g, com, J, J_axial or tip; letter: "s", "c", "S" or "C"
    angles: tuple[int, ...] = ()  # letter: θk, or (θj, θk) for a difference


class Algebra:
    """The generators of a system with `dof` coordinates, their ring, and calculus over them.

    Generator indices follow the order parameters, velocities, accelerations, letters, named
    quantities (`named`: their names, defined later with `define`), so that the parameters of
    a sparse monomial (`sparse`) come first.
    """

    def __init__(self, dof: int, named: Sequence[str] = ()) -> None:
        self.dof = dof
        self.generators: list[Generator] = []
        self._index: dict[str, int] = {}
        for group in PARAMETER_GROUPS:
            for i in range(dof):
                self._add(Generator(f"{group}{i}", PARAMETER, i, group))
        self._add(Generator("g", PARAMETER, 0, "g"))
        for group in LINK_GROUPS:  # after g: the paper's parameters keep their indices
            for i in group_indices(group, dof - 1):
                self._add(Generator(f"{group}{i}", PARAMETER, i, group))
        self.n_parameters = len(self.generators)
        for i in range(dof):
            self._add(Generator(f"dq{i}", VELOCITY, i))
        for i in range(dof):
            self._add(Generator(f"ddq{i}", ACCELERATION, i))
        # For ∂/∂θi: {letter generator: (sign, derivative letter generator)} per angle.
        self._by_angle: list[dict[int, tuple[int, int]]] = [{} for _ in range(dof)]
        for k in range(dof):
            s = self._add(Generator(f"s{k}", LETTER, 0, "s", (k,)))
            c = self._add(Generator(f"c{k}", LETTER, 0, "c", (k,)))
            self._by_angle[k][s] = (1, c)
            self._by_angle[k][c] = (-1, s)
        for j in range(dof):
            for k in range(j + 1, dof):
                cjk = self._add(Generator(f"c{j}_{k}", LETTER, 0, "C", (j, k)))
                sjk = self._add(Generator(f"s{j}_{k}", LETTER, 0, "S", (j, k)))
                self._by_angle[j][cjk], self._by_angle[k][cjk] = (-1, sjk), (1, sjk)
                self._by_angle[j][sjk], self._by_angle[k][sjk] = (1, cjk), (-1, cjk)
        for name in named:
            self._add(Generator(name, NAMED))
        self.ring: fmpq_mpoly_ctx = fmpq_mpoly_ctx.get([g.name for g in self.generators], "lex")
        self.gens: tuple[Poly, ...] = self.ring.gens()
        self._angles_of: dict[int, tuple[int, ...]] = {}  # generator -> angles it depends on
        for g, info in enumerate(self.generators):
            if info.kind == LETTER:
                self._angles_of[g] = info.angles
        # Named quantities: generator -> definition; ∂(named)/∂θi, computed on first use.
        self.named: dict[int, Poly] = {}
        self.fixed: dict[int, Fraction] = {}  # parameters folded into this algebra (`folded`)
        self.gradients: dict[int, dict[int, Poly]] = {}  # named quantity -> its given gradient
        self._named_derivative: dict[tuple[int, int], Poly] = {}
        self._symbols: Symbols | None = None
        self._sympy_meaning: list[sp.Expr] | None = None

    def _add(self, generator: Generator) -> int:
        index = len(self.generators)
        self.generators.append(generator)
        self._index[generator.name] = index
        return index

    # -- building -----------------------------------------------------------------------
    @property
    def zero(self) -> Poly:
        return self.ring.constant(0)

    @property
    def one(self) -> Poly:
        return self.ring.constant(1)

    def constant(self, value: int | Fraction) -> Poly:
        """The constant polynomial `value` (exact)."""
        value = Fraction(value)
        return self.ring.constant(fmpq(value.numerator, value.denominator))

    def total(self, polys: Iterable[Poly]) -> Poly:
        """Σ polys, added pairwise (a balanced tree: each term is merged about log k times
        rather than once per summand)."""
        parts = list(polys)
        if not parts:
            return self.zero
        while len(parts) > 1:
            paired = [a + b for a, b in zip(parts[::2], parts[1::2], strict=False)]
            parts = paired + parts[len(paired) * 2 :]
        return parts[0]

    def index(self, name: str) -> int:
        """The generator called `name` (C++ spelling: m1, delta0, g, dq2, s1, c1_2, r3)."""
        return self._index[name]

    def gen(self, name: str) -> Poly:
        return self.gens[self._index[name]]

    def m(self, i: int) -> Poly:
        return self.gen(f"m{i}")

    def l(self, i: int) -> Poly:  # noqa: E743 (the paper's name)
        return self.gen(f"l{i}")

    def delta(self, i: int) -> Poly:
        return self.gen(f"delta{i}")

    def com(self, i: int) -> Poly:
        """Distance from link i's pivot to its centre of gravity."""
        return self.gen(f"com{i}")

    def J(self, i: int) -> Poly:
        """Link i's inertia about its CoG (i >= 1), the arm's about the vertical (i = 0)."""
        return self.gen(f"J{i}")

    def J_axial(self, i: int) -> Poly:
        return self.gen(f"J_axial{i}")

    def tip(self, i: int) -> Poly:
        """The point mass at the far end of link i."""
        return self.gen(f"tip{i}")

    def g(self) -> Poly:
        return self.gen("g")

    def qd(self, i: int) -> int:
        """The generator index of θ̇i (`gens[...]` is the polynomial θ̇i)."""
        return self._index[f"dq{i}"]

    def qdd(self, i: int) -> int:
        """The generator index of θ̈i."""
        return self._index[f"ddq{i}"]

    def sin(self, k: int) -> Poly:
        return self.gen(f"s{k}")

    def cos(self, k: int) -> Poly:
        return self.gen(f"c{k}")

    def cos_difference(self, j: int | None, k: int | None) -> Poly:
        """cos(θj − θk); `None` stands for the angle 0 (the base's own direction)."""
        if j == k:
            return self.one
        if j is None or k is None:
            return self.cos(k if j is None else j)  # type: ignore[arg-type]
        return self.gen(f"c{min(j, k)}_{max(j, k)}")

    def define(self, name: str, definition: Poly, gradient: dict[int, Poly] | None = None) -> Poly:
        """The named quantity `name` (reserved when the algebra was made) stands for
        `definition`, which may use earlier ones. `gradient` ({angle: ∂/∂θ}, each equal to the
        chain rule's result but written more compactly, e.g. in other named quantities) is used
        instead of differentiating the definition."""
        index = self._index[name]
        self.named[index] = definition
        if gradient is not None:
            self.gradients[index] = gradient
        angles = sorted({a for g in self.used(definition) for a in self._angles_of.get(g, ())})
        self._angles_of[index] = tuple(angles)
        return self.gens[index]

    def folded(self, values: dict[int, Fraction]) -> Algebra:
        """A copy in which the parameter generators `values` (index -> value) are constants."""
        folded = object.__new__(Algebra)
        folded.__dict__.update(self.__dict__)
        folded.named = {g: self.substitute(p, values) for g, p in self.named.items()}
        folded.gradients = {
            g: {i: self.substitute(d, values) for i, d in ds.items()} for g, ds in self.gradients.items()
        }
        folded.fixed = {**self.fixed, **values}
        folded._named_derivative = {}
        folded._sympy_meaning = None
        return folded

    def constant_named(self) -> dict[int, Fraction]:
        """{named quantity: value} for those whose definition is a constant once the earlier
        constant ones are substituted (after `folded`, e.g. a mass moment of fixed parameters)."""
        constants: dict[int, Fraction] = {}
        for g in sorted(self.named):
            definition = self.substitute(self.named[g], constants)
            if definition.is_constant():
                value = definition.leading_coefficient() if definition else 0
                constants[g] = Fraction(int(value.p), int(value.q)) if value else Fraction(0)
        return constants

    def composed(self, replacements: dict[int, Poly]) -> Algebra:
        """A copy in which the parameter generators `replacements` (index -> polynomial in the
        other parameters) are replaced, in the named quantities' definitions too."""
        composed = object.__new__(Algebra)
        composed.__dict__.update(self.__dict__)
        composed.named = {g: self.compose(p, replacements) for g, p in self.named.items()}
        composed.gradients = {
            g: {i: self.compose(d, replacements) for i, d in ds.items()} for g, ds in self.gradients.items()
        }
        composed._named_derivative = {}
        composed._sympy_meaning = None
        return composed

    def compose(self, p: Poly, replacements: dict[int, Poly]) -> Poly:
        """p with the generators `replacements` (index -> polynomial) replaced."""
        if not replacements or p.is_zero() or not self.used(p) & replacements.keys():
            return p
        return p.compose(*(replacements.get(g, x) for g, x in enumerate(self.gens)))

    def substitute(self, p: Poly, values: dict[int, Fraction]) -> Poly:
        """p with the generators `values` (index -> exact value) replaced by constants."""
        wanted = {g: fmpq(v.numerator, v.denominator) for g, v in sorted(values.items())}
        return p.subs(wanted) if wanted and not p.is_zero() else p

    # -- inspection ---------------------------------------------------------------------
    def used(self, p: Poly) -> set[int]:
        """Every generator that occurs in some monomial of p."""
        if p.is_zero():
            return set()
        return set(compress(range(len(self.gens)), p.degrees()))

    # -- calculus -----------------------------------------------------------------------
    def gradient(self, p: Poly) -> dict[int, Poly]:
        """{i: ∂p/∂θi} for every angle p depends on, by the chain rule over the letters and
        named quantities that occur in p (the ring's `diff` for each)."""
        parts: dict[int, list[Poly]] = {}
        for g in sorted(self.used(p)):
            angles = self._angles_of.get(g)
            if not angles:
                continue
            d = p.derivative(g)
            for i in angles:
                if g in self.named:
                    term = d * self._derivative_of_named(g, i)
                else:
                    sign, target = self._by_angle[i][g]
                    term = d * self.gens[target] if sign > 0 else -(d * self.gens[target])
                parts.setdefault(i, []).append(term)
        gradient = {i: self.total(parts[i]) for i in sorted(parts)}
        return {i: d for i, d in gradient.items() if not d.is_zero()}

    def _derivative_of_named(self, g: int, i: int) -> Poly:
        if (g, i) not in self._named_derivative:
            gradient = self.gradients.get(g) or self.gradient(self.named[g])
            for angle in self._angles_of[g]:
                self._named_derivative[g, angle] = gradient.get(angle, self.zero)
        return self._named_derivative[g, i]

    # -- sympy views (tests, references) ------------------------------------------------
    @property
    def symbols(self) -> Symbols:
        """The sympy symbols of the system (θ, θ̇, θ̈, parameters, u)."""
        if self._symbols is None:
            from ipgen.model.symbols import Symbols

            self._symbols = Symbols.for_dof(self.dof)
        return self._symbols

    def to_sympy(self, p: Poly) -> sp.Expr:
        """p as a sympy expression in θ, θ̇, θ̈ and the parameters (named quantities expanded)."""
        import sympy as sp

        meaning = self._meanings()
        terms, den = sparse(p)
        return sp.Add(*(sp.Rational(terms[m], den) * sp.Mul(*(meaning[g] for g in m)) for m in sorted(terms)))

    def _meanings(self) -> list[sp.Expr]:
        if self._sympy_meaning is not None:
            return self._sympy_meaning
        import sympy as sp

        sym = self.symbols
        groups = {
            "m": sym.m,
            "l": sym.l,
            "delta": sym.delta,
            "com": sym.com,
            "J": sym.J,
            "J_axial": sym.J_axial,
            "tip": sym.tip,
        }
        meaning: list[sp.Expr] = []
        self._sympy_meaning = meaning
        for g, info in enumerate(self.generators):
            if info.kind == PARAMETER:
                meaning.append(sym.g if info.group == "g" else groups[info.group][info.index])
            elif info.kind == VELOCITY:
                meaning.append(sym.qd[info.index])
            elif info.kind == ACCELERATION:
                meaning.append(sym.qdd[info.index])
            elif info.kind == LETTER:
                j, *k = info.angles
                angle = sym.q[j] - sym.q[k[0]] if k else sym.q[j]
                meaning.append(sp.sin(angle) if info.group in ("s", "S") else sp.cos(angle))
            elif g in self.named:
                meaning.append(self.to_sympy(self.named[g]))  # earlier generators are ready
            else:
                meaning.append(sp.Symbol(info.name))  # reserved but never defined
        return meaning
