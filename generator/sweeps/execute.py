"""One run of a sweep, and a batch of them in one worker process.

`run_one` is a pure function of (scene text, overrides, seed, success test): the worker prepares
the scene once per process (`prepare`: the nominal scene, its TOML document, the model library's sources
and the compiled simulator from ipgen's cache, so no run compiles or starts an interpreter), then
per run applies the overrides in memory, validates the changed scene (a level the scene format
refuses is `refused` with that one-line reason), writes the resolved config to a scratch folder,
runs the simulator and judges its trajectory (`success.judge`).
"""

from __future__ import annotations

import atexit
import hashlib
import os
import shutil
import subprocess
import tempfile
import threading
import time
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING

from ipgen.errors import Error
from ipgen.sweeps import fixed as fixed_sweep
from ipgen.sweeps import overrides as override
from ipgen.sweeps.design_model import model_lines
from ipgen.sweeps.spec import SEEDED_KEYS
from ipgen.sweeps.success import Judgement, Success, judge

if TYPE_CHECKING:
    from ipgen.experiment.scene import Scene
    from ipgen.sweeps.fixed import FixedScene


@dataclass(frozen=True)
class SceneSource:
    """The scene a sweep runs, by value (a Dask worker on another machine has no access to the file)."""

    stem: str
    text: str
    cache: str | None = None  # the simulators' cache folder (None: ipgen's default)
    # The model's name and its library's sources ((file name, text) pairs), when the caller has
    # them (else the worker generates them: the same text, as generation is deterministic).
    model: str = ""
    header: tuple[tuple[str, str], ...] = ()
    # Files the scene names beside it ((file name, text): a fixed swing-up's plan CSV), written
    # beside the worker's copy of the scene.
    files: tuple[tuple[str, str], ...] = ()

    @property
    def digest(self) -> str:
        """SHA-256 of the stem, text and files: what a worker caches its preparation under."""
        files = "\0".join(f"{name}\0{text}" for name, text in self.files)
        return hashlib.sha256(f"{self.stem}\0{self.text}\0{self.cache}\0{files}".encode()).hexdigest()


@dataclass(frozen=True)
class Task:
    """One run: its place in the sweep, its seed and its overrides (key text, value)."""

    index: int
    criterion: str
    level: int
    repeat: int
    seed: int
    overrides: tuple[tuple[str, object], ...]


@dataclass(frozen=True)
class Result:
    """What one run did (`outcome`: pass, fail or refused)."""

    task: Task
    outcome: str
    reason: str
    status: int | None
    angle_error: float
    rate_error: float
    base_error: float
    max_travel: float
    t_final: float
    seconds: float


@dataclass
class Prepared:
    """A scene prepared in this process: nominal scene, document, simulator, scratch folder (a
    fixed-pivot scene: `fixed`, its nominal run planned, and no `scene`)."""

    path: Path
    scene: Scene | None
    document: dict
    simulator: Path
    scratch: Path
    model: str
    header: tuple[tuple[str, str], ...]  # the model library's sources
    fixed: FixedScene | None = None
    model_lines: tuple[str, ...] = ()  # the loop's nominal design model (`sweeps.design_model`), every run


_PREPARED: dict[str, Prepared] = {}
_LOCK = threading.Lock()


def scratch_root() -> str | None:
    """Where a worker's scratch folder goes: $TMPDIR when set (the user's choice, as `tempfile`
    honours it), else the RAM disk /dev/shm where there is one (the cfg and CSV of a run never
    reach a disk), else `tempfile`'s default (None)."""
    if os.environ.get("TMPDIR"):
        return None
    shm = "/dev/shm"
    return shm if os.path.isdir(shm) and os.access(shm, os.W_OK) else None


def release() -> None:
    """Remove this process's scratch folders now and forget its preparations (an interrupted
    sweep: not left to the exit, which SIGTERM would skip)."""
    with _LOCK:
        for prepared in _PREPARED.values():
            shutil.rmtree(prepared.scratch, ignore_errors=True)
        _PREPARED.clear()


def header_text(path: Path, folder: Path) -> tuple[str, tuple[tuple[str, str], ...]]:
    """(model name, its library's sources as (file name, text) pairs) of the scene at `path`,
    generated into `folder`."""
    from ipgen.pipeline import job
    from ipgen.pipeline.simulator import model_sources

    planned = job.for_the_simulator(job.plan(folder, scene=path, emit=("library",), force=True))
    job.run(planned)
    return planned.name, tuple(model_sources(folder, planned.name).items())


def prepare(source: SceneSource) -> Prepared:
    """The scene prepared once per process (and per scene): cached."""
    with _LOCK:
        found = _PREPARED.get(source.digest)
        if found is not None:
            return found
        from ipgen.experiment.scene import load_scene, read_document
        from ipgen.pipeline.simulator import build

        scratch = Path(tempfile.mkdtemp(prefix="ipgen-sweep.", dir=scratch_root()))
        atexit.register(shutil.rmtree, scratch, ignore_errors=True)
        path = scratch / f"{source.stem}.toml"
        path.write_text(source.text)
        for file_name, text in source.files:  # beside the scene (names checked by fixed.files)
            (scratch / file_name).write_text(text)
        if fixed_sweep.is_fixed_scene(path):
            fixed = fixed_sweep.prepare(fixed_sweep.load_fixed(path))
            sources = dict(fixed.plan.sources)
            simulator = build(sources, fixed.plan.name, None if source.cache is None else Path(source.cache))
            prepared = Prepared(
                path, None, fixed.document, simulator.path, scratch, fixed.plan.name,
                tuple(sources.items()), fixed,
            )  # fmt: skip
            _PREPARED[source.digest] = prepared
            return prepared
        name, header = (
            (source.model, source.header) if source.header else header_text(path, scratch / "model")
        )
        simulator = build(dict(header), name, None if source.cache is None else Path(source.cache))
        from ipgen.experiment.config import resolved_config

        scene = load_scene(path)
        nominal = tuple(model_lines(resolved_config(scene, model=name)))
        prepared = Prepared(
            path, scene, read_document(path), simulator.path, scratch, name, header, None, nominal
        )
        _PREPARED[source.digest] = prepared
        return prepared


def _message(error: Exception, path: Path) -> str:
    """A scene error's one line without the scratch file's name in front."""
    text = " ".join(str(error).split())
    for prefix in (f"{path.as_posix()}: ", f"{path.name}: "):
        if text.startswith(prefix):
            return text[len(prefix) :]
    return text


def _seeded(prepared: Prepared, task: Task) -> tuple[tuple[str, object], ...]:
    """The overrides with the run's seed as sensors.seed (the seed of every random stream of a run:
    sensor noise, drive noise, pulses) when the scene has [sensors] or a seeded key, or the run
    sets one (a scene's own [actuator] noise without [sensors] ran every repeat on seed 0)."""
    random = any(k.split("[")[0] in SEEDED_KEYS for k, _ in task.overrides)
    own = any(_given(prepared.document, key) for key in SEEDED_KEYS)
    if "sensors" not in prepared.document and not random and not own:
        return task.overrides
    if any(k == "sensors.seed" for k, _ in task.overrides):
        return task.overrides
    return (*task.overrides, ("sensors.seed", task.seed))


def _given(document: dict, key: str) -> bool:
    """Whether the scene document sets `key` ("table.name") to something other than 0 or empty."""
    table, name = key.split(".", 1)
    values = document.get(table)
    value = values.get(name) if isinstance(values, dict) else None
    return value not in (None, 0, [], ())


def nominal_estimator(scene: Scene, nominal: Scene, changes: tuple[tuple[str, object], ...]) -> Scene:
    """`scene` with the nominal scene's estimator model (gains, linearisation, covariances: its
    `EstimatorNumbers`, designed on the nominal scene like the controller), unless the run designs
    anew (a [controller], [swingup] or [estimator] key) or has no measured loop. The run's sensors
    and drive keys stay its own."""
    loop, designed = getattr(scene, "loop", None), getattr(nominal, "loop", None)
    if loop is None or designed is None or loop.estimator.kind != designed.estimator.kind:
        return scene
    if override.designs(changes) or any(key.startswith("estimator.") for key, _ in changes):
        return scene
    return replace(scene, loop=replace(loop, estimator=designed.estimator))


def _refused(task: Task, reason: str, started: float) -> Result:
    nan = float("nan")
    return Result(task, "refused", reason, None, nan, nan, nan, nan, nan, time.perf_counter() - started)


def _read_csv(path: Path, dof: int) -> tuple:
    import numpy as np

    with path.open() as f:
        columns = f.readline().strip().split(",")
    wanted = [columns.index("t")] + [columns.index(f"theta{i}") for i in range(dof)]
    wanted += [columns.index(f"dtheta{i}") for i in range(dof)]
    data = np.loadtxt(path, delimiter=",", skiprows=1, usecols=wanted, ndmin=2)
    return data[:, 0], data[:, 1:]


def run_one(source: SceneSource, task: Task, test: Success) -> Result:
    """Run `task` on the scene: refused, failed or passed, with its end-state errors."""
    from ipgen.common.build_cache import cache_folder

    with cache_folder(None if source.cache is None else Path(source.cache)):  # a Dask worker's too
        return _run_one(source, task, test)


def _run_one(source: SceneSource, task: Task, test: Success) -> Result:
    from ipgen.experiment.scene import scene_from_document

    started = time.perf_counter()
    prepared = prepare(source)
    if prepared.fixed is not None:
        return _run_fixed(prepared, prepared.fixed, task, test, started)
    assert prepared.scene is not None
    try:
        changes = _seeded(prepared, task)
        document = override.apply(prepared.document, prepared.scene, changes)
        designed = None if override.designs(changes) else prepared.scene
        scene = nominal_estimator(
            scene_from_document(prepared.path, document, designed=designed), prepared.scene, changes
        )
    except Error as error:
        return _refused(task, _message(error, prepared.path), started)
    if scene.controller is not None:
        goal = scene.controller.equilibrium
    elif scene.swingup is not None:  # the hold's target is in ipgen's coordinates, the CSV in the scene's
        goal = scene.coordinates.user_state(scene.swingup.target, scene.links)
    else:
        return _refused(
            task, "the scene has no [controller] or [swingup]: no goal to judge the run by", started
        )
    done, cfg, csv = _simulate(
        prepared, task, run_config(prepared, scene, nominal_design=designed is not None)
    )
    try:
        if done.returncode == 2:  # the simulator refused the resolved scene
            return _refused(task, _simulator_refusal(done), started)
        dof = scene.links + 1
        try:
            t, states = _read_csv(csv, dof)
        except (OSError, ValueError):
            t, states = [], []
        if len(t) == 0:
            return _no_trajectory(task, done.returncode, started)
        verdict = judge(
            test,
            t,
            states,
            goal,
            rotary=scene.type == "rotary",
            status=done.returncode,
            travel=scene.travel,
            balance=scene.swingup is None,
        )
    finally:
        cfg.unlink(missing_ok=True)
        csv.unlink(missing_ok=True)
    return _judged(task, verdict, done.returncode, started)


def run_config(prepared: Prepared, scene: Scene, *, nominal_design: bool) -> str:
    """The resolved config of one run of a cart or arm scene: `scene`'s, and with the nominal
    design the loop's model stated as the nominal scene's (`sweeps.design_model`)."""
    from ipgen.experiment.config import resolved_config

    text = resolved_config(scene, model=prepared.model)
    return text + "".join(f"{line}\n" for line in prepared.model_lines) if nominal_design else text


def _simulator_refusal(done: subprocess.CompletedProcess) -> str:
    """The reason of a run the simulator refused (exit status 2): its message on one line."""
    return " ".join(done.stderr.split())[:300] or "refused by the simulator"


def _no_trajectory(task: Task, status: int, started: float) -> Result:
    """A failed run whose CSV has no samples (or cannot be read)."""
    nan, elapsed = float("nan"), time.perf_counter() - started
    return Result(task, "fail", "no trajectory", status, nan, nan, nan, nan, nan, elapsed)


def _judged(task: Task, verdict: Judgement, status: int, started: float) -> Result:
    """A run's row from the success test's verdict."""
    return Result(
        task, "pass" if verdict.passed else "fail", verdict.reason, status, verdict.angle_error,
        verdict.rate_error, verdict.base_error, verdict.max_travel, verdict.t_final,
        time.perf_counter() - started,
    )  # fmt: skip


def _simulate(
    prepared: Prepared, task: Task, cfg_text: str
) -> tuple[subprocess.CompletedProcess, Path, Path]:
    """Write the run's cfg to the scratch folder and run the simulator on it: (its process, the
    cfg, the CSV); the caller removes both files."""
    stem = f"run{task.index}_{threading.get_ident()}"
    cfg, csv = prepared.scratch / f"{stem}.cfg", prepared.scratch / f"{stem}.csv"
    cfg.write_text(cfg_text)
    done = subprocess.run(
        [str(prepared.simulator), str(cfg), "--csv", str(csv), "--force"], capture_output=True, text=True
    )
    return done, cfg, csv


def _run_fixed(prepared: Prepared, scene: FixedScene, task: Task, test: Success, started: float) -> Result:
    """A fixed-pivot scene's run (`sweeps.fixed`): refused, failed or passed."""
    try:
        cfg_text = fixed_sweep.run_config(scene, prepared.path, task.overrides)
    except Error as error:  # without the scratch folder's name (the same on every worker)
        reason = _message(error, prepared.path).replace(f"{prepared.scratch.as_posix()}/", "")
        return _refused(task, reason, started)
    done, cfg, csv = _simulate(prepared, task, cfg_text)
    try:
        if done.returncode == 2:  # the simulator refused the resolved scene
            return _refused(task, _simulator_refusal(done), started)
        try:
            verdict = fixed_sweep.judge_run(test, csv, cfg_text, scene.chain.links, done.returncode)
        except (OSError, ValueError):
            return _no_trajectory(task, done.returncode, started)
    finally:
        cfg.unlink(missing_ok=True)
        csv.unlink(missing_ok=True)
    return _judged(task, verdict, done.returncode, started)


def run_batch(source: SceneSource, tasks: list[Task], test: Success) -> list[Result]:
    """Run `tasks` one after another in this process (one submission per batch, not per run)."""
    return [run_one(source, task, test) for task in tasks]
