"""The current generator against an earlier commit of it, side by side in one run.

    python -m bench.against_baseline                       # against BASELINE, writes docs/bench/baseline.md
    python -m bench.against_baseline --commit abc123 --links 1,2,5 --rounds 3 --out /tmp/b
    python -m bench.against_baseline --large               # also classical n = 50 (--force), once, <= 6 GB

The earlier generator is materialised at run time from git (`git archive COMMIT generator
templates` into build/bench/baseline-COMMIT/, laid out as the package `ipgen`), so nothing but
this checkout's history is needed. For every system both generators write their header(s) into
fresh folders:

- **headers**: byte-identical or not, and the arithmetic operations each function's comment
  states (`Cost: N arithmetic operations`), summed per header; the check fails (exit status 1)
  when an operation count differs by more than TOLERANCE, and says so;
- **times**: the whole `python -m ipgen` process (wall and CPU time of a fresh process: start,
  imports, derivation, code generation, writing) and, in a second fresh process, the
  derivation and the header's rendering alone (imports excluded), alternating old and new in
  every round so that both see the same machine load; medians over the rounds; peak memory.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import statistics
import subprocess
import sys
import tarfile
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

from bench.memory import ResidentLimit
from bench.report import BUILD, PYTHON, ROOT, machine
from bench.systems import ipgen_command

BASELINE = "4df5fe6"  # the last commit on the hand-written polynomial class (generator/poly.py)
TOLERANCE = 0.02  # largest relative change of an operation count that passes
# The paper's systems, then n = 5, 10, 20 of both types, and a few variants with other code paths.
SYSTEMS: tuple[tuple[str, ...], ...] = (
    ("--type", "classical", "--links", "2"),
    ("--type", "rotary", "--links", "1"),
    *(("--type", kind, "--links", str(n)) for kind in ("classical", "rotary") for n in (5, 10, 20)),
    ("--type", "rotary", "--links", "3", "--inertia", "full"),
    ("--type", "classical", "--links", "3", "--fix", "m0=0.3,l1=0.5,delta2=0"),
    ("--scene", "scenes/cdip_pulse.toml"),
    ("--scene", "scenes/rsip_pulse.toml"),
)
TIMED_LINKS = (1, 2, 5, 10, 20)
LARGE = (("classical", 50),)
LARGE_MEMORY_GB = 6.0  # the machine is shared: a large system gets at most this much memory
_COST = re.compile(r"Cost: (\d+) arithmetic operations")

# Run in a fresh process of either checkout: the derivation and the header's rendering, imports done.
_IN_PROCESS = """
import json, sys, time
from ipgen.codegen.header import HeaderRequest, render_header
try:
    from ipgen.model.derivation import derive
    from ipgen.model.system import System
except ModuleNotFoundError:  # a checkout from before the package's stages (the baseline)
    from ipgen.derive import derive
    from ipgen.model import System
kind, links = sys.argv[1], int(sys.argv[2])
start = time.perf_counter()
equations = derive(System(kind, links))
derived = time.perf_counter()
render_header(equations, HeaderRequest(f"{kind}{links}", "timing"))
print(json.dumps({"derive_s": derived - start, "codegen_s": time.perf_counter() - derived}))
"""


def materialise(commit: str, label: str = "baseline") -> Path:
    """A folder (build/bench/<label>-<commit>) holding `commit`'s generator as the importable
    package `ipgen` (cached): what the benchmarks compare this checkout with."""
    target = BUILD / f"{label}-{commit}"
    package = target / "ipgen"
    if (package / "__init__.py").exists():
        return target
    archive = subprocess.run(
        ["git", "-C", str(ROOT), "archive", "--format=tar", commit, "generator", "templates"],
        capture_output=True,
        check=True,
    ).stdout
    source = target / "src"
    source.mkdir(parents=True, exist_ok=True)
    with tempfile.NamedTemporaryFile(suffix=".tar") as tar:
        tar.write(archive)
        tar.flush()
        with tarfile.open(tar.name) as opened:
            opened.extractall(source, filter="data")
    (source / "generator").rename(package)
    (source / "templates").rename(package / "templates")
    subprocess.run([PYTHON, "-m", "compileall", "-q", str(package)], check=True)
    return target


def _environment(path: Path | None, ground_types: str = "") -> dict[str, str]:
    """The environment of a process that imports `ipgen` from `path` (None: this checkout),
    with sympy's SYMPY_GROUND_TYPES set to `ground_types` if given."""
    env = dict(os.environ)
    if ground_types:
        env["SYMPY_GROUND_TYPES"] = ground_types
    if path is not None:
        env["PYTHONPATH"] = str(path)
    else:
        env.pop("PYTHONPATH", None)
    return env


def _timed(
    command: list[str], path: Path | None, ground_types: str = "", memory_limit_gb: float = 0.0
) -> dict:
    """Wall, CPU and peak memory of one fresh process, with its JSON output if it prints some.

    With `memory_limit_gb` the process is killed when its resident memory exceeds that
    (`bench.memory`), and a failure is recorded (`failed`: its last line of stderr) instead of
    ending the benchmark."""
    start = time.perf_counter()
    process = subprocess.Popen(
        command,
        cwd=ROOT,
        env=_environment(path, ground_types),
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    )
    with ResidentLimit(process, memory_limit_gb) as watch:
        _, status, usage = os.wait4(process.pid, 0)
    wall = time.perf_counter() - start
    out = process.stdout.read().decode() if process.stdout else ""
    error = process.stderr.read().decode() if process.stderr else ""
    for stream in (process.stdout, process.stderr):
        if stream:
            stream.close()
    result = {"wall_s": wall, "cpu_s": usage.ru_utime + usage.ru_stime, "peak_mb": usage.ru_maxrss / 1024}
    if os.waitstatus_to_exitcode(status) != 0:
        if memory_limit_gb:
            last = "killed" if watch.tripped else (error.strip().splitlines() or ["?"])[-1]
            return result | {"failed": f"{last} (resident memory limited to {memory_limit_gb:g} GB)"}
        raise SystemExit(f"bench: {' '.join(command)} failed: {error.strip()}")
    return result | (json.loads(out) if out.strip().startswith("{") else {})


@dataclass
class HeaderCheck:
    system: str
    identical: bool
    operations: tuple[int, int]  # old, new (summed over the header's functions)
    changed: list[str] = field(default_factory=list)  # functions whose count moved beyond TOLERANCE


def compare_headers(baseline: Path) -> list[HeaderCheck]:
    """Write every SYSTEMS entry with both generators and compare the files."""
    checks = []
    for arguments in SYSTEMS:
        written: list[dict[str, str]] = []
        for path in (baseline, None):
            with tempfile.TemporaryDirectory(prefix="ipgen-baseline-") as out:
                force = ["--force"] if "--scene" not in arguments else []
                _timed([PYTHON, "-m", "ipgen", *arguments, "-o", out, *force], path)
                written.append({p.name: p.read_text() for p in sorted(Path(out).iterdir())})
        old, new = written
        identical = old == new
        old_costs = [int(c) for text in old.values() for c in _COST.findall(text)]
        new_costs = [int(c) for text in new.values() for c in _COST.findall(text)]
        changed = [
            f"function {i}: {a} -> {b}"
            for i, (a, b) in enumerate(zip(old_costs, new_costs, strict=False))
            if abs(b - a) > TOLERANCE * a
        ]
        if len(old_costs) != len(new_costs):
            changed.append(f"{len(old_costs)} functions -> {len(new_costs)}")
        checks.append(HeaderCheck(" ".join(arguments), identical, (sum(old_costs), sum(new_costs)), changed))
    return checks


@dataclass
class Timing:
    type: str
    links: int
    old: list[dict[str, float]] = field(default_factory=list)
    new: list[dict[str, float]] = field(default_factory=list)

    def median(self, side: str, key: str) -> float | None:
        values = [r[key] for r in getattr(self, side) if key in r and "failed" not in r]
        return statistics.median(values) if values else None

    def failure(self, side: str) -> str:
        return next((r["failed"] for r in getattr(self, side) if "failed" in r), "")


def time_points(
    baseline: Path, points: list[tuple[str, int]], rounds: int, memory_limit_gb: float = 0.0
) -> list[Timing]:
    """Old and new alternating, `rounds` times per point; with `memory_limit_gb` (large systems)
    only the whole process is timed, under that limit."""
    timings = []
    for kind, links in points:
        timing = Timing(kind, links)
        for _ in range(rounds):
            for side, path in (("old", baseline), ("new", None)):
                with tempfile.TemporaryDirectory(prefix="ipgen-baseline-") as out:
                    whole = _timed(ipgen_command(PYTHON, kind, links, out), path, "", memory_limit_gb)
                if memory_limit_gb:
                    getattr(timing, side).append(whole)
                    continue
                inner = _timed([PYTHON, "-c", _IN_PROCESS, kind, str(links)], path)
                getattr(timing, side).append(whole | {k: v for k, v in inner.items() if k.endswith("_s")})
        print(f"  {kind} n={links}: done", file=sys.stderr, flush=True)
        timings.append(timing)
    return timings


def ground_types(points: list[tuple[str, int]], rounds: int) -> list[str]:
    """This checkout's derivation + rendering (imports excluded) with sympy's pure-Python
    rationals against gmpy2's, alternating in every round: a Markdown table."""
    lines = [
        "| type | n | python [s] | gmpy [s] | gmpy / python |",
        "| --- | ---: | ---: | ---: | ---: |",
    ]
    for kind, links in points:
        times: dict[str, list[float]] = {"python": [], "gmpy": []}
        for _ in range(rounds):
            for types in times:
                inner = _timed([PYTHON, "-c", _IN_PROCESS, kind, str(links)], None, types)
                times[types].append(inner["derive_s"] + inner["codegen_s"])
        python, gmpy = (statistics.median(times[t]) for t in ("python", "gmpy"))
        lines.append(f"| {kind} | {links} | {python:.3f} | {gmpy:.3f} | {gmpy / python:.2f} |")
        print(lines[-1], file=sys.stderr, flush=True)
    return lines


def _s(value: float | None) -> str:
    return "–" if value is None else f"{value:.3f}"


def markdown(commit: str, checks: list[HeaderCheck], timings: list[Timing], rounds: int) -> str:
    lines = [
        f"# The generator against commit {commit}",
        "",
        "Written by `python -m bench.against_baseline` (bench/against_baseline.py): the same systems",
        f"generated by this checkout and by commit {commit} (materialised from git at run time), in one run.",
        "",
        *machine(),
        "",
        "## Headers",
        "",
        f"Operation counts are the sums of the `Cost:` comments of every function of the header(s);"
        f" a function whose count moves by more than {TOLERANCE:.0%} fails the check.",
        "",
        "| system | byte-identical | operations old | operations new | check |",
        "| --- | --- | ---: | ---: | --- |",
    ]
    for c in checks:
        verdict = "ok" if not c.changed else "CHANGED: " + "; ".join(c.changed)
        identical = "yes" if c.identical else "no"
        lines.append(f"| `{c.system}` | {identical} | {c.operations[0]} | {c.operations[1]} | {verdict} |")
    lines += [
        "",
        "## Times",
        "",
        "Seconds, medians over the rounds (old and new alternate within each round). *process*: wall",
        "time of the whole `python -m ipgen --type T --links N -o DIR` (start, imports, derivation, code",
        "generation, writing); *CPU*: its user + system time; *derive + codegen*: `derive()` and",
        "`render_header()` alone in a fresh process, imports excluded. *peak*: the process's peak",
        "resident memory (Linux keeps the high-water mark across exec: a peak below the forking",
        f"benchmark's own size reads as that size). {rounds} round(s); large systems one.",
        "",
        "| type | n | process old | process new | new/old | CPU old | CPU new | derive+codegen old"
        " | derive+codegen new | new/old | peak old [MB] | peak new [MB] |",
        "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |",
    ]
    for t in timings:
        old_wall, new_wall = t.median("old", "wall_s"), t.median("new", "wall_s")
        old_in = _sum(t.median("old", "derive_s"), t.median("old", "codegen_s"))
        new_in = _sum(t.median("new", "derive_s"), t.median("new", "codegen_s"))
        cells = [
            t.type,
            str(t.links),
            _s(old_wall),
            _s(new_wall),
            _ratio(new_wall, old_wall),
            _s(t.median("old", "cpu_s")),
            _s(t.median("new", "cpu_s")),
            _s(old_in),
            _s(new_in),
            _ratio(new_in, old_in),
            _mb(t.median("old", "peak_mb")),
            _mb(t.median("new", "peak_mb")),
        ]
        lines.append("| " + " | ".join(cells) + " |")
    failures = [(t, side, t.failure(side)) for t in timings for side in ("old", "new") if t.failure(side)]
    if failures:
        lines.append("")
    for t, side, failure in failures:
        cpu = t.__dict__[side][0]["cpu_s"]
        lines.append(f"- {t.type} n = {t.links}, {side}: failed after {cpu:.0f} s CPU: `{failure}`.")
    return "\n".join(lines) + "\n"


def _sum(a: float | None, b: float | None) -> float | None:
    return None if a is None or b is None else a + b


def _ratio(a: float | None, b: float | None) -> str:
    return "–" if a is None or not b else f"{a / b:.2f}"


def _mb(value: float | None) -> str:
    return "–" if value is None else f"{value:.0f}"


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(
        prog="python -m bench.against_baseline", description=__doc__.split("\n")[0]
    )
    parser.add_argument("--commit", default=BASELINE, help=f"the earlier generator (default {BASELINE})")
    parser.add_argument("--links", default=",".join(map(str, TIMED_LINKS)), help="n to time, comma-separated")
    parser.add_argument("--types", default="classical,rotary")
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--large", action="store_true", help="also classical n = 50 (--force), one round")
    parser.add_argument("--no-headers", action="store_true", help="times only")
    parser.add_argument(
        "--ground-types",
        action="store_true",
        help="instead: this checkout with SYMPY_GROUND_TYPES=python against gmpy (needs gmpy2)",
    )
    parser.add_argument("--out", type=Path, default=ROOT / "docs" / "bench" / "baseline.md")
    args = parser.parse_args(argv)
    points = [(kind, int(n)) for kind in args.types.split(",") for n in args.links.split(",")]
    if args.ground_types:
        print("\n".join([*machine(), "", *ground_types(points, args.rounds)]))
        return
    baseline = materialise(args.commit)
    checks = [] if args.no_headers else compare_headers(baseline)
    for c in checks:
        print(f"  {c.system}: identical={c.identical} operations {c.operations[0]} -> {c.operations[1]}")
    timings = time_points(baseline, points, args.rounds)
    if args.large:
        timings += time_points(baseline, list(LARGE), 1, LARGE_MEMORY_GB)
    text = markdown(args.commit, checks, timings, args.rounds)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(text)
    print(text)
    if any(c.changed for c in checks):
        raise SystemExit("bench: operation counts changed beyond the tolerance (see above)")


if __name__ == "__main__":
    main()
