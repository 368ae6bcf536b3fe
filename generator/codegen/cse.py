"""Common-subexpression elimination on the derived polynomials, and their C++ spelling.

A function's outputs become one graph of hash-consed nodes: leaves (generators, by their C++
name), positive rational constants, products (a multiset of factors) and sums (terms with a
sign). Identical sub-expressions are one node wherever they occur, so they are computed once.

1. Each polynomial is written as Σ_state (parameter part) · state monomial: its terms are grouped
   by their velocities, trig letters and named quantities, and each group's parameter part has
   its common monomial and common coefficient pulled out, leaving a sum of parameter terms:
   −l1 (m2 + m1/2) s1 dq1².
2. Products: the pair of factors that occurs in the most products is made a node of its own, in
   every product that has it, and so on while a pair occurs twice or more (greedy pairing).
   Sums: the same with pairs of signed terms.
3. A node used more than once becomes a temporary `const Scalar tN = ...;`; a node used once is
   written where it is used. Temporaries are numbered in the order they are emitted, which
   follows the outputs: the same input gives the same text, whatever the hash seed (node ids
   are creation order, every choice breaks ties by ids).
"""

from __future__ import annotations

import heapq
from bisect import bisect_left
from collections.abc import Callable, Hashable, Iterable, Sequence
from fractions import Fraction

from generator.poly import Monomial, Poly

LEAF, CONST, MUL, ADD = 0, 1, 2, 3

Signed = tuple[int, int]  # (sign ±1, node); node −1 is zero


class Graph:
    """Hash-consed expression nodes; see the module docstring.

    `data[node]`: LEAF: its C++ name; CONST: a positive Fraction; MUL: sorted tuple of factors
    (repeated for powers); ADD: {term: sign}, sign-normalised (see `add`).
    """

    def __init__(self) -> None:
        self.kind: list[int] = []
        self.data: list = []
        self.order: list[tuple] = []  # leaves: print order (parameters, velocities, letters...)
        self._interned: dict[Hashable, int] = {}

    def _node(self, kind: int, data: object, key: Hashable, order: tuple = ()) -> int:
        found = self._interned.get(key)
        if found is not None:
            return found
        node = len(self.kind)
        self.kind.append(kind)
        self.data.append(data)
        self.order.append(order)
        self._interned[key] = node
        return node

    def leaf(self, name: str, order: tuple = ()) -> int:
        return self._node(LEAF, name, (LEAF, name), order)

    def const(self, value: Fraction) -> int:
        """A positive rational constant."""
        return self._node(CONST, value, (CONST, value.numerator, value.denominator))

    def mul(self, factors: Iterable[int]) -> int:
        factors = tuple(sorted(factors))
        if len(factors) == 1:
            return factors[0]
        return self._node(MUL, factors, (MUL, factors))

    def add(self, terms: dict[int, int]) -> Signed:
        """The sum Σ sign·term as (sign, node): normalised so that at least half of the terms
        are positive (ties: the first term), and a single term is the term itself."""
        if not terms:
            return (1, -1)
        if len(terms) == 1:
            ((node, sign),) = terms.items()
            return (sign, node)
        negative = sum(1 for s in terms.values() if s < 0)
        flip = 2 * negative > len(terms) or (2 * negative == len(terms) and terms[min(terms)] < 0)
        if flip:
            terms = {t: -s for t, s in terms.items()}
        key = (ADD, tuple(sorted(terms.items())))
        return (-1 if flip else 1, self._node(ADD, terms, key))

    # -- polynomials -> nodes -----------------------------------------------------------
    def polynomial(self, p: Poly, leaves: Sequence[int], n_parameters: int) -> Signed:
        """p as Σ_state (parameter factor) · state monomial; see the module docstring."""
        groups: dict[Monomial, list[tuple[Monomial, int]]] = {}
        for m in sorted(p.terms):
            cut = bisect_left(m, n_parameters)
            groups.setdefault(m[cut:], []).append((m[:cut], p.terms[m]))
        terms: dict[int, int] = {}
        for state, parts in groups.items():
            sign, factors = self._parameter_factor(parts, p.den, leaves)
            factors += [leaves[g] for g in state]
            terms[self.mul(factors) if factors else self.const(Fraction(1))] = sign
        return self.add(terms)

    def _parameter_factor(
        self, parts: list[tuple[Monomial, int]], den: int, leaves: Sequence[int]
    ) -> tuple[int, list[int]]:
        """Σ (c/den)·monomial as sign and factors: the common monomial, |scale| and what is left.

        The scale is the coefficients' common absolute value if they have one (else 1), negative
        when every coefficient is: −l1 (m2 + m1/2), (3/2) g l1 (m1 − m2).
        """
        if len(parts) == 1:
            monomial, c = parts[0]
            factors = [leaves[g] for g in monomial]
            if abs(c) != den:
                factors.append(self.const(Fraction(abs(c), den)))
            return (1 if c > 0 else -1), factors
        common = _common_factor([m for m, _ in parts])
        numerators = [c for _, c in parts]
        magnitude = abs(numerators[0])
        if any(abs(c) != magnitude for c in numerators):
            magnitude = den  # no common absolute value: scale ±1
        sign = -1 if all(c < 0 for c in numerators) else 1
        inner: dict[int, int] = {}
        for m, c in parts:
            factors = [leaves[g] for g in _remove(m, common)]
            if abs(c) != magnitude or not factors:
                factors.append(self.const(Fraction(abs(c), magnitude)))
            inner[self.mul(factors)] = 1 if c * sign > 0 else -1
        inner_sign, node = self.add(inner)
        factors = [leaves[g] for g in common]
        factors.append(node)
        if magnitude != den:
            factors.append(self.const(Fraction(magnitude, den)))
        return sign * inner_sign, factors

    # -- common subexpressions ------------------------------------------------------------
    def share_products(self, roots: Iterable[int]) -> None:
        """Greedy pairing of factors over every product reachable from `roots`."""
        _pair_up([v for v in self.reachable(roots) if self.kind[v] == MUL], self.data, _Products(self))

    def share_sums(self, roots: Iterable[int]) -> None:
        """Greedy pairing of signed terms over every sum reachable from `roots`."""
        _pair_up([v for v in self.reachable(roots) if self.kind[v] == ADD], self.data, _Sums(self))

    def reachable(self, roots: Iterable[int]) -> list[int]:
        """Nodes reachable from `roots` (children before parents)."""
        seen: set[int] = set()
        order: list[int] = []
        for root in roots:
            if root < 0 or root in seen:
                continue
            stack = [(root, False)]
            while stack:
                node, done = stack.pop()
                if done:
                    order.append(node)
                    continue
                if node in seen:
                    continue
                seen.add(node)
                stack.append((node, True))
                stack.extend((c, False) for c in reversed(list(self.children(node))) if c not in seen)
        return order

    def children(self, node: int) -> Iterable[int]:
        kind = self.kind[node]
        if kind == MUL:
            return self.data[node]
        if kind == ADD:
            return self.data[node].keys()
        return ()

    def canonical(self, roots: Sequence[Signed]) -> list[Signed]:
        """Merge nodes that became equal or trivial while pairing; returns the new roots."""
        alias: dict[int, int] = {}
        interned: dict[Hashable, int] = {}
        for node in self.reachable(r for _, r in roots):
            kind = self.kind[node]
            if kind == MUL:
                data: object = tuple(sorted(alias.get(f, f) for f in self.data[node]))
                if len(data) == 1:  # type: ignore[arg-type]
                    alias[node] = data[0]  # type: ignore[index]
                    continue
                key: Hashable = (MUL, data)
            elif kind == ADD:
                terms: dict[int, int] = {}
                for t, s in self.data[node].items():
                    t = alias.get(t, t)
                    terms[t] = terms.get(t, 0) + s
                if any(abs(s) != 1 for s in terms.values()):  # two terms merged: keep them apart
                    continue
                if len(terms) == 1 and next(iter(terms.values())) > 0:
                    alias[node] = next(iter(terms))
                    continue
                data, key = terms, (ADD, tuple(sorted(terms.items())))
            else:
                continue
            self.data[node] = data
            found = interned.setdefault(key, node)
            if found != node:
                alias[node] = found
        return [(sign, alias.get(root, root)) for sign, root in roots]


def _common_factor(monomials: list[Monomial]) -> Monomial:
    """The largest monomial dividing every one of `monomials`."""
    common = list(monomials[0])
    for m in monomials[1:]:
        rest = list(m)
        kept = []
        for g in common:
            if g in rest:
                rest.remove(g)
                kept.append(g)
        common = kept
    return tuple(common)


def _remove(monomial: Monomial, factor: Monomial) -> Monomial:
    rest = list(monomial)
    for g in factor:
        rest.remove(g)
    return tuple(rest)


class _Products:
    """Pairs of factors in products: a product's data is its sorted tuple of factors."""

    def __init__(self, graph: Graph) -> None:
        self.graph = graph

    @staticmethod
    def elements(factors: tuple[int, ...]) -> Iterable[int]:
        return factors

    @staticmethod
    def pairs(factors: tuple[int, ...], shared: set[int], touching: Sequence[int] = ()) -> set[tuple]:
        """The pairs (x, y), x ≤ y, of `shared` factors in a product (only those with an element
        of `touching`, if given)."""
        candidates = [f for f in factors if f in shared]
        pairs = set()
        for i, x in enumerate(candidates):
            if i and candidates[i - 1] == x:
                if (not touching or x in touching) and (i < 2 or candidates[i - 2] != x):
                    pairs.add((x, x))
                continue
            if touching and x not in touching:
                pairs.update((x, y) for y in candidates[i + 1 :] if y in touching and y != x)
            else:
                pairs.update((x, y) for y in candidates[i + 1 :] if y != x)
        return pairs

    def combine(self, key: tuple[int, int]) -> tuple[int, Callable, tuple[int, ...]]:
        x, y = key
        pair = self.graph.mul((x, y))

        def apply(factors: tuple[int, ...]) -> tuple[int, ...] | None:
            rest = list(factors)
            rest.remove(x)
            rest.remove(y)
            return tuple(sorted((*rest, pair)))

        return pair, apply, (x, y, pair)


class _Sums:
    """Pairs of signed terms in sums: a sum's data is {term: sign}; the pair (a, b, s) stands for
    the terms ±a and ±s·b (a < b), whose sum is ±(a + s·b)."""

    def __init__(self, graph: Graph) -> None:
        self.graph = graph

    @staticmethod
    def elements(terms: dict[int, int]) -> Iterable[int]:
        return terms.keys()

    @staticmethod
    def pairs(terms: dict[int, int], shared: set[int], touching: Sequence[int] = ()) -> set[tuple]:
        candidates = sorted((t, s) for t, s in terms.items() if t in shared)
        if not touching:
            return {(a, b, sa * sb) for i, (a, sa) in enumerate(candidates) for b, sb in candidates[i + 1 :]}
        pairs = set()
        for t in touching:
            if t in terms and t in shared:
                st = terms[t]
                for u, su in candidates:
                    if u != t:
                        pairs.add((min(t, u), max(t, u), st * su))
        return pairs

    def combine(self, key: tuple[int, int, int]) -> tuple[int, Callable, tuple[int, ...]]:
        a, b, relative = key
        sign, pair = self.graph.add({a: 1, b: relative})
        assert sign == 1  # a < b: a two-term sum keeps its first term positive

        def apply(terms: dict[int, int]) -> dict[int, int] | None:
            if pair in terms:
                return None  # the sum would need the coefficient 2
            new = dict(terms)
            outer = new.pop(a)
            del new[b]
            new[pair] = outer
            return new

        return pair, apply, (a, b, pair)


def _pair_up(bags: list[int], data: list, kind: _Products | _Sums) -> None:
    """Greedy pairing (as in Re-Pair compression) over `bags`, the nodes whose `data` are a
    product's factors or a sum's terms: while some pair occurs in two bags or more, make the
    most frequent one (ties: the smallest key) a node of its own and use it in every bag.

    Only elements that occur in two bags or more can be part of a repeated pair (`shared`); a
    replacement changes only the pairs that touch the replaced elements or the new node.
    """
    occurrences: dict[int, int] = {}
    for bag in bags:
        for element in kind.elements(data[bag]):
            occurrences[element] = occurrences.get(element, 0) + 1
    shared = {e for e, count in occurrences.items() if count > 1}
    where: dict[tuple, dict[int, None]] = {}
    for bag in bags:
        for key in kind.pairs(data[bag], shared):
            holders = where.get(key)
            if holders is None:
                where[key] = {bag: None}
            else:
                holders[bag] = None
    heap = [(-len(holders), key) for key, holders in where.items() if len(holders) > 1]
    heapq.heapify(heap)
    while heap:
        negative_count, key = heapq.heappop(heap)
        current = len(where.get(key, ()))
        if current != -negative_count:
            if 1 < current < -negative_count:
                heapq.heappush(heap, (-current, key))
            continue
        pair, apply, touched = kind.combine(key)
        shared.add(pair)
        skipped = []
        for bag in list(where[key]):
            new = None if bag == pair else apply(data[bag])
            if new is None:
                skipped.append(bag)  # the pair itself, or a bag that cannot take it
                continue
            before = kind.pairs(data[bag], shared, touched)
            data[bag] = new
            after = kind.pairs(new, shared, touched)
            for old in before - after:
                holders = where[old]
                del holders[bag]
                if not holders:
                    del where[old]
            for added in after - before:
                holders = where.setdefault(added, {})
                holders[bag] = None
                if len(holders) > 1:
                    heapq.heappush(heap, (-len(holders), added))
        holders = where.get(key, {})
        for bag in skipped:
            holders.pop(bag, None)
        if not holders:
            where.pop(key, None)
        elif len(holders) > 1:
            heapq.heappush(heap, (-len(holders), key))
