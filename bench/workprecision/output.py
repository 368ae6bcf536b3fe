"""Work–precision results: plots, tables, the recommendation table and the issue's targets."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

from bench.report import machine, table, version

LEVELS = (1e-4, 1e-6, 1e-8, 1e-10)  # accuracy levels of the recommendation table (max error)
TARGET = 1e-8  # the CDIP comparison: final-time error


def _ok(run: dict[str, Any]) -> bool:
    return "failed" not in run and math.isfinite(run.get("max_error", math.inf))


def _methods(runs: list[dict[str, Any]], solver: str | None = None) -> list[str]:
    seen: list[str] = []
    for run in runs:
        if (solver is None or run["solver"] == solver) and run["method"] not in seen:
            seen.append(run["method"])
    return seen


def cheapest(
    runs: list[dict[str, Any]],
    method: str,
    level: float,
    metric: str = "max_error",
    coarse: list[dict[str, Any]] | None = None,
) -> dict | None:
    """The fastest run of `method` whose `metric` is at most `level` — and, given the same sweep
    with coarser output (`coarse`), whose setting meets the level there too."""

    def robust(run: dict[str, Any]) -> bool:
        if coarse is None:
            return True
        twin = [c for c in coarse if c["method"] == method and c["knob"] == run["knob"] and _ok(c)]
        return bool(twin) and twin[0][metric] <= level

    good = [r for r in runs if r["method"] == method and _ok(r) and r[metric] <= level and robust(r)]
    return min(good, key=lambda r: r["wall_per_second"]) if good else None


def _knob(run: dict[str, Any]) -> str:
    return f"{run['knob_name']} {run['knob']:.0e}".replace("e-0", "e-")


def _ms(value: float) -> str:
    milliseconds = value * 1e3
    return f"{milliseconds:.3f}" if milliseconds < 10 else f"{milliseconds:.1f}"


ADAPTIVE = ("bdf", "adams", "adams-fixed-point", "erk-dp5", "erk-fehlberg8")
# The accuracy the simulator's default is chosen for: 1e-6 over the trajectory, the bound the
# paper scenes' golden tests hold the default to (1e-8 shown next to it).
DEFAULT_LEVELS = (1e-6, 1e-8)


def recommendations(results: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Per kind of scene and accuracy level: the ipsim method whose worst slowdown against the
    fastest ipsim method of each scene is smallest, with a setting that meets the level on every
    scene of that kind. The last row, "any (default)", picks among the error-controlled methods
    over every scene, stiff ones included: the simulator's default follows it."""
    groups = [
        (kind, [r for r in results if r["kind"] == kind], None, LEVELS)
        for kind in sorted({r["kind"] for r in results}, reverse=True)
    ]
    groups.append(("any (default)", results, ADAPTIVE, DEFAULT_LEVELS))
    rows = []
    for kind, scenes, allowed, levels in groups:
        methods = [m for m in _methods(scenes[0]["runs"], "ipsim") if allowed is None or m in allowed]
        for level in levels:
            best_wall = {}
            for s in scenes:
                walls = [
                    c["wall_per_second"]
                    for m in methods
                    if (c := cheapest(s["runs"], m, level, coarse=s.get("coarse_runs")))
                ]
                best_wall[s["key"]] = min(walls) if walls else None
            candidates = []
            for method in methods:
                picks = [cheapest(s["runs"], method, level, coarse=s.get("coarse_runs")) for s in scenes]
                if any(p is None for p in picks) or any(best_wall[s["key"]] is None for s in scenes):
                    continue
                slowdown = max(
                    p["wall_per_second"] / best_wall[s["key"]] for p, s in zip(picks, scenes, strict=True)
                )
                # A setting that meets the level everywhere: the tightest of the per-scene picks.
                setting = min(picks, key=lambda p: p["knob"])
                candidates.append((slowdown, method, setting, picks))
            candidates.sort(key=lambda c: c[0])
            rows.append(
                {
                    "kind": kind,
                    "level": level,
                    "scenes": [s["key"] for s in scenes],
                    "choice": candidates[0][1] if candidates else None,
                    "setting": _knob(candidates[0][2]) if candidates else None,
                    "slowdown": candidates[0][0] if candidates else None,
                    "walls": [p["wall_per_second"] for p in candidates[0][3]] if candidates else [],
                    "runner_up": candidates[1][1] if len(candidates) > 1 else None,
                    "runner_up_slowdown": candidates[1][0] if len(candidates) > 1 else None,
                }
            )
    return rows


def targets(results: list[dict[str, Any]]) -> list[tuple[str, bool | None, str]]:
    """The issue's CDIP targets at 1e-8 final-time error, measured in this run."""
    cdip = next((r for r in results if r["key"] == "cdip"), None)
    if cdip is None:
        return [("CDIP targets", None, "CDIP not run")]
    runs = cdip["runs"]
    ours = [c for m in _methods(runs, "ipsim") if (c := cheapest(runs, m, TARGET, "final_error"))]
    adaptive = [c for c in ours if c["method"] != "rk4"]
    lines = []
    for peer, factor, pool, who in (
        ("MuJoCo RK4", 10, ours, "ipgen"),
        ("scipy DOP853", 30, ours, "ipgen"),
        ("MuJoCo RK4", 10, adaptive, "ipgen's best error-controlled method"),
        ("scipy DOP853", 30, adaptive, "ipgen's best error-controlled method"),
    ):
        best = min(pool, key=lambda r: r["wall_per_second"]) if pool else None
        theirs = cheapest(runs, peer, TARGET, "final_error")
        if best is None or theirs is None:
            lines.append((f"{who} <= 1/{factor} of {peer} at {TARGET:.0e} final error", None, "not reached"))
            continue
        ratio = theirs["wall_per_second"] / best["wall_per_second"]
        detail = (
            f"ipgen {best['method']} {_knob(best)}: {_ms(best['wall_per_second'])} ms/s "
            f"(error {best['final_error']:.1e}); "
            f"{peer} {_knob(theirs)}: {_ms(theirs['wall_per_second'])} ms/s "
            f"(error {theirs['final_error']:.1e}); {ratio:.0f}x"
        )
        lines.append((f"{who} <= 1/{factor} of {peer} at {TARGET:.0e} final error", ratio >= factor, detail))
    return lines


STYLE = {"ipsim": "-", "mujoco": "--", "scipy": ":"}


def plot(result: dict[str, Any], path: Path) -> None:
    figure, axes = plt.subplots(1, 2, figsize=(13, 5.2))
    runs = result["runs"]
    for index, method in enumerate(_methods(runs)):
        # In sweep order, loose to tight (rtol or step decreasing).
        points = sorted((r for r in runs if r["method"] == method and _ok(r)), key=lambda r: -r["knob"])
        if not points:
            continue
        solver = points[0]["solver"]
        colour = plt.get_cmap("tab20")(index % 20)
        for axis, metric in zip(axes, ("max_error", "final_error"), strict=True):
            xs = [p["wall_per_second"] * 1e3 for p in points]
            ys = [max(p[metric], 1e-16) for p in points]
            axis.plot(xs, ys, STYLE[solver], marker="o", markersize=3, color=colour, label=method)
    for axis, what in zip(
        axes, ("max error over the trajectory", f"error at t = {result['t_end']:g} s"), strict=True
    ):
        axis.set(xscale="log", yscale="log", xlabel="wall time per simulated second [ms]", ylabel=what)
        axis.grid(True, which="both", alpha=0.3)
    axes[0].legend(fontsize=7, ncol=2)
    figure.suptitle(f"{result['title']} ({result['model']}): ipsim solid, MuJoCo dashed, scipy dotted")
    figure.tight_layout()
    figure.savefig(path, dpi=110)
    plt.close(figure)


def markdown(results: list[dict[str, Any]], total: float) -> str:
    extra = {
        "SUNDIALS": "6.4.1 (Debian)",
        "MuJoCo": version("mujoco"),
        "scipy": version("scipy"),
        "numpy": version("numpy"),
        "benchmark wall time": f"{total:.0f} s",
    }
    lines = [
        "# Work–precision: ipsim's integrators against MuJoCo and scipy",
        "",
        "Written by `make bench` (`python -m bench.workprecision`). Each scene runs for 10 s with",
        "output every 0.01 s (the scenes' default: every ipsim method stops exactly on each sample,",
        "which caps its steps at 0.01 s; MuJoCo's steps divide it; scipy interpolates). Errors are",
        "the largest difference in any θ or θ̇ component from a reference — ipsim erk-fehlberg8",
        "(stiff scene: bdf) at rtol 1e-13, confirmed by ipsim RK4 at a tiny step and by bdf at rtol",
        "1e-13 — at t = 10 s and over all samples. Wall time: median of repeated runs per simulated",
        "second: the whole `simulate()` call for ipsim (set-up and sampling included),",
        "`mujoco.rollout` for MuJoCo, `solve_ivp` for scipy. Adaptive methods use atol = rtol/100.",
        "The machine is shared: the load average below says how busy it was.",
        "",
        *machine(extra),
        "",
        "## The issue's targets (CDIP, error at t = 10 s)",
        "",
    ]
    for text, met, detail in targets(results):
        state = "not measured" if met is None else ("met" if met else "MISSED")
        lines.append(f"- {text}: **{state}** — {detail}")
    lines += ["", "## Recommendation", "", *recommendation_table(results), ""]
    lines += ["## Scenes", ""]
    for r in results:
        ref = r["reference"]
        agree = r["mujoco_agreement"]
        lines += [
            f"### {r['title']}",
            "",
            f"`{r['scene']}` ({r['model']}). Reference: {ref['method']} at rtol 1e-13, "
            f"confirmed to {ref['agreement_trajectory']:.1e} by RK4 "
            f"(step {ref['check_step']:.0e}) and {ref['bdf_agreement_trajectory']:.1e} by bdf "
            f"(rtol 1e-13) over the trajectory. "
            f"MuJoCo's model agrees with it to {agree['trajectory']:.1e} "
            f"(RK4, step {agree['timestep']:.0e}). {r['note']}",
            "",
            f"![{r['key']}](workprecision_{r['key']}.png)",
            "",
            "Wall time per simulated second [ms] of the cheapest setting reaching each max error "
            "(– : not reached in the sweep):",
            "",
        ]
        header = ["method", *[f"≤ {level:.0e}" for level in LEVELS], "fastest run: ms/s (max error)"]
        rows = []
        for method in _methods(r["runs"]):
            cells = []
            for level in LEVELS:
                c = cheapest(r["runs"], method, level)
                cells.append(f"{_ms(c['wall_per_second'])} ({_knob(c)})" if c else "–")
            good = [x for x in r["runs"] if x["method"] == method and _ok(x)]
            fastest = min(good, key=lambda x: x["wall_per_second"]) if good else None
            cells.append(
                f"{_ms(fastest['wall_per_second'])} ({fastest['max_error']:.0e})" if fastest else "failed"
            )
            rows.append([method, *cells])
        lines += [*table(header, rows), ""]
    lines += [
        "Every run (errors, time, steps, evaluations): [workprecision_runs.md](workprecision_runs.md).",
        "",
    ]
    return "\n".join(lines)


def recommendation_table(results: list[dict[str, Any]]) -> list[str]:
    rows = []
    for rec in recommendations(results):
        if rec["choice"] is None:
            rows.append([rec["kind"], f"{rec['level']:.0e}", "–", "–", "–"])
            continue
        walls = ", ".join(_ms(w) for w in rec["walls"])
        runner = (
            f"{rec['runner_up']} ({rec['runner_up_slowdown']:.1f}x)" if rec["runner_up"] is not None else "–"
        )
        rows.append(
            [
                f"{rec['kind']} ({', '.join(rec['scenes'])})",
                f"{rec['level']:.0e}",
                f"**{rec['choice']}**, {rec['setting']}",
                f"{walls} ({rec['slowdown']:.1f}x)",
                runner,
            ]
        )
    header = [
        "kind of scene",
        "max error",
        "use",
        "its ms per simulated s per scene (worst slowdown vs the fastest there)",
        "runner-up",
    ]
    return table(header, rows)


def readme_table(results: list[dict[str, Any]]) -> str:
    """The recommendation table in the README's shorter form (kind, accuracy, what to use)."""
    rows = []
    for rec in recommendations(results):
        use = f"`{rec['choice']}`, {rec['setting']}" if rec["choice"] else "–"
        slow = f"{rec['slowdown']:.1f}x" if rec["choice"] else "–"
        rows.append([rec["kind"], f"≤ {rec['level']:.0e}", use, slow])
    header = ["kind of scene", "max error over 10 s", "use", "worst slowdown vs the best there"]
    return "\n".join(table(header, rows))


def runs_markdown(results: list[dict[str, Any]]) -> str:
    lines = [
        "# Work–precision: every run",
        "",
        "See [workprecision.md](workprecision.md) for the set-up.",
        "",
    ]
    header = ["method", "setting", "error at t_end", "max error", "ms/s", "steps", "RHS evals", "Jacobians"]
    for r in results:
        rows = []
        for run in r["runs"]:
            if not _ok(run):
                rows.append(
                    [run["method"], _knob(run), "–", "–", "–", "–", "–", run.get("failed", "failed")[:80]]
                )
                continue
            evals = str(run.get("rhs_evals", "–"))
            if run.get("dq_rhs_evals"):
                evals += f" + {run['dq_rhs_evals']}"
            rows.append(
                [
                    run["method"],
                    _knob(run),
                    f"{run['final_error']:.1e}",
                    f"{run['max_error']:.1e}",
                    _ms(run["wall_per_second"]),
                    str(run.get("steps", "–")),
                    evals,
                    str(run.get("jacobian_evals", "–")),
                ]
            )
        lines += [f"## {r['title']}", "", *table(header, rows), ""]
    return "\n".join(lines)


def save(results: list[dict[str, Any]], out: Path, total: float) -> list[str]:
    """Writes workprecision.md, workprecision_runs.md, workprecision.json and one PNG per scene;
    returns the summary lines (targets and recommendations)."""
    out.mkdir(parents=True, exist_ok=True)
    for r in results:
        plot(r, out / f"workprecision_{r['key']}.png")
    (out / "workprecision.md").write_text(markdown(results, total))
    (out / "workprecision_runs.md").write_text(runs_markdown(results))
    (out / "workprecision.json").write_text(json.dumps(results, indent=1, default=float) + "\n")
    (out / "workprecision_readme_table.md").write_text(readme_table(results) + "\n")
    summary = []
    for text, met, detail in targets(results):
        state = "not measured" if met is None else ("met" if met else "MISSED")
        summary.append(f"{text}: {state} ({detail})")
    for rec in recommendations(results):
        summary.append(f"{rec['kind']}, max error <= {rec['level']:.0e}: {rec['choice']} {rec['setting']}")
    return summary
