"""Turns the derived polynomials into the bodies of the header's C++ (or C99) functions.

For each function: its outputs are written in the trig letters of `polynomial.Algebra`
(sin/cos of each angle computed once; cos(θj − θk) = cj ck + sj sk from them), common
subexpressions are shared over all its outputs (`cse.py`: M and the bias share temporaries in
`forward_dynamics`), and the result is printed as C++ statements (`printer.py`), or as C99
ones with `syntax=C_SYNTAX` (the same graph and the same CSE, only the spelling differs).
Outputs that hold generalised forces (`Output.damped`: the bias, ∂D/∂θ̇) take their Rayleigh
damping as the joint torques r_i = δ_i ω_i (`bodies.joint_rates`), each computed once, rather
than from the expanded δ θ̇ terms: +r_i on the body a joint turns, −r_{i+1} from the next one;
the Rayleigh function itself (`Output.rayleigh`) as ½ Σ δ_i ω_i ω_i, each ω_i computed once.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import dataclass, field

from ipgen.codegen.cse import ADD, CONST, LEAF, MUL, Graph, Signed
from ipgen.codegen.printer import CppPrinter, CPrinter
from ipgen.model.bodies import joint_rates, named_meaning, rod_defaults
from ipgen.model.derivation import Equations, PolyMatrix
from ipgen.model.polynomial import ACCELERATION, LETTER, PARAMETER, VELOCITY, Algebra, Generator, Poly
from ipgen.model.system import LINK_GROUPS, split_parameter


@dataclass(frozen=True)
class Syntax:
    """How one target language spells a function body's statements (`CPP_SYNTAX`, `C_SYNTAX`)."""

    scalar: str  # the scalar type: Scalar (a C++ template parameter) or IPGEN_SCALAR (a C macro)
    printer: type[CppPrinter]
    index: str  # element i of a vector argument: "{name}({i})" or "{name}[{i}]"
    params: str  # the parameter struct: "p." (a C++ reference) or "p->" (a C pointer)
    c_arrays: bool  # matrices as flat row-major arrays M[r*dof + c] instead of M(r, c)
    sin: str = "sin"  # the sine and cosine functions of the scalar type
    cos: str = "cos"
    # The links as built (com, J, J_axial, tip): where they are read ("p." in Params, C: the
    # `links` pointer), which groups fall back to the rod default, and when an entry is given.
    links: str = "p."
    resolved: tuple[str, ...] = ("com", "J")  # tip and J_axial: Params zero-initialises them
    given: str = "detail::given({field})"
    extra_arguments: tuple[str, ...] = ()  # arguments besides q, qd, p (C: links)
    comment: str = "// {text}"
    literal: str = "Scalar({value})"  # an integer constant of the scalar type
    # What a generator's index is less than its entry's in the printed arrays (q, qd, Params): 0,
    # or 1 for a fixed-pivot chain printed from the cart's links block (link i, generators m_i,
    # s_i, dq_i, is entry i − 1: there is no base).
    offset: int = 0

    def element(self, name: str, r: int, c: int, rows: int, cols: int) -> str:
        """Entry (r, c) of the output matrix `name` (a vector when cols == 1)."""
        if cols == 1:
            return self.index.format(name=name, i=r)
        if self.c_arrays:
            return f"{name}[{r}*{cols} + {c}]"
        return f"{name}({r}, {c})"


CPP_SYNTAX = Syntax("Scalar", CppPrinter, "{name}({i})", "p.", c_arrays=False)
C_SYNTAX = Syntax(
    "IPGEN_SCALAR",
    CPrinter,
    "{name}[{i}]",
    "p->",
    c_arrays=True,
    sin="ipgen_sin",
    cos="ipgen_cos",
    links="links->",
    resolved=LINK_GROUPS,  # a null `links` pointer: every link a homogeneous rod
    given="links",
    extra_arguments=("links",),
    comment="/* {text} */",
    literal="(IPGEN_SCALAR){value}",
)


@dataclass(frozen=True)
class Output:
    """One returned quantity: a matrix of polynomials; 1×1 with `scalar` for a number."""

    name: str
    value: PolyMatrix
    scalar: bool = False
    symmetric: bool = False  # compute the upper triangle, mirror the rest
    lower_only: bool = False  # only the lower triangle is needed (Cholesky reads nothing else)
    # A vector of generalised forces whose entry k includes the damping force ∂D/∂θ̇_k (the bias,
    # ∂D/∂θ̇): that part is written with the joint torques r_i = δ_i ω_i (see the module docstring).
    damped: bool = False
    rayleigh: bool = False  # a scalar holding the Rayleigh function D: written as ½ Σ δ_i ω_i²


@dataclass
class FunctionBody:
    """Statements computing a function's outputs, with an operation count."""

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


def _trig_definition(letter: Generator, syntax: Syntax) -> tuple[str, tuple[str, ...]]:
    """Definition of a trig letter, and the letters it is built from."""
    if len(letter.angles) == 1:
        (k,) = letter.angles
        function = syntax.sin if letter.group == "s" else syntax.cos
        angle = syntax.index.format(name="q", i=k - syntax.offset)
        return f"const {syntax.scalar} {letter.name} = {function}({angle});", ()
    j, k = letter.angles
    if letter.group == "C":
        value, what = f"c{j}*c{k} + s{j}*s{k}", "cos"
    else:
        value, what = f"s{j}*c{k} - c{j}*s{k}", "sin"
    if not syntax.c_arrays:
        comment = f"// {what}(θ{j} − θ{k})"
    else:
        comment = f"/* {what}(q{j - syntax.offset} - q{k - syntax.offset}) */"
    return f"const {syntax.scalar} {letter.name} = {value};  {comment}", (
        f"s{j}",
        f"c{j}",
        f"s{k}",
        f"c{k}",
    )


def _targets(outputs: Sequence[Output], syntax: Syntax) -> list[tuple[str, Poly, int | None]]:
    """(target, polynomial, the coordinate whose damping force it includes or None) for every
    entry that must be computed."""
    targets: list[tuple[str, Poly, int | None]] = []
    for out in outputs:
        rows, cols = len(out.value), len(out.value[0])
        for r in range(rows):
            for c in range(cols):
                p = out.value[r][c]
                damped = r + syntax.offset if out.damped and cols == 1 and not out.scalar else None
                if out.scalar:
                    targets.append((out.name, p, RAYLEIGH if out.rayleigh else None))
                elif p and not ((out.symmetric and r > c) or (out.lower_only and r < c)):
                    targets.append((syntax.element(out.name, r, c, rows, cols), p, damped))
    return targets


RAYLEIGH = -1  # in place of a coordinate: the target is the Rayleigh function D itself


@dataclass(frozen=True)
class _Torque:
    """A joint torque r_i = δ_i ω_i of the Rayleigh damping (`bodies.joint_rates`) in a graph."""

    node: Signed  # r_i
    coefficient: Signed  # δ_i (folded where the algebra fixes it)
    rate: Signed  # ω_i
    poly: Poly  # r_i as a polynomial
    square: Poly  # δ_i ω_i², its part of 2 D
    acts: dict[int, int]  # {coordinate k: ∂ω_i/∂θ̇_k = ±1}: r_i enters the force on k with that sign


def _joint_torques(eqs: Equations, graph: Graph, leaves: _Leaves) -> list[_Torque]:
    """The joint torques δ_i·ω_i as graph nodes, δ_i folded where the algebra fixes it; dampers
    fixed at δ_i = 0 are left out."""
    algebra = eqs.algebra
    # The rates' leaves from the last coordinate down, so that a sum's normal form (its first
    # node positive) is ω_i = θ̇_i − θ̇_{i−1}: r_i then enters coordinate i's force with a plus
    # (which never leaves a force with only negative terms, whose negation would cost one more).
    for k in reversed(range(eqs.system.dof)):
        leaves[algebra.qd(k)]  # made on first use
    torques = []
    for i, rate in enumerate(joint_rates(eqs.system)):
        coefficient = algebra.substitute(algebra.delta(i), algebra.fixed)
        if coefficient.is_zero():
            continue
        c_sign, c_node = graph.polynomial(coefficient, leaves, algebra.n_parameters)
        r_sign, r_node = graph.add({leaves[algebra.qd(k)]: s for k, s in rate.items()})
        omega = algebra.total(s * algebra.gens[algebra.qd(k)] for k, s in rate.items())
        unit = graph.kind[c_node] == CONST and graph.data[c_node] == 1  # δ_i folded to 1
        node = r_node if unit else graph.mul((c_node, r_node))
        torques.append(
            _Torque(
                (c_sign * r_sign, node),
                (c_sign, c_node),
                (r_sign, r_node),
                coefficient * omega,
                coefficient * omega * omega,
                rate,
            )
        )
    return torques


def _with_terms(
    eqs: Equations, graph: Graph, leaves: _Leaves, p: Poly, rest: Poly, extra: dict[int, int]
) -> Signed:
    """p as the graph of `rest` plus the signed nodes `extra` (whose sum is p − rest); p whole if
    the rest already has one of those nodes."""
    n_parameters = eqs.algebra.n_parameters
    sign, node = graph.polynomial(rest, leaves, n_parameters)
    if node < 0:
        terms: dict[int, int] = {}
    elif graph.kind[node] == ADD:
        terms = {t: sign * s for t, s in graph.data[node].items()}
    else:
        terms = {node: sign}
    if terms.keys() & extra.keys():
        return graph.polynomial(p, leaves, n_parameters)
    return graph.add({**terms, **extra})


def _damped_root(
    eqs: Equations, graph: Graph, leaves: _Leaves, p: Poly, k: int, torques: list[_Torque]
) -> Signed:
    """p, the generalised force on coordinate k including its damping force Σ_i r_i ∂ω_i/∂θ̇_k,
    as the graph of (p − that force) plus the joint torques' nodes: exact, since the force is
    subtracted and added back as the same polynomial."""
    acting = [t for t in torques if k in t.acts]
    force = eqs.algebra.total(t.acts[k] * t.poly for t in acting)
    extra: dict[int, int] = {}
    for t in acting:
        if t.node[1] in extra:
            return graph.polynomial(p, leaves, eqs.algebra.n_parameters)
        extra[t.node[1]] = t.node[0] * t.acts[k]
    return _with_terms(eqs, graph, leaves, p, p - force, extra)


def _rayleigh_root(eqs: Equations, graph: Graph, leaves: _Leaves, p: Poly, torques: list[_Torque]) -> Signed:
    """p, the Rayleigh function D = ½ Σ_i δ_i ω_i², as ½ (Σ_i δ_i ω_i ω_i) with each joint rate
    computed once, plus the graph of whatever else p holds (p − D: nothing)."""
    if not torques:
        return graph.polynomial(p, leaves, eqs.algebra.n_parameters)
    squares: dict[int, int] = {}
    for t in torques:
        (c_sign, c_node), (_, r_node) = t.coefficient, t.rate
        unit = graph.kind[c_node] == CONST and graph.data[c_node] == 1
        squares[graph.mul((r_node, r_node) if unit else (c_node, r_node, r_node))] = c_sign
    sign, total = graph.add(squares)
    half = graph.mul((graph.const(1, 2), total))
    rayleigh = eqs.algebra.total(t.square for t in torques) / 2
    return _with_terms(eqs, graph, leaves, p, p - rayleigh, {half: sign})


def _mirror_lines(outputs: Sequence[Output], syntax: Syntax) -> list[str]:
    """Copies completing symmetric matrices from their computed upper triangle."""
    lines = []
    for out in outputs:
        if out.symmetric:
            n = len(out.value)
            for r, row in enumerate(out.value):
                lines += [
                    f"{syntax.element(out.name, r, c, n, n)} = {syntax.element(out.name, c, r, n, n)};"
                    for c in range(r)
                    if row[c]
                ]
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


def _expression(algebra: Algebra, p: Poly, syntax: Syntax) -> str:
    """p printed on its own, without shared subexpressions (named quantities' definitions)."""
    graph = Graph()
    leaves = _Leaves(graph, algebra)
    sign, node = graph.polynomial(p, leaves, algebra.n_parameters)
    return syntax.printer(graph, {}, leaves.generator).signed(sign, node)


def params_field(name: str, syntax: Syntax = CPP_SYNTAX) -> str:
    """Access to parameter `name`: m1 -> p.m[1] (C: p->m[1]), g -> p.g, com1 -> p.com[1] (C:
    links->com[1])."""
    group, index = split_parameter(name)
    where = syntax.links if group in LINK_GROUPS else syntax.params
    return f"{where}{group}" if index is None else f"{where}{group}[{index - syntax.offset}]"


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
    eqs: Equations,
    outputs: Sequence[Output],
    arguments: Sequence[str],
    late_source: str = "",
    syntax: Syntax = CPP_SYNTAX,
) -> FunctionBody:
    """Statements computing `outputs`; `arguments` are the function's parameter names (q, qd, p).

    Outputs may use θ̈: with `late_source` (a vector holding it), the statements that need it
    (transitively) are kept apart as the body's `late_*` part, and all others come first.
    `syntax` chooses the language (C++ by default); the expressions are the same in both.
    """
    algebra = eqs.algebra
    generators = algebra.generators
    targets = _targets(outputs, syntax)
    graph = Graph()
    leaves = _Leaves(graph, algebra)
    torques = _joint_torques(eqs, graph, leaves) if any(k is not None for *_, k in targets) else []
    roots = [
        graph.polynomial(p, leaves, algebra.n_parameters)
        if k is None
        else _rayleigh_root(eqs, graph, leaves, p, torques)
        if k == RAYLEIGH
        else _damped_root(eqs, graph, leaves, p, k, torques)
        for _, p, k in targets
    ]
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
    printer = syntax.printer(graph, names, leaves.generator)

    # Named quantities used, with what their definitions use (later ones build on earlier).
    for g in sorted(algebra.named, reverse=True):
        if g in used:
            used |= algebra.used(algebra.named[g])
    letters = [g for g in sorted(used) if generators[g].kind == LETTER]
    definitions = {generators[g].name: _trig_definition(generators[g], syntax) for g in letters}
    needed = {part for _, parts in definitions.values() for part in parts}
    for name in needed - definitions.keys():
        definitions[name] = _trig_definition(generators[algebra.index(name)], syntax)
    # per-angle sin/cos first (in angle order), then differences
    trig = sorted(definitions.items(), key=lambda item: _letter_key(generators[algebra.index(item[0])]))

    defaults = _resolution(eqs, used, syntax)
    for g in list(defaults):
        used |= algebra.used(defaults[g])

    body = FunctionBody()
    const = f"const {syntax.scalar}"
    for g in sorted(used):
        info = generators[g]
        if info.kind == PARAMETER:
            field = params_field(info.name, syntax)
            if g in defaults:
                rod = syntax.literal.format(value=0)
                if defaults[g]:
                    rod = _expression(algebra, defaults[g], syntax)
                field = f"{syntax.given.format(field=field)} ? {field} : {rod}"
            body.prelude.append(f"{const} {info.name} = {field};")
        elif info.kind == VELOCITY:
            rate = syntax.index.format(name="qd", i=info.index - syntax.offset)
            body.prelude.append(f"{const} {info.name} = {rate};")
        elif info.kind == ACCELERATION:
            solved = syntax.index.format(name=late_source, i=info.index - syntax.offset)
            body.late_prelude.append(f"{const} {info.name} = {solved};")
    body.prelude += [definition for _, (definition, _) in trig]
    body.prelude += [
        f"{const} {generators[g].name} = {_expression(algebra, algebra.named[g], syntax)};  "
        + syntax.comment.format(text=named_meaning(generators[g].name))
        for g in sorted(algebra.named)
        if g in used
    ]

    body.temporaries = [f"{const} {names[v]} = {printer.definition(v)};" for v in early]
    body.late_temporaries = [f"{const} {names[v]} = {printer.definition(v)};" for v in later]
    for (target, *_), (sign, node) in zip(targets, roots, strict=True):
        statement = f"{target} = {printer.signed(sign, node)};"
        (body.late_outputs if node in late else body.outputs).append(statement)
    body.outputs += _mirror_lines(outputs, syntax)
    computed = [*body.prelude, *body.temporaries, *body.outputs, *body.late_temporaries, *body.late_outputs]
    body.operations = sum(count_operations(line) for line in computed)
    body.trig_calls = sum(1 for _, (_, parts) in trig if not parts)

    parameters = [generators[g] for g in used if generators[g].kind == PARAMETER]
    needs = {
        "q": bool(trig),
        "qd": any(generators[g].kind == VELOCITY for g in used),
        "p": any(info.group not in LINK_GROUPS for info in parameters),
        "links": any(info.group in LINK_GROUPS for info in parameters),
    }
    body.unused_arguments = [a for a in arguments if not needs[a]]
    return body


def _resolution(eqs: Equations, used: set[int], syntax: Syntax) -> dict[int, Poly]:
    """{generator in `used` of a group `syntax` resolves: its rod default}, the folded
    parameters substituted: the value an entry left unset (C++: a NaN com or J; C: no links
    struct) stands for."""
    algebra = eqs.algebra
    defaults = {}
    for g, value in rod_defaults(eqs.system, algebra).items():
        if g in used and algebra.generators[g].group in syntax.resolved:
            defaults[g] = algebra.substitute(value, algebra.fixed)
    return defaults


def _letter_key(letter: Generator) -> tuple[int, ...]:
    """sin/cos of single angles first, then differences; sin before cos."""
    j, k = (*letter.angles, 0)[:2]
    return (len(letter.angles) > 1, j, k, letter.group.lower() == "c")


_OPERATOR = re.compile(r"(?<=[\w)])\s*[-+*/]\s*(?=[\w(])|(?<![\w)])-(?=[\w(])")


def count_operations(statement: str) -> int:
    """Arithmetic operations (+, −, ×, ÷, negation) on the right-hand side of a C++ or C statement.

    A conditional `c ? x : y` counts the operations of c and of its costlier branch. Literal
    casts such as `Scalar(1)/Scalar(3)` (C: `(IPGEN_SCALAR)1/(IPGEN_SCALAR)3`) are folded
    by the compiler and not counted.
    """
    if "=" not in statement:
        return 0
    right = statement.split("=", 1)[1].split("//", 1)[0].split("/*", 1)[0]
    condition, query, branches = right.partition(" ? ")
    if query:  # `given ? value : default`: one branch runs
        given, _, default = branches.partition(" : ")
        return _count(condition) + max(_count(given), _count(default))
    return _count(right)


_CPP_RATIO = re.compile(r"Scalar\(\d+\)/Scalar\(\d+\)")
_C_RATIO = re.compile(r"\(IPGEN_SCALAR\)\d+/\(IPGEN_SCALAR\)\d+")
_C_CAST = re.compile(r"\(IPGEN_SCALAR\)(\d+)")
_TRIG_CALL = re.compile(r"\b(ipgen_)?(sin|cos)\(q(\(\d+\)|\[\d+\])\)")


def _count(right: str) -> int:
    """Arithmetic operations in the expression `right` (see `count_operations`). Each rewrite
    runs only where its text occurs (the same result, for generation time: every statement of
    every header is counted)."""
    if "Scalar(" in right:
        right = _CPP_RATIO.sub("1", right)
    if "(IPGEN_SCALAR)" in right:
        right = _C_CAST.sub(r"\1", _C_RATIO.sub("1", right))
    if "(q" in right:
        right = _TRIG_CALL.sub("x", right)
    return len(_OPERATOR.findall(right))
