"""Prints expression-graph nodes (`cse.Graph`) as C++ for a templated `Scalar` type, or as C99
for the `IPGEN_SCALAR` macro (`CPrinter`, the same expressions with C casts).

Literals are cast to `Scalar` (`Scalar(1)/Scalar(3)`) so that the same code is exact in float
and double, powers are repeated products, a node that has a name (a temporary) is printed by
that name, and any other node is written out where it is used: a product inline, a sum in
parentheses inside a product and merged (with its signs) into an enclosing sum.

`Formula` records a short formula written for any arithmetic (`actuator.motor_terms`, the DC
motor's fold) as Python evaluates it, and `print_formula` prints it with the same literals,
operation for operation: the graph printers above reorder factors and terms, which is free for
the model's functions but would change the last bit of a formula whose Python floats the header
must reproduce.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from fractions import Fraction

from ipgen.codegen.cse import ADD, CONST, LEAF, MUL, Graph

EXACT_INTEGER = 2**53  # larger integers are neither exact in double nor always valid C constants


def literal(value: Fraction) -> str:
    """A rational constant in C++: `Scalar(1)/Scalar(3)`, or the nearest double `Scalar(0.1234...)`
    for a ratio of integers beyond 2^53 (folded parameters with many digits multiply up)."""
    if max(abs(value.numerator), value.denominator) > EXACT_INTEGER:
        return f"Scalar({float(value)!r})"
    if value.denominator == 1:
        return f"Scalar({value.numerator})"
    return f"Scalar({value.numerator})/Scalar({value.denominator})"


def c_literal(value: Fraction) -> str:
    """A rational constant in C99: integers cast to IPGEN_SCALAR, so that float mode stays float.

    A ratio of integers beyond 2^53 (folded parameters with many digits multiply up) is written as
    the nearest double instead, one floating constant cast to IPGEN_SCALAR."""
    if max(abs(value.numerator), value.denominator) > EXACT_INTEGER:
        return f"(IPGEN_SCALAR){float(value)!r}"
    if value.denominator == 1:
        return f"(IPGEN_SCALAR){value.numerator}"
    return f"(IPGEN_SCALAR){value.numerator}/(IPGEN_SCALAR){value.denominator}"


class CppPrinter:
    """Prints nodes of `graph`; `names` maps the nodes computed as temporaries to their names."""

    literal = staticmethod(literal)
    zero = "Scalar(0)"

    def __init__(self, graph: Graph, names: Mapping[int, str], leaf_order: Mapping[int, int]) -> None:
        self.graph = graph
        self.names = names
        self.leaf_order = leaf_order  # leaf node -> generator index (print order)

    def signed(self, sign: int, node: int) -> str:
        """The right-hand side for the value sign·node."""
        if node < 0:
            return self.zero
        if node not in self.names and self.graph.kind[node] == ADD:
            return self._sum({t: s * sign for t, s in self.graph.data[node].items()})
        text = self.definition(node) if node not in self.names else self.names[node]
        return f"-{self._factor(node, text)}" if sign < 0 else text

    def definition(self, node: int) -> str:
        """The node's own expression (for its temporary), its children by name or inline."""
        kind = self.graph.kind[node]
        if kind == MUL:
            return self._product(node)
        if kind == ADD:
            return self._sum(self.graph.data[node])
        return self._atom(node)

    def _atom(self, node: int) -> str:
        kind = self.graph.kind[node]
        if kind == LEAF:
            return self.graph.data[node]
        if kind == CONST:
            return self.literal(self.graph.data[node])
        return self.names[node]

    def _reference(self, node: int) -> str:
        if node in self.names or self.graph.kind[node] in (LEAF, CONST):
            return self._atom(node)
        return self.definition(node)

    def _factor(self, node: int, text: str) -> str:
        """`text` (node's printed form) as a factor of a product: sums in parentheses."""
        if node not in self.names and self.graph.kind[node] == ADD:
            return f"({text})"
        return text

    def _sort_key(self, node: int) -> tuple[int, int]:
        if node in self.names:
            return (1, int(self.names[node][1:]))
        kind = self.graph.kind[node]
        if kind == CONST:
            return (0, 0)
        if kind == LEAF:
            return (2, self.leaf_order[node])
        return (3 if kind == MUL else 4, node)

    def _product(self, node: int) -> str:
        """Factors of the product and of its inline sub-products, constants merged and first."""
        constant = Fraction(1)
        factors: list[int] = []
        pending = list(self.graph.data[node])
        while pending:
            f = pending.pop()
            kind = self.graph.kind[f]
            if kind == CONST:
                constant *= self.graph.data[f]
            elif kind == MUL and f not in self.names:
                pending.extend(self.graph.data[f])
            else:
                factors.append(f)
        factors.sort(key=self._sort_key)
        printed = [self._factor(f, self._reference(f)) for f in factors]
        if constant != 1 or not printed:
            printed.insert(0, self.literal(constant))
        return "*".join(printed)

    def _sum(self, terms: Mapping[int, int]) -> str:
        flat: list[tuple[int, int]] = []
        self._flatten(terms, 1, flat)
        flat.sort(key=lambda item: (item[1] < 0, self._sort_key(item[0])))
        text = ""
        for node, sign in flat:
            body = self._reference(node)
            if not text:
                text = f"-{self._factor(node, body)}" if sign < 0 else body
            else:
                text += f" - {body}" if sign < 0 else f" + {body}"
        return text

    def _flatten(self, terms: Mapping[int, int], sign: int, out: list[tuple[int, int]]) -> None:
        """Terms of a sum, with the terms of inline sub-sums merged in (signs multiplied)."""
        for node, s in terms.items():
            if node not in self.names and self.graph.kind[node] == ADD:
                self._flatten(self.graph.data[node], sign * s, out)
            else:
                out.append((node, sign * s))


class CPrinter(CppPrinter):
    """The same expressions as `CppPrinter`, spelled in C99 for the scalar type `IPGEN_SCALAR`."""

    literal = staticmethod(c_literal)
    zero = "(IPGEN_SCALAR)0"


@dataclass(frozen=True)
class Formula:
    """A formula recorded as Python computes it: leaves, rational constants, +, * and /.

    A function written for any arithmetic (floats, Fractions, sympy: `actuator.motor_terms`) run
    on leaves returns its expression with every operation and its grouping as Python performs
    them, for `print_formula`. Equal formulas (same operations on the same leaves) compare equal.

    Parameters
    ----------
    operator : {"leaf", "const", "+", "*", "/"}
        What the node is: a named leaf, a constant or a binary operation.
    args : tuple of Formula
        The operands (two for a binary operation, none otherwise).
    name : str
        A leaf's spelling in the printed code (``motor->Rm``, ``Rm``).
    value : Fraction
        A constant's value.

    Examples
    --------
    >>> kt, rm = Formula.leaf("kt"), Formula.leaf("Rm")
    >>> print_formula(2 * kt / (rm * rm), c_literal)
    '(IPGEN_SCALAR)2*kt/(Rm*Rm)'
    """

    operator: str
    args: tuple[Formula, ...] = ()
    name: str = ""
    value: Fraction = Fraction(0)

    @staticmethod
    def leaf(name: str) -> Formula:
        """The leaf spelled `name` in the printed code."""
        return Formula("leaf", name=name)

    @staticmethod
    def _of(value: object) -> Formula | None:
        """`value` as a Formula: itself, or an int or Fraction as a constant (None otherwise)."""
        if isinstance(value, Formula):
            return value
        if isinstance(value, int | Fraction):
            return Formula("const", value=Fraction(value))
        return None

    def _binary(self, operator: str, left: object, right: object) -> Formula:
        a, b = Formula._of(left), Formula._of(right)
        if a is None or b is None:
            return NotImplemented
        return Formula(operator, (a, b))

    def __add__(self, other: object) -> Formula:
        return self._binary("+", self, other)

    def __radd__(self, other: object) -> Formula:
        return self._binary("+", other, self)

    def __mul__(self, other: object) -> Formula:
        return self._binary("*", self, other)

    def __rmul__(self, other: object) -> Formula:
        return self._binary("*", other, self)

    def __truediv__(self, other: object) -> Formula:
        return self._binary("/", self, other)

    def __rtruediv__(self, other: object) -> Formula:
        return self._binary("/", other, self)

    def __pow__(self, exponent: object) -> Formula:
        """Refused: libm's pow rounds differently from any product now and then, so a power in
        Python floats has no C expression that gives its bits everywhere; write x * x."""
        raise TypeError(f"a Formula has no powers (x**{exponent}): write the product (x * x)")


_BINDS = {"+": 0, "*": 1, "/": 1}  # how tightly an operator binds (C's precedence, left-associative)


def print_formula(
    formula: Formula,
    literal: Callable[[Fraction], str],
    names: Mapping[Formula, str] | None = None,
    readable: bool = False,
) -> str:
    """`formula` as a C or C++ expression that computes it operation for operation as Python did.

    Parameters
    ----------
    formula : Formula
        The recorded formula.
    literal : callable
        Prints a constant: `c_literal` (C99), `literal` (C++ `Scalar`), or `double_literal`.
    names : mapping, optional
        Sub-formulas printed by a name instead (a call to the function that computes them).
    readable : bool
        The notation of a comment instead: products as spaces, a product of two equal factors as
        a square ``x^2``, constants as plain numbers (``b Kg km / r``).

    Returns
    -------
    str
        Parentheses only where the grouping needs them: ``a*b/c*d`` is ((a*b)/c)*d.

    Examples
    --------
    >>> a, b, c = Formula.leaf("a"), Formula.leaf("b"), Formula.leaf("c")
    >>> print_formula(a * (b * c) / (c * c), c_literal)
    'a*(b*c)/(c*c)'
    >>> print_formula(a * (b * c) / (c * c), c_literal, {b * c: "bc()"}, readable=True)
    'a bc() / c^2'
    """
    names = names or {}

    def square(node: Formula) -> bool:  # x^2 in a comment
        return readable and node.operator == "*" and node.args[0] == node.args[1]

    def operand(node: Formula, right: bool, binds: int) -> str:
        text = show(node)
        inner = None if node in names or square(node) else _BINDS.get(node.operator)
        if inner is not None and (inner < binds or (right and inner == binds)):
            return f"({text})"
        return text

    def show(node: Formula) -> str:
        if node in names:
            return names[node]
        if node.operator == "leaf":
            return node.name
        if node.operator == "const":
            return str(node.value) if readable else literal(node.value)
        if square(node):
            return f"{operand(node.args[0], True, 2)}^2"
        left, right = node.args
        binds = _BINDS[node.operator]
        spelled = f" {node.operator} " if readable or node.operator == "+" else node.operator  # as CppPrinter
        if readable and node.operator == "*":
            spelled = " "
        return f"{operand(left, False, binds)}{spelled}{operand(right, True, binds)}"

    return show(formula)


def double_literal(value: Fraction) -> str:
    """A rational constant in C++ `double` code (outside the `Scalar` templates): `double(1)/double(3)`."""
    if value.denominator == 1:
        return f"double({value.numerator})"
    return f"double({value.numerator})/double({value.denominator})"
