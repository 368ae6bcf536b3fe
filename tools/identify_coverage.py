"""How often the 95 % intervals of ipgen identify contain the truth (docs/identify.md).

Runs the seeded synthetic experiments of tests/test_identify.py many more times than the test
does (rotary QUBE-Servo 2 with its DC motor: J1, delta0, delta1, kt; a cart with one link as
built: com1, J1, delta0, delta1; two noise levels alternating) and prints the fraction of runs
whose interval holds the true value, per parameter.

    python tools/identify_coverage.py [--runs 40]
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))
import test_identify as cases  # the test's experiments


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=40)
    args = parser.parse_args(argv)
    setup = cases.qube_setup()
    free = ("J1", "delta0", "delta1", "kt")
    truth = cases.truth_of(setup, {"J1": 1.08, "delta0": 1.3, "delta1": 0.7, "kt": 0.93})
    x0 = np.array([0.0, math.pi + 0.1, 0.0, 0.0])
    hits = [
        cases._coverage(setup, truth, free, cases.volts, x0, (0.001, 0.005)[s % 2], 200 + s)[0]
        for s in range(args.runs)
    ]
    rate = np.mean(hits, axis=0)
    print(
        f"rotary + DC motor, {args.runs} runs: "
        + ", ".join(f"{n} {r:.3f}" for n, r in zip(free, rate, strict=True))
    )
    print(f"  overall {np.mean(hits):.3f}", flush=True)
    setup = cases.setup_from_scene(cases.load_scene(cases._cart_scene_path()))
    free = ("com1", "J1", "delta0", "delta1")
    truth = cases.truth_of(setup, {"com1": 1.1, "J1": 0.85, "delta0": 1.2, "delta1": 1.5})
    x0 = np.array([0.0, math.pi - 0.3, 0.0, 0.0])
    hits = [
        cases._coverage(setup, truth, free, cases.force, x0, (0.0005, 0.002)[s % 2], 300 + s)[0]
        for s in range(args.runs)
    ]
    rate = np.mean(hits, axis=0)
    print(
        f"cart, links as built, {args.runs} runs: "
        + ", ".join(f"{n} {r:.3f}" for n, r in zip(free, rate, strict=True))
    )
    print(f"  overall {np.mean(hits):.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
