"""`ipgen run SCENE.toml -o OUT/`: from a scene to results in one command.

Generates the scene's model library and resolved scene (or takes them from the cache, where the
last run of the same scene left them: pipeline/run_plan.py), builds (or takes from the cache) the
scene's simulator (pipeline/simulator.py), runs it, and writes into OUT:

    <stem>.cfg  the resolved scene (rerun it with the simulator named in the summary)
    <stem>.csv  the trajectory, written by the simulator
    <stem>.png  a plot of the run (plots/run.py; not with `plot=False`, `ipgen run --no-plot`)
    <stem>.txt  the summary paragraph: the simulator's own report of the run

Every file is checked before any work: a file there that ipgen (or the simulator) did not write
is replaced only with `force`. The simulator's exit status is the run's: 0, or its own non-zero
status with its message (a failed or diverging run still gets its plot and summary when the
simulator wrote a CSV).
"""

from __future__ import annotations

import contextlib
import re
import signal
import subprocess
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from ipgen.common.build_cache import cache_folder
from ipgen.common.files import (
    OutputError,
    check_replaceable,
    prepare_directory,
    removed_if_left_empty,
    write_file,
)
from ipgen.common.limits import MAX_SIMULATED_LINKS
from ipgen.common.safetext import shown_path
from ipgen.pipeline import job
from ipgen.pipeline.run_plan import RunPlan, load_plan, named_files, plan_key, store_plan
from ipgen.pipeline.simulator import BuildError, Simulator, build, model_sources

if TYPE_CHECKING:
    from ipgen.experiment.scene import Scene

# The first line of a CSV the simulator wrote (the rule of simulate.cpp's written_by_simulator):
# the state, the energies, u, the measured loop's columns (ipsim/sensors.hpp) and a swing-up's phase.
SIMULATOR_CSV = re.compile(
    r"t((?:,theta\d+)+)((?:,dtheta\d+)+)(,kinetic,potential,input_work,dissipated)?(,u|(?:,u\d+)+)?"
    r"(?:,y_theta\d+)*(?:,hat_theta\d+)*(?:,hat_dtheta\d+)*(?:,hat_gain)?(?:,phase)?"
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
    not even with --force, nor the files it names (a plan CSV). The CSV is the simulator's:
    replaced if it wrote it, else with force. Without "png" in `paths` (no plot) the PNG is not
    checked."""
    keep = [scene, *named_files(scene)]
    check_replaceable(paths["cfg"], force, keep=keep)
    check_replaceable(paths["txt"], force, keep=keep)
    if "png" in paths:
        from ipgen.plots.run import PNG

        check_replaceable(paths["png"], force, PNG, keep=keep)
    csv = paths["csv"]
    check_replaceable(csv, True, keep=keep)  # the path itself: a directory, too long, ...
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
    plot: bool = True,
) -> Outcome:
    """Generate, build, simulate and plot `scene_path` into the folder `out`.

    Parameters
    ----------
    scene_path : Path
        The scene file.
    out : Path
        The folder of the results (created if needed).
    force : bool
        Replace files in `out` that ipgen did not write.
    cache : Path or None
        The cache of compiled simulators (None: `build_cache.cache_root`'s default).
    announce : callable
        Called with each progress or warning line.
    divergence_angle : float or None
        The simulator's --divergence-angle [rad] (None: its default, π/2).
    plot : bool
        Draw `<stem>.png` (matplotlib, imported only then); False: no PNG is drawn or checked, and
        one already in `out` is left as it is.

    Returns
    -------
    Outcome
        The run's files, simulator, exit status and summary.
    """
    # A run that fails or is interrupted before it writes (a first compile) leaves no empty `out`.
    with cache_folder(cache), removed_if_left_empty():  # an MPC's libraries go to the cache too
        return _run_scene(scene_path, out, force, cache, announce, divergence_angle, plot)


def _run_scene(
    scene_path: Path,
    out: Path,
    force: bool,
    cache: Path | None,
    announce: Callable[[str], None],
    divergence_angle: float | None,
    plot: bool,
) -> Outcome:
    key = plan_key(Path(scene_path), force)
    plan = load_plan(cache, key) if key is not None else None
    if plan is None:
        plan = _make_plan(scene_path, out, force, plot, announce)
        if key is not None and plan_key(Path(scene_path), force) == key:  # not edited meanwhile
            store_plan(cache, key, plan)
    else:  # the scene's checks passed when the plan was made: the same warnings, the same files
        for warning in plan.warnings:
            announce(warning)
        _prepare_outputs(plan.stem, out, scene_path, force, plot)
    stem = plan.stem
    paths = _paths(stem, out, plot)
    sources, name = plan.sources, plan.name
    cfg_text = plan.cfg
    simulator = build(sources, name, cache, announce)
    prepare_directory(out)  # again: a concurrent run into the same new -o may have removed it, failing
    write_file(paths["cfg"], cfg_text, force=True)  # checked above
    before = _stamp(paths["csv"])
    command = [str(simulator.path), str(paths["cfg"]), "--csv", str(paths["csv"]), "--force"]
    command += ["--progress", repr(PROGRESS_SECONDS)]
    if divergence_angle is not None:
        command += ["--divergence-angle", repr(float(divergence_angle))]
    files = [paths["cfg"]]  # what this run has written, for an interruption's message too
    try:
        start = time.perf_counter()
        done = _simulate(command, progress=_progress_line(announce))
        seconds = time.perf_counter() - start
        status, ended_by = _status(done.returncode)
        if _stamp(paths["csv"]) != before and paths["csv"].is_file():  # the simulator wrote it now
            files.append(paths["csv"])
        unplotted = ""
        if plot and paths["csv"] in files:
            unplotted = _plot(plan, paths, status, ended_by)
            if not unplotted:
                files.append(paths["png"])
        stale = paths["csv"] not in files and paths["csv"].is_file()  # kept by the simulator's policy
        earlier = f"{shown_path(paths['csv'])} is an earlier run's: this run wrote no CSV" if stale else ""
        summary = _summary(done, status, ended_by, earlier, unplotted, simulator)
        _write_summary(paths["txt"], summary, plan, Path(scene_path))
        files.append(paths["txt"])
        messages = "\n".join(part for part in (done.stderr.rstrip("\n"), ended_by, earlier) if part)
        return Outcome(status, files, simulator, summary, messages, seconds)
    except KeyboardInterrupt as interrupt:  # Ctrl-C or SIGTERM, while simulating or after it
        if paths["csv"] not in files and _stamp(paths["csv"]) != before and paths["csv"].is_file():
            files.append(paths["csv"])  # the simulator had renamed its CSV in when it was stopped
        beside = (paths.get("png"), paths["txt"]) if paths["csv"] in files else ()  # else they match it still
        earlier_files = [path for path in beside if path and path not in files and path.is_file()]
        raise RunInterrupted(files, interrupt, earlier_files) from None


def _plot(plan: RunPlan, paths: dict[str, Path], status: int, ended_by: str) -> str:
    """Draw the run's CSV into its PNG; "" when drawn, else the summary's "No plot: ..." sentence
    (a run that grew beyond what can be drawn still gets its summary)."""
    from ipgen.plots.run import PlotError, plot_run, read_run, sampled_beside

    links = f"{plan.links} link{'s' if plan.links > 1 else ''}"
    title = f"{plan.stem}: {plan.type} pendulum, {links} (model {plan.name})"
    if status != 0:
        title += f"; the run ended with status {status}{f' ({ended_by})' if ended_by else ''}"
    try:
        plot_run(
            read_run(paths["csv"], fixed=plan.type == "fixed"),
            paths["png"],
            title,
            plan.type,
            force=True,
            coordinates=plan.coordinates,
            input_unit=plan.unit,  # V with a dc_motor, m/s² or rad/s² with an acceleration input
            sampled=sampled_beside(paths["cfg"]),
        )
    except PlotError as exc:
        return f"No plot: {exc}."
    return ""


def _summary(
    done: subprocess.CompletedProcess[str], status: int, ended_by: str, earlier: str, unplotted: str,
    simulator: Simulator,
) -> str:  # fmt: skip
    """The run's one-paragraph summary: the simulator's report, why it stopped, what is missing."""
    origin = "taken from the cache, not compiled"
    if simulator.built:
        origin = f"built in {simulator.seconds:.1f} s"
    parts = [report] if (report := " ".join(done.stdout.split())) else []
    if status != 0:
        why = f" ({ended_by})" if ended_by else ""
        problem = " ".join(done.stderr.split()) or "no message"
        parts.append(f"The simulator stopped with exit status {status}{why}: {problem}")
    if earlier:
        parts.append(f"{earlier}.")
    if unplotted:
        parts.append(unplotted)
    parts.append(f"Simulator {simulator.path} ({origin}).")
    return " ".join(parts)


def _write_summary(path: Path, summary: str, plan: RunPlan, scene: Path) -> None:
    """STEM.txt: the summary, where it comes from and what the CSV's columns are."""
    frame = plan.coordinates
    angles = (
        ""
        if frame.is_canonical
        else f" (the angles and rates in the rig's coordinates: angles {frame.angles}, zero "
        f"{frame.zero}, positive {frame.positive}; docs/model.md)"
    )
    write_file(
        path,
        f"{summary}\n\n(Generated by ipgen run from {_source(scene)}; the CSV's columns: t, "
        f"theta0..thetaN, dtheta0..dthetaN{angles}, then the energies and u if the scene has them.)\n",
        force=True,
    )


class RunInterrupted(KeyboardInterrupt):
    """`ipgen run` interrupted (Ctrl-C, or SIGTERM as the command's `Terminated`) while its simulator
    ran or after it: the simulator was ended the same way (it removes its partial CSV); `written`:
    the files this run wrote (the CSV among them when the simulator had finished it), `earlier`
    the files beside them that are still an earlier run's, `cause` the interruption."""

    def __init__(self, written: list[Path], cause: BaseException, earlier: list[Path] | None = None) -> None:
        super().__init__(*cause.args)
        self.written = written
        self.cause = cause
        self.earlier = earlier or []


PROGRESS_SECONDS = 3.0  # a long run says how far it has come this often (the simulator's --progress)
_PROGRESS = re.compile(r"progress (\S+) (\S+)")


def _progress_line(announce: Callable[[str], None]) -> Callable[[float, float], None]:
    """The announcement of a simulator's progress line: the simulated time reached of t_end."""

    def report(t: float, t_end: float) -> None:
        share = f" ({100 * t / t_end:.0f} %)" if t_end > 0 else ""
        announce(f"simulating: t = {t:.6g} of {t_end:.6g} s{share}")

    return report


def _simulate(
    command: list[str], progress: Callable[[float, float], None] = lambda t, end: None
) -> subprocess.CompletedProcess[str]:
    """Runs the simulator to its end, handing its progress lines (its progress option) to `progress` as
    they come; interrupted, it passes SIGTERM on and waits for it (10 s, then SIGKILL), so no
    simulator goes on alone and its scratch file goes with it."""
    import threading

    lines: list[str] = []

    def read_errors() -> None:  # stderr as it comes: progress announced, the rest kept in order
        assert child is not None and child.stderr is not None
        for line in child.stderr:
            found = _PROGRESS.fullmatch(line.rstrip("\n"))
            if found is None:
                lines.append(line)
                continue
            try:
                reached, end = float(found.group(1)), float(found.group(2))
            except ValueError:
                lines.append(line)
                continue
            with contextlib.suppress(Exception):  # a failing announcement must not stop the reading
                progress(reached, end)

    child: subprocess.Popen[str] | None = None
    # The simulator's start and the reader's are inside the try: an interruption while the reader
    # thread starts (a loaded machine can take that long) must stop the simulator too. During
    # Popen itself (until `child` holds the process) SIGINT and SIGTERM wait, blocked in this
    # thread; the simulator starts with them blocked and unblocks them once its handlers are in
    # place (simulate.cpp, install_cleanup_handlers), so one sent meanwhile still stops it.
    try:
        blocked = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT, signal.SIGTERM})
        try:
            # errors="replace": a byte that is not UTF-8 (a path) must not end the reader, or the
            # simulator would block on a full pipe
            child = subprocess.Popen(
                command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, errors="replace"
            )
        finally:
            signal.pthread_sigmask(signal.SIG_SETMASK, blocked)
        reader = threading.Thread(target=read_errors, daemon=True)
        reader.start()
        assert child.stdout is not None
        out = child.stdout.read()
        child.wait()
        reader.join()
        err = "".join(lines)
    except KeyboardInterrupt:
        if child is None:
            raise
        child.terminate()
        try:
            child.wait(timeout=10)
        except subprocess.TimeoutExpired:
            child.kill()
            child.wait()
        raise
    return subprocess.CompletedProcess(command, child.returncode, out, err)


def _source(scene: Path) -> str:
    """The scene as the summary names it: "preset NAME" for a preset (`--preset`), else its path."""
    from ipgen.common.presets import preset_of

    name = preset_of(scene)
    return f"preset {name}" if name else shown_path(scene)


def _status(returncode: int) -> tuple[int, str]:
    """A simulator's exit status as a shell reports it (ended by signal n: 128 + n), and the
    signal named ("ended by SIGXFSZ: ...") or ""."""
    if returncode >= 0:
        return returncode, ""
    number = -returncode
    try:
        name = signal.Signals(number).name
        why = signal.strsignal(number) or ""
    except ValueError:
        name, why = f"signal {number}", ""
    return 128 + number, f"ended by {name}{': ' + why if why else ''}"


def _paths(stem: str, out: Path, plot: bool) -> dict[str, Path]:
    """The run's files in `out` by suffix (no "png" without a plot)."""
    suffixes = ("cfg", "csv", "png", "txt") if plot else ("cfg", "csv", "txt")
    return {suffix: out / f"{stem}.{suffix}" for suffix in suffixes}


def _prepare_outputs(stem: str, out: Path, scene_path: Path, force: bool, plot: bool) -> None:
    """Create `out` if needed and check every file the run will write there (`_check_outputs`)."""
    prepare_directory(out)
    _check_outputs(_paths(stem, out, plot), Path(scene_path), force)


def _make_plan(
    scene_path: Path, out: Path, force: bool, plot: bool, announce: Callable[[str], None]
) -> RunPlan:
    """Check the scene, announce its warnings, check the outputs, then generate the model's
    library sources and the resolved scene (run_plan.RunPlan), in that order."""
    from ipgen.scene.fixed import is_fixed_document
    from ipgen.scene.load import parse_document

    reader, document = parse_document(Path(scene_path))
    if is_fixed_document(document):  # a chain on a fixed pivot (pipeline/fixed_run.py)
        from ipgen.pipeline.fixed_run import fixed_plan

        plan = fixed_plan(Path(scene_path), document, reader)
        for warning in plan.warnings:  # e.g. gigabytes of CSV: the run goes on
            announce(warning)
        _prepare_outputs(plan.stem, out, scene_path, force, plot)
        return plan
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
        _prepare_outputs(scene.stem, out, scene_path, force, plot)
        job.run(planned)
        frame = scene.coordinates
        return RunPlan(
            name=planned.name,
            stem=scene.stem,
            type=scene.type,
            links=scene.links,
            angles=frame.angles,
            zero=frame.zero,
            positive=frame.positive,
            unit=_unit(scene),
            warnings=tuple(scene.warnings),
            cfg=(Path(staging) / f"{scene.stem}.cfg").read_text(),
            sources=model_sources(Path(staging), planned.name),
        )


def _unit(scene: Scene) -> str | None:
    """u's unit when the scene's actuator makes it other than a force or torque."""
    drive = scene.actuator
    return drive.unit(scene.type) if drive.is_motor or drive.is_acceleration else None
