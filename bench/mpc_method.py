"""The microcontroller's method of the MPC step against the interior point, in closed loop (issue 47).

    .venv/bin/python -m bench.mpc_method [--out docs/bench/mpc_method.md]

The QUBE-Servo 2 (tests/test_mpc.py's `qube`: u in volts, ±10 V, the arm within ±1 rad, N = 30,
T = 10 ms) in closed loop on the exact model (scipy's solve_ivp between samples, u held: the
tests' `closed_loop`) for 3 s from three starts that drive u to its bound and the arm to its
travel, with

- the interior point to its tolerance on RK4's exact sensitivities (the default method),
- FAST at barrier weights κ = 0.1 down to 1e-6: `qp_iterations = 1`
  (one barrier Newton step a sample, warm-started from the last sample's slacks and
  multipliers), `sensitivities = "frozen"`,
- the barrier alone (exact sensitivities) and the frozen sensitivities alone at κ's default,

each in double and in float: the closed-loop cost Σ xᵀQx + R u² over the samples, the largest
|θ0| (the arm; its bound 1 rad), the largest |u| and the largest |x| at the end, and the host's
time per step (median of the warm steps, the ctypes call included). Writes the report.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

import numpy as np

from bench.report import ROOT, machine, table

sys.path.insert(0, str(ROOT / "tests"))

OUT = ROOT / "docs" / "bench" / "mpc_method.md"
HEADER = [
    "method",
    "closed-loop cost",
    "change",
    "max |θ0| [rad]",
    "max |u| [V]",
    "max |x| at 3 s",
    "host µs a step",
    "QP residual: median, max",
]
STARTS = ([0.5, 0.15, 1.0, 0.0], [0.0, 0.3, 1.5, 0.0], [-0.3, -0.2, -1.5, 0.5])
METHODS: tuple[tuple[str, dict[str, object]], ...] = (
    ("interior point, exact sensitivities (default)", {}),
    ("FAST κ = 1e-1", {"barrier": 1e-1, "qp_iterations": 1, "sensitivities": "frozen"}),
    ("FAST κ = 1e-2", {"barrier": 1e-2, "qp_iterations": 1, "sensitivities": "frozen"}),
    ("FAST κ = 1e-3", {"barrier": 1e-3, "qp_iterations": 1, "sensitivities": "frozen"}),
    ("FAST κ = 1e-4", {"barrier": 1e-4, "qp_iterations": 1, "sensitivities": "frozen"}),
    ("FAST κ = 1e-5", {"barrier": 1e-5, "qp_iterations": 1, "sensitivities": "frozen"}),
    ("FAST κ = 1e-6", {"barrier": 1e-6, "qp_iterations": 1, "sensitivities": "frozen"}),
    ("barrier κ = 1e-3, 1 Newton step, exact sensitivities", {"barrier": 1e-3, "qp_iterations": 1}),
    ("interior point, frozen sensitivities", {"sensitivities": "frozen"}),
)


def _timed(make: object, options: dict[str, object], x0: list[float]) -> tuple[float, ...]:
    """(cost, max |θ0|, max |u|, max |x_end|, median seconds a warm step, median and largest QP
    residual of the warm steps) of one closed loop."""
    from test_mpc import closed_loop

    controller = make(**options)  # type: ignore[operator]
    states, inputs = closed_loop([controller], x0, 3.0)
    x, u = states[:-1], inputs[:, 0]
    cost = float(np.einsum("ki,ij,kj->", x, controller.Q, x) + controller.R[0, 0] * u @ u)
    controller.reset()
    seconds, residuals = [], []
    for state in states[:-1]:  # the same states again, timed (the first, cold, left out)
        start = time.perf_counter()
        controller.step(state)
        seconds.append(time.perf_counter() - start)
        residuals.append(controller.info.qp_residual if controller.info else float("nan"))
    return (cost, float(np.max(np.abs(states[:, 0]))), float(np.max(np.abs(u))),
            float(np.max(np.abs(states[-1]))), statistics.median(seconds[1:]),
            statistics.median(residuals[1:]), max(residuals[1:]))  # fmt: skip


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=OUT)
    args = parser.parse_args()
    from test_mpc import qube

    rows = []
    for precision in ("double", "float"):
        baseline: list[float] = []
        for name, options in METHODS:
            results = [_timed(qube, {**options, "precision": precision}, x0) for x0 in STARTS]
            costs = [r[0] for r in results]
            if not baseline:
                baseline = costs
            change = " / ".join(f"{100 * (c - b) / b:+.2f} %" for c, b in zip(costs, baseline, strict=True))
            rows.append([
                f"{name}, {precision}", " / ".join(f"{c:.2f}" for c in costs), change,
                " / ".join(f"{r[1]:.5f}" for r in results), f"{max(r[2] for r in results):.4f}",
                f"{max(r[3] for r in results):.1e}", f"{1e6 * statistics.median(r[4] for r in results):.0f}",
                f"{statistics.median(r[5] for r in results):.1e}, {max(r[6] for r in results):.1e}",
            ])  # fmt: skip
    lines = [
        "# MPC: the microcontroller's method in closed loop",
        "",
        "Made by `.venv/bin/python -m bench.mpc_method` (bench/mpc_method.py; what it runs is its",
        "docstring).",
        "",
        *machine({}),
        "",
        "The QUBE-Servo 2 (±10 V, the arm within ±1 rad, N = 30, T = 10 ms) for 3 s on the exact model",
        "from θ, θ̇ = " + ", ".join(f"({x[0]}, {x[1]}; {x[2]}, {x[3]})" for x in STARTS) + " (each cell:",
        'the three starts). FAST = `qp_iterations = 1`, `sensitivities = "frozen"` at the barrier',
        "weight shown. Cost change: against the default method's cost from the same start, the same",
        "precision. Host time: the median warm step through ctypes (this machine; the M4's count is",
        "docs/bench/mpc.md's). QP residual: `info.qp_residual` of the warm steps (the interior point's",
        "at its end, the barrier's before its last Newton step), the starts' median and largest.",
        "",
        *table(HEADER, rows),
    ]
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
