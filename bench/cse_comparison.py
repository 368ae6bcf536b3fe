"""ipgen's own common-subexpression elimination against `sympy.cse`, on forward_dynamics.

    python -m bench.cse_comparison                 # n = 2, 5, 10, both types; prints a Markdown table

For each system the outputs of `forward_dynamics` (the lower triangle of M and the bias b, as the
derivation's ring elements) go through

- **ipgen**: `codegen.functions.build_body` (grouping by state monomial, greedy pairing of
  products and sums, printing), as in a header;
- **sympy**: the same polynomials converted to sympy expressions in the same generators (trig
  letters and named quantities as symbols, term by term from `polynomial.sparse`), then
  `sympy.cse(..., optimizations="basic")`; integer powers are expanded into products
  (`sympy.codegen.rewriting.create_expand_pow_optimization`) and the result printed with
  `sympy.ccode`.

Both are counted with the same rule, ipgen's `count_operations` on the printed statements
(+, −, ×, ÷, negation; a rational literal counts as a constant), over the temporaries and the
outputs; the prelude (parameters, sin/cos, cos(θj − θk), named quantities) is the same for both
and left out. Times are the CSE alone, median of ROUNDS, in this process (the conversion to
sympy is not counted for sympy; ipgen's time includes its printing).
"""

from __future__ import annotations

import argparse
import re
import statistics
import time
from dataclasses import dataclass

import sympy as sp
from sympy.codegen.rewriting import create_expand_pow_optimization

from ipgen.codegen.functions import CPP_SYNTAX, Output, _targets, build_body, count_operations
from ipgen.codegen.header import function_outputs
from ipgen.model.derivation import Equations, derive
from ipgen.model.polynomial import Poly, sparse
from ipgen.model.system import System

FUNCTION = "forward_dynamics"
LINKS = (2, 5, 10)
ROUNDS = 3
_EXPAND_POWERS = create_expand_pow_optimization(8)
_RATIONAL = re.compile(r"\(?\d+(\.\d*)?/\d+(\.\d*)?\)?")


@dataclass
class Comparison:
    type: str
    links: int
    ipgen_operations: int
    ipgen_temporaries: int
    ipgen_s: float
    sympy_operations: int
    sympy_temporaries: int
    sympy_s: float
    expanded_operations: int  # the outputs without any CSE, for scale


def _outputs(eqs: Equations) -> tuple[list[Output], tuple[str, ...]]:
    return function_outputs(eqs, FUNCTION)


def _c_operations(name: str, expr: sp.Expr) -> int:
    """Operations of `name = expr;` printed by sympy.ccode, powers expanded, counted as ipgen counts."""
    text = sp.ccode(_EXPAND_POWERS(expr))
    return count_operations(f"{name} = {_RATIONAL.sub('1', text)};")


def _median_time(run, rounds: int) -> tuple[float, object]:
    times, result = [], None
    for _ in range(rounds):
        start = time.perf_counter()
        result = run()
        times.append(time.perf_counter() - start)
    return statistics.median(times), result


def _as_expr(p: Poly, symbols: list[sp.Symbol]) -> sp.Expr:
    """p as a sympy expression in its generators' symbols (expanded, as ipgen's CSE reads it)."""
    terms, den = sparse(p)
    return sp.Add(*(sp.Rational(c, den) * sp.Mul(*(symbols[g] for g in m)) for m, c in terms.items()))


def compare(kind: str, links: int, rounds: int = ROUNDS) -> Comparison:
    eqs = derive(System(kind, links))
    outputs, arguments = _outputs(eqs)
    ipgen_s, body = _median_time(lambda: build_body(eqs, outputs, arguments), rounds)
    ipgen_operations = sum(count_operations(line) for line in [*body.temporaries, *body.outputs])

    targets = [(target, p) for target, p, _ in _targets(outputs, CPP_SYNTAX)]
    symbols = [sp.Symbol(name) for name in eqs.algebra.ring.names()]
    exprs = [_as_expr(p, symbols) for _, p in targets]
    sympy_s, (replacements, reduced) = _median_time(lambda: sp.cse(exprs, optimizations="basic"), rounds)
    sympy_operations = sum(_c_operations(str(symbol), value) for symbol, value in replacements)
    sympy_operations += sum(_c_operations(target, e) for (target, _), e in zip(targets, reduced, strict=True))
    expanded = sum(_c_operations(target, e) for (target, _), e in zip(targets, exprs, strict=True))
    return Comparison(
        kind,
        links,
        ipgen_operations,
        len(body.temporaries),
        ipgen_s,
        sympy_operations,
        len(replacements),
        sympy_s,
        expanded,
    )


def markdown(results: list[Comparison]) -> list[str]:
    lines = [
        "| type | n | no CSE: ops | ipgen CSE: ops | temporaries | time [s] | sympy.cse: ops | temporaries"
        " | time [s] | sympy / ipgen ops | sympy / ipgen time |",
        "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |",
    ]
    for r in results:
        lines.append(
            f"| {r.type} | {r.links} | {r.expanded_operations} | {r.ipgen_operations} | {r.ipgen_temporaries}"
            f" | {r.ipgen_s:.3f} | {r.sympy_operations} | {r.sympy_temporaries} | {r.sympy_s:.3f}"
            f" | {r.sympy_operations / r.ipgen_operations:.2f} | {r.sympy_s / r.ipgen_s:.1f} |"
        )
    return lines


def section(types: tuple[str, ...], links: tuple[int, ...] = LINKS, rounds: int = ROUNDS) -> list[str]:
    """The Markdown section of docs/bench/generation.md: what is compared, and the table."""
    results = [compare(kind, n, rounds) for kind in types for n in links]
    return [
        "## ipgen's CSE against sympy.cse",
        "",
        "`python -m bench.cse_comparison` (bench/cse_comparison.py), in the same run: the outputs of",
        "`forward_dynamics` (lower triangle of M and the bias) through ipgen's CSE (`build_body`, with",
        'printing) and through `sympy.cse(..., optimizations="basic")` on the same polynomials as',
        "sympy expressions in the same generators (built term by term; conversion not timed), powers",
        "expanded, printed by `sympy.ccode`. Operations counted by one rule (ipgen's `count_operations`:",
        "+, −, ×, ÷, negation) over temporaries and outputs; the shared prelude (parameters, sin/cos,",
        f"named quantities) left out. *no CSE*: the expanded polynomials. Times: median of {rounds}.",
        "",
        *markdown(results),
    ]


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(
        prog="python -m bench.cse_comparison", description=__doc__.split("\n")[0]
    )
    parser.add_argument("--links", default=",".join(map(str, LINKS)))
    parser.add_argument("--types", default="classical,rotary")
    parser.add_argument("--rounds", type=int, default=ROUNDS)
    args = parser.parse_args(argv)
    results = [
        compare(kind, int(n), args.rounds) for kind in args.types.split(",") for n in args.links.split(",")
    ]
    print("\n".join(markdown(results)))


if __name__ == "__main__":
    main()
