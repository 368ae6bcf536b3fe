"""`make bench-swingup`: swing-up planning speed and closed-loop robustness (docs/bench/swingup.md).

For classical and rotary n = 1..4 with the paper's parameters (CDIP / RSIP, extended with equal
links): the trajectory plan (CasADi + IPOPT, `ipgen.control.trajectory`) is solved `--repeat`
times (build of the NLP and IPOPT's solve timed apart, the median kept, IPOPT iterations
counted); then the plan's time-varying LQR (100 Hz for n ≤ 3, 500 Hz for n = 4) runs on the
reference closed loop (tests/swingup_reference.py: scipy's DOP853 on the exact sympy model,
zero-order hold) for the nominal plant and for each link mass ±5 % and all damping ±20 %, the
controller always computed for the nominal plant. The energy controller of the single links
(`ipgen.control.energy`) gets the same robustness runs. Last, a 5 s run is animated (GIF) and
plotted (PNG) with the time and size recorded.

    .venv/bin/python -m bench.swingup [--quick] [--repeat 3] [--out docs/bench]

Swung up and held: from some sampling instant on (the swing-up time) every link stays within
0.05 rad of upright until the end of the run (the plan's duration plus HOLD seconds of LQR hold).
At rest: the last state has every link within 1e-2 rad of upright, the base within 5e-2 (m or
rad) of 0 and every rate within 5e-2. A failure is listed with its final state, not dropped.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import statistics
import time
from pathlib import Path

import numpy as np
from tqdm import tqdm

from bench.report import BUILD, ROOT, machine, table, version
from ipgen.control.casadi_model import Plant, plant
from ipgen.control.energy import energy_swingup
from ipgen.control.swingup import trajectory_swingup
from ipgen.control.trajectory import PlanError
from ipgen.plots.animation import animate_run, plot_plan_and_run
from ipgen.plots.run import input_unit_beside
from tests.swingup_reference import Run, simulate

DOCS = ROOT / "docs" / "bench"
HOLD = 5.0  # s of hold after the plan (energy control: the whole run is ENERGY_T)
ENERGY_T = 8.0
ANGLE, BASE, RATE = 1e-2, 5e-2, 5e-2
BAND = 0.05  # rad: "swung up" once every link stays this close to upright


@dataclasses.dataclass(frozen=True)
class Case:
    kind: str
    links: int
    duration: float  # s
    u_max: float  # N or N m
    x_max: float | None  # m (cart travel); None: free arm
    period: float  # s
    margin: float = 1.0  # the plan keeps |u| ≤ margin · u_max

    @property
    def label(self) -> str:
        return f"{self.kind} {self.links}"


CASES = [
    Case("classical", 1, 2.0, 20.0, 1.0, 0.01),
    Case("rotary", 1, 2.0, 5.0, None, 0.01),
    Case("classical", 2, 3.0, 50.0, 1.0, 0.01),
    Case("rotary", 2, 3.0, 10.0, None, 0.01),
    Case("classical", 3, 3.5, 50.0, 1.0, 0.01),
    Case("rotary", 3, 3.5, 10.0, None, 0.01),
    Case("classical", 4, 4.0, 80.0, 1.5, 0.002, 0.9),
    Case("rotary", 4, 5.0, 20.0, None, 0.002, 0.9),
]
ENERGY = [("classical", 20.0), ("rotary", 5.0)]


def paper_plant(kind: str, links: int) -> Plant:
    if kind == "classical":
        return plant(kind, links, [0.3] + [0.275] * links, [0.0] + [0.5] * links, [0.3] + [0.1] * links)
    return plant(kind, links, [0.5] + [0.275] * links, [0.6] + [0.5] * links, [0.3] + [0.011458] * links)


def variants(p: Plant, quick: bool) -> list[tuple[str, Plant]]:
    """Nominal, each link mass ±5 %, all damping ±20 % (quick: nominal, m_n +5 %, δ +20 %)."""
    out = [("nominal", p)]
    for i in range(1, p.links + 1):
        for factor in (1.05, 0.95):
            if quick and (i != p.links or factor != 1.05):
                continue
            m = list(p.m)
            m[i] *= factor
            out.append((f"m{i} {factor - 1:+.0%}", p.with_params(m=m)))
    for factor in (1.2, 0.8):
        if quick and factor != 1.2:
            continue
        out.append((f"δ {factor - 1:+.0%}", p.with_params(delta=[d * factor for d in p.delta])))
    return out


def hanging(links: int) -> np.ndarray:
    x = np.zeros(2 * (links + 1))
    x[1 : links + 1] = math.pi
    return x


def assess(run: Run, period: float, x_max: float | None) -> dict:
    dof = run.x.shape[1] // 2
    final = run.x[-1]
    links = np.array([math.remainder(a, 2 * math.pi) for a in final[1:dof]])
    ok = (
        abs(final[0]) <= BASE
        and bool(np.all(np.abs(links) <= ANGLE))
        and bool(np.all(np.abs(final[dof:]) <= RATE))
    )
    wrapped = np.abs(np.remainder(run.x[:, 1:dof] + math.pi, 2 * math.pi) - math.pi)
    inside = np.all(wrapped <= BAND, axis=1)
    outside = np.nonzero(~inside)[0]
    swung = None if not inside[-1] else float(run.t[outside[-1] + 1] if outside.size else 0.0)
    travel = float(np.max(np.abs(run.x[:, 0])))
    return {
        "success": bool(ok),
        "swing_up_time": swung,
        "max_u": float(np.max(np.abs(run.u))),
        "int_abs_u": float(np.sum(np.abs(run.u[:-1])) * period),
        "travel": travel,
        "travel_ok": x_max is None or travel <= x_max * 1.01,
        "final_error": float(np.max(np.abs(np.r_[final[0], links, final[dof:]]))),
    }


def plan_timing(case: Case, repeat: int) -> dict:
    p = paper_plant(case.kind, case.links)
    runs = []
    for _ in range(repeat):
        start, cpu = time.perf_counter(), time.process_time()
        try:
            plan, _schedule = trajectory_swingup(
                p,
                duration=case.duration,
                u_max=case.u_max,
                x_max=case.x_max,
                period=case.period,
                margin=case.margin,
            )
        except PlanError as exc:
            return {"error": str(exc)}
        total, total_cpu = time.perf_counter() - start, time.process_time() - cpu
        runs.append((plan.build_time, plan.solve_time, plan.iterations, total, plan.attempts, total_cpu))
    return {
        "build": statistics.median(r[0] for r in runs),
        "solve": statistics.median(r[1] for r in runs),
        "iterations": runs[0][2],
        "plan_and_gains": statistics.median(r[3] for r in runs),
        "plan_and_gains_cpu": statistics.median(r[5] for r in runs),
        "attempts": list(runs[0][4]),
        "intervals": plan.intervals,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--quick", action="store_true", help="n = 1, 2 only, fewer variants, into build/bench/quick/"
    )
    parser.add_argument(
        "--repeat", type=int, default=3, help="plan solves per case (median kept); n = 4 once"
    )
    parser.add_argument("--out", type=Path, default=None)
    args = parser.parse_args()
    out = args.out or (BUILD / "quick" if args.quick else DOCS)
    out.mkdir(parents=True, exist_ok=True)
    cases = [c for c in CASES if not args.quick or c.links <= 2]
    # warm-up: derive and convert every model once, so that timings are of planning alone
    for case in cases:
        paper_plant(case.kind, case.links)
    results: dict = {"plans": {}, "robustness": [], "pictures": {}}
    for case in tqdm(cases, desc="plans (timing)"):
        results["plans"][case.label] = plan_timing(case, 1 if case.links == 4 else args.repeat)
    jobs = []
    for case in cases:
        for name, variant in variants(paper_plant(case.kind, case.links), args.quick):
            jobs.append(("trajectory", case, name, variant))
    for kind, u_max in ENERGY:
        for name, variant in variants(paper_plant(kind, 1), args.quick):
            jobs.append(("energy", Case(kind, 1, ENERGY_T, u_max, None, 0.01), name, variant))
    controllers: dict = {}
    for method, case, name, variant in tqdm(jobs, desc="closed loops"):
        key = (method, case.label)
        row = {
            "method": method,
            "system": case.label,
            "variant": name,
            "period": case.period,
            "u_max": case.u_max,
        }
        if key not in controllers:
            nominal = paper_plant(case.kind, case.links)
            try:
                if method == "trajectory":
                    plan, schedule = trajectory_swingup(
                        nominal,
                        duration=case.duration,
                        u_max=case.u_max,
                        x_max=case.x_max,
                        period=case.period,
                        margin=case.margin,
                    )
                    controllers[key] = (plan, schedule.control, lambda: None)
                else:
                    energy = energy_swingup(nominal, u_max=case.u_max, period=case.period)
                    controllers[key] = (None, energy.control, energy.reset)
            except PlanError as exc:
                controllers[key] = exc
        entry = controllers[key]
        if isinstance(entry, Exception):
            results["robustness"].append(row | {"success": False, "error": str(entry)})
            continue
        plan, control, reset = entry
        reset()
        t_end = case.duration + HOLD if method == "trajectory" else ENERGY_T
        run = simulate(variant, control, hanging(case.links), t_end, case.period)
        results["robustness"].append(
            row | assess(run, case.period, case.x_max) | {"final": run.x[-1].tolist()}
        )
        if name == "nominal" and (method, case.label) in (
            ("trajectory", "classical 2"),
            ("energy", "rotary 1"),
        ):
            stem = "swingup_cdip" if method == "trajectory" else "swingup_rsip_energy"
            csv_path = BUILD / f"{stem}.csv"
            csv_path.parent.mkdir(parents=True, exist_ok=True)
            keep = run.t <= 5.0 + 1e-9  # a 5 s manoeuvre
            Run(run.t[keep], run.x[keep], run.u[keep], tuple(np.array(run.phase)[keep])).write_csv(
                str(csv_path)
            )
            start, cpu = time.perf_counter(), time.process_time()
            gif = animate_run(csv_path, out / f"{stem}.gif", case.kind, variant.l, force=True)
            results["pictures"][stem] = {
                "gif_seconds": time.perf_counter() - start,
                "gif_cpu_seconds": time.process_time() - cpu,
                "gif_bytes": gif.stat().st_size,
            }
            times = np.linspace(0.0, 5.0, 501)
            kwargs = {}
            if plan is not None:
                kwargs = {
                    "plan_t": times[times <= plan.duration],
                    "plan_x": np.array([plan.state(t) for t in times[times <= plan.duration]]),
                    "plan_u": np.array([plan.input(t) for t in times[times <= plan.duration]]),
                }
            unit = input_unit_beside(csv_path)  # V for a motor case
            plot_plan_and_run(
                out / f"{stem}.png", csv_path, u_max=case.u_max, force=True, input_unit=unit, **kwargs
            )
    results["machine"] = machine({"casadi": version("casadi"), "repeat": str(args.repeat)})
    (out / "swingup.json").write_text(json.dumps(results, indent=1) + "\n")
    (out / "swingup.md").write_text(render(results, cases))
    print(f"wrote {out / 'swingup.md'}")


def _s(value: float | None) -> str:
    return "–" if value is None else f"{value:.2f}"


def render(results: dict, cases: list[Case]) -> str:
    lines = [
        "# Swing-up: planning speed and closed-loop robustness",
        "",
        "Written by `make bench-swingup` (`.venv/bin/python -m bench.swingup`, bench/swingup.py).",
        "The paper's CDIP / RSIP parameters, extended with equal links; hanging at rest → upright at rest.",
        "",
        "## Plans (CasADi + IPOPT, Hermite–Simpson collocation)",
        "",
        "Build: the NLP's CasADi graph and IPOPT's set-up; solve: IPOPT's wall time (median of the repeats,",
        "n = 4 once); plan + gains: the whole `trajectory_swingup` call (plan and time-varying LQR), wall",
        "clock and, in parentheses, CPU time of the process (the machine is shared: see its load below).",
        "Targets (issue 23): ≤ 1 s for n = 1, ≤ 3 s for n = 2 and 3, ≤ 10 s for n = 4.",
        "",
    ]
    rows = []
    for case in cases:
        r = results["plans"][case.label]
        limits = f"{case.u_max:g}" + ("" if case.x_max is None else f", ±{case.x_max:g}")
        if "error" in r:
            rows.append([case.label, f"{case.duration:g}", limits, "–", "–", "–", "–", "–", r["error"]])
            continue
        target = 1.0 if case.links == 1 else 3.0 if case.links <= 3 else 10.0
        total = r["build"] + r["solve"]
        rows.append(
            [
                case.label,
                f"{case.duration:g}",
                limits + (f" (plan ≤ {case.margin:g}·u_max)" if case.margin < 1 else ""),
                str(r["intervals"]),
                f"{r['build']:.2f}",
                f"{r['solve']:.2f}",
                str(r["iterations"]),
                f"{r['plan_and_gains']:.2f} ({r['plan_and_gains_cpu']:.2f})",
                ("met" if total <= target else "missed") + f" ({target:g} s)",
            ]
        )
    lines += table(
        [
            "system",
            "duration [s]",
            "u_max, x_max",
            "intervals",
            "build [s]",
            "solve [s]",
            "IPOPT iterations",
            "plan + gains [s] (CPU)",
            "target (build + solve)",
        ],
        rows,
    )
    lines += [
        "",
        "## Robustness (reference closed loop, controller for the nominal plant)",
        "",
        f"Trajectory: the plan's duration plus {HOLD:g} s of hold; energy control: {ENERGY_T:g} s.",
        f"Swung up, held: from the swing-up time on, every link stays within {BAND:g} rad of upright.",
        f"At rest: links within {ANGLE:g} rad of upright, base within {BASE:g}, rates within {RATE:g} at the",
        "end.",
        "∫|u| dt over the whole run; max |θ0| flagged when over x_max by more than 1 %.",
        "",
    ]
    rows = []
    failures = []
    for r in results["robustness"]:
        if "error" in r:
            rows.append([r["system"], r["method"], r["variant"], "no plan", "–", "–", "–", "–", "–"])
            failures.append(f"- {r['system']} ({r['method']}, {r['variant']}): {r['error']}")
            continue
        travel = f"{r['travel']:.2f}" + ("" if r["travel_ok"] else " (over x_max)")
        rows.append(
            [
                r["system"],
                f"{r['method']}, {1 / r['period']:.0f} Hz",
                r["variant"],
                "yes" if r["swing_up_time"] is not None else "**no**",
                "yes" if r["success"] else f"no ({r['final_error']:.2g})",
                _s(r["swing_up_time"]),
                f"{r['max_u']:.2f} / {r['u_max']:g}",
                f"{r['int_abs_u']:.2f}",
                travel,
            ]
        )
        if r["swing_up_time"] is None:
            failures.append(
                f"- {r['system']} ({r['method']}, {r['variant']}): final state "
                f"{np.array2string(np.array(r['final']), precision=3, max_line_width=200)}"
            )
    lines += table(
        [
            "system",
            "method",
            "plant",
            "swung up, held",
            "at rest at the end (largest error)",
            "swing-up [s]",
            "max |u| / limit",
            "∫|u| dt",
            "max |θ0|",
        ],
        rows,
    )
    held = sum(1 for r in results["robustness"] if r.get("swing_up_time") is not None)
    ok = sum(1 for r in results["robustness"] if r.get("success"))
    total = len(results["robustness"])
    lines += [
        "",
        f"{held} of {total} runs swing up and stay upright; {ok} of them are also at rest within the",
        "tolerance at the end (the others are still converging in the hold: their largest error is given).",
        "",
    ]
    lines += ["### Failures (not swung up, or lost again)", ""] + (failures or ["None."]) + [""]
    if results["pictures"]:
        lines += ["## Pictures (5 s of the nominal runs)", ""]
        for stem, facts in results["pictures"].items():
            lines.append(
                f"- `{stem}.gif`: rendered in {facts['gif_seconds']:.1f} s "
                f"({facts['gif_cpu_seconds']:.1f} s CPU), "
                f"{facts['gif_bytes'] / 1e6:.2f} MB; "
                f"`{stem}.png`: the run (and plan) with u(t) and its limit."
            )
        lines.append("")
    lines += ["## Machine", "", *results["machine"], ""]
    return "\n".join(lines)


if __name__ == "__main__":
    main()
