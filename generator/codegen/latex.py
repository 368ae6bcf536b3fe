"""Equations as a person writes them: LaTeX of sums of parameter × velocity × trig terms.

Every quantity of these models is a polynomial in the parameters (m, l, δ, g), the rates θ̇
and sines and cosines of angles and angle differences. `readable_terms` writes one such
sympy expression as a list of LaTeX terms, each with its sign:

- terms with the same rates and trigonometric part are collected, and their parameter
  polynomial is factored: the monomial all its terms share comes out, so
  ½ m1 l1 + m2 l1 is printed (m1/2 + m2) l1;
- sin θk cos θk becomes ½ sin 2θk (eq. 31's form); sin²θ1 and cos(θ1 − θ2) stay as they are;
- rational coefficients are fractions, never decimals;
- the order is fixed: constant part first, then by rates, then by trig part.

`LatexPrinter` prints the atoms: θ_i, θ̇_i, m_i, l_i, δ_i, g, u, and sin/cos with the
argument forms θk, 2θk and (θj − θk) written without needless parentheses.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from fractions import Fraction

import sympy as sp
from sympy.printing.latex import LatexPrinter as _SympyLatexPrinter

_INDEXED = re.compile(r"(ddtheta|dtheta|theta|delta|m|l|com|J_axial|J|tip|Ir|gr|u)(\d+)\Z")
_SYMBOL_LATEX = {
    "theta": r"\theta_{{{i}}}",
    "dtheta": r"\dot{{\theta}}_{{{i}}}",
    "ddtheta": r"\ddot{{\theta}}_{{{i}}}",
    "delta": r"\delta_{{{i}}}",
    "m": "m_{{{i}}}",
    "l": "l_{{{i}}}",
    # the links as built (docs/model.md)
    "com": r"\mathrm{{com}}_{{{i}}}",
    "J": "J_{{{i}}}",
    "J_axial": r"J_{{\mathrm{{axial}},{i}}}",
    "tip": r"\mathrm{{tip}}_{{{i}}}",
    # a fixed pivot's motors (docs/model.md, "A fixed pivot"): rotor inertia, gear ratio, torque
    "Ir": r"\mathrm{{Ir}}_{{{i}}}",
    "gr": r"\mathrm{{gr}}_{{{i}}}",
    "u": "u_{{{i}}}",
}
# Parameters inside a monomial: masses, then g, lengths, damping (the paper's "m1 g l1").
_PARAMETER_RANK = {
    **{"m": 0, "tip": 0, "g": 1, "l": 2, "com": 2, "J": 2, "J_axial": 2, "delta": 3},
    **{"Ir": 4, "gr": 5, "u": 6},  # a fixed pivot's rotors, then its inputs
}


def _split_name(symbol: sp.Symbol) -> tuple[str, int]:
    match = _INDEXED.match(symbol.name)
    if match:
        return match.group(1), int(match.group(2))
    return symbol.name, -1


class LatexPrinter(_SympyLatexPrinter):
    """sympy's LaTeX printer with the model's notation for symbols and trigonometry."""

    def _print_Symbol(self, expr: sp.Symbol, style: str = "plain") -> str:
        group, index = _split_name(expr)
        if group in _SYMBOL_LATEX and index >= 0:
            return _SYMBOL_LATEX[group].format(i=index)
        return expr.name

    def _trig(self, name: str, expr: sp.Function, exp: str | None) -> str:
        head = rf"\{name}" + (f"^{{{exp}}}" if exp is not None else "")
        return f"{head}{self.argument(expr.args[0])}"

    def _print_sin(self, expr: sp.Function, exp: str | None = None) -> str:
        return self._trig("sin", expr, exp)

    def _print_cos(self, expr: sp.Function, exp: str | None = None) -> str:
        return self._trig("cos", expr, exp)

    def argument(self, angle: sp.Expr) -> str:
        """θk → `\\theta_{k}`, 2θk → `2\\theta_{k}`, θj − θk → `(\\theta_{j} - \\theta_{k})`."""
        coefficient, rest = angle.as_coeff_Mul()
        if rest.is_Symbol:
            scale = "" if coefficient == 1 else f"{coefficient}"
            return f" {scale}{self._print(rest)}"
        combination = angle.as_coefficients_dict()
        positive = [s for s, c in combination.items() if c == 1]
        negative = [s for s, c in combination.items() if c == -1]
        if len(positive) == 1 and len(negative) == 1 and len(combination) == 2:
            return rf"({self._print(positive[0])} - {self._print(negative[0])})"
        if coefficient != 1:
            return rf" {coefficient}({self._print(rest)})"
        return rf"\left({self._print(angle)}\right)"


PRINTER = LatexPrinter()


def latex(expr: sp.Expr) -> str:
    """One atom or simple product in the model's notation (θ_{1}, \\sin^{2}\\theta_{1}, …)."""
    return PRINTER.doprint(expr)


# --------------------------------------------------------------------------- terms


@dataclass(frozen=True)
class _Group:
    """Σ c·(parameter monomial), times one rate monomial and one trig monomial."""

    rates: tuple[tuple[sp.Symbol, int], ...]
    trig: tuple[tuple[sp.Expr, int], ...]


def _symbol_key(symbol: sp.Symbol) -> tuple[int, int, str]:
    group, index = _split_name(symbol)
    return (_PARAMETER_RANK.get(group, 9), index, symbol.name)


def _angle_key(function: sp.Expr) -> tuple[tuple[int, ...], int, str]:
    angle = function.args[0]
    indices = sorted(_split_name(s)[1] for s in angle.free_symbols)
    double = 1 if angle.as_coeff_Mul()[0] != 1 else 0
    return (tuple(indices), double, type(function).__name__)


def _fraction(value: sp.Rational) -> Fraction:
    return Fraction(int(value.p), int(value.q))


def _collect(expr: sp.Expr, rate_symbols: frozenset[sp.Symbol]) -> dict[_Group, dict[tuple, Fraction]]:
    """expr (expanded) → {group: {parameter monomial: coefficient}}; a monomial is a sorted
    tuple of (symbol, exponent)."""
    groups: dict[_Group, dict[tuple, Fraction]] = {}
    for term in sp.Add.make_args(sp.expand(expr)):
        if term == 0:
            continue
        coefficient, factors = term.as_coeff_mul()
        value = _fraction(sp.Rational(coefficient))
        params: dict[sp.Symbol, int] = {}
        rates: dict[sp.Symbol, int] = {}
        trig: dict[sp.Expr, int] = {}
        for factor in factors:
            base, exponent = factor.as_base_exp()
            if not exponent.is_Integer or exponent < 1:
                raise ValueError(f"not a polynomial term: {term}")
            if isinstance(base, sp.sin | sp.cos):
                trig[base] = trig.get(base, 0) + int(exponent)
            elif base.is_Symbol and base in rate_symbols:
                rates[base] = rates.get(base, 0) + int(exponent)
            elif base.is_Symbol:
                params[base] = params.get(base, 0) + int(exponent)
            else:
                raise ValueError(f"unexpected factor {factor} in {term}")
        # sin x cos x = ½ sin 2x (eq. 31's sin 2θ1)
        for function in [f for f in trig if isinstance(f, sp.sin)]:
            partner = sp.cos(function.args[0])
            if trig.get(function) == 1 and trig.get(partner) == 1:
                del trig[function], trig[partner]
                trig[sp.sin(2 * function.args[0])] = 1
                value /= 2
        key = _Group(
            tuple(sorted(rates.items(), key=lambda item: _symbol_key(item[0]))),
            tuple(sorted(trig.items(), key=lambda item: _angle_key(item[0]))),
        )
        monomial = tuple(sorted(params.items(), key=lambda item: _symbol_key(item[0])))
        bucket = groups.setdefault(key, {})
        bucket[monomial] = bucket.get(monomial, Fraction(0)) + value
    return {
        key: {m: c for m, c in bucket.items() if c}
        for key, bucket in groups.items()
        if any(c for c in bucket.values())
    }


def _monomial_latex(monomial: tuple[tuple[sp.Symbol, int], ...]) -> str:
    return " ".join(latex(s) + (f"^{{{e}}}" if e > 1 else "") for s, e in monomial)


def _coefficient_times(value: Fraction, body: str, inline: bool) -> str:
    """|value| · body (value > 0): `\\tfrac{1}{2} m_{1}` (inline) or `\\frac{m_{1}}{2}`."""
    p, q = value.numerator, value.denominator
    if not body:
        return f"\\frac{{{p}}}{{{q}}}" if q != 1 else f"{p}"
    if q == 1:
        return body if p == 1 else f"{p} {body}"
    if inline:
        return f"\\tfrac{{{p}}}{{{q}}} {body}"
    return f"\\frac{{{body if p == 1 else f'{p} {body}'}}}{{{q}}}"


def _common_monomial(monomials: list[tuple]) -> dict[sp.Symbol, int]:
    common = dict(monomials[0])
    for monomial in monomials[1:]:
        exponents = dict(monomial)
        common = {s: min(e, exponents[s]) for s, e in common.items() if s in exponents}
    return common


def _divide(monomial: tuple, common: dict[sp.Symbol, int]) -> tuple:
    return tuple((s, e - common.get(s, 0)) for s, e in monomial if e - common.get(s, 0) > 0)


def _signed(terms: list[tuple[int, str]]) -> list[str]:
    return [("- " if sign < 0 else "+ ") + body for sign, body in terms]


def _group_terms(group: _Group, polynomial: dict[tuple, Fraction]) -> list[tuple[int, str]]:
    """The terms (sign, LaTeX) of one group: spliced when it is a bare sum, else one term."""
    tail = " ".join(
        [latex(s) + (f"^{{{e}}}" if e > 1 else "") for s, e in group.rates]
        + [PRINTER._print(f, exp=str(e) if e > 1 else None) for f, e in group.trig]  # type: ignore[call-arg]
    )
    monomials = sorted(polynomial, key=lambda m: [(*_symbol_key(s), e) for s, e in m])
    if len(monomials) == 1:
        value = polynomial[monomials[0]]
        body = " ".join(b for b in (_monomial_latex(monomials[0]), tail) if b)
        return [(1 if value > 0 else -1, _coefficient_times(abs(value), body, inline=True))]
    common = _common_monomial(monomials)
    if not common and not tail:  # a bare sum such as m0 + m1 + m2 or δ1 + δ2
        return [
            (1 if polynomial[m] > 0 else -1, _coefficient_times(abs(polynomial[m]), _monomial_latex(m), True))
            for m in monomials
        ]
    values = [polynomial[m] for m in monomials]
    sign = -1 if all(v < 0 for v in values) else 1
    values = [v * sign for v in values]
    shared = abs(values[0]) if len({abs(v) for v in values}) == 1 and abs(values[0]) != 1 else Fraction(1)
    inner_terms = _signed(
        [
            (
                1 if v > 0 else -1,
                _coefficient_times(abs(v) / shared, _monomial_latex(_divide(m, common)), False),
            )
            for m, v in zip(monomials, values, strict=True)
        ]
    )
    inner = " ".join(inner_terms)
    inner = inner[2:] if inner.startswith("+ ") else "-" + inner[1:]
    outside = _monomial_latex(tuple(sorted(common.items(), key=lambda item: _symbol_key(item[0]))))
    body = " ".join(b for b in (rf"\left({inner}\right)", outside, tail) if b)
    return [(sign, _coefficient_times(shared, body, inline=True))]


def _group_order(item: tuple[_Group, dict]) -> tuple:
    group = item[0]
    return (
        len(group.rates) > 0 or len(group.trig) > 0,
        [(_symbol_key(s), -e) for s, e in group.rates],
        [(_angle_key(f), e) for f, e in group.trig],
    )


def readable_terms(expr: sp.Expr, rate_symbols: frozenset[sp.Symbol]) -> list[str]:
    """`expr` as LaTeX terms, each starting with "+ " or "- " (`join_terms` makes a sum).

    `rate_symbols` are the θ̇ (and θ̈) symbols: the factors a group is keyed by, together with
    the trigonometric ones; every other symbol counts as a parameter.
    """
    groups = _collect(expr, rate_symbols)
    terms: list[tuple[int, str]] = []
    for group, polynomial in sorted(groups.items(), key=_group_order):
        terms += _group_terms(group, polynomial)
    return _signed(terms)


def join_terms(terms: list[str]) -> str:
    """ "+ a", "- b" → "a - b"; no terms → "0"."""
    if not terms:
        return "0"
    text = " ".join(terms)
    return text[2:] if text.startswith("+ ") else "-" + text[1:]


_COMMAND = re.compile(r"\\[A-Za-z]+|[{}_^]")


def visible_width(latex_text: str) -> int:
    """A rough width of typeset LaTeX in characters: commands count as one, braces as none."""
    return len(
        _COMMAND.sub(lambda m: "x" if m.group(0).startswith("\\") else "", latex_text).replace(" ", "")
    )


def break_lines(terms: list[str], width: int = 56) -> list[str]:
    """Terms joined into lines of about `width` visible characters; the first line without
    its leading "+ "."""
    if not terms:
        return ["0"]
    lines: list[list[str]] = [[]]
    used = 0
    for term in terms:
        size = visible_width(term)
        if lines[-1] and used + size > width:
            lines.append([])
            used = 0
        lines[-1].append(term)
        used += size
    text = [" ".join(line) for line in lines]
    text[0] = join_terms(lines[0])
    return text
