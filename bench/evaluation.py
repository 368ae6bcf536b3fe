"""Evaluation benchmark: ipgen's generated C++ against Pinocchio's CRBA, nonLinearEffects and ABA.

For each system a header is generated (rotary with `--inertia full`: the rigid thin rod that
Pinocchio models), compiled with bench/eval/bench.cpp and the Pinocchio side
(bench/eval/reference.cpp, compiled once) into one binary, and run. The binary first checks that
both agree at random states, mapped to absolute angles, and prints timings only if they do.
Pinocchio comes from the `pin` wheel (headers and libraries under site-packages/cmeel.prefix);
its algorithms are used header-only, compiled here with the same compiler and flags.
"""

from __future__ import annotations

import hashlib
import json
import re
import subprocess
import sysconfig
from concurrent.futures import ThreadPoolExecutor
from dataclasses import asdict, dataclass, field
from pathlib import Path

from tqdm import tqdm

from bench.report import (
    BUILD,
    PYTHON,
    ROOT,
    compiler_version,
    machine,
    style_axis,
    table,
    verdict,
    version,
)
from bench.systems import LINKS, TYPES

PAIRS = (("mass_matrix", "crba"), ("bias", "nonLinearEffects"), ("forward_dynamics", "aba"))
LABELS = {"crba": "CRBA", "nonLinearEffects": "nonLinearEffects", "aba": "ABA"}
COMPILER = "g++"
FLAGS = ("-std=c++17", "-O3", "-march=native", "-DNDEBUG")
EIGEN = Path("/usr/include/eigen3")
SOURCES = ROOT / "bench" / "eval"
ROUNDS = 30
MILLISECONDS = 5.0
TOLERANCE = 1e-10
# The targets: forward_dynamics at most this fraction of ABA's time at these n.
ABA_TARGETS = (("n ≤ 3", (1, 2, 3), 0.15), ("n = 10", (10,), 0.35), ("n = 20", (20,), 0.5))


@dataclass
class Evaluation:
    type: str
    links: int
    agree: bool
    checks: dict[str, float] = field(default_factory=dict)  # function -> max relative difference
    times: dict[str, list[float]] = field(default_factory=dict)  # function -> [ipgen ns, Pinocchio ns]
    # function -> Pinocchio's ns per convention (local, and world for CRBA and ABA); `times` has the faster
    conventions: dict[str, dict[str, float]] = field(default_factory=dict)
    calls: dict[str, int] = field(default_factory=dict)  # calls per timed batch
    error: str = ""


def cmeel_prefix() -> Path:
    prefix = Path(sysconfig.get_paths()["purelib"]) / "cmeel.prefix"
    if not (prefix / "include" / "pinocchio").is_dir():
        raise SystemExit(f"bench: Pinocchio's headers are not under {prefix}: pip install pin")
    return prefix


def pinocchio_defines(prefix: Path) -> list[str]:
    """The compile definitions Pinocchio's CMake package gives its header-only target."""
    targets = (prefix / "lib" / "cmake" / "pinocchio" / "pinocchioTargets.cmake").read_text()
    block = targets.split("pinocchio::pinocchio_headers PROPERTIES", 1)[1]
    found = re.search(r'INTERFACE_COMPILE_DEFINITIONS "([^"]*)"', block)
    return [f"-D{d}" for d in found.group(1).split(";")] if found else []


def _compile(arguments: list[str]) -> None:
    done = subprocess.run([COMPILER, *arguments], capture_output=True, text=True)
    if done.returncode != 0:
        raise RuntimeError(f"{COMPILER} {' '.join(arguments)} failed:\n{done.stderr[-4000:]}")


def reference_object() -> Path:
    """Pinocchio's side, compiled once per compiler, flags, sources and Pinocchio version (~3 min)."""
    prefix = cmeel_prefix()
    arguments = [*FLAGS, *pinocchio_defines(prefix), f"-I{EIGEN}", "-isystem", str(prefix / "include")]
    key = hashlib.sha256(
        "\n".join(
            [
                compiler_version(COMPILER),
                version("pin"),
                *arguments,
                (SOURCES / "reference.cpp").read_text(),
                (SOURCES / "reference.hpp").read_text(),
            ]
        ).encode()
    ).hexdigest()[:16]
    target = BUILD / f"reference-{key}.o"
    if not target.exists():
        BUILD.mkdir(parents=True, exist_ok=True)
        print("bench: compiling Pinocchio's algorithms once (a few minutes) ...", flush=True)
        partial = target.with_suffix(".tmp.o")
        _compile(
            [*arguments, "-Wno-stringop-overread", "-c", str(SOURCES / "reference.cpp"), "-o", str(partial)]
        )
        partial.rename(target)
    return target


def header(kind: str, links: int) -> tuple[Path, str]:
    """Generate the system's header; return its folder and namespace name."""
    name = f"{kind}{links}"
    directory = BUILD / "headers"
    command = [PYTHON, "-m", "ipgen", "--type", kind, "--links", str(links), "--name", name, "-o"]
    command += [str(directory)] + (["--inertia", "full"] if kind == "rotary" else [])
    subprocess.run(command, cwd=ROOT, check=True, capture_output=True, text=True)
    return directory, name


def binary(kind: str, links: int, reference: Path) -> Path:
    directory, name = header(kind, links)
    target = BUILD / "bin" / name
    target.parent.mkdir(parents=True, exist_ok=True)
    _compile(
        [
            *FLAGS,
            f"-I{EIGEN}",
            f"-I{SOURCES}",
            f"-I{directory}",
            f'-DIPGEN_HEADER="{name}.hpp"',
            f"-DIPGEN_NAMESPACE={name}",
            str(SOURCES / "bench.cpp"),
            str(reference),
            "-o",
            str(target),
        ]
    )
    return target


def parse(kind: str, links: int, output: str, status: int) -> Evaluation:
    result = Evaluation(kind, links, agree=status == 0)
    for line in output.splitlines():
        words = line.split()
        if words[:1] == ["check"]:
            result.checks[words[1]] = float(words[2])
        elif words[:1] == ["time"]:
            function, ours, theirs = words[1], float(words[4]), [float(w) for w in words[5:]]
            result.conventions[function] = dict(zip(("local", "world"), theirs, strict=False))
            result.times[function] = [ours, min(theirs)]
            result.calls[function] = int(words[3])
        elif words[:1] == ["disagree:"]:
            result.error = line
    return result


def sweep(
    links: tuple[int, ...] = LINKS,
    types: tuple[str, ...] = TYPES,
    rounds: int = ROUNDS,
    milliseconds: float = MILLISECONDS,
) -> list[Evaluation]:
    reference = reference_object()
    systems = [(kind, n) for kind in types for n in links]
    # Compile two at a time, then time one at a time (no compiler competing for the cores).
    with ThreadPoolExecutor(max_workers=2) as pool:
        jobs = [pool.submit(binary, kind, n, reference) for kind, n in systems]
        binaries = [job.result() for job in tqdm(jobs, desc="compile", unit="binary")]
    results = []
    with tqdm(list(zip(systems, binaries, strict=True)), desc="evaluation", unit="system") as bar:
        for (kind, n), program in bar:
            bar.set_postfix_str(f"{kind} n={n}")
            done = subprocess.run(
                [str(program), str(rounds), str(milliseconds)], capture_output=True, text=True
            )
            results.append(parse(kind, n, done.stdout, done.returncode))
    return results


def _ratio(result: Evaluation, function: str) -> float | None:
    if function not in result.times:
        return None
    ours, theirs = result.times[function]
    return ours / theirs


def _target(
    text: str, subset: list[Evaluation], function: str, limit: float, strict: bool = False
) -> tuple[str, bool | None, str]:
    """One target: ipgen's time at most (strict: less than) `limit` times Pinocchio's."""
    misses = []
    for r in subset:
        ratio = _ratio(r, function)
        if ratio is None or ratio > limit or (strict and ratio >= limit):
            misses.append(f"{r.type} n={r.links}: " + ("no timing" if ratio is None else f"{ratio:.3f}"))
    return text, (not misses) if subset else None, ", ".join(misses)


def targets(results: list[Evaluation]) -> list[tuple[str, bool | None, str]]:
    """The issue's targets: (statement, met? or None when not measured, the misses)."""
    verdicts: list[tuple[str, bool | None, str]] = []
    for where, sizes, fraction in ABA_TARGETS:
        subset = [r for r in results if r.links in sizes]
        verdicts.append(
            _target(f"forward_dynamics ≤ {fraction} × ABA at {where}", subset, "forward_dynamics", fraction)
        )
    for function, algorithm in PAIRS[:2]:
        subset = [r for r in results if r.links <= 20]
        verdicts.append(
            _target(
                f"{function} faster than {LABELS[algorithm]} at every n ≤ 20",
                subset,
                function,
                1.0,
                strict=True,
            )
        )
    return verdicts


def markdown(results: list[Evaluation], rounds: int, milliseconds: float) -> str:
    lines = [
        "# Evaluation time: ipgen's generated C++ against Pinocchio",
        "",
        "Written by `make bench` (bench/run.py, bench/evaluation.py, bench/eval/); nanoseconds per call,",
        "lower is better; ratio = ipgen / Pinocchio.",
        "",
        "![nanoseconds per call against the number of links, ipgen and Pinocchio](evaluation.png)",
        "",
        "- Same system on both sides: a cart (prismatic joint) or an arm turning about the vertical (a",
        "  thin rod of inertia m0 l0²/3) carrying n thin rods (CoG at l/2, m l²/12 about the axes across",
        "  the rod). Rotary headers use `--inertia full`, the rigid thin rod Pinocchio models. Damping 0",
        "  (Pinocchio's algorithms have none), random masses and lengths, g = 9.81 along −z.",
        "- Pinocchio works in relative joint angles, ipgen in absolute ones; states are mapped before",
        "  timing, so each side is timed in its own coordinates. Pinocchio's CRBA fills the upper",
        "  triangle only (not symmetrised in the timed call). CRBA and ABA are timed in both of",
        "  Pinocchio's conventions, LOCAL (its default) and WORLD; the table keeps the faster (w: WORLD).",
        "- Equivalence checked in the same binary before timing: at 10 random states, mass_matrix = CRBA",
        "  (symmetrised), bias = nonLinearEffects, forward_dynamics = ABA, mapped to absolute angles, to",
        f"  {TOLERANCE:g} relative (max |difference| / max |entry|); a pair that disagrees gets no timing.",
        "- Timing: one binary per system, both sides compiled by the same compiler with the same flags;",
        "  every call out of line, results stored to memory; inputs cycle through 256 precomputed random",
        f"  states; warm-up, then {rounds} rounds of one batch per contender in rotating order (AB, BA, …),",
        f"  ~{milliseconds:g} ms per round; the median over rounds. Batches are timed in the thread's CPU",
        "  time (CLOCK_THREAD_CPUTIME_ID): time preempted by other processes on the machine is not counted.",
        "",
        *machine(
            {
                "compiler": compiler_version(COMPILER),
                "flags": " ".join(FLAGS),
                "Pinocchio": f"{version('pin')} (PyPI `pin`, header-only: its algorithms compiled here)",
                "Eigen": str(EIGEN),
            }
        ),
        "",
    ]
    for kind in TYPES:
        rows = []
        for r in (r for r in results if r.type == kind):
            row = [str(r.links)]
            for function, _ in PAIRS:
                if function in r.times:
                    ours, theirs = r.times[function]
                    world = r.conventions[function].get("world") == theirs
                    row += [f"{ours:.0f}", f"{theirs:.0f}" + (" w" if world else ""), f"{ours / theirs:.2f}"]
                else:
                    row += ["–", "–", "–"]
            row.append(f"{max(r.checks.values()):.1e}" if r.checks else "–")
            row.append("yes" if r.agree else "**NO**: no timing")
            rows.append(row)
        if not rows:
            continue
        header = ["n"]
        for function, algorithm in PAIRS:
            header += [function, LABELS[algorithm], "ratio"]
        header += ["max rel. diff.", "agree"]
        title = kind + (" (`--inertia full`)" if kind == "rotary" else "")
        lines += [f"## {title}", "", *table(header, rows), ""]
    lines += ["## Targets", ""]
    for text, met, misses in targets(results):
        state = "not measured" if met is None else verdict(met)
        lines.append(f"- {text}: **{state}**" + (f" ({misses})" if misses else ""))
    return "\n".join(lines) + "\n"


def plot(results: list[Evaluation], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    kinds = [kind for kind in TYPES if any(r.type == kind for r in results)]
    figure, axes = plt.subplots(1, len(kinds), figsize=(5.5 * len(kinds), 4.2), squeeze=False)
    for axis, kind in zip(axes[0], kinds, strict=True):
        rows = [r for r in results if r.type == kind and r.times]
        for colour, (function, algorithm) in zip(("C0", "C1", "C2"), PAIRS, strict=True):
            xs = [r.links for r in rows if function in r.times]
            ours = [r.times[function][0] for r in rows if function in r.times]
            theirs = [r.times[function][1] for r in rows if function in r.times]
            axis.plot(xs, ours, "-", color=colour, marker="o", markersize=3, label=f"ipgen {function}")
            axis.plot(
                xs,
                theirs,
                "--",
                color=colour,
                marker="s",
                markersize=3,
                label=f"Pinocchio {LABELS[algorithm]}",
            )
        style_axis(axis, [r.links for r in rows], "ns per call", kind)
    figure.suptitle("Evaluating the dynamics (lower is better)")
    figure.tight_layout()
    figure.savefig(path, dpi=120)
    plt.close(figure)


def save(results: list[Evaluation], directory: Path, rounds: int, milliseconds: float) -> None:
    directory.mkdir(parents=True, exist_ok=True)
    (directory / "evaluation.md").write_text(markdown(results, rounds, milliseconds))
    (directory / "evaluation.json").write_text(json.dumps([asdict(r) for r in results], indent=1) + "\n")
    plot(results, directory / "evaluation.png")
