"""`make bench` (work–precision part): every ipsim method against MuJoCo and scipy on five scenes.

    python -m bench.workprecision                 # everything, writes docs/bench/workprecision*
    python -m bench.workprecision --quick         # CDIP only, fewer settings, into build/bench/quick/
    python -m bench.workprecision --scenes cdip,stiff
    python -m bench.workprecision --from-json docs/bench/workprecision.json   # tables and plots only

For each scene: a reference (ipsim erk-fehlberg8 at rtol 1e-13, confirmed by RK4 at a tiny step
and by bdf at rtol 1e-13), every ipsim method over a sweep of tolerances (rk4: steps), MuJoCo
(RK4 and Euler over time steps; first checked against the reference at a tiny step) and scipy
solve_ivp (DOP853, LSODA) on the generator's lambdified equations. Errors are the largest state
difference from the reference at t_end and over all samples (every 0.01 s).
"""

from __future__ import annotations

import argparse
import json
import subprocess
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from bench.report import BUILD, ROOT, STARTED, commit
from bench.workprecision import build, output
from bench.workprecision.mujoco_peer import MujocoPendulum
from bench.workprecision.scipy_peer import ScipyPendulum
from ipgen.experiment.scene import Scene

HERE = Path(__file__).resolve().parent
RTOLS = (1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11, 1e-12)
STEPS = (1e-2, 5e-3, 2e-3, 1e-3, 5e-4, 2e-4, 1e-4)
COARSE_SAMPLE = 0.1  # [s] output interval of the second ipsim sweep


@dataclass(frozen=True)
class BenchScene:
    key: str
    toml: Path
    title: str
    kind: str  # "non-stiff" or "stiff"
    rk4_steps: tuple[float, ...] = STEPS
    mujoco_rk4: tuple[float, ...] = STEPS
    mujoco_euler: tuple[float, ...] = STEPS
    mujoco_check: float = 1e-4  # MuJoCo RK4 step of the agreement check [s]
    check_step: float = 2.5e-5  # ipsim RK4 step confirming the reference [s]
    reference_method: str = "erk-fehlberg8"  # ipsim method computing the reference at rtol 1e-13
    scipy: dict[str, tuple[float, ...]] = field(
        default_factory=lambda: {
            "DOP853": (1e-4, 1e-6, 1e-8, 1e-10, 1e-12),
            "LSODA": (1e-4, 1e-6, 1e-8, 1e-10),
        }
    )
    note: str = ""


STIFF_STEPS = (4e-5, 2e-5, 1e-5, 5e-6, 2e-6)
SCENES = (
    BenchScene("cdip", ROOT / "scenes/cdip_pulse.toml", "CDIP (the paper's Fig. 4)", "non-stiff"),
    BenchScene("rsip", HERE / "scenes/wp_rsip_full.toml", "RSIP, full inertia (Fig. 6)", "non-stiff"),
    BenchScene("classical5", HERE / "scenes/wp_classical5.toml", "classical, n = 5", "non-stiff"),
    BenchScene("rotary3", HERE / "scenes/wp_rotary3.toml", "rotary, n = 3, full inertia", "non-stiff"),
    BenchScene(
        "stiff",
        HERE / "scenes/wp_stiff.toml",
        "stiff: CDIP with a light link, delta2 = 50",
        "stiff",
        rk4_steps=STIFF_STEPS,
        mujoco_rk4=(2e-5, 1e-5),
        mujoco_check=1e-5,
        check_step=1e-6,
        reference_method="bdf",  # Fehlberg 8(7) fails its error test at rtol 1e-13 here
        scipy={"LSODA": (1e-4, 1e-6, 1e-8, 1e-10)},
        note="scipy DOP853 not run: explicit, stability-bound (about 70 s per run)",
    ),
)


def _errors(states: np.ndarray, reference: np.ndarray) -> tuple[float, float]:
    if states.shape != reference.shape or not np.all(np.isfinite(states)):
        return float("inf"), float("inf")
    difference = np.abs(states - reference)
    return float(difference[-1].max()), float(difference.max())


def run_ipsim(
    bench: BenchScene, cfg: Path, driver: Path, folder: Path, quick: bool, sample: float | None = None
) -> tuple[dict, list[dict]]:
    """The driver's reference and runs; `sample` overrides the scene's output interval (the
    reference is then computed at that interval too, into reference_<sample>.csv)."""
    rtols = RTOLS[::2] if quick else RTOLS
    name = "reference.csv" if sample is None else f"reference_{sample:g}.csv"
    command = [
        str(driver),
        str(cfg),
        *(["--sample", repr(sample)] if sample is not None else []),
        "--reference",
        str(folder / name),
        "--rtols",
        ",".join(repr(r) for r in rtols),
        "--rk4-steps",
        ",".join(repr(s) for s in bench.rk4_steps),
        "--check-step",
        repr(bench.check_step),
        "--reference-method",
        bench.reference_method,
        "--repeat-seconds",
        "0.05" if quick else "0.1",
        # The coarse sweep is for errors only: one run per setting.
        *(["--max-repeats", "1"] if sample is not None else []),
    ]
    done = subprocess.run(command, capture_output=True, text=True, check=True)
    lines = [json.loads(line) for line in done.stdout.splitlines()]
    reference = next(line for line in lines if line["kind"] == "reference")
    runs = []
    for line in lines:
        if line["kind"] != "run":
            continue
        knob = "step" if line["method"] == "rk4" else "rtol"
        entry = {"solver": "ipsim", "knob_name": knob, **{k: v for k, v in line.items() if k != "kind"}}
        runs.append(entry | ({"sample": sample} if sample is not None else {}))
    return reference, runs


def run_mujoco(
    bench: BenchScene, scene: Scene, reference: np.ndarray, quick: bool
) -> tuple[dict, list[dict]]:
    pendulum = MujocoPendulum(scene)
    check = pendulum.run("rk4", bench.mujoco_check, scene.sample, repeat_seconds=0.0)
    final, worst = _errors(check.states, reference)
    agreement = {"integrator": "rk4", "timestep": bench.mujoco_check, "final": final, "trajectory": worst}
    runs = []
    for integrator, steps in (("rk4", bench.mujoco_rk4), ("euler", bench.mujoco_euler)):
        for step in steps[::2] if quick else steps:
            run = pendulum.run(integrator, step, scene.sample, repeat_seconds=0.05 if quick else 0.1)
            final, worst = _errors(run.states, reference)
            entry = {
                "solver": "mujoco",
                "method": f"MuJoCo {integrator.upper() if integrator == 'rk4' else 'Euler'}",
                "knob_name": "timestep",
                "knob": step,
                "final_error": final,
                "max_error": worst,
                "wall_per_second": run.wall_per_second,
                "repeats": run.repeats,
                "steps": run.steps,
                "rhs_evals": run.steps * (4 if integrator == "rk4" else 1),
            }
            if run.unstable:
                entry["failed"] = "unstable (MuJoCo reset the state: NaN or huge acceleration)"
            runs.append(entry)
    return agreement, runs


def run_scipy(bench: BenchScene, scene: Scene, reference: np.ndarray, quick: bool) -> list[dict]:
    pendulum = ScipyPendulum(scene)
    runs = []
    for method, rtols in bench.scipy.items():
        for rtol in rtols[::2] if quick else rtols:
            run = pendulum.run(method, rtol, scene.sample, repeat_seconds=0.2 if quick else 0.3)
            entry: dict[str, Any] = {
                "solver": "scipy",
                "method": f"scipy {method}",
                "knob_name": "rtol",
                "knob": rtol,
            }
            if run.failed:
                entry["failed"] = run.failed
            else:
                final, worst = _errors(run.states, reference)
                entry |= {
                    "final_error": final,
                    "max_error": worst,
                    "wall_per_second": run.wall_per_second,
                    "repeats": run.repeats,
                    "rhs_evals": run.rhs_evals,
                }
            runs.append(entry)
    return runs


def render(source: Path, out: Path) -> None:
    """The reports and plots of `source` (a workprecision.json) again, by the current code, without
    running anything; the JSON itself is left as it is."""
    results = json.loads(source.read_text())
    recorded = output.recorded_facts(source.parent / "workprecision.md")
    lines = recorded or ["- machine: not recorded (no workprecision.md next to the JSON)"]
    lines.append(
        f"{output.RENDERED} on {STARTED.strftime('%Y-%m-%d %H:%M %Z')} at commit {commit()} "
        "(measurements unchanged)"
    )
    for line in output.save(results, out, lines, write_json=out.resolve() != source.parent.resolve()):
        print(f"  {line}")


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(
        prog="python -m bench.workprecision", description=__doc__.splitlines()[0]
    )
    parser.add_argument("--scenes", help=f"comma-separated, from {','.join(s.key for s in SCENES)}")
    parser.add_argument(
        "--quick", action="store_true", help="CDIP only (unless --scenes), every other setting"
    )
    parser.add_argument("--out", type=Path, help="output folder (default docs/bench, or build/bench/quick)")
    parser.add_argument(
        "--from-json",
        type=Path,
        help="run nothing: render the reports and plots again from a workprecision.json (the machine "
        "record is kept from the workprecision.md next to it)",
    )
    options = parser.parse_args(argv)
    if options.from_json:
        render(options.from_json, options.out or options.from_json.parent)
        return
    wanted = options.scenes.split(",") if options.scenes else (["cdip"] if options.quick else None)
    scenes = [s for s in SCENES if wanted is None or s.key in wanted]
    if not scenes:
        parser.error(f"no such scene: {options.scenes}")
    out = options.out or (BUILD / "quick" if options.quick else ROOT / "docs" / "bench")
    started = time.perf_counter()

    prepared = build.prepare_all([s.toml for s in scenes])
    print(
        f"workprecision: built {len(prepared)} drivers in {time.perf_counter() - started:.0f} s", flush=True
    )
    results = []
    for bench, (scene, cfg, driver) in zip(scenes, prepared, strict=True):
        begun = time.perf_counter()
        folder = cfg.parent
        reference_info, runs = run_ipsim(bench, cfg, driver, folder, options.quick)
        # The same sweep with output every 0.1 s: a setting recommended for its accuracy must not
        # owe it to the step cap that samples every 0.01 s impose.
        _, coarse_runs = run_ipsim(bench, cfg, driver, folder, options.quick, sample=COARSE_SAMPLE)
        reference = np.loadtxt(folder / "reference.csv", delimiter=",")[:, 1:]
        agreement, mujoco_runs = run_mujoco(bench, scene, reference, options.quick)
        scipy_runs = run_scipy(bench, scene, reference, options.quick)
        results.append(
            {
                "key": bench.key,
                "title": bench.title,
                "kind": bench.kind,
                "scene": scene.path.relative_to(ROOT).as_posix(),
                "model": f"{scene.type}, n = {scene.links}"
                + (f", {scene.inertia}" if scene.type == "rotary" else ""),
                "t_end": scene.t_end,
                "sample": scene.sample,
                "note": bench.note,
                "reference": reference_info,
                "mujoco_agreement": agreement,
                "runs": runs + mujoco_runs + scipy_runs,
                "coarse_sample": COARSE_SAMPLE,
                "coarse_runs": coarse_runs,
                "seconds": time.perf_counter() - begun,
            }
        )
        print(
            f"workprecision: {bench.key}: reference confirmed to "
            f"{reference_info['agreement_trajectory']:.1e}, "
            f"MuJoCo agrees to {agreement['trajectory']:.1e}, {time.perf_counter() - begun:.0f} s",
            flush=True,
        )
    total = time.perf_counter() - started
    summary = output.save(results, out, output.facts(total))
    where = out.relative_to(ROOT) if out.is_relative_to(ROOT) else out
    print(f"\nworkprecision: wrote {where}/ in {total:.0f} s")
    for line in summary:
        print(f"  {line}")
