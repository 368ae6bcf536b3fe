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

import functools
import re
from dataclasses import dataclass
from typing import TYPE_CHECKING

import sympy as sp

from ipgen.codegen.header import frame_context
from ipgen.codegen.latex import break_lines, latex, readable_terms
from ipgen.common.version import __version__
from ipgen.model.specialise import format_exact

if TYPE_CHECKING:
    from collections.abc import Callable

    import jinja2

    from ipgen.codegen.header import HeaderRequest
    from ipgen.model.derivation import Equations
    from ipgen.model.fixed_equations import FixedEquations
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
    """The document's lines from `eqs`; `fixed`: the links of a chain on a fixed pivot (the
    classical chain with the cart held still: θ0 = θ̇0 = 0, no tip masses), printed from link 1."""

    def __init__(self, eqs: Equations, fixed: bool = False) -> None:
        self.eqs = eqs
        self.system = eqs.system
        self.sym: Symbols = eqs.symbols
        self.rates = frozenset(self.sym.qd) | frozenset(self.sym.qdd)
        self.fixed = fixed
        self.still = {self.sym.q[0]: sp.Integer(0), self.sym.qd[0]: sp.Integer(0)} if fixed else {}
        self.first = 1 if fixed else 0  # the first coordinate printed (link 1 on a fixed pivot)

    def line(self, lhs: str, expr: sp.Expr) -> Line:
        if self.still:
            expr = expr.xreplace(self.still)
        terms = readable_terms(expr, self.rates)
        if len(terms) > TERM_CAP:
            return Line(lhs, [rf"\text{{({len(terms)} terms, not expanded here)}}"], capped=len(terms))
        return Line(lhs, break_lines(terms))

    # -- the bodies -------------------------------------------------------------------
    def link_values(self, i: int) -> tuple[sp.Expr, sp.Expr, sp.Expr, sp.Expr]:
        """(com_i, J_i, J_axial_i, tip_i) as the document shows them: symbols for the links as
        built, the paper's rod values (l_i/2, m_i l_i²/12, 0, 0) for a rod view."""
        sym = self.sym
        if self.eqs.rod_links:
            return sym.l[i] / 2, sym.m[i] * sym.l[i] ** 2 / 12, sp.Integer(0), sp.Integer(0)
        if self.fixed:  # a fixed chain's links have no tip masses
            return sym.com[i], sym.J[i], sp.Integer(0), sp.Integer(0)
        return sym.com[i], sym.J[i], sym.J_axial[i], sym.tip[i]

    def base(self) -> Block:
        sym, system = self.sym, self.system
        if system.is_rotary:
            inertia = sym.m[0] * sym.l[0] ** 2 / 3 if self.eqs.rod_links else sym.J[0]
        else:
            inertia = sym.m[0]
        dissipation = sp.expand(self.eqs.dissipation)
        damping0 = dissipation.coeff(sym.delta[0]) * sym.delta[0]
        lines = []
        if system.is_rotary:
            title = "The arm (body 0)"
            if self.eqs.rod_links:  # as built, J0 is a parameter of its own (J_0 = J_0 said nothing)
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
        """Link i: its CoG (at com_i along it) and its far end (the tip mass), their positions and
        velocities, T_i (both masses and the link's spin), V_i and D_i (docs/model.md)."""
        sym, system = self.sym, self.system
        q, qd = sym.q, sym.qd
        dissipation = sp.expand(self.eqs.dissipation)
        blocks = []
        below_reach = below_height = sp.Integer(0)  # the pivot of link i
        for i in range(1, system.dof):
            k_ = f"{i}"
            com, spin, axial, tip = self.link_values(i)
            s, c = sp.sin(q[i]), sp.cos(q[i])
            reach, height = below_reach + com * s, below_height + com * c
            far_reach, far_height = below_reach + sym.l[i] * s, below_height + sym.l[i] * c
            below_reach, below_height = far_reach, far_height

            def rate(expr: sp.Expr) -> sp.Expr:
                return sum(sp.diff(expr, q[k]) * qd[k] for k in range(1, system.dof))

            if system.is_rotary:
                # In the arm's frame: across the arm l0 θ̇0 + ṙ, along it −r θ̇0, vertical ż.
                def velocity(r: sp.Expr, z: sp.Expr) -> list[sp.Expr]:
                    return [-r * qd[0], sym.l[0] * qd[0] + rate(r), rate(z)]

                parts = velocity(reach, height)
                lines = [
                    self.line(f"r_{{{k_}}}", reach),
                    self.line(f"z_{{{k_}}}", height),
                    self.line(rf"v_{{{k_}\parallel}}", parts[0]),
                    self.line(rf"v_{{{k_}\perp}}", parts[1]),
                    self.line(rf"v_{{{k_}z}}", parts[2]),
                ]
            else:
                parts = [qd[0] + rate(reach), rate(height)]
                lines = [
                    self.line(f"x_{{{k_}}}", q[0] + reach),
                    self.line(f"z_{{{k_}}}", height),
                    self.line(rf"\dot{{x}}_{{{k_}}}", parts[0]),
                    self.line(rf"\dot{{z}}_{{{k_}}}", parts[1]),
                ]
            # The speeds squared written as a person would (cos(θa − θb), not the expanded sines and
            # cosines of the components above): CoG at com_i along link i, the tip at its far end.
            arms = [(sym.l[k], k) for k in range(1, i)]
            kinetic = sym.m[i] * self.speed_squared([*arms, (com, i)]) / 2 + spin * qd[i] ** 2 / 2
            if system.is_rotary and system.inertia == "full":
                kinetic += (spin * s**2 + axial * c**2) * qd[0] ** 2 / 2
            potential = sym.m[i] * sym.g * height
            if tip != 0:
                kinetic += tip * self.speed_squared([*arms, (sym.l[i], i)]) / 2
                potential += tip * sym.g * far_height
            damping = dissipation.coeff(sym.delta[i]) * sym.delta[i]
            lines += [
                self.line(f"T_{{{k_}}}", kinetic),
                self.line(f"V_{{{k_}}}", potential),
                self.dissipation_line(f"D_{{{k_}}}", damping, i),
            ]
            blocks.append(Block(f"Link {i} (body {i})", lines))
        return blocks

    def speed_squared(self, terms: list[tuple[sp.Expr, int]]) -> sp.Expr:
        """|v|² of a point at Σ c_k (sin θk, cos θk) from the link plane's pivot line, `terms` the
        (c_k, k): its in-plane velocity is the base's b plus Σ c_k θ̇k (cos θk, −sin θk) (b = θ̇0 for
        a cart, l0 θ̇0 across the arm), so |v|² = b² + 2 b Σ c_k θ̇k cos θk + Σ_a Σ_b c_a c_b θ̇a θ̇b
        cos(θa − θb); an arm adds the speed along it, r θ̇0 with r = Σ c_k sin θk."""
        sym = self.sym
        q, qd = sym.q, sym.qd
        base = qd[0] if not self.system.is_rotary else sym.l[0] * qd[0]
        total = base**2 + 2 * base * sum(c * qd[k] * sp.cos(q[k]) for c, k in terms)
        for a, (ca, ka) in enumerate(terms):
            total += ca**2 * qd[ka] ** 2
            for cb, kb in terms[a + 1 :]:
                total += 2 * ca * cb * qd[ka] * qd[kb] * sp.cos(q[ka] - q[kb])
        if self.system.is_rotary:
            total += (sum(c * sp.sin(q[k]) for c, k in terms) * qd[0]) ** 2
        return total

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

    def mass(self, matrix: sp.Matrix | None = None) -> Block:
        """M's entries on and above the diagonal (`matrix`: M with a fixed chain's rotors)."""
        matrix = self.eqs.mass_matrix if matrix is None else matrix
        dof, at = matrix.rows, self.first
        lines = [
            self.line(f"M_{{{_index(dof, j + at, k + at)}}}", matrix[j, k])
            for j in range(dof)
            for k in range(j, dof)
        ]
        return Block("M", lines)

    def n_matrix(self) -> tuple[Block, list[str]]:
        matrix, at = self.eqs.n_matrix, self.first
        dof = matrix.rows
        lines, zeros = [], []
        for j in range(dof):
            for k in range(dof):
                name = f"N_{{{_index(dof, j + at, k + at)}}}"
                if matrix[j, k] == 0:
                    zeros.append(name)
                else:
                    lines.append(self.line(name, matrix[j, k]))
        return Block("N", lines), zeros

    def gravity(self) -> Block:
        vector, at = self.eqs.gravity, self.first
        return Block("P", [self.line(f"P_{{{k + at}}}", vector[k, 0]) for k in range(vector.rows)])

    # -- a fixed chain's motors -----------------------------------------------------------
    def rotors(self, chain: FixedEquations) -> list[Block]:
        """Per motor k at joint j: its rotor's rate ω = gr θ̇j + (1 − gr) θ̇(j−1) (θ̇0 = 0, the
        ground) and kinetic energy ½ Ir ω² (docs/model.md, "A fixed pivot")."""
        qd = self.sym.qd  # the cart's numbering: link i's rate is qd[i]
        blocks = []
        for k, joint in enumerate(chain.joints, start=1):
            rotor, ratio = sp.Symbol(f"Ir{k}", nonnegative=True), sp.Symbol(f"gr{k}", real=True)
            rate = ratio * qd[joint] + ((1 - ratio) * qd[joint - 1] if joint >= 2 else 0)
            where = "the shoulder" if joint == 1 else f"joint {joint}"
            blocks.append(
                Block(
                    f"Motor {k}: the rotor at {where}",
                    [
                        self.line(rf"\omega_{{\mathrm{{r}},{k}}}", rate),
                        self.line(rf"T_{{\mathrm{{r}},{k}}}", rotor * rate**2 / 2),
                    ],
                )
            )
        return blocks

    def torques(self, chain: FixedEquations) -> Block:
        """τ = B u row by row: the torques the motors put on each link."""
        forced = chain.input_matrix * sp.Matrix(chain.u)
        return Block("tau", [self.line(rf"\tau_{{{i + 1}}}", forced[i, 0]) for i in range(forced.rows)])


def _common(
    name: str, command: str, links: int, blocks: list[Block], totals: Block, result: list[Block], n: tuple
) -> dict:
    """The context keys both kinds of document share: the names, the bodies and totals, M, N
    (`n`: the block and its zero count), P, and how many entries were capped. `result` is
    [M, N, P, …]."""
    capped = [line for block in [*blocks, totals, *result] for line in block.lines if line.capped]
    return {
        "name": name,
        "command": command,
        "version": __version__,
        "links": links,
        "last": links,
        "bodies": blocks,
        "totals": totals,
        "mass": result[0],
        "n_block": n[0],
        "n_zeros": n[1],
        "gravity": result[2],
        "capped": len(capped),
        "cap": TERM_CAP,
    }


def _context(eqs: Equations, request: HeaderRequest) -> dict:
    builder = _Builder(eqs)
    system = eqs.system
    n_block, n_zeros = builder.n_matrix()
    blocks = [builder.base(), *builder.links()]
    totals = builder.totals()
    result = [builder.mass(), n_block, builder.gravity()]
    return {
        **_common(request.name, request.command, system.links, blocks, totals, result, (n_block, n_zeros)),
        "rotary": system.is_rotary,
        "dof": system.dof,
        "inertia": system.inertia,
        "fixed": [(name, format_exact(value)) for name, value in request.specialisation.fixed],
        "rod_links": eqs.rod_links,
        "frame": frame_context(request.coordinates),
        "fixed_pivot": False,
        "drive": request.drive,
    }


def _fixed_context(name: str, command: str, joints: tuple[int, ...], links: int) -> dict:
    """The documents' context for a chain of `links` links on a fixed pivot driven at `joints`:
    the bodies, N, P, V and D of the held cart's chain (`fixed_poly.fixed_poly_equations`, as the
    headers print them), M and T with the rotors, and B, from `fixed_equations` (ipgen's
    coordinates)."""
    from ipgen.model.coordinates import Coordinates
    from ipgen.model.fixed_equations import fixed_equations
    from ipgen.model.fixed_poly import fixed_poly_equations

    eqs = fixed_poly_equations(links)
    chain = fixed_equations(links, joints, "tanh", Coordinates())
    builder = _Builder(eqs, fixed=True)
    n_block, n_zeros = builder.n_matrix()
    blocks = [*builder.links(), *builder.rotors(chain)]
    totals = Block(
        "Totals",
        [
            builder.line("T", chain.kinetic_energy),
            builder.line("V", eqs.potential_energy),
            builder.line("D", eqs.dissipation),
        ],
    )
    result = [builder.mass(chain.mass_matrix), n_block, builder.gravity(), builder.torques(chain)]
    matrix = chain.input_matrix
    return {
        **_common(name, command, links, blocks, totals, result, (n_block, n_zeros)),
        "rotary": False,
        "dof": links,
        "inertia": "pivot",
        "fixed": [],
        "fixed_pivot": True,
        "rod_links": False,
        "frame": None,
        "drive": "direct",
        "joints": list(joints),
        "inputs": len(joints),
        "torques": result[3],
        "input_matrix": r"\begin{pmatrix} "
        + r" \\ ".join(" & ".join(str(matrix[i, k]) for k in range(matrix.cols)) for i in range(matrix.rows))
        + r" \end{pmatrix}",
    }


@functools.cache
def _environment(escape: Callable[[str], str]) -> jinja2.Environment:
    """The templates' environment with `escape_text` escaping for one format: one per format and
    process (they shared one, whose filter the Markdown and TeX renders of two threads set in
    turn: a .md came out with TeX's escapes)."""
    from ipgen.codegen.header import new_environment

    documents = new_environment()
    documents.filters["escape_text"] = escape
    return documents


def render_equations(eqs: Equations, request: HeaderRequest) -> dict[str, str]:
    """{".md": Markdown with $$ math, ".tex": a standalone amsmath document}; deterministic."""
    return _render(_context(eqs, request))


def render_fixed_equations(name: str, command: str, joints: tuple[int, ...], links: int) -> dict[str, str]:
    """The documents of a chain of `links` links on a fixed pivot driven at `joints` (1 = the
    shoulder), in ipgen's coordinates, as `render_equations` lays out the cart's and the arm's.

    Parameters
    ----------
    name : str
        The model's name (the title; escaped).
    command : str
        The command that regenerates the files (escaped).
    joints : tuple of int
        The driven joints, one input u_k each in this order.
    links : int
        The number of links n >= 1.

    Returns
    -------
    dict of str to str
        {".md": Markdown with $$ math, ".tex": a standalone amsmath document}; deterministic.
    """
    return _render(_fixed_context(name, command, joints, links))


def _render(context: dict) -> dict[str, str]:
    markdown = _environment(markdown_escape).get_template(MD_TEMPLATE).render(context)
    tex = _environment(tex_escape).get_template(TEX_TEMPLATE).render(context)
    return {".md": markdown, ".tex": tex}
