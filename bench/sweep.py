"""`make bench-sweep`: how fast `ipgen sweep` runs, and the robustness scorecards it gives.

docs/bench/sweep.md — speed: the scorecard of the paper's rotary single pendulum under LQR at 1 kHz
(scenes/rsip_lqr.toml, 10 s runs), a ≈ 700-run sweep of that scene (the scorecard plus its basin
θ1 × θ̇1 on a 24 × 24 grid; target ≤ 2 min on the 2-core machine), and one fixed sweep run on 1 and
2 local worker processes and through a Dask LocalCluster (2 worker processes on 127.0.0.1), whose
tables must be identical.

docs/bench/robustness.md — the scorecards of LQR on the rotary single and double pendulum
(1 kHz) and of the two swing-ups (rotary single: energy; cart double: planned trajectory + TVLQR)
on the exact state, and the rotary single's LQR and swing-up again as a rig measures them
(2048-count encoders; rates from the Kalman filter, Quanser's derivative filter, or the EKF).

    .venv/bin/python -m bench.sweep [--quick] [--out docs/bench] [--part speed|robustness|all]
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import time
from pathlib import Path
from typing import Any

import ipgen
from bench.report import BUILD, ROOT, machine, table, version
from ipgen.sweeps.runner import Outcome
from ipgen.sweeps.success import Success
from ipgen.sweeps.table import RESULT

RSIP = ROOT / "scenes" / "rsip_lqr.toml"
# The swing-ups' runs are 10-20 s of BDF each and a period level re-plans the cart's trajectory
# (IPOPT): their model criteria get 11 levels, their period criterion three.
SWINGUP_LEVELS = {
    "mass": "0.75:1.25:11",
    "com": "0.75:1.25:11",
    "inertia": "0.75:1.25:11",
    "damping": "0:2:11",
    "coulomb": "0:0.1:11",
    "period": "0.005,0.01,0.02",
}
# The QUBE-Servo 2's swing-up at 1 kHz: the swing-ups' levels, its own periods.
QUBE_LEVELS = {**SWINGUP_LEVELS, "period": "0.0005,0.001,0.002,0.005"}
SWINGUP_REPEAT = 4  # runs per level of the seeded criteria (drive noise, pulses) of the swing-ups
BENCH_SCENES = ROOT / "bench" / "scenes"
# (label, scene, levels, repeat): None = the scorecard's defaults.
ROBUSTNESS = (
    ("rotary single, LQR 1 kHz, exact state", ROOT / "scenes" / "rsip_lqr.toml", None, None),
    ("rotary single, LQR 1 kHz, encoders + Kalman", BENCH_SCENES / "rsip_lqr_kalman.toml", None, None),
    ("rotary single, LQR 1 kHz, encoders + filter", BENCH_SCENES / "rsip_lqr_filter.toml", None, None),
    ("rotary double, LQR 1 kHz, exact state", BENCH_SCENES / "rdip_lqr_1khz.toml", None, None),
    ("rotary single, energy swing-up, exact state", ROOT / "scenes" / "rsip_swingup.toml", SWINGUP_LEVELS,
     SWINGUP_REPEAT),
    ("rotary single, energy swing-up, encoders + EKF", BENCH_SCENES / "rsip_swingup_ekf.toml", SWINGUP_LEVELS,
     SWINGUP_REPEAT),
    ("cart double, trajectory swing-up, exact state", ROOT / "scenes" / "cdip_swingup.toml", SWINGUP_LEVELS,
     SWINGUP_REPEAT),
    ("QUBE-Servo 2, energy swing-up in volts, encoders + filter", ROOT / "scenes" / "rigs" /
     "qube_servo2_swingup.toml", QUBE_LEVELS, SWINGUP_REPEAT),
)  # fmt: skip
# The speed part's ≈ 700 runs: the exact-state scorecard of rsip_lqr.toml and this basin grid.
BASIN = ("initial.theta[1]=-1.2:1.2:17", "initial.dtheta[1]=-6:6:17")
SCALING = ("initial.theta[1]=-1.2:1.2:12", "initial.dtheta[1]=-6:6:12")
TARGET = 120.0  # s for the ≈ 700-run sweep


CPU: dict[str, float] = {}  # label -> CPU seconds of the sweep (this process and every worker)


def _cpu() -> float:
    """CPU seconds (user + system) of this process and its reaped descendants (workers, simulators)."""
    own, children = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + children.ru_utime + children.ru_stime


def _timed(label: str, **kwargs: Any) -> tuple[Outcome, float]:
    print(f"{label} ...", flush=True)
    cpu = _cpu()
    started = time.perf_counter()
    outcome = ipgen.sweep(force=True, **kwargs)
    seconds = time.perf_counter() - started
    CPU[label] = _cpu() - cpu
    print(
        f"  {outcome.runs} runs in {seconds:.1f} s, {CPU[label]:.1f} CPU s (load {os.getloadavg()[0]:.1f})",
        flush=True,
    )
    return outcome, seconds


def _results(outcome: Outcome) -> list[tuple[str, ...]]:
    return [tuple(row[c] for c in RESULT) for row in outcome.rows]


def _dask_cluster(workers: int) -> object:
    from distributed import LocalCluster

    return LocalCluster(
        n_workers=workers, threads_per_worker=1, processes=True, host="127.0.0.1", dashboard_address=None
    )


def _row(label: str, outcome: Outcome, seconds: float, workers: int, cpu: float | None = None) -> list[str]:
    """A table row: runs, wall time of the whole command and of the runs alone, runs/s (runs alone),
    CPU ms per run (the whole command's CPU time in every process, over its runs)."""
    rate = outcome.runs / outcome.seconds
    shown = "–" if cpu is None else f"{1000 * cpu / outcome.runs:.0f}"
    return [
        label,
        str(outcome.runs),
        f"{seconds:.1f}",
        f"{outcome.seconds:.1f}",
        f"{rate:.1f}",
        f"{rate / workers:.1f}",
        shown,
    ]


def speed(out: Path, quick: bool) -> list[str]:
    """docs/bench/sweep.md's lines."""
    work = BUILD / "sweep"
    rows = []
    card, card_s = _timed(
        "the scorecard, 2 local workers", scene=RSIP, out=work / "card", scorecard=True, jobs=2
    )
    rows.append(
        _row(
            "the scorecard, 2 local workers",
            card,
            card_s,
            2,
            CPU["the scorecard, 2 local workers"],
        )
    )
    basin = BASIN if not quick else ("initial.theta[1]=-1.2:1.2:8", "initial.dtheta[1]=-6:6:8")
    load_before = os.getloadavg()
    big, big_s = _timed(
        "the scorecard + the basin grid, 2 local workers",
        scene=RSIP,
        out=work / "big",
        scorecard=True,
        vary=basin,
        jobs=2,
    )
    load_after = os.getloadavg()
    grid = big.scores[-1]
    rows.append(
        _row(
            f"the scorecard + the basin {grid.criterion.label}, 2 local workers",
            big,
            big_s,
            2,
            CPU["the scorecard + the basin grid, 2 local workers"],
        )
    )
    shutil.copyfile(work / "big" / "grid.png", out / "sweep_basin.png")
    scaling = SCALING if not quick else ("initial.theta[1]=-1.2:1.2:6", "initial.dtheta[1]=-6:6:6")
    tables = {}
    for jobs in (1, 2):
        outcome, seconds = _timed(
            f"the scaling grid, {jobs} local worker(s)",
            scene=RSIP,
            out=work / f"j{jobs}",
            vary=scaling,
            jobs=jobs,
            plots=False,
        )
        tables[f"{jobs} local"] = _results(outcome)
        rows.append(
            _row(
                f"scaling grid, local process pool, {jobs} worker{'s' if jobs > 1 else ''}",
                outcome,
                seconds,
                jobs,
                CPU[f"the scaling grid, {jobs} local worker(s)"],
            )
        )
    dask_version = "not installed"
    try:
        import distributed

        dask_version = distributed.__version__
        with _dask_cluster(2) as cluster:
            for when in ("cold", "warm"):
                outcome, seconds = _timed(
                    f"the scaling grid, Dask LocalCluster (2 processes, {when})",
                    scene=RSIP,
                    out=work / f"dask_{when}",
                    vary=scaling,
                    dask=cluster.scheduler_address,
                    plots=False,
                )
                tables[f"dask {when}"] = _results(outcome)
                rows.append(
                    _row(
                        f"scaling grid, Dask LocalCluster, 2 worker processes on 127.0.0.1, {when}",
                        outcome,
                        seconds,
                        2,
                    )
                )
    except ImportError:
        rows.append(
            ["Dask LocalCluster", "–", "not run: pip install 'ipgen-pendulum[dask]'", "–", "–", "–", "–"]
        )
    same = all(t == tables["1 local"] for t in tables.values())
    per_run = [float(row["seconds"]) for row in big.rows]
    mean_run = sum(per_run) / len(per_run)
    lines = [
        "# Sweep speed (`make bench-sweep`)",
        "",
        f"`ipgen sweep` on the paper's rotary single pendulum under LQR at 1 kHz ({RSIP.relative_to(ROOT)}: "
        "10 s runs, rk4 with a 1 ms step, the CSV at 100 Hz). Each run: the scene with its overrides "
        "validated in memory, the cached simulator (no compile) run as a subprocess on a RAM disk, its "
        "trajectory judged; runs go in batches to worker processes that prepared the scene once. "
        "Written by `python -m bench.sweep` (bench/sweep.py)" + (" with --quick" if quick else "") + ".",
        "",
        "## Results",
        "",
        "*command* is the whole call (reading and validating the scene — importing scipy for the LQR "
        "design —, generating its header, the pool's start, the runs, the plots); *runs* the runs alone "
        "(from the first submission to the last result), from which runs/s is computed. *cold*: the Dask "
        "workers' first sweep (each worker process imports ipgen and prepares the scene); *warm*: the same "
        "sweep again on the running cluster. *CPU ms per run*: the CPU time (user + system) of the whole "
        "command in every process — this one, the workers, the simulators — over its runs; it does not "
        "depend on the other sessions' load (the Dask workers are not this process's children: not counted).",
        "",
        *table(
            ["sweep", "runs", "command [s]", "runs [s]", "runs/s", "runs/s per worker", "CPU ms per run"],
            rows,
        ),
        "",
        f"- Target: ≈ 700 runs of 10 s in ≤ {TARGET:.0f} s on this 2-core machine: "
        f"{big.runs} runs took {big_s:.1f} s — " + ("met" if big_s <= TARGET else "NOT met") + ".",
        "- Mean wall time of one run inside a worker (validation, simulator, judging): "
        f"{1000 * mean_run:.0f} ms.",
        "- The tables of the 1- and 2-worker pools and the Dask cluster are identical (every column but "
        f"the wall time): {'yes' if same else 'NO'}.",
        f"- Load average (1 min) before / after the ≈ 700-run sweep: {load_before[0]:.1f} / "
        f"{load_after[0]:.1f} on 2 cores (the machine is shared with other sessions: with a load above 2 "
        "a second worker finds no free core, and runs/s fall with the load).",
        f"- Dask: distributed {dask_version}.",
        "",
        "The basin grid (fraction of runs passing per point): ![basin](sweep_basin.png)",
        "",
        "## Machine",
        "",
        *machine({"numpy": version("numpy")}),
        "",
    ]
    return lines


def robustness(out: Path, quick: bool) -> list[str]:
    """docs/bench/robustness.md's lines."""
    work = BUILD / "robustness"
    levels = (
        {
            "mass": "0.75:1.25:5",
            "com": "0.75:1.25:5",
            "inertia": "0.75:1.25:5",
            "damping": "0:2:5",
            "coulomb": "0:0.1:5",
            "period": "0.005,0.01,0.02",
        }
        if quick
        else None
    )
    lines = [
        "# Robustness scorecards (`make bench-sweep`)",
        "",
        "Each scene's controller designed on its nominal model, run on the changed plant (`ipgen sweep "
        "SCENE --scorecard`, the default levels; the swing-ups with 11 levels per model criterion and "
        "the periods "
        "0.005, 0.01, 0.02 s; docs/sweep.md). A level passes when more than half its runs pass; "
        "a criterion's score is its fraction of passing levels; the score the mean over the criteria run. "
        "Written by `python -m bench.sweep` (bench/sweep.py)" + (" with --quick" if quick else "") + ".",
        "",
    ]
    lines += [
        "The measured variants ([sensors]: both angles from 2048-count encoders; [estimator]: the "
        "steady-state Kalman filter, the derivative filter 50 s/(s + 50), or the EKF) keep the estimator "
        "designed on the nominal scene in every run, like the controller. On the exact state the "
        "measurement criteria (resolution, sensor_noise) change nothing and are not run. The swing-ups' "
        f"seeded criteria (drive_noise, pulses) run {SWINGUP_REPEAT} times per level, the LQR's 10 times.",
        "",
    ]
    summary = []
    summary_at = len(lines)
    for label, scene, own, repeat in ROBUSTNESS:
        stem = scene.stem
        outcome, seconds = _timed(
            f"scorecard of {label}",
            scene=scene,
            out=work / stem,
            scorecard=True,
            levels=levels or own,
            repeat=2 if quick else repeat,
            jobs=2,
        )
        shutil.copyfile(work / stem / "scores.png", out / f"robustness_{stem}.png")
        scores = json.loads((work / stem / "scores.json").read_text())
        text = (work / stem / "scores.md").read_text().splitlines()
        body = [line for line in text if line.startswith("|")]
        total = "—" if scores["score"] is None else f"{100 * scores['score']:.0f} %"
        summary.append([label, f"`{scene.relative_to(ROOT)}`", total, str(outcome.runs), f"{seconds:.0f}"])
        lines += [
            f"## {label}: {total}",
            "",
            f"`{scene.relative_to(ROOT)}`, {outcome.runs} runs in {seconds:.0f} s on 2 workers.",
            "",
            *body,
            "",
            f"![scores](robustness_{stem}.png)",
            "",
        ]
    lines[summary_at:summary_at] = [
        *table(["controller", "scene", "score", "runs", "wall time [s]"], summary),
        "",
    ]
    lines += [
        f"Success test: {Success().text()}.",
        "",
        "## Machine",
        "",
        *machine(),
        "",
    ]
    return lines


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="smaller grids; write to build/bench/quick/")
    parser.add_argument("--out", type=Path, default=None)
    parser.add_argument("--part", choices=("speed", "robustness", "all"), default="all")
    args = parser.parse_args(argv)
    out = args.out or (BUILD / "quick" if args.quick else ROOT / "docs" / "bench")
    out.mkdir(parents=True, exist_ok=True)
    if args.part in ("speed", "all"):
        (out / "sweep.md").write_text("\n".join(speed(out, args.quick)))
        print(f"wrote {out / 'sweep.md'}")
    if args.part in ("robustness", "all"):
        (out / "robustness.md").write_text("\n".join(robustness(out, args.quick)))
        print(f"wrote {out / 'robustness.md'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
