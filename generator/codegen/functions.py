"""Turns the derived expressions into the bodies of the header's C++ functions.

For each function: the expressions it returns are rewritten in per-angle sines and cosines
(sin/cos of each angle computed once; cos(θj − θk) = cj ck + sj sk), common subexpressions
are shared by one `sympy.cse` over all its outputs (M and the bias share temporaries in
`forward_dynamics`), and the result is printed as C++ statements.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import sympy as sp

from generator.codegen.printer import CppPrinter
from generator.derive import Equations


@dataclass(frozen=True)
class Output:
    """One returned quantity: a scalar (`shape == ()`), a vector or a matrix."""

    name: str
    value: sp.Matrix | sp.Expr
    symmetric: bool = False  # matrices: compute the upper triangle, mirror the rest
    lower_only: bool = False  # matrices: only the lower triangle is needed (Cholesky)


@dataclass
class FunctionBody:
    """C++ statements computing a function's outputs, with an operation count."""

    prelude: list[str] = field(default_factory=list)  # parameter, state and trig bindings
    temporaries: list[str] = field(default_factory=list)
    outputs: list[str] = field(default_factory=list)
    unused_arguments: list[str] = field(default_factory=list)
    operations: int = 0  # additions, multiplications, divisions after CSE
    trig_calls: int = 0  # sin/cos evaluations


@dataclass(frozen=True)
class _Trig:
    """Per-angle sin/cos symbols, and cos/sin of angle differences built from them."""

    symbol: sp.Symbol
    cpp: str  # C++ definition
    order: tuple[int, ...]  # definition order: single angles first
    depends: tuple[sp.Symbol, ...] = ()  # per-angle symbols a difference term is built from


def _trig_rewrite(exprs: Sequence[sp.Expr], q: Sequence[sp.Symbol]) -> tuple[list[sp.Expr], list[_Trig]]:
    """Replace sin/cos of θk and of θj − θk by named symbols defined once."""
    index = {angle: k for k, angle in enumerate(q)}
    atoms: set[sp.Expr] = set()
    for expr in exprs:
        atoms |= expr.atoms(sp.sin, sp.cos)
    defs: dict[str, _Trig] = {}
    replace: dict[sp.Expr, sp.Symbol] = {}

    def single(kind: str, k: int) -> sp.Symbol:
        name = f"{kind}{k}"
        if name not in defs:
            fn = "sin" if kind == "s" else "cos"
            symbol = sp.Symbol(name)
            defs[name] = _Trig(
                symbol, f"const Scalar {name} = {fn}(q({k}));", (k, 0, 0 if kind == "s" else 1)
            )
        return defs[name].symbol

    for atom in sorted(atoms, key=sp.default_sort_key):
        kind = "s" if isinstance(atom, sp.sin) else "c"
        weights = atom.args[0].as_coefficients_dict()
        if len(weights) == 1 and weights.get(atom.args[0]) == 1 and atom.args[0] in index:
            replace[atom] = single(kind, index[atom.args[0]])
            continue
        terms = sorted((index[s], int(c)) for s, c in weights.items() if s in index)
        if len(terms) != 2 or len(weights) != 2 or sorted(c for _, c in terms) != [-1, 1]:
            raise ValueError(f"unexpected trigonometric argument {atom.args[0]}")
        (j, cj), (k, _) = terms
        if cj < 0:  # keep the canonical θj − θk with j < k
            raise ValueError(f"non-canonical angle difference {atom.args[0]}")
        sj, cj_, sk, ck = single("s", j), single("c", j), single("s", k), single("c", k)
        name = f"{kind}{j}_{k}"
        if name not in defs:
            value = f"{cj_}*{ck} + {sj}*{sk}" if kind == "c" else f"{sj}*{ck} - {cj_}*{sk}"
            what = "cos" if kind == "c" else "sin"
            defs[name] = _Trig(
                sp.Symbol(name),
                f"const Scalar {name} = {value};  // {what}(θ{j} − θ{k})",
                (j, k, 0 if kind == "s" else 1),
                (sj, cj_, sk, ck),
            )
        replace[atom] = defs[name].symbol
    rewritten = [expr.xreplace(replace) for expr in exprs]
    ordered = sorted(defs.values(), key=lambda d: (d.order[1] != 0, d.order))
    return rewritten, ordered


def _flatten(outputs: Sequence[Output]) -> list[tuple[str, sp.Expr]]:
    """(C++ target, expression) for every entry that must be computed."""
    targets: list[tuple[str, sp.Expr]] = []
    for out in outputs:
        value = out.value
        if not isinstance(value, sp.MatrixBase):
            targets.append((out.name, value))
            continue
        for r in range(value.rows):
            for c in range(value.cols):
                if (out.symmetric and r > c) or (out.lower_only and r < c) or value[r, c] == 0:
                    continue
                target = f"{out.name}({r})" if value.cols == 1 else f"{out.name}({r}, {c})"
                targets.append((target, value[r, c]))
    return targets


def _mirror_lines(outputs: Sequence[Output]) -> list[str]:
    """Copies completing symmetric matrices from their computed upper triangle."""
    lines = []
    for out in outputs:
        if out.symmetric and isinstance(out.value, sp.MatrixBase):
            for r in range(out.value.rows):
                for c in range(r):
                    if out.value[c, r] != 0:
                        lines.append(f"{out.name}({r}, {c}) = {out.name}({c}, {r});")
    return lines


def count_operations(exprs: Sequence[sp.Expr]) -> int:
    return sum(int(sp.count_ops(e)) for e in exprs)


def build_body(eqs: Equations, outputs: Sequence[Output], arguments: Sequence[str]) -> FunctionBody:
    """Statements computing `outputs`; `arguments` are the C++ parameter names (q, qd, p, u)."""
    sym = eqs.symbols
    targets = _flatten(outputs)
    exprs, trig = _trig_rewrite([e for _, e in targets], sym.q)
    temporaries, reduced = sp.cse(exprs, symbols=sp.numbered_symbols("t"))

    used: set[sp.Symbol] = set()
    for expr in [*reduced, *(v for _, v in temporaries)]:
        used |= expr.free_symbols
    for t in trig:  # a difference term needs its per-angle factors even if nothing else does
        if t.symbol in used:
            used |= set(t.depends)
    trig_used = [t for t in trig if t.symbol in used]

    names: dict[sp.Symbol, str] = {t.symbol: t.symbol.name for t in trig}
    names.update({s: s.name for s, _ in temporaries})
    body = FunctionBody()
    for group, cpp in ((sym.m, "p.m"), (sym.l, "p.l"), (sym.delta, "p.delta")):
        for k, s in enumerate(group):
            names[s] = s.name
            if s in used:
                body.prelude.append(f"const Scalar {s.name} = {cpp}[{k}];")
    names[sym.g] = "g"
    if sym.g in used:
        body.prelude.append("const Scalar g = p.g;")
    for k, s in enumerate(sym.qd):
        names[s] = f"dq{k}"
        if s in used:
            body.prelude.append(f"const Scalar dq{k} = qd({k});")
    for k, s in enumerate(sym.q):
        names[s] = f"q({k})"
    names[sym.u] = "u"
    body.prelude += [t.cpp for t in trig_used]

    printer = CppPrinter(names)
    body.temporaries = [f"const Scalar {s.name} = {printer(v)};" for s, v in temporaries]
    body.outputs = [f"{target} = {printer(v)};" for (target, _), v in zip(targets, reduced, strict=True)]
    body.outputs += _mirror_lines(outputs)
    body.operations = count_operations([v for _, v in temporaries] + list(reduced))
    body.operations += 3 * sum(1 for t in trig_used if t.depends)  # cj*ck + sj*sk
    body.trig_calls = sum(1 for t in trig_used if not t.depends)

    needs = {
        "q": bool(used & set(sym.q)) or bool(trig_used),
        "qd": bool(used & set(sym.qd)),
        "p": bool(used & set(sym.parameters)),
        "u": sym.u in used,
    }
    body.unused_arguments = [a for a in arguments if not needs[a]]
    return body
