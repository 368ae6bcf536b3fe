"""`make bench`: time ipgen's generation and its generated code, write docs/bench/, print a summary.

python -m bench.run                       # both parts, n = 1, 2, 3, 5, 10, 20 (+ classical 50)
python -m bench.run --part evaluation --links 1,2,3
python -m bench.run --quick               # n = 1, 2, 3, fewer rounds, into build/bench/quick/
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from bench import cse_comparison, evaluation, generation
from bench.report import BUILD, ROOT, verdict
from bench.systems import LINKS, TYPES


def _numbers(text: str) -> tuple[int, ...]:
    return tuple(int(word) for word in text.split(","))


def _names(text: str) -> tuple[str, ...]:
    names = tuple(text.split(","))
    unknown = set(names) - set(TYPES)
    if unknown:
        raise argparse.ArgumentTypeError(f"unknown type {', '.join(sorted(unknown))}: use classical, rotary")
    return names


def arguments(argv: list[str] | None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(prog="python -m bench.run", description=__doc__.splitlines()[0])
    parser.add_argument("--part", choices=("all", "generation", "evaluation"), default="all")
    parser.add_argument("--links", type=_numbers, help="comma-separated n (default 1,2,3,5,10,20)")
    parser.add_argument("--types", type=_names, default=TYPES, help="classical,rotary")
    parser.add_argument("--quick", action="store_true", help="n = 1,2,3, 10 rounds, 30 s limit, no n = 50")
    parser.add_argument("--rounds", type=int, help=f"timing rounds (default {evaluation.ROUNDS})")
    parser.add_argument(
        "--timeout", type=float, help=f"reference time limit [s] (default {generation.TIMEOUT:.0f})"
    )
    parser.add_argument("--out", type=Path, help="output folder (default docs/bench, or build/bench/quick)")
    return parser.parse_args(argv)


def main(argv: list[str] | None = None) -> None:
    options = arguments(argv)
    links = options.links or ((1, 2, 3) if options.quick else LINKS)
    rounds = options.rounds or (10 if options.quick else evaluation.ROUNDS)
    milliseconds = 2.0 if options.quick else evaluation.MILLISECONDS
    timeout = options.timeout or (30.0 if options.quick else generation.TIMEOUT)
    extra = () if options.quick or options.links else generation.EXTRA
    out = options.out or (BUILD / "quick" if options.quick else ROOT / "docs" / "bench")
    start = time.perf_counter()

    summary: list[str] = []
    if options.part in ("all", "generation"):
        timings, checks = generation.sweep(links, options.types, timeout, extra)
        cse = None if options.quick else cse_comparison.section(options.types)
        generation.save(timings, checks, out, timeout, cse)
        verdicts = generation.targets(timings, timeout) + generation.targets(timings, timeout, cpu=True)
        for text, met, misses in verdicts:
            summary.append(f"generation: {text}: {_state(met)}" + (f" ({misses})" if misses else ""))
    if options.part in ("all", "evaluation"):
        results = evaluation.sweep(links, options.types, rounds, milliseconds)
        evaluation.save(results, out, rounds, milliseconds)
        for r in results:
            if not r.agree:
                summary.append(f"evaluation: {r.type} n={r.links} DISAGREES with Pinocchio: {r.error}")
        for text, met, misses in evaluation.targets(results):
            summary.append(f"evaluation: {text}: {_state(met)}" + (f" ({misses})" if misses else ""))

    print(
        f"\nbench: wrote {out.relative_to(ROOT) if out.is_relative_to(ROOT) else out}/ "
        f"in {time.perf_counter() - start:.0f} s; the issue's targets:"
    )
    for line in summary:
        print(f"  {line}")


def _state(met: bool | None) -> str:
    return "not measured" if met is None else verdict(met)


if __name__ == "__main__":
    main()
