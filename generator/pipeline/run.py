"""`ipgen run SCENE.toml -o OUT/`: from a scene to results in one command.

Generates the scene's model header and resolved scene, builds (or takes from the cache) the
scene's simulator (pipeline/simulator.py), runs it, and writes into OUT:

    <stem>.cfg  the resolved scene (rerun it with the simulator named in the summary)
    <stem>.csv  the trajectory, written by the simulator
    <stem>.png  a plot of the run (plots/run.py)
    <stem>.txt  the summary paragraph: the simulator's own report of the run

Every file is checked before any work: a file there that ipgen (or the simulator) did not write
is replaced only with `force`. The simulator's exit status is the run's: 0, or its own non-zero
status with its message (a failed or diverging run still gets its plot and summary when the
simulator wrote a CSV).
"""

from __future__ import annotations

import re
import subprocess
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from ipgen.common.files import OutputError, check_replaceable, prepare_directory, write_file
from ipgen.common.limits import MAX_SIMULATED_LINKS
from ipgen.common.safetext import shown_path
from ipgen.pipeline import job
from ipgen.pipeline.simulator import BuildError, Simulator, build, model_sources
from ipgen.plots.run import PNG, PlotError, plot_run, read_run, sampled_beside

if TYPE_CHECKING:
    from ipgen.experiment.scene import Scene

# The first line of a CSV the simulator wrote (the rule of simulate.cpp's written_by_simulator).
SIMULATOR_CSV = re.compile(
    r"t((?:,theta\d+)+)((?:,dtheta\d+)+)(,kinetic,potential,input_work,dissipated)?(,u)?"
)


@dataclass(frozen=True)
class Outcome:
    """What one run did: its files, the simulator, its status and report."""

    status: int  # the simulator's exit status (0: success)
    files: list[Path]  # written into OUT
    simulator: Simulator
    summary: str  # the paragraph written to <stem>.txt
    messages: str  # the simulator's stderr (warnings, or the error that ended the run)
    seconds: float  # wall time of the simulator's process


def _csv_from_simulator(path: Path) -> bool:
    try:
        with path.open() as f:
            first = f.readline(4096).rstrip("\r\n")
    except (OSError, UnicodeDecodeError):
        return False
    return SIMULATOR_CSV.fullmatch(first) is not None


def _check_outputs(paths: dict[str, Path], scene: Path, force: bool) -> None:
    """The output-path policy (common.files) for each file of the run; never the scene itself,
    not even with --force. The CSV is the simulator's: replaced if it wrote it, else with force."""
    check_replaceable(paths["cfg"], force, keep=[scene])
    check_replaceable(paths["txt"], force, keep=[scene])
    check_replaceable(paths["png"], force, PNG, keep=[scene])
    csv = paths["csv"]
    check_replaceable(csv, True, keep=[scene])  # the path itself: a directory, too long, ...
    if csv.exists() and not force and not _csv_from_simulator(csv):
        raise OutputError(
            f"{shown_path(csv)} exists and was not written by the simulator: move it away or pass --force"
        )


def _stamp(path: Path) -> tuple[int, int] | None:
    try:
        info = path.stat()
    except OSError:
        return None
    return info.st_ino, info.st_mtime_ns


def run_scene(
    scene_path: Path,
    out: Path,
    *,
    force: bool = False,
    cache: Path | None = None,
    announce: Callable[[str], None] = lambda message: None,
    divergence_angle: float | None = None,
) -> Outcome:
    """Generate, build, simulate and plot `scene_path` into the folder `out`; `divergence_angle`
    [rad]: the simulator's --divergence-angle (None: its default, π/2)."""
    with tempfile.TemporaryDirectory(prefix="ipgen-run.") as staging:
        planned = job.for_the_simulator(job.plan(staging, scene=scene_path, emit=("library",), force=force))
        assert planned.scene is not None
        scene = planned.scene
        if scene.links > MAX_SIMULATED_LINKS:
            raise BuildError(
                f"ipgen run simulates chains of up to {MAX_SIMULATED_LINKS} links, this scene has "
                f"{scene.links}: generate its header (ipgen --scene ... -o DIR) and build a simulator of "
                "its own with CMake's ipgen_add_simulator (docs/simulator.md)"
            )
        for warning in scene.warnings:  # e.g. a unit slip: the run goes on
            announce(warning)
        stem = scene.stem
        paths = {suffix: out / f"{stem}.{suffix}" for suffix in ("cfg", "csv", "png", "txt")}
        prepare_directory(out)
        _check_outputs(paths, Path(scene_path), force)
        job.run(planned)
        sources = model_sources(Path(staging), planned.name)
        cfg_text = (Path(staging) / f"{stem}.cfg").read_text()
    simulator = build(sources, planned.name, cache, announce)
    write_file(paths["cfg"], cfg_text, force=True)  # checked above
    before = _stamp(paths["csv"])
    command = [str(simulator.path), str(paths["cfg"]), "--csv", str(paths["csv"]), "--force"]
    if divergence_angle is not None:
        command += ["--divergence-angle", repr(float(divergence_angle))]
    start = time.perf_counter()
    done = subprocess.run(command, capture_output=True, text=True)
    seconds = time.perf_counter() - start
    files = [paths["cfg"]]
    report = " ".join(done.stdout.split())
    unplotted = ""
    if _stamp(paths["csv"]) != before and paths["csv"].is_file():  # the simulator wrote it now
        files.append(paths["csv"])
        links = f"{scene.links} link{'s' if scene.links > 1 else ''}"
        title = f"{stem}: {scene.type} pendulum, {links} (model {planned.name})"
        if done.returncode != 0:
            title += f"; the run ended with status {done.returncode}"
        try:
            unit = _unit(scene)  # V with a dc_motor, m/s² or rad/s² with an acceleration input
            plot_run(
                read_run(paths["csv"]),
                paths["png"],
                title,
                scene.type,
                force=True,
                coordinates=scene.coordinates,
                input_unit=unit,
                sampled=sampled_beside(paths["cfg"]),
            )
            files.append(paths["png"])
        except PlotError as exc:  # e.g. a run that grew beyond what can be drawn: still a summary
            unplotted = f"No plot: {exc}."
    origin = (
        f"built in {simulator.seconds:.1f} s" if simulator.built else "taken from the cache, not compiled"
    )
    parts = [report] if report else []
    if done.returncode != 0:
        problem = " ".join(done.stderr.split()) or "no message"
        parts.append(f"The simulator stopped with exit status {done.returncode}: {problem}")
    if unplotted:
        parts.append(unplotted)
    parts.append(f"Simulator {simulator.path} ({origin}).")
    summary = " ".join(parts)
    frame = scene.coordinates
    angles = (
        ""
        if frame.is_canonical
        else f" (the angles and rates in the rig's coordinates: angles {frame.angles}, zero {frame.zero}, "
        f"positive {frame.positive}; docs/model.md)"
    )
    write_file(
        paths["txt"],
        f"{summary}\n\n(Generated by ipgen run from {shown_path(scene_path)}; the CSV's columns: t, "
        f"theta0..thetaN, dtheta0..dthetaN{angles}, then the energies and u if the scene has them.)\n",
        force=True,
    )
    files.append(paths["txt"])
    return Outcome(done.returncode, files, simulator, summary, done.stderr, seconds)


def _unit(scene: Scene) -> str | None:
    """u's unit when the scene's actuator makes it other than a force or torque."""
    if scene.actuator.is_motor:
        return "V"
    if scene.actuator.is_acceleration:
        return "rad/s²" if scene.type == "rotary" else "m/s²"
    return None
