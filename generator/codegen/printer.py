"""Prints sympy expressions as C++ for a templated `Scalar` type.

A deliberately small printer (the expressions are polynomials in parameters, velocities
and per-angle sin/cos): literals are cast to `Scalar` so the same code is exact in float
and double, small integer powers become products, and nothing is printed that the caller
did not name (an unnamed symbol is a bug, reported as such).
"""

from __future__ import annotations

from collections.abc import Mapping

import sympy as sp


class CppPrinter:
    """Prints an expression; `names` maps every symbol to its C++ spelling."""

    def __init__(self, names: Mapping[sp.Symbol, str]) -> None:
        self.names = names

    def __call__(self, expr: sp.Expr) -> str:
        return self._print(sp.sympify(expr))

    def _print(self, expr: sp.Expr) -> str:
        if isinstance(expr, sp.Symbol):
            if expr not in self.names:
                raise KeyError(f"symbol {expr} has no C++ name")
            return self.names[expr]
        if isinstance(expr, sp.Integer):
            return f"Scalar({int(expr)})"
        if isinstance(expr, sp.Rational):
            return f"Scalar({expr.p})/Scalar({expr.q})"
        if isinstance(expr, sp.Float):
            return f"Scalar({sp.Float(expr, 17)})"
        if isinstance(expr, sp.Add):
            return self._print_add(expr)
        if isinstance(expr, sp.Mul):
            return self._print_mul(expr)
        if isinstance(expr, sp.Pow):
            return self._print_mul(expr)
        if isinstance(expr, (sp.sin, sp.cos, sp.sqrt)):
            return f"{type(expr).__name__}({self._print(expr.args[0])})"
        raise TypeError(f"cannot print {type(expr).__name__}: {expr}")

    def _print_add(self, expr: sp.Add) -> str:
        text = ""
        for term in expr.args:
            negative = term.could_extract_minus_sign()
            body = self._factor(-term if negative else term, in_sum=True)
            if not text:
                text = f"-{body}" if negative else body
            else:
                text += f" - {body}" if negative else f" + {body}"
        return text

    def _factor(self, expr: sp.Expr, in_sum: bool = False) -> str:
        """Print `expr` so that it can stand as one factor of a product."""
        text = self._print(expr)
        if isinstance(expr, sp.Add) or (not in_sum and text.startswith("-")):
            return f"({text})"
        return text

    def _power(self, base: sp.Expr, exponent: int) -> str:
        factor = self._factor(base)
        return "*".join([factor] * exponent)

    def _print_mul(self, expr: sp.Expr) -> str:
        coefficient, factors = expr.as_coeff_mul()
        numerator: list[str] = []
        denominator: list[str] = []
        for factor in factors:
            base, exponent = factor.as_base_exp()
            if exponent.is_Integer and exponent > 0:
                numerator.append(self._power(base, int(exponent)))
            elif exponent.is_Integer and exponent < 0:
                denominator.append(self._power(base, int(-exponent)))
            elif exponent == sp.S.Half:
                numerator.append(f"sqrt({self._print(base)})")
            else:
                numerator.append(f"pow({self._print(base)}, {self._print(exponent)})")
        sign = ""
        if coefficient < 0:
            sign, coefficient = "-", -coefficient
        if coefficient != 1 or not numerator:
            numerator.insert(0, self._print(coefficient))
        text = "*".join(numerator)
        if denominator:
            den = denominator[0] if len(denominator) == 1 else "(" + "*".join(denominator) + ")"
            text += f"/{den}"
        return sign + text
