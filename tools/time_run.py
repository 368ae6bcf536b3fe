"""Wall time of `ipgen run` on a scene: the first run of its model (an empty simulator cache, so
the simulator is compiled) and then cached runs (the README quotes these numbers).

    .venv/bin/python tools/time_run.py scenes/rdip_lqr.toml [--repeat 3]

Prints, with the load average before and after: the first run's total and compile time, and
each cached run's total, the simulation's own wall time (from the simulator's summary) and the
overhead (total − simulation: Python start-up, the derivation, the cache lookup, the plot).
"""

from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path


def load() -> str:
    return " ".join(f"{value:.2f}" for value in os.getloadavg())


def timed_run(scene: Path, out: Path, cache: Path) -> tuple[float, str, str]:
    start = time.perf_counter()
    done = subprocess.run(
        [sys.executable, "-m", "ipgen", "run", str(scene), "-o", str(out), "--force"],
        capture_output=True,
        text=True,
        env={**os.environ, "IPGEN_CACHE_DIR": str(cache)},
    )
    seconds = time.perf_counter() - start
    if done.returncode != 0:
        raise SystemExit(f"ipgen run failed ({done.returncode}): {done.stderr}")
    return seconds, done.stdout, done.stderr


def main() -> None:
    formatter = argparse.RawDescriptionHelpFormatter
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=formatter)
    parser.add_argument("scene", type=Path)
    parser.add_argument("--repeat", type=int, default=3, help="cached runs (default 3)")
    args = parser.parse_args()
    print(f"load average before (1, 5, 15 min): {load()}")
    with tempfile.TemporaryDirectory() as folder:
        out, cache = Path(folder) / "out", Path(folder) / "cache"
        seconds, _, stderr = timed_run(args.scene, out, cache)
        built = re.search(r"built \S+ in ([\d.]+) s", stderr)
        compile_time = f"{built.group(1)} s" if built else "not compiled?"
        print(f"first run: {seconds:.2f} s in all, of which compiling the simulator {compile_time}")
        for _ in range(args.repeat):
            seconds, stdout, stderr = timed_run(args.scene, out, cache)
            if "building" in stderr:
                raise SystemExit("a cached run compiled again")
            wall = re.search(r"Wall time ([\d.e+-]+) s", stdout)
            simulated = float(wall.group(1)) if wall else float("nan")
            print(
                f"cached run: {seconds:.2f} s in all, simulation {simulated:.3f} s, "
                f"overhead {seconds - simulated:.2f} s"
            )
    print(f"load average after (1, 5, 15 min): {load()}")


if __name__ == "__main__":
    main()
