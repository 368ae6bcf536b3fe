"""The generators of one system's polynomials: parameters, velocities and trig letters.

Every quantity in these equations is a polynomial (`poly.Poly`) in the parameters (m, l, δ,
g), the velocities θ̇ (and accelerations θ̈) and a few trigonometric "letters": s_k = sin θk,
c_k = cos θk, and C_jk = cos(θj − θk), S_jk = sin(θj − θk) for j < k. Named intermediate
quantities (the rotary reaches r_i, rho_k) are generators too, with a definition: derivatives
go through it by the chain rule, and the generated code computes each once. ∂/∂θi is the chain
rule over the letters and named quantities that depend on θi.

sympy is used only for the sympy views (`to_sympy`, `symbols`), imported on first use: the
generation path never loads it.
"""

from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction
from typing import TYPE_CHECKING

from ipgen.poly import ONE, ZERO, Monomial, Poly, from_numerators, insert

if TYPE_CHECKING:
    import sympy as sp

    from ipgen.model import Symbols

PARAMETER, VELOCITY, ACCELERATION, LETTER, NAMED = "parameter", "velocity", "acceleration", "letter", "named"


@dataclass(frozen=True)
class Generator:
    """One generator: its name in C++ (`m1`, `dq0`, `s1`, `c1_2`, `r2`) and what it is."""

    name: str
    kind: str  # PARAMETER, VELOCITY, ACCELERATION, LETTER or NAMED
    index: int = 0  # parameter: the Params entry (m1 -> 1); velocity, acceleration: the angle
    group: str = ""  # parameter: "m", "l", "delta" or "g"; letter: "s", "c", "S" or "C"
    angles: tuple[int, ...] = ()  # letter: θk, or (θj, θk) for a difference


class Algebra:
    """The generators of a system with `dof` coordinates, and calculus over them.

    Generator indices follow the order parameters, velocities, accelerations, letters, named
    quantities, so that the parameters of a (sorted) monomial come first.
    """

    def __init__(self, dof: int) -> None:
        self.dof = dof
        self.generators: list[Generator] = []
        self._index: dict[str, int] = {}
        for group in ("m", "l", "delta"):
            for i in range(dof):
                self._add(Generator(f"{group}{i}", PARAMETER, i, group))
        self._add(Generator("g", PARAMETER, 0, "g"))
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
        self._angles_of: dict[int, tuple[int, ...]] = {}  # generator -> angles it depends on
        for g, info in enumerate(self.generators):
            if info.kind == LETTER:
                self._angles_of[g] = info.angles
        # Named quantities: generator -> definition; ∂(named)/∂θi, computed on first use.
        self.named: dict[int, Poly] = {}
        self._named_derivative: dict[tuple[int, int], Poly] = {}
        self._symbols: Symbols | None = None
        self._sympy_meaning: list[sp.Expr] | None = None

    def _add(self, generator: Generator) -> int:
        index = len(self.generators)
        self.generators.append(generator)
        self._index[generator.name] = index
        return index

    # -- building -----------------------------------------------------------------------
    def index(self, name: str) -> int:
        """The generator called `name` (C++ spelling: m1, delta0, g, dq2, s1, c1_2, r3)."""
        return self._index[name]

    def gen(self, name: str) -> Poly:
        return Poly.generator(self._index[name])

    def m(self, i: int) -> Poly:
        return self.gen(f"m{i}")

    def l(self, i: int) -> Poly:  # noqa: E743 (the paper's name)
        return self.gen(f"l{i}")

    def delta(self, i: int) -> Poly:
        return self.gen(f"delta{i}")

    def g(self) -> Poly:
        return self.gen("g")

    def qd(self, i: int) -> int:
        """The generator index of θ̇i (for `times_generator` and `diff`)."""
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
            return ONE
        if j is None or k is None:
            return self.cos(k if j is None else j)  # type: ignore[arg-type]
        return self.gen(f"c{min(j, k)}_{max(j, k)}")

    def define(self, name: str, definition: Poly) -> Poly:
        """A named quantity: a generator that stands for `definition` (which may use earlier ones)."""
        index = self._add(Generator(name, NAMED))
        self.named[index] = definition
        angles = sorted({a for g in definition.generators() for a in self._angles_of.get(g, ())})
        self._angles_of[index] = tuple(angles)
        return Poly.generator(index)

    def folded(self, values: dict[int, Fraction]) -> Algebra:
        """A copy in which the parameter generators `values` (index -> value) are constants."""
        folded = object.__new__(Algebra)
        folded.__dict__.update(self.__dict__)
        folded.named = {g: p.substitute(values) for g, p in self.named.items()}
        folded._named_derivative = {}
        folded._sympy_meaning = None
        return folded

    # -- calculus -----------------------------------------------------------------------
    def gradient(self, p: Poly) -> dict[int, Poly]:
        """{i: ∂p/∂θi} for every angle p depends on, by the chain rule over the letters and
        named quantities, in one pass over p's terms."""
        by_angle = self._by_angle
        by_letter: dict[int, dict[Monomial, int]] = {}  # angle -> numerators over p.den
        by_named: dict[tuple[int, int], dict[Monomial, int]] = {}  # (named, angle) -> cofactor
        for m, c in p.terms.items():
            previous = -1
            for at, g in enumerate(m):
                if g == previous:
                    continue
                previous = g
                angles = self._angles_of.get(g)
                if angles is None:
                    continue
                rest = (*m[:at], *m[at + 1 :])
                c_times_exponent = c * m.count(g) if g in rest else c
                for i in angles:
                    if g in self.named:
                        cofactor = by_named.setdefault((g, i), {})
                        cofactor[rest] = cofactor.get(rest, 0) + c_times_exponent
                    else:
                        sign, target = by_angle[i][g]
                        terms = by_letter.setdefault(i, {})
                        key = insert(rest, target)
                        terms[key] = terms.get(key, 0) + sign * c_times_exponent
        parts: dict[int, list[Poly]] = {
            i: [from_numerators({m: c for m, c in terms.items() if c}, p.den)]
            for i, terms in by_letter.items()
        }
        for (g, i), cofactor in sorted(by_named.items()):
            rest = from_numerators({m: c for m, c in cofactor.items() if c}, p.den)
            parts.setdefault(i, []).append(rest * self._derivative_of_named(g, i))
        gradient = {i: Poly.total(parts[i]) for i in sorted(parts)}
        return {i: d for i, d in gradient.items() if d}

    def _derivative_of_named(self, g: int, i: int) -> Poly:
        if (g, i) not in self._named_derivative:
            gradient = self.gradient(self.named[g])
            for angle in self._angles_of[g]:
                self._named_derivative[g, angle] = gradient.get(angle, ZERO)
        return self._named_derivative[g, i]

    # -- sympy views (tests, references) ------------------------------------------------
    @property
    def symbols(self) -> Symbols:
        """The sympy symbols of the system (θ, θ̇, θ̈, parameters, u); imports sympy."""
        if self._symbols is None:
            from ipgen.model import Symbols

            self._symbols = Symbols.for_dof(self.dof)
        return self._symbols

    def to_sympy(self, p: Poly) -> sp.Expr:
        """p as a sympy expression in θ, θ̇, θ̈ and the parameters (named quantities expanded)."""
        import sympy as sp

        meaning = self._meanings()
        terms = []
        for m, c in p.items():
            terms.append(sp.Rational(c.numerator, c.denominator) * sp.Mul(*(meaning[g] for g in m)))
        return sp.Add(*terms)

    def _meanings(self) -> list[sp.Expr]:
        if self._sympy_meaning is not None:
            return self._sympy_meaning
        import sympy as sp

        sym = self.symbols
        groups = {"m": sym.m, "l": sym.l, "delta": sym.delta}
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
            else:
                meaning.append(self.to_sympy(self.named[g]))  # earlier generators are ready
        return meaning
