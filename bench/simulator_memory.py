"""Peak resident memory of the simulator for 10^4 and 10^7 output samples (issue 19).

simulate_<model> streams each sample to its CSV as the integration reaches it, so its memory
should not grow with the number of samples. This runs the simulator `ipgen run` builds (ipsim's
simulator compiled once, on the model library of classical2: pipeline/simulator.py; built into
the cache first if needed) on the paper's double pendulum on a cart (scenes/cdip_pulse.toml
resolved by `ipgen run --no-plot`: a 0.4 N push for 1 s) for the same
t_end with two sample periods, 10^4 and 10^7 samples, and reads each run's peak resident set
(`/usr/bin/time -f %M`: ru_maxrss of its child). Not os.wait4 on a child of this Python process:
Linux carries the high-water mark of the process image an exec replaces into ru_maxrss, so every
child would show at least this interpreter's ~20 MB. Target: the two peaks within 20 MB.
The CSV (about 1.4 GB for 10^7 samples) goes to build/bench/simulator_memory/ and is deleted.
Writes docs/bench/simulator_memory.md (or --out); exit status 1 when the target is missed.

    python -m bench.simulator_memory [--simulator PATH --cfg CFG] [--out FILE]

--simulator measures another simulator (e.g. CMake's build/bin/simulate_cdip, compiled for the
model, with --cfg build/scenes/cdip_pulse.cfg, or one built from an older commit) and prints
its numbers without writing the report.
"""

from __future__ import annotations

import argparse
import os
import re
import shlex
import subprocess
import sys
import tempfile
import threading
import time
from dataclasses import dataclass
from pathlib import Path

from bench.report import BUILD, ROOT, machine, table

T_END = 100.0  # s of simulated time in both runs
SAMPLES = (10**4, 10**7)
TARGET_MB = 20.0
OUT = ROOT / "docs" / "bench" / "simulator_memory.md"
POLL_S = 0.5
TIME = Path("/usr/bin/time")  # GNU time (Debian package `time`)
# The simulator before streaming (commit 67de603), measured with
# `python -m bench.simulator_memory --simulator <its simulate_cdip>` on the machine below:
# peak RSS [MiB] for 1e4 and 1e7 samples.
BEFORE = ("67de603", 8.4, 770.8)


@dataclass(frozen=True)
class Run:
    samples: int
    peak_mb: float  # peak resident set of the simulator [MiB]
    wall: float  # s
    csv_bytes: int


def measure(
    simulator: list[str], cfg: Path, samples: int, folder: Path, bytes_per_row: float | None
) -> Run:
    """One run to T_END sampled every T_END / samples (samples + 1 rows): peak RSS, wall time, CSV size."""
    from tqdm import tqdm

    sample = T_END / samples
    csv = folder / f"cdip_{samples}.csv"
    command = [*simulator, str(cfg), "--t-end", repr(T_END), "--sample", repr(sample), "--csv", str(csv)]
    command += ["--force"]
    with tempfile.NamedTemporaryFile("r", suffix=".rss") as rss:
        started = time.monotonic()
        process = subprocess.Popen(
            [str(TIME), "-f", "%M", "-o", rss.name, *command],
            stdout=subprocess.DEVNULL,
            stderr=subprocess.PIPE,
        )
        # The child's stderr is read by a thread, so that a long warning cannot block it.
        errors: list[bytes] = []
        reader = threading.Thread(
            target=lambda: errors.append(process.stderr.read() if process.stderr else b"")
        )
        reader.start()
        total = int(samples * bytes_per_row) if bytes_per_row else None
        with tqdm(total=total, desc=f"{samples:.0e} samples", unit="B", unit_scale=True, leave=False) as bar:
            while process.poll() is None:
                written = sum(p.stat().st_size for p in folder.glob(".simulate.*"))
                bar.update(max(0, written - bar.n))
                time.sleep(POLL_S)
        wall = time.monotonic() - started
        reader.join()
        if process.returncode != 0:
            raise SystemExit(
                f"simulator_memory: {' '.join(command)} failed: {b''.join(errors).decode().strip()}"
            )
        peak_kb = int(rss.read().split()[-1])
    size = csv.stat().st_size
    csv.unlink()
    return Run(samples, peak_kb / 1024.0, wall, size)


def run_simulator(folder: Path) -> tuple[list[str], Path]:
    """The simulator `ipgen run` runs for scenes/cdip_pulse.toml (the runtime simulator and the
    model library, from its launcher) and the .cfg it wrote; built into the cache if needed."""
    env = {**os.environ}
    env.pop("IPGEN_SIM_OPT", None)  # the default build, -O2
    scene = ROOT / "scenes" / "cdip_pulse.toml"
    done = subprocess.run(
        [sys.executable, "-m", "ipgen", "run", str(scene), "-o", str(folder), "--no-plot", "--force"],
        capture_output=True,
        text=True,
        env=env,
    )
    if done.returncode != 0:
        raise SystemExit(f"simulator_memory: ipgen run failed: {done.stderr.strip()}")
    summary = (folder / "cdip_pulse.txt").read_text()
    launcher = Path(re.search(r"Simulator (.+?) \((built in|taken from the cache)", summary).group(1))
    words = shlex.split(launcher.read_text().splitlines()[1])  # exec PROGRAM --model LIBRARY "$@"
    (folder / "cdip_pulse.csv").unlink(missing_ok=True)
    return words[1:4], folder / "cdip_pulse.cfg"


def report(runs: list[Run], simulator: list[str], cfg: Path) -> list[str]:
    small, large = runs
    growth = large.peak_mb - small.peak_mb
    verdict = "met" if abs(growth) <= TARGET_MB else "MISSED"
    rows = [
        [
            f"{r.samples:.0e}".replace("e+0", "e"),
            f"{T_END / r.samples:g}",
            f"{r.csv_bytes / 1e6:,.1f}",
            f"{r.wall:.1f}",
            f"{r.peak_mb:.1f}",
        ]
        for r in runs
    ]
    return [
        "# Memory of the simulator: streamed output",
        "",
        "Written by `make bench-memory` (`python -m bench.simulator_memory`, part of `make bench`).",
        "The simulator `ipgen run` builds and runs (ipsim's simulator compiled once, loading the",
        f"model library of classical2: `{' '.join(Path(word).name for word in simulator)}`) runs the paper's",
        f"double pendulum on a cart (`{cfg.name}`: a 0.4 N push for 1 s, bdf, rtol 1e-10) to t = {T_END:g} s",
        "with two sample periods; peak RSS is `/usr/bin/time -f %M` of the simulator. It writes",
        "each sample to its temporary CSV as the integration reaches it and keeps only the summary",
        "(first and last state, largest |u|, counters), so its memory does not grow with the samples.",
        "",
        *table(["samples", "sample [s]", "CSV [MB]", "wall [s]", "peak RSS [MiB]"], rows),
        "",
        f"Target: the two peaks within {TARGET_MB:g} MB: {verdict} (difference {growth:+.1f} MiB).",
        "",
        "Before streaming, the simulator kept every sample (and the list of every stop) in memory and",
        f"wrote the CSV at the end: commit {BEFORE[0]}'s simulate_cdip peaked at {BEFORE[1]:.1f} MiB for",
        f"10^4 samples and {BEFORE[2]:,.1f} MiB for 10^7 (measured once with `--simulator` on that build).",
        "",
        "Machine:",
        "",
        *machine(),
        "",
    ]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--simulator", type=Path, help="another simulator to measure (no report written)")
    parser.add_argument("--cfg", type=Path, help="the .cfg for --simulator (its model's)")
    parser.add_argument("--out", type=Path, default=OUT, help=f"report (default {OUT.relative_to(ROOT)})")
    args = parser.parse_args(argv)
    if not TIME.is_file():
        sys.exit(f"simulator_memory: {TIME} not found: install GNU time (Debian package `time`)")
    folder = BUILD / "simulator_memory"
    folder.mkdir(parents=True, exist_ok=True)
    if args.simulator is not None:
        if args.cfg is None:
            sys.exit("simulator_memory: --simulator needs --cfg (the resolved scene of its model)")
        simulator, cfg = [str(args.simulator.resolve())], args.cfg
    else:
        simulator, cfg = run_simulator(folder / "run")
    for path in (Path(simulator[0]), cfg):
        if not path.is_file():
            sys.exit(f"simulator_memory: {path} not found")
    runs: list[Run] = []
    for samples in SAMPLES:
        bytes_per_row = runs[0].csv_bytes / runs[0].samples if runs else None
        runs.append(measure(simulator, cfg, samples, folder, bytes_per_row))
        print(
            f"{samples:.0e} samples: peak RSS {runs[-1].peak_mb:.1f} MiB, {runs[-1].wall:.1f} s", flush=True
        )
    growth = runs[1].peak_mb - runs[0].peak_mb
    print(f"difference {growth:+.1f} MiB (target: within {TARGET_MB:g} MB)")
    if args.simulator is None:
        args.out.write_text("\n".join(report(runs, simulator, cfg)))
        print(f"wrote {args.out}")
    return 0 if abs(growth) <= TARGET_MB else 1


if __name__ == "__main__":
    sys.exit(main())
