"""Turns the derived polynomials into the bodies of the header's C++ functions.

For each function: its outputs are written in the trig letters of `polynomial.Algebra`
(sin/cos of each angle computed once; cos(θj − θk) = cj ck + sj sk from them), common
subexpressions are shared over all its outputs (`cse.py`: M and the bias share temporaries in
`forward_dynamics`), and the result is printed as C++ statements (`printer.py`).
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import dataclass, field

from ipgen.codegen.cse import ADD, LEAF, MUL, Graph, Signed
from ipgen.codegen.printer import CppPrinter
from ipgen.derive import Equations, PolyMatrix
from ipgen.model import split_parameter
from ipgen.polynomial import ACCELERATION, LETTER, PARAMETER, VELOCITY, Algebra, Generator, Poly


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


def _trig_definition(letter: Generator) -> tuple[str, tuple[str, ...]]:
    """C++ definition of a trig letter, and the letters it is built from."""
    if len(letter.angles) == 1:
        (k,) = letter.angles
        return f"const Scalar {letter.name} = {'sin' if letter.group == 's' else 'cos'}(q({k}));", ()
    j, k = letter.angles
    if letter.group == "C":
        value, what = f"c{j}*c{k} + s{j}*s{k}", "cos"
    else:
        value, what = f"s{j}*c{k} - c{j}*s{k}", "sin"
    return f"const Scalar {letter.name} = {value};  // {what}(θ{j} − θ{k})", (
        f"s{j}",
        f"c{j}",
        f"s{k}",
        f"c{k}",
    )


def _targets(outputs: Sequence[Output]) -> list[tuple[str, Poly]]:
    """(C++ target, polynomial) for every entry that must be computed."""
    targets: list[tuple[str, Poly]] = []
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


class _Leaves(dict[int, int]):
    """{generator: graph leaf}, the leaves made on first use; `generator` maps them back."""

    def __init__(self, graph: Graph, algebra: Algebra) -> None:
        super().__init__()
        self.graph = graph
        self.algebra = algebra
        self.generator: dict[int, int] = {}  # leaf -> generator

    def __missing__(self, g: int) -> int:
        node = self[g] = self.graph.leaf(self.algebra.generators[g].name)
        self.generator[node] = g
        return node


def _expression(algebra: Algebra, p: Poly) -> str:
    """p printed on its own, without shared subexpressions (named quantities' definitions)."""
    graph = Graph()
    leaves = _Leaves(graph, algebra)
    sign, node = graph.polynomial(p, leaves, algebra.n_parameters)
    return CppPrinter(graph, {}, leaves.generator).signed(sign, node)


def params_field(name: str) -> str:
    """C++ access to parameter `name` in a Params p: m1 -> p.m[1], g -> p.g."""
    group, index = split_parameter(name)
    return f"p.{group}" if index is None else f"p.{group}[{index}]"


def _schedule(
    graph: Graph, roots: Sequence[Signed], order: list[int], late: set[int]
) -> tuple[list[int], list[int]]:
    """Nodes computed as temporaries (used twice or more), in emission order: those before θ̈
    is known, then those that need it (`late`). A temporary comes after everything it uses.
    `order` is every node reachable from `roots`."""
    uses: dict[int, int] = {}
    for _, root in roots:
        uses[root] = uses.get(root, 0) + 1
    for node in order:
        for child in graph.children(node):
            uses[child] = uses.get(child, 0) + 1
    early_roots = [r for _, r in roots if r not in late]
    late_roots = [r for _, r in roots if r in late]
    early: list[int] = []
    later: list[int] = []
    for node in graph.reachable([*early_roots, *late_roots]):
        if uses[node] > 1 and graph.kind[node] in (MUL, ADD):
            (later if node in late else early).append(node)
    return early, later


def build_body(
    eqs: Equations, outputs: Sequence[Output], arguments: Sequence[str], late_source: str = ""
) -> FunctionBody:
    """Statements computing `outputs`; `arguments` are the C++ parameter names (q, qd, p).

    Outputs may use θ̈: with `late_source` (a C++ vector holding it), the statements that need
    it (transitively) are kept apart as the body's `late_*` part, and all others come first.
    """
    algebra = eqs.algebra
    generators = algebra.generators
    targets = _targets(outputs)
    graph = Graph()
    leaves = _Leaves(graph, algebra)
    roots = [graph.polynomial(p, leaves, algebra.n_parameters) for _, p in targets]
    graph.share_products(r for _, r in roots)
    graph.share_sums(r for _, r in roots)
    roots = graph.canonical(roots)

    reachable = graph.reachable(r for _, r in roots)
    used = {leaves.generator[v] for v in reachable if graph.kind[v] == LEAF}
    late = {leaves[g] for g in used if generators[g].kind == ACCELERATION}
    if late and not late_source:
        raise ValueError("outputs use accelerations but no late_source names them")
    for node in reachable:  # children first
        if any(child in late for child in graph.children(node)):
            late.add(node)
    early, later = _schedule(graph, roots, reachable, late)
    names = {node: f"t{i}" for i, node in enumerate([*early, *later])}
    printer = CppPrinter(graph, names, leaves.generator)

    # Named quantities used, with what their definitions use (later ones build on earlier).
    for g in sorted(algebra.named, reverse=True):
        if g in used:
            used |= algebra.used(algebra.named[g])
    letters = [g for g in sorted(used) if generators[g].kind == LETTER]
    definitions = {generators[g].name: _trig_definition(generators[g]) for g in letters}
    needed = {part for _, parts in definitions.values() for part in parts}
    for name in needed - definitions.keys():
        definitions[name] = _trig_definition(generators[algebra.index(name)])
    # per-angle sin/cos first (in angle order), then differences
    trig = sorted(definitions.items(), key=lambda item: _letter_key(generators[algebra.index(item[0])]))

    body = FunctionBody()
    for g in sorted(used):
        info = generators[g]
        if info.kind == PARAMETER:
            body.prelude.append(f"const Scalar {info.name} = {params_field(info.name)};")
        elif info.kind == VELOCITY:
            body.prelude.append(f"const Scalar {info.name} = qd({info.index});")
        elif info.kind == ACCELERATION:
            body.late_prelude.append(f"const Scalar {info.name} = {late_source}({info.index});")
    body.prelude += [definition for _, (definition, _) in trig]
    body.prelude += [
        f"const Scalar {generators[g].name} = {_expression(algebra, algebra.named[g])};"
        for g in sorted(algebra.named)
        if g in used
    ]

    body.temporaries = [f"const Scalar {names[v]} = {printer.definition(v)};" for v in early]
    body.late_temporaries = [f"const Scalar {names[v]} = {printer.definition(v)};" for v in later]
    for (target, _), (sign, node) in zip(targets, roots, strict=True):
        statement = f"{target} = {printer.signed(sign, node)};"
        (body.late_outputs if node in late else body.outputs).append(statement)
    body.outputs += _mirror_lines(outputs)
    computed = [*body.prelude, *body.temporaries, *body.outputs, *body.late_temporaries, *body.late_outputs]
    body.operations = sum(count_operations(line) for line in computed)
    body.trig_calls = sum(1 for _, (_, parts) in trig if not parts)

    needs = {
        "q": bool(trig),
        "qd": any(generators[g].kind == VELOCITY for g in used),
        "p": any(generators[g].kind == PARAMETER for g in used),
    }
    body.unused_arguments = [a for a in arguments if not needs[a]]
    return body


def _letter_key(letter: Generator) -> tuple[int, ...]:
    """sin/cos of single angles first, then differences; sin before cos."""
    j, k = (*letter.angles, 0)[:2]
    return (len(letter.angles) > 1, j, k, letter.group.lower() == "c")


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
