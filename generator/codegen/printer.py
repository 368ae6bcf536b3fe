"""Prints expression-graph nodes (`cse.Graph`) as C++ for a templated `Scalar` type, or as C99
for the `IPGEN_SCALAR` macro (`CPrinter`, the same expressions with C casts).

Literals are cast to `Scalar` (`Scalar(1)/Scalar(3)`) so that the same code is exact in float
and double, powers are repeated products, a node that has a name (a temporary) is printed by
that name, and any other node is written out where it is used: a product inline, a sum in
parentheses inside a product and merged (with its signs) into an enclosing sum.
"""

from __future__ import annotations

from collections.abc import Mapping
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
