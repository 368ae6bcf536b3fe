"""Process wall time and peak memory of the whole `ipgen` command, next to KanesMethod.

Each point runs `python -m generator --type T --links N -o <temporary folder>` in a fresh process
(Python start, imports, derivation, code generation, writing), repeated and reported as the
median. With --kane, sympy.physics.mechanics' KanesMethod derivation of the same system
(bench/references.py: the derivation alone, imports excluded) is timed in the same rounds,
alternating with ipgen, so that both see the same machine load. Peak memory is the maximum
resident set size of the ipgen process. The load average is printed before and after: the
machine may be shared.

    tools/time_generation.py                       # n = 1, 2, 3, 5, 10, 20, both types
    tools/time_generation.py --kane --repeat 5     # and KanesMethod, 5 rounds each
    tools/time_generation.py --large               # also n = 30 and 50 classical, once
    tools/time_generation.py --root ../other-checkout --links 1,20   # time another checkout
    tools/time_generation.py --baseline /tmp/ipgen-old --kane        # before/after, same rounds

By default the checkout's `generator` package is byte-compiled first (as `pip install` does),
so that the timings do not include compiling its sources, which PYTHONDONTWRITEBYTECODE would
otherwise repeat in every run; --no-compile keeps whatever is there.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
from bench.systems import LINKS, TYPES, ipgen_command  # noqa: E402

DEFAULT_PYTHON = ROOT / ".venv" / "bin" / "python"
LARGE = (("classical", 30), ("classical", 50))


@dataclass
class Point:
    type: str
    links: int
    wall_s: list[float] = field(default_factory=list)  # ipgen, one entry per round
    peak_mb: list[float] = field(default_factory=list)
    kane_derive_s: list[float] = field(default_factory=list)
    baseline_wall_s: list[float] = field(default_factory=list)
    baseline_peak_mb: list[float] = field(default_factory=list)

    def row(self) -> str:
        wall = statistics.median(self.wall_s)
        text = f"{self.type:9} {self.links:3}  {wall:8.3f} s  {max(self.peak_mb):7.0f} MB"
        if self.baseline_wall_s:
            before = statistics.median(self.baseline_wall_s)
            text += f"  {before:8.3f} s  {max(self.baseline_peak_mb):7.0f} MB"
        if self.kane_derive_s:
            kane = statistics.median(self.kane_derive_s)
            verdict = "faster" if wall < kane else "SLOWER"
            text += f"  {kane:8.3f} s  {wall / kane:5.2f}  {verdict}"
        return text


def run_ipgen(python: str, root: Path, kind: str, links: int) -> tuple[float, float]:
    """(wall time [s], peak resident memory [MB]) of one ipgen process."""
    env = {**os.environ, "PYTHONPATH": str(root)}
    with tempfile.TemporaryDirectory(prefix="ipgen-time-") as out:
        command = ipgen_command(python, kind, links, out)
        start = time.perf_counter()
        process = subprocess.Popen(
            command, cwd=root, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE
        )
        _, status, usage = os.wait4(process.pid, 0)
        wall = time.perf_counter() - start
        process.returncode = os.waitstatus_to_exitcode(status)
        error = process.stderr.read().decode() if process.stderr else ""
        if process.stderr:
            process.stderr.close()
        if process.returncode != 0:
            raise SystemExit(f"ipgen failed on {kind} {links}: {error.strip()}")
    return wall, usage.ru_maxrss / 1024  # ru_maxrss is in KiB on Linux


def run_kane(python: str, kind: str, links: int) -> float:
    """KanesMethod's derivation time (imports excluded), from bench/references.py."""
    done = subprocess.run(
        [python, "-m", "bench.references", "kane", kind, str(links)],
        cwd=ROOT,
        env={**os.environ, "PYTHONPATH": str(ROOT)},
        capture_output=True,
        text=True,
        check=True,
    )
    return float(json.loads(done.stdout)["derive_s"])


def load() -> str:
    one, five, fifteen = os.getloadavg()
    return f"load average {one:.2f}, {five:.2f}, {fifteen:.2f} ({os.cpu_count()} CPUs)"


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "--python", default=str(DEFAULT_PYTHON if DEFAULT_PYTHON.exists() else sys.executable)
    )
    parser.add_argument("--root", type=Path, default=ROOT, help="checkout whose generator is timed")
    parser.add_argument("--baseline", type=Path, help="another checkout, timed in the same rounds")
    parser.add_argument("--links", default=",".join(map(str, LINKS)), help="comma-separated n")
    parser.add_argument("--types", default=",".join(TYPES))
    parser.add_argument("--repeat", type=int, default=3, help="rounds per point (median reported)")
    parser.add_argument("--kane", action="store_true", help="also time KanesMethod's derivation")
    parser.add_argument("--large", action="store_true", help="also n = 30 and 50 classical, once each")
    parser.add_argument("--no-compile", action="store_true", help="do not byte-compile the package first")
    parser.add_argument("--json", type=Path, help="also write the raw timings here")
    args = parser.parse_args(argv)
    root = args.root.resolve()
    baseline = args.baseline.resolve() if args.baseline else None
    if not args.no_compile:
        for checkout in filter(None, (root, baseline)):
            subprocess.run([args.python, "-m", "compileall", "-q", str(checkout / "generator")], check=True)

    points = [Point(kind, int(n)) for kind in args.types.split(",") for n in args.links.split(",")]
    print(f"ipgen in {root}, {args.python}; {args.repeat} rounds; start: {load()}")
    if baseline:
        print(f"baseline: {baseline}")
    header = f"{'type':9} {'n':>3}  {'ipgen wall':>10}  {'peak':>10}"
    if baseline:
        header += f"  {'baseline':>10}  {'peak':>10}"
    if args.kane:
        header += f"  {'Kane derive':>10}  ratio"
    print(header)
    for point in points:
        for _ in range(args.repeat):
            wall, peak = run_ipgen(args.python, root, point.type, point.links)
            point.wall_s.append(wall)
            point.peak_mb.append(peak)
            if baseline:
                wall, peak = run_ipgen(args.python, baseline, point.type, point.links)
                point.baseline_wall_s.append(wall)
                point.baseline_peak_mb.append(peak)
            if args.kane:
                point.kane_derive_s.append(run_kane(args.python, point.type, point.links))
        print(point.row(), flush=True)
    if args.large:
        for kind, n in LARGE:
            point = Point(kind, n)
            wall, peak = run_ipgen(args.python, root, kind, n)
            point.wall_s.append(wall)
            point.peak_mb.append(peak)
            points.append(point)
            print(point.row(), flush=True)
    print(f"end: {load()}")
    if args.json:
        args.json.write_text(json.dumps([asdict(p) for p in points], indent=1) + "\n")


if __name__ == "__main__":
    main()
