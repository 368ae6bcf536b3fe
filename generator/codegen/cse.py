"""Common-subexpression elimination on the derived polynomials (printed by `printer.py`).

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
from collections import Counter
from collections.abc import Callable, Hashable, Iterable, Sequence
from fractions import Fraction

from ipgen.model.polynomial import Monomial, Poly, sparse

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
        self._interned: dict[Hashable, int] = {}
        self._factored: dict[tuple, tuple[int, list[int]]] = {}  # parameter part -> sign, factors

    def _node(self, kind: int, data: object, key: Hashable) -> int:
        found = self._interned.get(key)
        if found is not None:
            return found
        node = len(self.kind)
        self.kind.append(kind)
        self.data.append(data)
        self._interned[key] = node
        return node

    def leaf(self, name: str) -> int:
        return self._node(LEAF, name, (LEAF, name))

    def const(self, numerator: int, denominator: int = 1) -> int:
        """The positive rational constant numerator/denominator."""
        node = self._interned.get((CONST, numerator, denominator))
        if node is None:
            value = Fraction(numerator, denominator)
            node = self._node(CONST, value, (CONST, value.numerator, value.denominator))
            self._interned[CONST, numerator, denominator] = node
        return node

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
        """p (an element of the system's ring) as Σ_state (parameter factor) · state monomial;
        see the module docstring. `leaves[g]` is the leaf of generator g."""
        numerators, den = sparse(p)
        groups: dict[Monomial, list[tuple[Monomial, int]]] = {}
        for m in sorted(numerators):
            cut = bisect_left(m, n_parameters)
            groups.setdefault(m[cut:], []).append((m[:cut], numerators[m]))
        terms: dict[int, int] = {}
        for state, parts in groups.items():
            key = (den, *parts)  # the same parameter part recurs under many state monomials
            factored = self._factored.get(key)
            if factored is None:
                factored = self._factored[key] = self._parameter_factor(parts, den, leaves)
            sign, factors = factored[0], [*factored[1], *(leaves[g] for g in state)]
            terms[self.mul(factors) if factors else self.const(1)] = sign
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
                factors.append(self.const(abs(c), den))
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
                factors.append(self.const(abs(c), magnitude))
            inner[self.mul(factors)] = 1 if c * sign > 0 else -1
        inner_sign, node = self.add(inner)
        factors = [leaves[g] for g in common]
        factors.append(node)
        if magnitude != den:
            factors.append(self.const(magnitude, den))
        return sign * inner_sign, factors

    # -- common subexpressions ------------------------------------------------------------
    def share_products(self, roots: Iterable[int]) -> None:
        """Greedy pairing of factors over every product reachable from `roots`."""
        _pair_up([v for v in self.reachable(roots) if self.kind[v] == MUL], self.data, _Products(self))

    def share_sums(self, roots: Iterable[int]) -> None:
        """Greedy pairing of signed terms over every sum reachable from `roots`."""
        _pair_up([v for v in self.reachable(roots) if self.kind[v] == ADD], self.data, _Sums(self))

    def reachable(self, roots: Iterable[int]) -> list[int]:
        """Nodes reachable from `roots` (-1, zero, is skipped), children before parents."""
        seen: set[int] = set()
        order: list[int] = []
        kind, data = self.kind, self.data
        for root in roots:
            if root < 0 or root in seen:
                continue
            seen.add(root)
            stack = [(root, iter(self.children(root)))]
            while stack:
                node, pending = stack[-1]
                for child in pending:
                    if child in seen:
                        continue
                    seen.add(child)
                    if kind[child] < MUL:  # a leaf or a constant
                        order.append(child)
                        continue
                    stack.append((child, iter(data[child])))
                    break
                else:
                    stack.pop()
                    order.append(node)
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
    everywhere = set(monomials[0]).intersection(*monomials[1:])
    if not everywhere:
        return ()
    common: list[int] = []
    for g in sorted(everywhere):
        common += [g] * min(m.count(g) for m in monomials)
    return tuple(common)


def _remove(monomial: Monomial, factor: Monomial) -> Monomial:
    if not factor:
        return monomial
    rest = list(monomial)
    for g in factor:
        rest.remove(g)
    return tuple(rest)


_BITS = 32  # node ids are below 2**32: a pair of them packs into one int key


class _Products:
    """Pairs of factors in products: a product's data is its sorted tuple of factors, and the
    pair x·y (x ≤ y) has the key x·2³² + y."""

    def __init__(self, graph: Graph) -> None:
        self.graph = graph

    @staticmethod
    def elements(factors: tuple[int, ...]) -> Iterable[int]:
        return set(factors)

    @staticmethod
    def pairs(factors: tuple[int, ...], shared: set[int]) -> list[int]:
        """Every pair of `shared` factors a product contains, once."""
        candidates = [f for f in factors if f in shared]
        pairs = []
        for i, x in enumerate(candidates):
            if i and candidates[i - 1] == x:
                if i < 2 or candidates[i - 2] != x:
                    pairs.append(x << _BITS | x)
                continue
            high = x << _BITS
            pairs.extend({high | y for y in candidates[i + 1 :] if y != x})
        return pairs

    @staticmethod
    def touching(factors: tuple[int, ...], shared: set[int], element: int) -> set[int]:
        """The pairs of `shared` factors that contain `element`."""
        if element not in factors:
            return set()
        pairs = {min(f, element) << _BITS | max(f, element) for f in factors if f != element and f in shared}
        if factors.count(element) > 1:
            pairs.add(element << _BITS | element)
        return pairs

    @staticmethod
    def has(factors: tuple[int, ...], key: int) -> bool:
        x, y = key >> _BITS, key & ((1 << _BITS) - 1)
        if x == y:
            return factors.count(x) > 1
        return x in factors and y in factors

    def combine(self, key: int) -> tuple[int, Callable[[tuple[int, ...]], tuple[int, ...]]]:
        x, y = key >> _BITS, key & ((1 << _BITS) - 1)
        pair = self.graph.mul((x, y))

        def apply(factors: tuple[int, ...]) -> tuple[int, ...]:
            rest = list(factors)
            rest.remove(x)
            rest.remove(y)
            return tuple(sorted((*rest, pair)))

        return pair, apply


class _Sums:
    """Pairs of signed terms in sums: a sum's data is {term: sign}; the pair of terms ±a, ±s·b
    (a < b), whose sum is ±(a + s·b), has the key a·2³³ + b·2 + (1 if s < 0 else 0)."""

    def __init__(self, graph: Graph) -> None:
        self.graph = graph

    @staticmethod
    def elements(terms: dict[int, int]) -> Iterable[int]:
        return terms.keys()

    @staticmethod
    def pairs(terms: dict[int, int], shared: set[int]) -> list[int]:
        candidates = sorted((t, s) for t, s in terms.items() if t in shared)
        return [
            a << (_BITS + 1) | b << 1 | (sa != sb)
            for i, (a, sa) in enumerate(candidates)
            for b, sb in candidates[i + 1 :]
        ]

    @staticmethod
    def touching(terms: dict[int, int], shared: set[int], element: int) -> set[int]:
        if element not in terms:
            return set()
        sign = terms[element]
        return {
            min(t, element) << (_BITS + 1) | max(t, element) << 1 | (s != sign)
            for t, s in terms.items()
            if t != element and t in shared
        }

    @staticmethod
    def has(terms: dict[int, int], key: int) -> bool:
        a, b = key >> (_BITS + 1), (key >> 1) & ((1 << _BITS) - 1)
        return a in terms and b in terms and (terms[a] != terms[b]) == bool(key & 1)

    def combine(self, key: int) -> tuple[int, Callable[[dict[int, int]], dict[int, int] | None]]:
        a, b = key >> (_BITS + 1), (key >> 1) & ((1 << _BITS) - 1)
        sign, pair = self.graph.add({a: 1, b: -1 if key & 1 else 1})
        assert sign == 1  # a < b: a two-term sum keeps its first term positive

        def apply(terms: dict[int, int]) -> dict[int, int] | None:
            if pair in terms:
                return None  # the sum would need the coefficient 2
            new = dict(terms)
            outer = new.pop(a)
            del new[b]
            new[pair] = outer
            return new

        return pair, apply


def _pair_up(bags: list[int], data: list, kind: _Products | _Sums) -> None:
    """Greedy pairing (as in Re-Pair compression) over `bags`, the nodes whose `data` are a
    product's factors or a sum's terms: while some pair occurs in two bags or more, make the
    most frequent one (ties: the smallest key) a node of its own and use it in every bag.

    A replacement only adds the new node to a bag, so a pair of older elements never gains
    occurrences: only the pairs that occur twice at the start, and those with a new node, are
    tracked. Elements in a single bag (not `shared`) cannot be part of a repeated pair. A bag
    that loses a pair is not removed from that pair's holders at once: the holders of a pair
    are checked when it comes first in the heap, whose entries are never below the true counts.
    """
    occurrences: Counter[int] = Counter()
    for bag in bags:
        occurrences.update(kind.elements(data[bag]))
    shared = {e for e, count in occurrences.items() if count > 1}
    initial = [kind.pairs(data[bag], shared) for bag in bags]
    counts: Counter[int] = Counter()
    for pairs in initial:
        counts.update(pairs)
    where: dict[int, dict[int, None]] = {key: {} for key, count in counts.items() if count > 1}
    for bag, pairs in zip(bags, initial, strict=True):
        for key in pairs:
            holders = where.get(key)
            if holders is not None:
                holders[bag] = None
    del initial, counts
    heap = [(-len(holders), key) for key, holders in where.items()]
    heapq.heapify(heap)
    while heap:
        negative_count, key = heapq.heappop(heap)
        holders = where.get(key)
        if holders is None or len(holders) < -negative_count:
            continue  # superseded by a later entry
        valid = {bag: None for bag in holders if kind.has(data[bag], key)}
        if len(valid) < len(holders):
            if len(valid) > 1:
                where[key] = valid
                heapq.heappush(heap, (-len(valid), key))
            else:
                del where[key]
            continue
        pair, apply = kind.combine(key)
        shared.add(pair)
        left: dict[int, None] = {}
        for bag in holders:
            new = None if bag == pair else apply(data[bag])
            if new is None:
                continue  # the pair itself, or a bag that cannot take it
            data[bag] = new
            if kind.has(new, key):
                left[bag] = None  # a power or a repeated term: the pair is there again
            for added in kind.touching(new, shared, pair):
                pair_holders = where.setdefault(added, {})
                pair_holders[bag] = None
                if len(pair_holders) > 1:
                    heapq.heappush(heap, (-len(pair_holders), added))
        if len(left) > 1:
            where[key] = left
            heapq.heappush(heap, (-len(left), key))
        else:
            del where[key]
