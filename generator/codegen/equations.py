"""The equations for people (`--emit equations`): NAME.md and NAME.tex from the derived model.

The document follows the paper's section 2 and eq. 29: the system and its symbols; body by
body the CoG position, its velocity, the kinetic and potential energy and the Rayleigh
dissipation; the totals T, V, D and the Lagrangian; then M(θ), N(θ, θ̇), P(θ) and the input
vector entry by entry. Every formula comes from the project's model (`model.bodies`, the
`Equations` sympy views) through one printer (`latex.readable_terms`); two templates
(templates/equations.md.jinja and equations.tex.jinja) only lay it out.

An entry that would take more than `TERM_CAP` terms is not expanded (its size is stated
instead): the document is for reading, the C++ header has every entry.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import TYPE_CHECKING

import sympy as sp

from ipgen.codegen.latex import break_lines, latex, readable_terms
from ipgen.common.version import __version__
from ipgen.model.bodies import base_inertia, bodies
from ipgen.model.specialise import format_exact

if TYPE_CHECKING:
    from collections.abc import Callable

    import jinja2

    from ipgen.codegen.header import HeaderRequest
    from ipgen.model.derivation import Equations
    from ipgen.model.symbols import Symbols

TERM_CAP = 40  # terms per printed entry; larger entries are stated by size only
MD_TEMPLATE, TEX_TEMPLATE = "equations.md.jinja", "equations.tex.jinja"


@dataclass
class Line:
    """One displayed equation `lhs = rhs`; `rhs` is broken into lines for the page."""

    lhs: str
    rhs: list[str]
    capped: int = 0  # the number of terms, when the entry was too long to print


@dataclass
class Block:
    """Displayed equations under a heading (the templates add the words)."""

    title: str  # plain ASCII words
    lines: list[Line]


# --------------------------------------------------------------------------- escaping

_MD_SPECIAL = re.compile(r"([\\`*_\[\]<>|$~&#])")
_TEX_SPECIAL = {
    "\\": r"\textbackslash{}",
    "&": r"\&",
    "%": r"\%",
    "$": r"\$",
    "#": r"\#",
    "_": r"\_",
    "{": r"\{",
    "}": r"\}",
    "~": r"\textasciitilde{}",
    "^": r"\textasciicircum{}",
    "<": r"\textless{}",
    ">": r"\textgreater{}",
    "|": r"\textbar{}",
}


def markdown_escape(text: str) -> str:
    """`text` shown literally in Markdown (every punctuation character with a meaning escaped)."""
    return _MD_SPECIAL.sub(r"\\\1", text.replace("\n", " ").replace("\r", " "))


def tex_escape(text: str) -> str:
    """`text` shown literally in LaTeX body text."""
    return "".join(_TEX_SPECIAL.get(ch, ch) for ch in text.replace("\n", " ").replace("\r", " "))


# --------------------------------------------------------------------------- content


def _index(dof: int, *indices: int) -> str:
    """Subscript of an entry: M_{01} for small systems, M_{0,1} once an index has two digits."""
    joiner = "," if dof > 10 else ""
    return joiner.join(str(i) for i in indices)


class _Builder:
    def __init__(self, eqs: Equations) -> None:
        self.eqs = eqs
        self.system = eqs.system
        self.sym: Symbols = eqs.symbols
        self.rates = frozenset(self.sym.qd) | frozenset(self.sym.qdd)

    def line(self, lhs: str, expr: sp.Expr) -> Line:
        terms = readable_terms(expr, self.rates)
        if len(terms) > TERM_CAP:
            return Line(lhs, [rf"\text{{({len(terms)} terms, not expanded here)}}"], capped=len(terms))
        return Line(lhs, break_lines(terms))

    # -- the bodies -------------------------------------------------------------------
    def base(self) -> Block:
        sym, system = self.sym, self.system
        algebra = self.eqs.algebra
        inertia = algebra.to_sympy(base_inertia(system, algebra))
        dissipation = sp.expand(self.eqs.dissipation)
        damping0 = dissipation.coeff(sym.delta[0]) * sym.delta[0]
        lines = []
        if system.is_rotary:
            title = "The arm (body 0)"
            lines.append(self.line("J_{0}", inertia))
        else:
            title = "The cart (body 0)"
            lines.append(self.line("x_{0}", sym.q[0]))
        lines += [
            self.line("T_{0}", inertia * sym.qd[0] ** 2 / 2),
            Line("V_{0}", ["0"]),
            self.line("D_{0}", damping0),
        ]
        return Block(title, lines)

    def links(self) -> list[Block]:
        sym, system, algebra = self.sym, self.system, self.eqs.algebra
        to_sympy = algebra.to_sympy
        dissipation = sp.expand(self.eqs.dissipation)
        blocks = []
        for i, body in enumerate(bodies(system, algebra), start=1):
            k_ = f"{i}"
            # Velocity components from the CoG Jacobian: a column term c·u(θk) is the vector
            # c (cos θk, −sin θk) in the links' plane (u(0) = (1, 0)); `normal` is across it.
            along = sp.Integer(0)  # first in-plane component (x, or across the arm)
            vertical = sp.Integer(0)
            normal = sp.Integer(0)  # rotary: along the arm
            reach = sp.Integer(0)  # the position's first in-plane component, links only
            height = sp.Integer(0)
            for k, column in enumerate(body.jacobian):
                rate = sym.qd[k]
                for coefficient, angle in column.terms:
                    c = to_sympy(coefficient)
                    if angle is None:
                        along += c * rate
                    else:
                        along += c * sp.cos(sym.q[angle]) * rate
                        vertical -= c * sp.sin(sym.q[angle]) * rate
                        reach += c * sp.sin(sym.q[angle])
                        height += c * sp.cos(sym.q[angle])
                normal += to_sympy(column.normal) * rate
            mass = to_sympy(body.mass)
            kinetic = sp.Integer(0)
            columns = body.jacobian
            for a in range(len(columns)):
                for b in range(len(columns)):
                    dot = to_sympy(columns[a].dot(columns[b], algebra))
                    kinetic += mass * dot * sym.qd[a] * sym.qd[b] / 2
            for (a, b), spin in body.rotational.items():
                kinetic += to_sympy(spin) * sym.qd[a] * sym.qd[b] / 2
            potential = mass * sym.g * to_sympy(body.height)
            damping = dissipation.coeff(sym.delta[i]) * sym.delta[i]
            if system.is_rotary:
                lines = [
                    self.line(f"r_{{{k_}}}", reach),
                    self.line(f"z_{{{k_}}}", height),
                    self.line(rf"v_{{{k_}\parallel}}", normal),
                    self.line(rf"v_{{{k_}\perp}}", along),
                    self.line(rf"v_{{{k_}z}}", vertical),
                ]
            else:
                lines = [
                    self.line(f"x_{{{k_}}}", sym.q[0] + reach),
                    self.line(f"z_{{{k_}}}", height),
                    self.line(rf"\dot{{x}}_{{{k_}}}", along),
                    self.line(rf"\dot{{z}}_{{{k_}}}", vertical),
                ]
            lines += [
                self.line(f"T_{{{k_}}}", kinetic),
                self.line(f"V_{{{k_}}}", potential),
                self.dissipation_line(f"D_{{{k_}}}", damping, i),
            ]
            blocks.append(Block(f"Link {i} (body {i})", lines))
        return blocks

    def dissipation_line(self, lhs: str, damping: sp.Expr, i: int) -> Line:
        """½ δi (θ̇i − θ̇(i−1))² written as such (the Rayleigh term of link i)."""
        sym = self.sym
        if i >= 2 and sp.expand(damping - sym.delta[i] * (sym.qd[i] - sym.qd[i - 1]) ** 2 / 2) == 0:
            rates = f"{latex(sym.qd[i])} - {latex(sym.qd[i - 1])}"
            return Line(lhs, [rf"\tfrac{{1}}{{2}} {latex(sym.delta[i])} ({rates})^{{2}}"])
        return self.line(lhs, damping)

    # -- totals and the result -----------------------------------------------------------
    def totals(self) -> Block:
        eqs = self.eqs
        return Block(
            "Totals",
            [
                self.line("T", eqs.kinetic_energy),
                self.line("V", eqs.potential_energy),
                self.line("D", eqs.dissipation),
            ],
        )

    def mass(self) -> Block:
        dof, matrix = self.system.dof, self.eqs.mass_matrix
        lines = [
            self.line(f"M_{{{_index(dof, j, k)}}}", matrix[j, k]) for j in range(dof) for k in range(j, dof)
        ]
        return Block("M", lines)

    def n_matrix(self) -> tuple[Block, list[str]]:
        dof, matrix = self.system.dof, self.eqs.n_matrix
        lines, zeros = [], []
        for j in range(dof):
            for k in range(dof):
                name = f"N_{{{_index(dof, j, k)}}}"
                if matrix[j, k] == 0:
                    zeros.append(name)
                else:
                    lines.append(self.line(name, matrix[j, k]))
        return Block("N", lines), zeros

    def gravity(self) -> Block:
        dof, vector = self.system.dof, self.eqs.gravity
        return Block("P", [self.line(f"P_{{{k}}}", vector[k, 0]) for k in range(dof)])


def _context(eqs: Equations, request: HeaderRequest) -> dict:
    builder = _Builder(eqs)
    system = eqs.system
    n = system.links
    n_block, n_zeros = builder.n_matrix()
    blocks = [builder.base(), *builder.links()]
    totals = builder.totals()
    result = [builder.mass(), n_block, builder.gravity()]
    capped = [line for block in [*blocks, totals, *result] for line in block.lines if line.capped]
    fixed = [(name, format_exact(value)) for name, value in request.specialisation.fixed]
    return {
        "name": request.name,
        "command": request.command,
        "version": __version__,
        "rotary": system.is_rotary,
        "links": n,
        "dof": system.dof,
        "inertia": system.inertia,
        "last": n,
        "bodies": blocks,
        "totals": totals,
        "mass": result[0],
        "n_block": n_block,
        "n_zeros": n_zeros,
        "gravity": result[2],
        "capped": len(capped),
        "cap": TERM_CAP,
        "fixed": fixed,
    }


def _environment(escape: Callable[[str], str]) -> jinja2.Environment:
    """The templates' environment (codegen.header's), with `escape_text` escaping for one format."""
    from ipgen.codegen.header import environment

    documents = environment()
    documents.filters["escape_text"] = escape
    return documents


def render_equations(eqs: Equations, request: HeaderRequest) -> dict[str, str]:
    """{".md": Markdown with $$ math, ".tex": a standalone amsmath document}; deterministic."""
    context = _context(eqs, request)
    markdown = _environment(markdown_escape).get_template(MD_TEMPLATE).render(context)
    tex = _environment(tex_escape).get_template(TEX_TEMPLATE).render(context)
    return {".md": markdown, ".tex": tex}
