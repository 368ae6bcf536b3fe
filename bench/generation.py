"""Generation benchmark: the whole `ipgen` command against sympy.physics.mechanics derivations.

Every point runs in a fresh process. ipgen is timed as the process wall time of
`python -m generator --type T --links N -o DIR` (imports, derivation, code generation, writing).
The references (bench/references.py) report the derivation alone, imports excluded, and the
process wall time. A run shorter than REPEAT_BELOW is repeated and the median of RUNS (FLOOR_RUNS for
the start-up floor) reported. A
run over the time limit is stopped and reported as "> limit"; larger n of that method are
skipped. Rotary systems use the default (pivot) inertia on both sides.
"""

from __future__ import annotations

import json
import resource
import statistics
import subprocess
import tempfile
import time
from dataclasses import asdict, dataclass
from pathlib import Path

from tqdm import tqdm

from bench.memory import ResidentLimit
from bench.references import agrees_with_ipgen
from bench.report import PYTHON, ROOT, machine, seconds, style_axis, table, verdict
from bench.systems import LINKS, TYPES, ipgen_command

METHODS = ("ipgen", "kane", "lagrange")
# The start-up floor: an interpreter that only imports the libraries ipgen is built on (the CLI,
# the templates and python-flint, whose polynomials the derivation uses). No ipgen command can be
# faster; where KanesMethod's derivation is faster still, the target is out of reach for any tool
# built on them.
FLOOR = "floor"
FLOOR_CODE = "import click, jinja2, flint"
EXTRA = (("classical", 50),)  # ipgen alone, one run, with the --force ipgen asks for (systems.py)
EXTRA_TIMEOUT = 900.0
EXTRA_MEMORY_GB = 6.0  # the machine is shared: the large system gets at most this much memory
TIMEOUT = 120.0
REPEAT_BELOW = 10.0
RUNS = 3  # runs of a quick point (median)
FLOOR_RUNS = 11  # the floor is the yardstick of every small-n point: more runs
TARGET_N20 = 10.0
TOLERANCE = 1e-10  # the references must derive ipgen's equations (checked at n = 2)


@dataclass
class Timing:
    type: str
    method: str  # ipgen, kane or lagrange
    links: int
    wall_s: float | None  # process wall time, None when it timed out or was skipped
    derive_s: float | None  # references only: the derivation, imports excluded
    runs: int
    status: str  # ok, timeout, skipped or failed
    error: str = ""
    # CPU time (user + system) of the process, and of the derivation alone (references): wall time
    # minus the time other processes of the machine took from it
    cpu_s: float | None = None
    derive_cpu_s: float | None = None


def _command(method: str, kind: str, links: int, directory: str) -> list[str]:
    if method == FLOOR:
        return [PYTHON, "-c", FLOOR_CODE]
    if method == "ipgen":
        return ipgen_command(PYTHON, kind, links, directory)
    return [PYTHON, "-m", "bench.references", method, kind, str(links)]


def _run_once(
    method: str, kind: str, links: int, timeout: float, memory_limit_gb: float = 0.0
) -> dict[str, float]:
    """Wall and CPU seconds of one fresh process (and the derivation's, for references); with
    `memory_limit_gb`, the process is killed when its resident memory exceeds that."""
    with tempfile.TemporaryDirectory(prefix="ipgen-bench-") as directory:
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        start = time.perf_counter()
        command = _command(method, kind, links, directory)
        process = subprocess.Popen(
            command, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
        )
        with ResidentLimit(process, memory_limit_gb) as watch:
            try:
                out, error = process.communicate(timeout=timeout)
            except subprocess.TimeoutExpired:
                process.kill()
                process.communicate()
                raise
        if process.returncode != 0:
            why = f"resident memory over {memory_limit_gb:g} GB" if watch.tripped else error
            raise subprocess.CalledProcessError(process.returncode, command, out, why)
        wall = time.perf_counter() - start
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime
    reference = method not in ("ipgen", FLOOR)
    return {"wall_s": wall, "cpu_s": cpu} | (json.loads(out) if reference else {})


def measure(
    method: str,
    kind: str,
    links: int,
    timeout: float = TIMEOUT,
    repeat: bool = True,
    quick_runs: int = RUNS,
    memory_limit_gb: float = 0.0,
) -> Timing:
    """Time one point: once, and `quick_runs` times in all (median) when it was quick."""
    try:
        runs = [_run_once(method, kind, links, timeout, memory_limit_gb)]
        if repeat and runs[0]["wall_s"] < REPEAT_BELOW:
            runs += [_run_once(method, kind, links, timeout) for _ in range(quick_runs - 1)]
    except subprocess.TimeoutExpired:
        return Timing(kind, method, links, None, None, 1, "timeout")
    except subprocess.CalledProcessError as e:
        message = (e.stderr or "").strip().splitlines()
        return Timing(kind, method, links, None, None, 1, "failed", message[-1] if message else str(e))

    def median(key: str) -> float | None:
        return statistics.median(r[key] for r in runs) if key in runs[0] else None

    return Timing(
        kind,
        method,
        links,
        median("wall_s"),
        median("derive_s"),
        len(runs),
        "ok",
        cpu_s=median("cpu_s"),
        derive_cpu_s=median("derive_cpu_s"),
    )


def sweep(
    links: tuple[int, ...] = LINKS,
    types: tuple[str, ...] = TYPES,
    timeout: float = TIMEOUT,
    extra: tuple[tuple[str, int], ...] = EXTRA,
) -> tuple[list[Timing], dict[str, float]]:
    """Check that the references derive ipgen's equations, then time every point."""
    checks = {f"{method} {kind}": agrees_with_ipgen(method, kind) for kind in types for method in METHODS[1:]}
    for name, difference in checks.items():
        if difference > TOLERANCE:
            raise SystemExit(f"bench: the {name} reference differs from ipgen by {difference:.1e}: no timing")
    points = [("any", FLOOR, 0)]
    points += [(kind, method, n) for kind in types for method in METHODS for n in links]
    points += [(kind, "ipgen", n) for kind, n in extra]
    results: list[Timing] = []
    timed_out: set[tuple[str, str]] = set()
    with tqdm(points, desc="generation", unit="point", leave=True) as bar:
        for kind, method, n in bar:
            bar.set_postfix_str(f"{method} {kind} n={n}")
            if (kind, method) in timed_out:
                results.append(Timing(kind, method, n, None, None, 0, "skipped"))
                continue
            once = (kind, n) in extra
            limit = EXTRA_TIMEOUT if once else timeout
            runs = FLOOR_RUNS if method == FLOOR else RUNS
            memory = EXTRA_MEMORY_GB if once else 0.0
            timing = measure(method, kind, n, limit, repeat=not once, quick_runs=runs, memory_limit_gb=memory)
            if timing.status == "timeout":
                timed_out.add((kind, method))
            results.append(timing)
    return results, checks


def _find(results: list[Timing], kind: str, method: str, n: int) -> Timing | None:
    return next((r for r in results if (r.type, r.method, r.links) == (kind, method, n)), None)


def floor(results: list[Timing]) -> Timing | None:
    return _find(results, "any", FLOOR, 0)


def _out_of_reach(kane: Timing, start: Timing | None, cpu: bool) -> bool:
    """Kane's derivation alone is faster than an interpreter that only imports click and jinja2."""
    theirs = _theirs(kane, cpu)
    mine = None if start is None else _ours(start, cpu)
    return theirs is not None and mine is not None and theirs < mine


def _cell(timing: Timing | None, derive: bool, timeout: float) -> str:
    if timing is None:
        return "–"
    if timing.status == "timeout":
        return f"> {timeout:.0f}"
    if timing.status == "skipped":
        return "skipped"
    if timing.status == "failed":
        return "failed"
    return seconds(timing.derive_s if derive else timing.wall_s)


def _cpu(timing: Timing | None, derive: bool) -> str:
    value = None if timing is None else (timing.derive_cpu_s if derive else timing.cpu_s)
    return seconds(value)


def _ours(timing: Timing, cpu: bool) -> float | None:
    return timing.cpu_s if cpu else timing.wall_s


def _theirs(timing: Timing, cpu: bool) -> float | None:
    return timing.derive_cpu_s if cpu else timing.derive_s


def _faster(ours: Timing, kane: Timing, timeout: float, cpu: bool) -> bool:
    mine = _ours(ours, cpu)
    if mine is None:
        return False
    if kane.status in ("timeout", "skipped"):  # Kane's method took longer than the limit
        return mine < timeout
    theirs = _theirs(kane, cpu)
    return theirs is not None and mine < theirs


def targets(
    results: list[Timing], timeout: float = TIMEOUT, cpu: bool = False
) -> list[tuple[str, bool | None, str]]:
    """The issue's targets on wall time (or, with cpu, on CPU time): (statement, met?, misses).

    met is None when not measured in this run.
    """
    clock = "CPU time" if cpu else "wall time"
    verdicts: list[tuple[str, bool | None, str]] = []
    for kind in TYPES:
        pairs = [(_find(results, kind, "ipgen", n), _find(results, kind, "kane", n)) for n in range(1, 21)]
        pairs = [(ours, kane) for ours, kane in pairs if ours is not None and kane is not None]
        start = floor(results)
        misses = [
            f"n={ours.links}" + (" (below the start-up floor)" if _out_of_reach(kane, start, cpu) else "")
            for ours, kane in pairs
            if not _faster(ours, kane, timeout, cpu)
        ]
        verdicts.append(
            (
                f"{kind}: the whole ipgen command faster than KanesMethod's derivation alone, every n ≤ 20"
                f" ({clock})",
                (not misses) if pairs else None,
                ", ".join(misses),
            )
        )
        n20 = _find(results, kind, "ipgen", 20)
        seconds_n20 = None if n20 is None else _ours(n20, cpu)
        met = None if n20 is None else seconds_n20 is not None and seconds_n20 < TARGET_N20
        verdicts.append((f"{kind}: ipgen n = 20 under {TARGET_N20:.0f} s ({clock})", met, ""))
    return verdicts


def markdown(
    results: list[Timing], checks: dict[str, float], timeout: float = TIMEOUT, cse: list[str] | None = None
) -> str:
    lines = [
        "# Generation time: ipgen against sympy.physics.mechanics",
        "",
        "Written by `make bench` (bench/run.py, bench/generation.py); seconds, lower is better.",
        "",
        "![seconds to derive the equations against the number of links](generation.png)",
        "",
        "- **ipgen**: process wall time of `python -m generator --type T --links N -o DIR`, everything",
        "  included (interpreter start, imports, derivation, C++ generation, writing the header).",
        "- **Kane / Lagrange**: `sympy.physics.mechanics` `KanesMethod` / `LagrangesMethod` deriving the",
        "  same model (bench/references.py: rods with CoG at l/2 and inertia m l²/12, absolute angles,",
        "  the same damping; rotary links with the pivot inertia, ipgen's default) up to the mass matrix",
        "  and forcing vector, no code generation. *derive*: the derivation alone, imports excluded;",
        "  *process*: wall time of the whole process. *(CPU)*: user + system CPU time of the same (the",
        "  machine is shared: wall time includes time other processes took). The targets use wall time.",
        "- Before timing, each reference's M and forcing are checked against ipgen's M and B u − bias at",
        "  n = 2 (a random state): largest relative difference "
        f"{max(checks.values(), default=float('nan')):.1e}.",
        "  The frames, bodies and loads are tests/independent_model.py's, the model the tests check",
        "  ipgen against.",
        f"- **Start-up floor**: a process that only runs `python -c '{FLOOR_CODE}'`, the CLI, template",
        "  and polynomial libraries ipgen is built on; no ipgen command can be faster. A miss marked",
        "  *below the start-up floor* is one where KanesMethod's derivation alone takes less than that:",
        "  out of reach for any tool built on them.",
        f"- Each point in a fresh process; median of {RUNS} runs ({FLOOR_RUNS} for the floor) when a run",
        f"  takes under {REPEAT_BELOW:.0f} s, else one run. Runs over {timeout:.0f} s are stopped",
        f'  ("> {timeout:.0f}"), larger n then skipped.',
        "",
        *machine(),
        "",
    ]
    links = sorted({r.links for r in results if (r.type, r.links) not in EXTRA and r.method != FLOOR})
    start = floor(results)
    if start is not None:
        lines += [
            f"Start-up floor (`python -c '{FLOOR_CODE}'`): {_cell(start, False, timeout)} s wall,"
            f" {_cpu(start, False)} s CPU.",
            "",
        ]
    for kind in TYPES:
        if not any(r.type == kind for r in results):
            continue
        lines += [f"## {kind}", ""]
        rows = []
        for n in links:
            ours, kane, lagrange = (_find(results, kind, m, n) for m in METHODS)
            ratio = (
                f"{ours.wall_s / kane.derive_s:.2f}"
                if ours and kane and ours.wall_s and kane.derive_s
                else "–"
            )
            rows.append(
                [
                    str(n),
                    _cell(ours, False, timeout),
                    _cpu(ours, False),
                    _cell(kane, True, timeout),
                    _cpu(kane, True),
                    _cell(kane, False, timeout),
                    _cell(lagrange, True, timeout),
                    _cell(lagrange, False, timeout),
                    ratio,
                ]
            )
        header = [
            "n",
            "ipgen command",
            "(CPU)",
            "Kane derive",
            "(CPU)",
            "Kane process",
            "Lagrange derive",
            "Lagrange process",
            "ipgen / Kane derive",
        ]
        lines += [*table(header, rows), ""]
        for kind_extra, n in EXTRA:
            big = _find(results, kind_extra, "ipgen", n)
            if kind_extra == kind and big is not None:
                text = f"{_cell(big, False, EXTRA_TIMEOUT)} s" + (f" ({big.error})" if big.error else "")
                lines += [f"ipgen, {kind} n = {n} (one run, `--force`): {text}.", ""]
    lines += ["## Targets", ""]
    lines += [
        "The issue states the targets in wall time; on a busy shared machine wall time also counts what",
        "other processes took, so they are judged on CPU time as well.",
        "",
    ]
    for text, met, misses in targets(results, timeout) + targets(results, timeout, cpu=True):
        state = "not measured" if met is None else verdict(met)
        lines.append(f"- {text}: **{state}**" + (f" ({misses})" if misses else ""))
    if cse:
        lines += ["", *cse]
    return "\n".join(lines) + "\n"


def plot(results: list[Timing], path: Path, timeout: float = TIMEOUT) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    kinds = [kind for kind in TYPES if any(r.type == kind for r in results)]
    figure, axes = plt.subplots(1, len(kinds), figsize=(5.5 * len(kinds), 4.2), squeeze=False)
    series = [
        ("ipgen", False, "ipgen command (process)", "C0", "-"),
        ("kane", True, "KanesMethod (derivation only)", "C1", "-"),
        ("kane", False, "KanesMethod (process)", "C1", ":"),
        ("lagrange", True, "LagrangesMethod (derivation only)", "C2", "-"),
        ("lagrange", False, "LagrangesMethod (process)", "C2", ":"),
    ]
    for axis, kind in zip(axes[0], kinds, strict=True):
        for method, derive, label, colour, style in series:
            points = sorted(
                (r.links, r.derive_s if derive else r.wall_s)
                for r in results
                if r.type == kind and r.method == method and r.status == "ok"
            )
            if points:
                xs, ys = zip(*points, strict=True)
                axis.plot(xs, ys, style, color=colour, marker="o", markersize=3, label=label)
        start = floor(results)
        if start is not None and start.wall_s is not None:
            label = f"start-up floor ({FLOOR_CODE})"
            axis.axhline(start.wall_s, color="C0", linewidth=0.6, linestyle="--", label=label)
        axis.axhline(timeout, color="grey", linewidth=0.6, linestyle="--", label=f"limit {timeout:.0f} s")
        style_axis(axis, sorted({r.links for r in results if r.type == kind}), "seconds", kind)
    figure.suptitle("Deriving the equations of motion (lower is better)")
    figure.tight_layout()
    figure.savefig(path, dpi=120)
    plt.close(figure)


def save(
    results: list[Timing],
    checks: dict[str, float],
    directory: Path,
    timeout: float = TIMEOUT,
    cse: list[str] | None = None,
) -> None:
    """generation.md (with the CSE comparison's section `cse`, if given), .json and .png."""
    directory.mkdir(parents=True, exist_ok=True)
    (directory / "generation.md").write_text(markdown(results, checks, timeout, cse))
    record = {"checks": checks, "timings": [asdict(r) for r in results]}
    (directory / "generation.json").write_text(json.dumps(record, indent=1) + "\n")
    plot(results, directory / "generation.png", timeout)
