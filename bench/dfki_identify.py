"""`make bench-dfki`: the DFKI double pendulum (design C.0) identified from its real recordings,
against DFKI's own model_3.0 (docs/bench/dfki_identify.md, docs/rigs.md).

The recordings are DFKI's sys_id trajectories 00–06, 12, 13 (github:dfki-ric-underactuated-lab/
double_pendulum, BSD-3-Clause; a copy in ../shared/dfki or wherever --recordings points). Three
evaluations, all through `ipgen.pipeline.identify_torques.identify_torques` (what `ipgen identify`
runs) with the preset dfki_c0 (DFKI's model_3.0) as the values compared with:

- the split chosen before any result was seen: fit on 00–03 and 12, validate on 04–06 and 13
  (each set with one large swing);
- leave one recording out: each of the nine predicted by a fit on the eight others;
- the split with the two large swings exchanged (fit 00–03, 13; validate 04–06, 12), looked at
  after the first;
- the base parameters fitted on the small oscillations alone, on the swing-ups alone and on all.

RMS torque errors are against the measured torque low-passed like the regression's inputs; both
models are evaluated at the same filtered states. model_3.0 was identified by DFKI from these
recordings (and possibly 07–11), so it has seen every "held-out" one.

    .venv/bin/python -m bench.dfki_identify [--recordings ../shared/dfki] [--out docs/bench]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

import ipgen
from bench.report import ROOT, machine, table
from ipgen.pipeline.identify_torques import TorqueIdentified, identify_torques

NAMES = ("00", "01", "02", "03", "04", "05", "06", "12", "13")
SPLIT = (("00", "01", "02", "03", "12"), ("04", "05", "06", "13"))
EXCHANGED = (("00", "01", "02", "03", "13"), ("04", "05", "06", "12"))


def _path(folder: Path, name: str) -> Path:
    return folder / f"design_C.0_20220914_sys_id_trajectory_{name}.csv.gz"


def _run(
    folder: Path, fit: tuple[str, ...], validate: tuple[str, ...], out: Path | None = None
) -> TorqueIdentified:
    scene = ipgen.FixedPendulum.preset("dfki_c0")
    return identify_torques(
        scene,
        "dfki_c0",
        [_path(folder, n) for n in fit],
        [_path(folder, n) for n in validate],
        out,
        force=True,
    )


def _pair(ours: np.ndarray, theirs: np.ndarray) -> list[str]:
    return (
        [f"{ours[k]:.4f}" for k in range(2)]
        + [f"{theirs[k]:.4f}" for k in range(2)]
        + ["yes" if np.all(ours <= theirs) else "no"]
    )


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--recordings", type=Path, default=ROOT.parent / "shared" / "dfki")
    parser.add_argument("--out", type=Path, default=ROOT / "docs" / "bench")
    args = parser.parse_args(argv)
    missing = [n for n in NAMES if not _path(args.recordings, n).is_file()]
    if missing:
        print(
            f"bench.dfki_identify: recordings {', '.join(missing)} not in {args.recordings}", file=sys.stderr
        )
        return 2
    header = ["", "ipgen τ1", "ipgen τ2", "model_3.0 τ1", "model_3.0 τ2", "ipgen ≤ model_3.0 both"]
    main_run = _run(args.recordings, *SPLIT, out=args.out / "dfki_identify")
    rows = []
    for score_ours, score_theirs in zip(main_run.scores[::2], main_run.scores[1::2], strict=True):
        label = f"{score_ours.role} {score_ours.recording.rsplit('_', 1)[-1]}"
        rows.append([label, *_pair(score_ours.filtered, score_theirs.filtered)])
    for role in ("fit", "validate"):
        rows.append(
            [
                f"**{role}, pooled**",
                *_pair(main_run.pooled(role, "identified"), main_run.pooled(role, "scene")),
            ]
        )
    errors_ours, errors_theirs, loro = [], [], []
    for name in NAMES:
        run = _run(args.recordings, tuple(n for n in NAMES if n != name), (name,))
        held = [s for s in run.scores if s.role == "validate"]
        ours, theirs = held[0], held[1]
        errors_ours.append(ours.filtered**2 * ours.samples)
        errors_theirs.append(theirs.filtered**2 * theirs.samples)
        loro.append([f"held out {name}", *_pair(ours.filtered, theirs.filtered)])
    samples = sum(s.samples for s in main_run.scores[::2])
    pooled_ours, pooled_theirs = (np.sqrt(np.sum(e, axis=0) / samples) for e in (errors_ours, errors_theirs))
    loro.append(["**all nine, pooled**", *_pair(pooled_ours, pooled_theirs)])
    exchanged = _run(args.recordings, *EXCHANGED)
    swapped = [
        [f"**{role}, pooled**", *_pair(exchanged.pooled(role, "identified"), exchanged.pooled(role, "scene"))]
        for role in ("fit", "validate")
    ]
    kinds = {"00–06": NAMES[:7], "12, 13": NAMES[7:], "all nine": NAMES}
    by_kind = {label: _run(args.recordings, chosen, ()).fit for label, chosen in kinds.items()}
    base = main_run.fit.base
    reference = base.of(main_run.fit.regressor.parameters(ipgen.FixedPendulum.preset("dfki_c0")))
    kind_rows = [
        [label, *(f"{by_kind[k].estimate[i]:.4g}" for k in kinds), f"{reference[i]:.4g}"]
        for i, label in enumerate(base.labels())
    ]
    lines = [
        "# The DFKI double pendulum identified from its real recordings",
        "",
        "Generated by `.venv/bin/python -m bench.dfki_identify` (bench/dfki_identify.py; its docstring says",
        "what is run). RMS torque error [N m] per joint, against the measured torque low-passed like the",
        "regression's inputs (6 Hz zero-phase Butterworth); ipgen's identified base parameters against",
        "DFKI's model_3.0 (the preset dfki_c0) at the same filtered states.",
        "",
        "## Split chosen before the results: fit 00–03, 12; validate 04–06, 13",
        "",
        *table(header, rows),
        "",
        "Estimates (95 % intervals) beside model_3.0's values, `ipgen identify`'s report:",
        "",
        "```",
        *[line for line in main_run.report.splitlines()[2:] if not line.startswith("  ")],
        "```",
        "",
        "![measured against predicted torques](dfki_identify/dfki_c0_identify.png)",
        "",
        "## Leave one recording out (each predicted by a fit on the eight others)",
        "",
        *table(header, loro),
        "",
        "## The two large swings exchanged (fit 00–03, 13; validate 04–06, 12), after the first split",
        "",
        *table(header, swapped),
        "",
        "## Fits on one kind of motion: the small oscillations (00–06), the swing-ups (12, 13), all",
        "",
        *table(["base parameter", *(f"fit on {k}" for k in kinds), "model_3.0"], kind_rows),
        "",
        "## Machine",
        "",
        *machine(),
        "",
    ]
    (args.out / "dfki_identify.md").write_text("\n".join(lines), encoding="utf-8")
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
