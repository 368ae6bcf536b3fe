"""The RealAIGym simulation leaderboard's acrobot and pendubot, swung up in ipgen's simulator.

For each preset (scenes/rigs/acrobot_swingup.toml, pendubot_swingup.toml: DFKI design C.1
model 1.0 without rotors, damping or friction, 6 N m on the driven joint, 10 s from hanging):
`--replan` plans the swing-up with IPOPT (control/fixed_swingup.py) and writes the preset's plan
CSV; then `ipgen run` of the preset (ipsim: the plan tracked by TVLQR every 2 ms, then the LQR
hold; CVODE between samples), and the v2 score of its CSV (experiment/leaderboard.py), beside the
published entries; the same for acrobot_mpc and pendubot_mpc (the same plan tracked by the MPC
every 10 ms, then its hold). Writes docs/bench/leaderboard.md and a GIF per system
(docs/bench/leaderboard_*.gif, the TVLQR runs).

    python -m bench.leaderboard [--replan] [--quick]   (--quick: no GIFs, build/bench/quick/)
"""

from __future__ import annotations

import argparse
import csv
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
RIGS = ROOT / "scenes" / "rigs"
SYSTEMS = {"acrobot": 2, "pendubot": 1}
# The presets of each system: the plan's tracking, by TVLQR (…_swingup) and by the MPC (…_mpc).
TRACKING = {"swingup": "TVLQR", "mpc": "MPC"}
# Plans: duration [s] and the planner's weights (fixed_swingup.fixed_plan).
PLANS = {"acrobot": {"duration": 4.0}, "pendubot": {"duration": 3.0, "weight_velocity": 0.05}}
# The published simulation v2 entries, "RealAI Score" column, highest first: github.com/
# dfki-ric-underactuated-lab/real_ai_gym_leaderboard at commit 81ea5bc (2025-09-26),
# leaderboards/{acrobot,pendubot}_simulation_performance_leaderboard_v2.csv (both last changed
# 2024-09-03: f398b99, f2653be).
PUBLISHED_SOURCE = (
    "github.com/dfki-ric-underactuated-lab/real_ai_gym_leaderboard at commit 81ea5bc, "
    "leaderboards/{system}_simulation_performance_leaderboard_v2.csv, RealAI Score"
)
PUBLISHED = {
    "acrobot": [
        ("History SAC", 0.655),
        ("AR-EAPO", 0.633),
        ("evolsac", 0.524),
        ("TVLQR", 0.504),
        ("iLQR Riccati Gains", 0.396),
        ("iLQR MPC stabilization", 0.345),
        ("mcpilco", 0.316),
    ],
    "pendubot": [
        ("History SAC", 0.682),
        ("AR-EAPO", 0.659),
        ("evolsac", 0.596),
        ("iLQR Riccati Gains", 0.536),
        ("TVLQR", 0.526),
        ("mcpilco", 0.48),
        ("iLQR MPC stabilization", 0.353),
    ],
}


def published_lines(scores: dict[str, float]) -> list[str]:
    """The published entries of each system, highest first, with ipgen's score placed among them.

    Parameters
    ----------
    scores : dict of str to float
        ipgen's v2 score per system ("acrobot", "pendubot"), or per system and tracking
        ("acrobot TVLQR", "acrobot MPC").

    Returns
    -------
    list of str
        Markdown lines.
    """
    lines = [f"Published simulation_v2 entries ({PUBLISHED_SOURCE}), ipgen's score in bold among them:", ""]
    for which, entries in PUBLISHED.items():
        ranked = [(value, name) for name, value in entries]
        for tracked, value in scores.items():
            system, _, tracking = tracked.partition(" ")
            if system == which:
                label = f"ipgen {tracking} (this run)" if tracking else "ipgen (this run)"
                ranked.append((value, f"**{label}**"))
        ranked.sort(key=lambda entry: -entry[0])
        text = ", ".join(
            f"**{name.strip('*')} {value:.3f}**" if name.startswith("**") else f"{name} {value:.3f}"
            for value, name in ranked
        )
        lines.append(f"- {which}: {text}")
    return lines


def replan(which: str) -> str:
    from ipgen.control.fixed_swingup import fixed_plan, write_plan
    from ipgen.model.fixed import FixedPendulum

    scene = RIGS / f"{which}_swingup.toml"
    chain = FixedPendulum.from_scene(scene)
    began = time.perf_counter()
    plan = fixed_plan(chain, u_max=6.0, period=0.002, **PLANS[which])
    seconds = time.perf_counter() - began
    note = (
        f"The {which} swing-up plan of {scene.name} (bench/leaderboard.py --replan; "
        f"control/fixed_swingup.fixed_plan, {plan.iterations} IPOPT iterations).\n"
        "Columns: t [s], u1 [N m] held from t (0 on the last row), x1..x4 = q1, q2, dq1, dq2 "
        "(DFKI's coordinates)."
    )
    write_plan(RIGS / f"{which}_swingup.plan.csv", plan, note)
    return f"{plan.iterations} iterations, {seconds:.1f} s (with CasADi's graph)"


def read_csv(path: Path, joint: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, list[str]]:
    with path.open() as stream:
        rows = [row for row in csv.reader(line for line in stream if not line.startswith("#"))]
    header, body = rows[0], rows[1:]
    col = {name: i for i, name in enumerate(header)}
    data = np.array(
        [[float(row[col[c]]) for c in ("t", "theta0", "theta1", "dtheta0", "dtheta1", "u")] for row in body]
    )
    phases = [row[col["phase"]] for row in body] if "phase" in col else []
    u = np.zeros((len(data), 2))
    u[:, joint - 1] = data[:, 5]
    return data[:, 0], data[:, 1:5], u, phases


def animate(which: str, t: np.ndarray, x: np.ndarray, u: np.ndarray, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.animation import FuncAnimation, PillowWriter

    l1, l2 = 0.2, 0.3
    step = 20  # 25 frames per second of the 2 ms samples
    frames = range(0, len(t), step)
    fig, (ax, axu) = plt.subplots(1, 2, figsize=(8, 4), gridspec_kw={"width_ratios": [1, 1.3]})
    ax.set_xlim(-0.55, 0.55)
    ax.set_ylim(-0.55, 0.55)
    ax.set_aspect("equal")
    ax.axhline(0.9 * (l1 + l2), color="0.8", lw=0.8, ls="--")
    ax.set_title(f"{which} (DFKI C.1), ipgen's simulator")
    (line,) = ax.plot([], [], "o-", lw=3, color="tab:blue")
    label = ax.text(-0.5, -0.5, "")
    axu.plot(t, u[:, SYSTEMS[which] - 1], color="tab:red", lw=1)
    axu.set_xlabel("t [s]")
    axu.set_ylabel(f"u{SYSTEMS[which]} [N m]")
    axu.set_ylim(-6.5, 6.5)
    marker = axu.axvline(0.0, color="k", lw=0.8)
    fig.tight_layout()

    def draw(k: int):
        q1, q2 = x[k, 0], x[k, 1]
        p1 = (l1 * np.sin(q1), -l1 * np.cos(q1))
        p2 = (p1[0] + l2 * np.sin(q1 + q2), p1[1] - l2 * np.cos(q1 + q2))
        line.set_data([0, p1[0], p2[0]], [0, p1[1], p2[1]])
        label.set_text(f"t = {t[k]:.2f} s")
        marker.set_xdata([t[k], t[k]])
        return line, label, marker

    FuncAnimation(fig, draw, frames=frames, blit=False).save(path, writer=PillowWriter(fps=25))
    plt.close(fig)


def main(argv: list[str] | None = None) -> None:
    from ipgen.experiment.leaderboard import NORMALIZE, score
    from ipgen.pipeline.run import run_scene

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--replan", action="store_true", help="plan again with IPOPT, rewrite the plan CSVs")
    parser.add_argument("--quick", action="store_true", help="no GIFs; results into build/bench/quick/")
    args = parser.parse_args(argv)
    docs = ROOT / ("build/bench/quick" if args.quick else "docs/bench")
    docs.mkdir(parents=True, exist_ok=True)
    out_root = ROOT / "build" / "bench" / "leaderboard"
    rows, notes = [], []
    for which, joint in SYSTEMS.items():
        if args.replan:
            notes.append(f"- {which}: replanned, {replan(which)}")
        for suffix, tracking in TRACKING.items():
            name = f"{which}_{suffix}"
            began = time.perf_counter()
            outcome = run_scene(RIGS / f"{name}.toml", out_root / name, force=True, plot=False)
            seconds = time.perf_counter() - began
            if outcome.status != 0:
                raise SystemExit(f"{name}: ipgen run exited with {outcome.status}")
            t, x, u, phases = read_csv(out_root / name / f"{name}.csv", joint)
            s = score(t, x, u, 0.2, 0.3)
            rows.append((f"{which} {tracking}", s, seconds, x[-1], phases))
            if not args.quick and suffix == "swingup":
                animate(which, t, x, u, docs / f"leaderboard_{which}.gif")
    lines = [
        "# The RealAIGym simulation leaderboard's acrobot and pendubot in ipgen's simulator",
        "",
        "Generated by `make bench-leaderboard` (bench/leaderboard.py); do not edit.",
        "",
        "DFKI's double pendulum, design C.1 model 1.0",
        "(github.com/dfki-ric-underactuated-lab/double_pendulum,",
        "BSD-3-Clause) without rotor inertia, damping or friction, as the simulation_v2 leaderboards set it:",
        "6 N m on the driven joint, 10 s from hanging at rest, goal upright. Presets `acrobot_swingup` and",
        "`pendubot_swingup`: a plan on the exact model (control/fixed_swingup.py: multiple shooting with",
        "the input held over 10 ms, RK4 at 2 ms, CasADi + IPOPT; cost ∫u² + 10⁻⁴ ∫u̇² (+ 0.05 ∫|q̇|² for",
        "the pendubot); |u| ≤ 0.95·6 N m),",
        "shipped as the preset's plan CSV, tracked in ipsim by the discrete time-varying LQR every 2 ms",
        "(Q = diag(10, 10, 1, 1), R = 1), then the discrete LQR hold (TVLQR rows); or by the constrained",
        "MPC every 10 ms (presets `acrobot_mpc`, `pendubot_mpc`: N = 40, one real-time iteration a sample,",
        "|u| ≤ 6 N m, the plan its reference per stage, then its hold; MPC rows, docs/mpc.md); ipsim",
        "integrates with CVODE between the samples and writes every 2 ms (the leaderboard's dt). The score",
        "is the repository's v2 formula",
        "(analysis/leaderboard.py with simulation_v2/calculate_leaderboard_score.py's weights, all 1, and",
        "normalisations) on ipgen's CSV (experiment/leaderboard.py):",
        "score = success · (1 − ⅕ Σ tanh(π · value / norm)), norms: "
        + ", ".join(f"{k} {v:g}" for k, v in NORMALIZE.items())
        + "; a record shorter than 0.99 of the 10 s episode scores 0 (DFKI's rule).",
        "",
        "| system, tracking | success | swing-up time [s] | energy [J] | torque cost | torque smoothness "
        "| velocity cost "
        "| max |u| [N m] | **score** | end state (q1, q2, q̇1, q̇2) | run [s] |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for which, s, seconds, end, _ in rows:
        lines.append(
            f"| {which} | {int(s.success)} | {s.swingup_time:.3f} | {s.energy:.2f} | {s.tau_cost:.2f} | "
            f"{s.tau_smoothness:.4f} | {s.velocity_cost:.1f} | {s.max_tau:.2f} | **{s.score:.3f}** | "
            f"{', '.join(f'{v:.2e}' for v in (end[0] - np.pi, end[1], end[2], end[3]))} (q1 − π) "
            f"| {seconds:.1f} |"
        )
    lines += ["", *published_lines({which: s.score for which, s, *_ in rows})]
    if not args.quick:
        lines += ["", "![acrobot](leaderboard_acrobot.gif) ![pendubot](leaderboard_pendubot.gif)"]
    if notes:
        lines += ["", *notes]
    (docs / "leaderboard.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
