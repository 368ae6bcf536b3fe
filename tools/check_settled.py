"""Check that a simulated pendulum has settled hanging down (or upright), from the last row of its CSV.

    .venv/bin/python tools/check_settled.py RUN.csv --angle-tol 1e-3 --rate-tol 1e-3 [--at upright]

Every link angle theta1..thetaN must be within angle-tol [rad] of ±π modulo 2π, and every rate
dtheta0..dthetaN (the base too) must be below rate-tol in magnitude. Prints the final angles
and rates; exits 0 if settled, 1 if not, 2 if the file cannot be read. ctest's
paper.<model>.settles tests run it on the paper's experiments simulated to 30 s. With
`--at upright` every angle theta0..thetaN (the base too) must instead be within angle-tol of 0
(a stabilising controller brings the whole state back: control.rdip_lqr.upright).
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path


def main() -> int:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("csv", type=Path)
    parser.add_argument("--angle-tol", type=float, required=True, help="rad, from ±π")
    parser.add_argument("--rate-tol", type=float, required=True, help="rad/s (m/s for a cart)")
    parser.add_argument("--at", choices=("hanging", "upright"), default="hanging", help="the rest state")
    args = parser.parse_args()
    try:
        lines = args.csv.read_text().split()
        header = lines[0].split(",")
        final = dict(zip(header, map(float, lines[-1].split(",")), strict=True))
    except (OSError, ValueError, IndexError) as e:
        print(f"check_settled: error: {args.csv}: {e}", file=sys.stderr)
        return 2
    angles = [name for name in header if name.startswith("theta") and name != "theta0"]
    target, label = (math.pi, "±π") if args.at == "hanging" else (0.0, "0")
    if args.at == "upright":
        angles.insert(0, "theta0")
    rates = [name for name in header if name.startswith("dtheta")]
    problems = []
    for name in angles:
        # the base's position or angle itself; a link's distance from the target modulo 2π
        base = name == "theta0"
        off = abs(final[name]) if base else abs(math.remainder(final[name] - target, 2 * math.pi))
        print(f"{name} = {final[name]:.12g}, {off:.3e} from {label}")
        if not off <= args.angle_tol:
            problems.append(f"{name} is {off:.3e} rad from {label} (> {args.angle_tol:g})")
    for name in rates:
        print(f"{name} = {final[name]:.3e}")
        if not abs(final[name]) <= args.rate_tol:
            problems.append(f"|{name}| = {abs(final[name]):.3e} (> {args.rate_tol:g})")
    t = final["t"]
    if problems:
        print(f"check_settled: NOT settled at t = {t:g} s: " + "; ".join(problems))
        return 1
    print(f"check_settled: settled at t = {t:g} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
