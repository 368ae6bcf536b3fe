"""Reads the equations documents back: displayed entries → sympy, for the tests.

Why not sympy's `parse_latex(..., backend="lark")`: in sympy 1.14 it rejects `\\dot{\\theta}`
and multi-digit subscripts (`\\theta_{10}`), fails on a product after `\\right)` or after
`\\cos(\\theta_1 - \\theta_2)`, and returns an ambiguous parse tree, not an expression, for
`\\cos\\theta_{1} \\sin\\theta_{2}` (cos(θ1 sin θ2) or cos θ1 · sin θ2). So this is a strict
recursive-descent reader of exactly the notation the documents use — numbers, `\\frac` and
`\\tfrac`, `\\left( … \\right)`, powers `^{k}`, θ_k, θ̇_k, m_k, l_k, δ_k, g, u, and sin/cos of
θk, 2θk or (θj − θk) with an optional power, and the names of the links as built and of a
fixed pivot's motors (`\\mathrm{com}_{k}`, `J_{k}`, `\\mathrm{Ir}_{k}`, `\\mathrm{gr}_{k}`,
`u_{k}`) — and anything else is an error, so a change of notation fails the tests instead of
being misread.
"""

from __future__ import annotations

import re

import sympy as sp

from ipgen.model.symbols import Symbols

_TOKEN = re.compile(r"\\[A-Za-z]+|\\[,;! ]|\d+|[A-Za-z]|[{}()^_+\-=&]|\s+")
_SKIP = {r"\quad", r"\,", r"\;", r"\!", "\\ ", "&"}


def tokens(text: str) -> list[str]:
    result, at = [], 0
    while at < len(text):
        match = _TOKEN.match(text, at)
        if not match:
            raise ValueError(f"unexpected character {text[at]!r} at {at} in {text!r}")
        at = match.end()
        token = match.group(0)
        if not token.isspace() and token not in _SKIP:
            result.append(token)
    return result


class Reader:
    """Parses one right-hand side in the symbols `sym` (`Reader(text, sym).parse()`)."""

    def __init__(self, text: str, sym: Symbols) -> None:
        self.text = text
        self.tokens = tokens(text)
        self.at = 0
        self.sym = sym

    # -- helpers ------------------------------------------------------------------------
    def peek(self) -> str | None:
        return self.tokens[self.at] if self.at < len(self.tokens) else None

    def take(self, expected: str | None = None) -> str:
        token = self.peek()
        if token is None or (expected is not None and token != expected):
            raise ValueError(
                f"expected {expected or 'more'} at token {self.at} in {self.text!r}, got {token!r}"
            )
        self.at += 1
        return token

    def fail(self, what: str) -> ValueError:
        return ValueError(f"{what} at token {self.at} ({self.peek()!r}) in {self.text!r}")

    # -- grammar ------------------------------------------------------------------------
    def parse(self) -> sp.Expr:
        value = self.sum()
        if self.peek() is not None:
            raise self.fail("trailing input")
        return value

    def sum(self) -> sp.Expr:
        terms = []
        sign = 1
        if self.peek() in ("+", "-"):
            sign = -1 if self.take() == "-" else 1
        terms.append(sign * self.product())
        while self.peek() in ("+", "-"):
            sign = -1 if self.take() == "-" else 1
            terms.append(sign * self.product())
        return sp.Add(*terms)

    def product(self) -> sp.Expr:
        factors = [self.power()]
        while self.peek() not in (None, "+", "-", "}", ")", r"\right", "="):
            factors.append(self.power())
        return sp.Mul(*factors)

    def power(self) -> sp.Expr:
        base = self.atom()
        if self.peek() == "^":
            self.take()
            base = base ** self.group()
        return base

    def group(self) -> sp.Expr:
        self.take("{")
        value = self.sum()
        self.take("}")
        return value

    def index(self) -> int:
        self.take("_")
        self.take("{")
        number = self.take()
        if not number.isdigit():
            raise self.fail("expected an index")
        self.take("}")
        return int(number)

    def atom(self) -> sp.Expr:
        token = self.take()
        sym = self.sym
        if token.isdigit():
            return sp.Integer(token)
        if token in (r"\frac", r"\tfrac"):
            numerator = self.group()
            return numerator / self.group()
        if token == "(":
            value = self.sum()
            self.take(")")
            return value
        if token == r"\left":
            self.take("(")
            value = self.sum()
            self.take(r"\right")
            self.take(")")
            return value
        if token in (r"\sin", r"\cos"):
            function = sp.sin if token == r"\sin" else sp.cos
            exponent = sp.Integer(1)
            if self.peek() == "^":
                self.take()
                exponent = self.group()
            return function(self.argument()) ** exponent
        if token == r"\theta":
            return sym.q[self.index()]
        if token == r"\delta":
            return sym.delta[self.index()]
        if token in (r"\dot", r"\ddot"):
            self.take("{")
            self.take(r"\theta")
            self.take("}")
            return (sym.qd if token == r"\dot" else sym.qdd)[self.index()]
        if token in ("m", "l"):
            return (sym.m if token == "m" else sym.l)[self.index()]
        if token == "g":
            return sym.g
        if token == "u":  # a fixed pivot's inputs are numbered: u_{k}
            return sp.Symbol(f"u{self.index()}", real=True) if self.peek() == "_" else sym.u
        if token == "J":
            return sym.J[self.index()]
        if token == r"\mathrm":  # the links as built (com, tip) and a fixed pivot's rotors (Ir, gr)
            self.take("{")
            word = ""
            while self.peek() != "}":
                word += self.take()
            self.take("}")
            k = self.index()
            if word in ("com", "tip"):
                return getattr(sym, word)[k]
            if word in ("Ir", "gr"):
                return sp.Symbol(f"{word}{k}", real=True)
            self.at -= 1
            raise self.fail(f"unknown name {word!r}")
        self.at -= 1
        raise self.fail("unknown token")

    def argument(self) -> sp.Expr:
        """θk, 2θk or (θj − θk), as the printer writes a sine's or cosine's argument."""
        if self.peek() == "(":
            self.take()
            value = self.sum()
            self.take(")")
            return value
        scale = sp.Integer(self.take()) if (self.peek() or "").isdigit() else sp.Integer(1)
        if self.peek() == "(":
            return scale * self.argument()
        self.take(r"\theta")
        return scale * self.sym.q[self.index()]


def parse(text: str, sym: Symbols) -> sp.Expr:
    return Reader(text, sym).parse()


# --------------------------------------------------------------------------- documents

_MD_DISPLAY = re.compile(r"^\$\$\n(.*?)\n\$\$$", re.DOTALL | re.MULTILINE)
_TEX_DISPLAY = re.compile(r"\\begin\{(align\*|equation\*)\}\n(.*?)\n\\end\{\1\}", re.DOTALL)


def _equations_of(body: str) -> list[str]:
    """One display's lines → its equations, continuation lines ("&\\quad …") joined."""
    body = body.replace(r"\begin{aligned}", "").replace(r"\end{aligned}", "")
    equations: list[str] = []
    for raw in body.split("\n"):
        line = raw.strip()
        if not line:
            continue
        line = line.removesuffix(r"\\").strip()
        if line.startswith(r"&\quad") and equations:
            equations[-1] += " " + line.removeprefix(r"&\quad")
        else:
            equations.append(line.replace("&=", "="))
    return equations


def displayed(text: str, kind: str) -> dict[str, str]:
    """{left-hand side: right-hand side} of every displayed `lhs = rhs` of a document (`kind`
    "md" or "tex"); `a = b = 0` gives a and b. Displays that are not one entry (eq. 29's
    statement, Lagrange's equation, the Christoffel formula) are left out."""
    bodies = (
        [m.group(1) for m in _MD_DISPLAY.finditer(text)]
        if kind == "md"
        else [m.group(2) for m in _TEX_DISPLAY.finditer(text)]
    )
    entries: dict[str, str] = {}
    for body in bodies:
        for equation in _equations_of(body):
            sides = [side.strip() for side in equation.split(" = ")]
            if len(sides) < 2 or any(s.startswith(("\\frac{d}", r"\mathbf", "C_{kj}")) for s in sides[:1]):
                continue
            for lhs in sides[:-1]:
                if lhs in entries:
                    raise ValueError(f"{lhs} displayed twice")
                entries[lhs] = sides[-1]
    return entries
