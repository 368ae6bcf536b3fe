"""Work–precision results: plots, tables, the recommendation table and the issue's targets."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

from bench.report import machine, sundials_version, table, version

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


def _meets(run: dict[str, Any] | None, level: float, coarse: list[dict[str, Any]] | None) -> bool:
    """Whether `run` reaches max error `level`, and its setting does with the coarser output too."""
    if run is None or not _ok(run) or run["max_error"] > level:
        return False
    if coarse is None:
        return True
    twin = [c for c in coarse if c["method"] == run["method"] and c["knob"] == run["knob"] and _ok(c)]
    return bool(twin) and twin[0]["max_error"] <= level


def _at(runs: list[dict[str, Any]], method: str, knob: float) -> dict[str, Any] | None:
    return next((r for r in runs if r["method"] == method and r["knob"] == knob), None)


def recommendations(results: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Per kind of scene and accuracy level: one ipsim method and one setting of it (rtol or step)
    that meets the level on every scene of that kind, chosen for the smallest worst slowdown: on
    each scene, that setting's wall time against the fastest setting of any of the methods
    considered that meets the level there (both also with output every 0.1 s). The last row,
    "any (default)", picks among the error-controlled methods over every scene, stiff ones
    included: the simulator's default follows it."""
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
            if all(best_wall[s["key"]] is not None for s in scenes):
                for method in methods:
                    # Every setting of the method that meets the level on every scene; its worst
                    # slowdown is taken over the scenes at that one setting.
                    knobs = sorted({r["knob"] for r in scenes[0]["runs"] if r["method"] == method})
                    for knob in knobs:
                        runs = [_at(s["runs"], method, knob) for s in scenes]
                        if not all(
                            _meets(run, level, s.get("coarse_runs"))
                            for run, s in zip(runs, scenes, strict=True)
                        ):
                            continue
                        slowdown = max(
                            run["wall_per_second"] / best_wall[s["key"]]  # type: ignore[index]
                            for run, s in zip(runs, scenes, strict=True)
                        )
                        candidates.append((slowdown, method, runs))
            # The best setting of each method, then the methods by their best worst slowdown.
            best: dict[str, tuple[float, str, list[dict[str, Any]]]] = {}
            for candidate in sorted(candidates, key=lambda c: c[0]):
                best.setdefault(candidate[1], candidate)
            ranked = list(best.values())
            rows.append(
                {
                    "kind": kind,
                    "level": level,
                    "scenes": [s["key"] for s in scenes],
                    "choice": ranked[0][1] if ranked else None,
                    "setting": _knob(ranked[0][2][0]) if ranked else None,
                    "slowdown": ranked[0][0] if ranked else None,
                    "walls": [run["wall_per_second"] for run in ranked[0][2]] if ranked else [],
                    # The other methods by their worst slowdown, then those that miss the level
                    # on some scene at every setting.
                    "others": [(method, slowdown) for slowdown, method, _ in ranked[1:]],
                    "unreached": [m for m in methods if m not in best],
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


def facts(total: float) -> list[str]:
    """The machine and software of this run, as Markdown bullets."""
    return machine(
        {
            "SUNDIALS": sundials_version(),
            "MuJoCo": version("mujoco"),
            "scipy": version("scipy"),
            "numpy": version("numpy"),
            "benchmark wall time": f"{total:.0f} s",
        }
    )


RENDERED = "- tables rendered again from workprecision.json"


def recorded_facts(report: Path) -> list[str] | None:
    """The machine bullets of an earlier workprecision.md (those of the run that measured the
    JSON), without an earlier "rendered again" line; None if there is no such report."""
    if not report.is_file():
        return None
    bullets, started = [], False
    for line in report.read_text().splitlines():
        if line.startswith("## "):
            break
        if line.startswith("- "):
            started = True
            if not line.startswith(RENDERED):
                bullets.append(line)
        elif started:
            break
    return bullets or None


def markdown(results: list[dict[str, Any]], machine_lines: list[str]) -> str:
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
        *machine_lines,
        "",
        "## The issue's targets (CDIP, error at t = 10 s)",
        "",
    ]
    for text, met, detail in targets(results):
        state = "not measured" if met is None else ("met" if met else "MISSED")
        lines.append(f"- {text}: **{state}** — {detail}")
    lines += [
        "",
        "## Recommendation",
        "",
        "Per kind of scene and max error: one method and one setting of it that reaches the error on",
        "every scene of that kind, also with output every 0.1 s (so that its accuracy is not owed to the",
        "step cap of sampling every 0.01 s). Its worst slowdown: over those scenes, the largest ratio of",
        "that setting's wall time to the fastest setting of any method considered that reaches the",
        "error (with both outputs) on the same scene. The method with the smallest worst slowdown is",
        "shown with its best setting, then every other method with its own best setting's worst",
        'slowdown. The "any (default)" rows consider only the error-controlled methods, over every',
        "scene.",
        "",
        *recommendation_table(results),
        "",
    ]
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


def _times(ratio: float) -> str:
    return f"{ratio:.1f}x" if ratio < 100 else f"{ratio:.0f}x"


def recommendation_table(results: list[dict[str, Any]]) -> list[str]:
    rows = []
    for rec in recommendations(results):
        if rec["choice"] is None:
            rows.append([rec["kind"], f"{rec['level']:.0e}", "–", "–", "–"])
            continue
        walls = ", ".join(_ms(w) for w in rec["walls"])
        others = [f"{method} {_times(slowdown)}" for method, slowdown in rec["others"]]
        if rec["unreached"]:
            others.append(f"not reached: {', '.join(rec['unreached'])}")
        rows.append(
            [
                f"{rec['kind']} ({', '.join(rec['scenes'])})",
                f"{rec['level']:.0e}",
                f"**{rec['choice']}**, {rec['setting']}",
                f"{walls} ({rec['slowdown']:.1f}x)",
                "; ".join(others) or "–",
            ]
        )
    header = [
        "kind of scene",
        "max error",
        "use",
        "its ms per simulated s per scene (worst slowdown vs the fastest there)",
        "the other methods (their worst slowdown)",
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


def save(
    results: list[dict[str, Any]], out: Path, machine_lines: list[str], write_json: bool = True
) -> list[str]:
    """Writes workprecision.md, workprecision_runs.md, workprecision_readme_table.md, one PNG per
    scene and (unless rendering an existing one again) workprecision.json; returns the summary
    lines (targets and recommendations)."""
    out.mkdir(parents=True, exist_ok=True)
    for r in results:
        plot(r, out / f"workprecision_{r['key']}.png")
    (out / "workprecision.md").write_text(markdown(results, machine_lines))
    (out / "workprecision_runs.md").write_text(runs_markdown(results))
    if write_json:
        (out / "workprecision.json").write_text(json.dumps(results, indent=1, default=float) + "\n")
    (out / "workprecision_readme_table.md").write_text(readme_table(results) + "\n")
    summary = []
    for text, met, detail in targets(results):
        state = "not measured" if met is None else ("met" if met else "MISSED")
        summary.append(f"{text}: {state} ({detail})")
    for rec in recommendations(results):
        summary.append(f"{rec['kind']}, max error <= {rec['level']:.0e}: {rec['choice']} {rec['setting']}")
    return summary
