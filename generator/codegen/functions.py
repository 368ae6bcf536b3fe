"""Turns the derived polynomials into the bodies of the header's C++ functions.

For each function: its outputs are written in the trig letters of `polynomial.Algebra`
(sin/cos of each angle computed once; cos(θj − θk) = cj ck + sj sk from them), common
subexpressions are shared by one `sympy.cse` over all its outputs (M and the bias share
temporaries in `forward_dynamics`), and the result is printed as C++ statements.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import dataclass, field

import sympy as sp
from sympy.polys.rings import PolyElement

from generator.codegen.printer import CppPrinter
from generator.derive import Equations, PolyMatrix


@dataclass(frozen=True)
class Output:
    """One returned quantity: a matrix of polynomials; 1×1 with `scalar` for a number."""

    name: str
    value: PolyMatrix
    scalar: bool = False
    symmetric: bool = False  # compute the upper triangle, mirror the rest
    lower_only: bool = False  # only the lower triangle is needed (Cholesky reads nothing else)


@dataclass
class FunctionBody:
    """C++ statements computing a function's outputs, with an operation count."""

    prelude: list[str] = field(default_factory=list)  # parameter, velocity and trig bindings
    temporaries: list[str] = field(default_factory=list)
    outputs: list[str] = field(default_factory=list)
    # Statements that need θ̈ (bound from `late_source`), emitted after it has been solved for.
    late_prelude: list[str] = field(default_factory=list)
    late_temporaries: list[str] = field(default_factory=list)
    late_outputs: list[str] = field(default_factory=list)
    unused_arguments: list[str] = field(default_factory=list)
    operations: int = 0  # additions, multiplications, divisions after CSE
    trig_calls: int = 0  # sin/cos evaluations


_LETTER = re.compile(r"([scCS])(\d+)(?:_(\d+))?\Z")


def _trig_definition(letter: sp.Symbol) -> tuple[str, tuple[str, ...]]:
    """C++ definition of a trig letter, and the letters it is built from."""
    kind, j, k = _LETTER.match(letter.name).groups()  # type: ignore[union-attr]
    name = _cpp_name(letter)
    if k is None:
        return f"const Scalar {name} = {'sin' if kind == 's' else 'cos'}(q({j}));", ()
    if kind == "C":
        value, what = f"c{j}*c{k} + s{j}*s{k}", "cos"
    else:
        value, what = f"s{j}*c{k} - c{j}*s{k}", "sin"
    return f"const Scalar {name} = {value};  // {what}(θ{j} − θ{k})", (f"s{j}", f"c{j}", f"s{k}", f"c{k}")


def _cpp_name(letter: sp.Symbol) -> str:
    return letter.name.lower()  # C1_2 -> c1_2: cos(θ1 − θ2); S1_2 -> s1_2


def _targets(outputs: Sequence[Output]) -> list[tuple[str, PolyElement]]:
    """(C++ target, polynomial) for every entry that must be computed."""
    targets: list[tuple[str, PolyElement]] = []
    for out in outputs:
        rows, cols = len(out.value), len(out.value[0])
        for r in range(rows):
            for c in range(cols):
                p = out.value[r][c]
                if out.scalar:
                    targets.append((out.name, p))
                elif p and not ((out.symmetric and r > c) or (out.lower_only and r < c)):
                    targets.append((f"{out.name}({r})" if cols == 1 else f"{out.name}({r}, {c})", p))
    return targets


def _mirror_lines(outputs: Sequence[Output]) -> list[str]:
    """Copies completing symmetric matrices from their computed upper triangle."""
    lines = []
    for out in outputs:
        if out.symmetric:
            for r, row in enumerate(out.value):
                lines += [f"{out.name}({r}, {c}) = {out.name}({c}, {r});" for c in range(r) if row[c]]
    return lines


def build_body(
    eqs: Equations, outputs: Sequence[Output], arguments: Sequence[str], late_source: str = ""
) -> FunctionBody:
    """Statements computing `outputs`; `arguments` are the C++ parameter names (q, qd, p).

    Outputs may use θ̈: with `late_source` (a C++ vector holding it), the statements that need
    it (transitively) are kept apart as the body's `late_*` part, and all others come first.
    """
    sym, algebra = eqs.symbols, eqs.algebra
    targets = _targets(outputs)
    exprs = [algebra.to_expr(p, letters=True) for _, p in targets]
    temporaries, reduced = sp.cse(exprs, symbols=sp.numbered_symbols("t"))

    used: set[sp.Symbol] = set()
    for expr in [*reduced, *(v for _, v in temporaries)]:
        used |= expr.free_symbols
    # Named quantities used, with what their definitions use (later ones build on earlier).
    named_code = {s: algebra.to_expr(p, letters=True) for s, p in algebra.named.items()}
    for symbol in reversed(list(named_code)):
        if symbol in used:
            used |= named_code[symbol].free_symbols
    letters = [s for s in algebra.letters if s in used]
    definitions = {s.name: _trig_definition(s) for s in letters}
    needed = {part for _, parts in definitions.values() for part in parts}
    singles = [s for s in algebra.letters if s.name in needed and s.name not in definitions]
    definitions.update({s.name: _trig_definition(s) for s in singles})
    # per-angle sin/cos first (in angle order), then differences
    trig = sorted(definitions.items(), key=lambda item: (bool(item[1][1]), _sort_key(item[0])))

    names: dict[sp.Symbol, str] = {s: _cpp_name(s) for s in algebra.letters}
    names.update({s: s.name for s in named_code})
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
    body.prelude += [definition for _, (definition, _) in trig]

    late: set[sp.Symbol] = set()
    for k, s in enumerate(sym.qdd):
        names[s] = f"ddq{k}"
        if s in used:
            body.late_prelude.append(f"const Scalar ddq{k} = {late_source}({k});")
            late.add(s)
    if late and not late_source:
        raise ValueError("outputs use accelerations but no late_source names them")

    printer = CppPrinter(names)
    named_used = [s for s in named_code if s in used]
    body.prelude += [f"const Scalar {s.name} = {printer(named_code[s])};" for s in named_used]
    for symbol, value in temporaries:
        is_late = bool(value.free_symbols & late)
        if is_late:
            late.add(symbol)
        statement = f"const Scalar {symbol.name} = {printer(value)};"
        (body.late_temporaries if is_late else body.temporaries).append(statement)
    for (target, _), value in zip(targets, reduced, strict=True):
        statement = f"{target} = {printer(value)};"
        (body.late_outputs if value.free_symbols & late else body.outputs).append(statement)
    body.outputs += _mirror_lines(outputs)
    computed = [*body.prelude, *body.temporaries, *body.outputs, *body.late_temporaries, *body.late_outputs]
    body.operations = sum(count_operations(line) for line in computed)
    body.trig_calls = sum(1 for _, (_, parts) in trig if not parts)

    needs = {
        "q": bool(trig),
        "qd": bool(used & set(sym.qd)),
        "p": bool(used & set(sym.parameters)),
    }
    body.unused_arguments = [a for a in arguments if not needs[a]]
    return body


_OPERATOR = re.compile(r"(?<=[\w)])\s*[-+*/]\s*(?=[\w(])|(?<![\w)])-(?=[\w(])")


def count_operations(statement: str) -> int:
    """Arithmetic operations (+, −, ×, ÷, negation) on the right-hand side of a C++ statement.

    Literal casts such as `Scalar(1)/Scalar(3)` are folded by the compiler and not counted.
    """
    if "=" not in statement:
        return 0
    right = statement.split("=", 1)[1].split("//", 1)[0]
    right = re.sub(r"Scalar\(\d+\)/Scalar\(\d+\)", "1", right)
    right = re.sub(r"\b(sin|cos)\(q\(\d+\)\)", "x", right)
    return len(_OPERATOR.findall(right))


def _sort_key(name: str) -> tuple[int, ...]:
    kind, j, k = _LETTER.match(name).groups()  # type: ignore[union-attr]
    return (int(j), int(k or 0), kind.lower() == "c")
