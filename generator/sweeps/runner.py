"""A whole sweep: plan the runs, run those the table does not have yet, score, write the outputs.

OUT/ receives runs.csv (`table.py`), scores.json and scores.md (`scores.py`) and the PNGs
(`plots.py`): criterion_<name>.png per 1-D criterion run, grid.png for a 2-D grid, scores.png.
"""

from __future__ import annotations

from collections.abc import Callable
from concurrent.futures import Executor
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING

from ipgen.common import files
from ipgen.common.safetext import shown_path
from ipgen.sweeps import engine, execute, plots, scorecard, table
from ipgen.sweeps import fixed as fixed_sweep
from ipgen.sweeps import overrides as override
from ipgen.sweeps import scores as scoring
from ipgen.sweeps.execute import Result, SceneSource, Task, prepare
from ipgen.sweeps.spec import GRID, Criterion, Key, SweepError, check_total, grid, parse_vary
from ipgen.sweeps.success import Success
from ipgen.sweeps.units import axis_label

if TYPE_CHECKING:
    from ipgen.experiment.scene import Scene

MAX_SCENE_CHARS = 1_000_000


@dataclass(frozen=True)
class Outcome:
    """What a sweep wrote and found."""

    files: list[Path]
    scores: list[scoring.CriterionScore]
    score: float | None
    runs: int  # in the table
    ran: int  # run now (the others were resumed from the table)
    workers: int
    seconds: float  # wall time of the runs made now
    rows: list[dict[str, str]] = field(default_factory=list)


def plan(criteria: list[Criterion], seed: int, scene_for_pulses: object = None) -> list[Task]:
    """Every run of the sweep, numbered in order: criteria, levels, repetitions; seeds explicit."""
    tasks = []
    for criterion in criteria:
        if criterion.refused:
            continue
        for index, level in enumerate(criterion.levels):
            for repeat in range(criterion.repeat):
                run_seed = scorecard.seed_of(seed, criterion.name, index, repeat)
                overrides = level.overrides
                if criterion.name == "pulses" and scene_for_pulses is not None:
                    drawn = scorecard.pulse(scene_for_pulses, level.values[0], run_seed)  # type: ignore[arg-type]
                    overrides = (("actuator.pulses", drawn),)
                tasks.append(Task(len(tasks), criterion.name, index, repeat, run_seed, overrides))
    return tasks


# What a sweep writes besides runs.csv (`_write_outputs`): the scores and their picture, and a
# picture per criterion (a 1-D one's criterion_<name>.png, a 2-D grid's grid.png, spec.grid's name).
SCORES = ("scores.json", "scores.md", "scores.png")


def _picture(name: str, axes: int) -> str:
    """The file name of the picture of criterion `name` over `axes` keys."""
    return f"criterion_{name}.png" if axes == 1 else f"{name}.png"


def _remove_outputs(out: Path) -> None:
    """Removes the files a sweep writes besides runs.csv (`_write_outputs`), of an earlier sweep:
    the scores and the picture of each criterion its runs.csv names (grid.png only after a --vary
    grid), and nothing else (a user's criterion_holiday.png beside them was deleted by a glob)."""
    earlier = _earlier_criteria(out)  # a --vary sweep's is GRID, over one key or two
    names = [*SCORES, *(_picture(name, 1) for name in earlier)]
    if GRID in earlier:
        names.append(_picture(GRID, 2))
    for path in (out / name for name in names):
        if path.is_file() or path.is_symlink():
            path.unlink()


def _earlier_criteria(out: Path) -> set[str]:
    """The criteria an earlier sweep's runs.csv in `out` names (none without a readable one)."""
    import csv

    try:
        with (out / "runs.csv").open(newline="", encoding="utf-8") as f:
            return {row.get("criterion") or "" for row in csv.DictReader(f)} - {""}
    except (OSError, UnicodeDecodeError, csv.Error):
        return set()


def _check_out(out: Path, force: bool) -> None:
    """The output policy's checks of OUT (`files.check_directory`), then: a folder with files
    but no runs.csv is another's, written into only with `force`."""
    files.check_directory(out)
    if out.is_dir() and any(out.iterdir()) and not (out / "runs.csv").exists() and not force:
        raise SweepError(
            f"{shown_path(out)} holds files and no runs.csv of a sweep: pass another -o, "
            "or --force to write there"
        )


@dataclass(frozen=True)
class Planned:
    """A planned sweep: the scene by value, its criteria, every run, the success test."""

    source: SceneSource
    criteria: list[Criterion]
    tasks: list[Task]
    test: Success
    seed: int
    digest: str = ""  # table.sweep_digest: every row carries it
    note: str = ""  # what the success test adds for this scene (a fixed chain's: fixed.NOTE)

    def values(self, task: Task) -> tuple[float, ...]:
        """The values of the run's level."""
        criterion = next(c for c in self.criteria if c.name == task.criterion)
        return criterion.levels[task.level].values


def sweep(
    scene: str | Path,
    out: str | Path,
    *,
    scorecard_criteria: bool | tuple[str, ...] = False,
    vary: tuple[str, ...] = (),
    levels: dict[str, str] | None = None,
    repeat: int | None = None,
    seed: int = 0,
    success: Success | None = None,
    dask: str | None = None,
    jobs: int | None = None,
    force: bool = False,
    cache: str | Path | None = None,
    progress: Callable[[int, int], None] | None = None,
    plot: bool = True,
    random: int = 0,
    spread: float = scorecard.RANDOM_SPREAD,
) -> Outcome:
    """Run the sweep of `scene` into the folder `out` (see `ipgen.sweep`)."""
    from ipgen.common.build_cache import cache_folder

    with cache_folder(None if cache is None else Path(cache)):  # what it builds goes there too
        from ipgen.experiment.scene import load_scene

        test = success or Success()
        if repeat is not None and repeat < 1:
            raise SweepError(f"--repeat {repeat}: give a number of runs per level >= 1")
        if jobs is not None and jobs < 1:
            raise SweepError(f"--jobs {jobs}: give a number of worker processes >= 1")
        if not isinstance(seed, int) or seed < 0:
            raise SweepError(f"--seed {seed!r}: give an integer >= 0")
        if not scorecard_criteria and not vary and not random:
            raise SweepError(
                "nothing to sweep: pass --scorecard, --random N, or --vary KEY=LO:HI:N (repeatable)"
            )
        path, out = Path(scene), Path(out)
        fixed = fixed_sweep.load_fixed(path) if fixed_sweep.is_fixed_scene(path) else None
        criteria: list[Criterion] = []
        nominal: Scene | None = None
        if fixed is not None:  # a chain on a fixed pivot (sweeps/fixed.py)
            if random:
                raise SweepError(
                    "--random is for a cart or an arm so far: sweep a fixed chain with --scorecard or --vary"
                )
            if not fixed.controlled:
                raise SweepError(
                    f"{shown_path(path)} has no [controller] or [swingup]: a sweep judges a closed loop "
                    "(its goal is the controller's equilibrium or the swing-up's target)"
                )
            if scorecard_criteria:
                chosen = None if scorecard_criteria is True else tuple(scorecard_criteria)
                criteria += fixed_sweep.fixed_criteria(fixed, chosen, levels, repeat)
            elif levels:
                raise SweepError("--criterion changes the scorecard's levels: add --scorecard")
            if vary:
                keys = [fixed_sweep.parse_vary_fixed(spec) for spec in vary]
                criteria.append(_grid(keys, repeat, "fixed", "N m"))  # u: the joints' torques
            check_total(criteria)
            fixed_sweep.check_keys(fixed, criteria)
        else:
            nominal = load_scene(path)  # a scene with a problem stops here, with its own message
            draws = (random, spread, seed)
            criteria = _criteria(path, nominal, scorecard_criteria, vary, levels, repeat, draws)
        text = path.read_text()
        if len(text) > MAX_SCENE_CHARS:
            raise SweepError(f"{shown_path(path)} is too large for a sweep")
        beside = fixed.files() if fixed is not None else ()
        if dask is not None:
            engine.check_address(dask)
        tasks = plan(criteria, seed, nominal)
        _check_out(out, force)
        digest = table.sweep_digest(text + "".join(f"\0{name}\0{body}" for name, body in beside), test)
        finished = table.resumable(out / "runs.csv", tasks, force, digest)
        folder = None if cache is None else str(Path(cache).resolve())
        source = SceneSource(path.stem, text, folder, files=beside)
        try:
            # Generated and built once here: the workers get the header and find the simulator in the
            # cache (forked local workers inherit this preparation).
            prepared = prepare(source)
            source = replace(source, model=prepared.model, header=prepared.header)
            note = fixed_sweep.NOTE if fixed is not None else ""
            planned = Planned(source, criteria, tasks, test, seed, digest, note)
            # A bad --dask writes nothing; a sweep stopped before its first run leaves no empty OUT.
            with engine.executor(dask, jobs) as (pool, workers), files.removed_if_left_empty():
                files.prepare_directory(out)
                if force:  # starting over: no scores or pictures of the sweep before beside the new runs
                    _remove_outputs(out)
                return _run(planned, finished, pool, workers, out, progress, plot)
        except BaseException:  # interrupted (SIGINT, or SIGTERM through the command), or failed
            execute.release()  # the scratch folders now, not at exit
            raise


def _grid(
    keys: list[tuple[Key, tuple[float, ...]]], repeat: int | None, system: str, input_unit: str
) -> Criterion:
    """The `--vary` grid of `keys`, its plots' axes titled with each key's unit on `system`."""
    return grid(keys, repeat or 1, tuple(axis_label(key, system, input_unit) for key, _ in keys))


def _criteria(
    path: Path,
    nominal: Scene,
    scorecard_criteria: bool | tuple[str, ...],
    vary: tuple[str, ...],
    levels: dict[str, str] | None,
    repeat: int | None,
    random: tuple[int, float, int] = (0, scorecard.RANDOM_SPREAD, 0),
) -> list[Criterion]:
    """The criteria of a cart's or arm's scene: the scorecard's, the `--vary` grid and `random`'s
    (count, spread, seed) random starts, checked."""
    from ipgen.experiment.scene import read_document

    if nominal.specialise and any(spec.strip().startswith("parameters.") for spec in vary):
        raise SweepError(
            f"{shown_path(path)} is specialised (its parameters are compiled in): "
            "set specialise = false to sweep them"
        )
    criteria: list[Criterion] = []
    if scorecard_criteria:
        chosen = None if scorecard_criteria is True else tuple(scorecard_criteria)
        estimator = read_document(path).get("estimator", {}).get("kind", "exact")
        criteria += scorecard.criteria(nominal, chosen, levels, repeat, str(estimator))
    elif levels:
        raise SweepError("--criterion changes the scorecard's levels: add --scorecard")
    if vary:
        keys = [parse_vary(spec) for spec in vary]
        criteria.append(_grid(keys, repeat, nominal.type, nominal.actuator.unit(nominal.type)))
    count, spread, seed = random
    if count:
        criteria.append(scorecard.random_starts(nominal, count, spread, seed))
    check_total(criteria)  # before the runs are planned: a bound on the work, in one line
    _check_keys(path, nominal, criteria)
    return criteria


def _check_keys(path: Path, nominal: object, criteria: list[Criterion]) -> None:
    """Every criterion's overrides applied once to the nominal scene's document: a key or an
    index the scene cannot have (parameters.com[9] of a single pendulum) is a SweepError now,
    not a refusal of every run. The values are judged per run, by the scene's own checks."""
    from ipgen.experiment.scene import read_document

    document = read_document(path)
    for criterion in criteria:
        if criterion.refused or not criterion.levels:
            continue
        try:
            override.apply(document, nominal, criterion.levels[0].overrides)  # type: ignore[arg-type]
        except SweepError as error:
            raise SweepError(f"--vary {error}") from None


def _run(
    planned: Planned,
    finished: dict[int, dict[str, str]],
    pool: Executor,
    workers: int,
    out: Path,
    progress: Callable[[int, int], None] | None,
    plot: bool,
) -> Outcome:
    """Run what the table lacks on `pool`, appending to runs.csv as batches finish; write the outputs."""
    import time

    runs_csv = out / "runs.csv"
    todo = [task for task in planned.tasks if task.index not in finished]
    rows = dict(finished)
    with files.writing(runs_csv):
        appender = table.Appender(runs_csv, [rows[i] for i in sorted(rows)])
    total = len(planned.tasks)
    if progress is not None:
        progress(len(rows), total)

    def done(results: list[Result]) -> None:
        new = [table.row(result, planned.values(result.task), planned.digest) for result in results]
        with files.writing(runs_csv):
            appender.add(new)
        for result, written in zip(results, new, strict=True):
            rows[result.task.index] = written
        if progress is not None:
            progress(len(rows), total)

    started = time.perf_counter()
    try:
        if todo:
            engine.execute(pool, workers, planned.source, todo, planned.test, done)
    finally:
        appender.close()
    seconds = time.perf_counter() - started
    ordered = [rows[i] for i in sorted(rows)]
    found = scoring.score(planned.criteria, ordered)
    with files.writing(out):
        table.write_all(runs_csv, ordered)
        written = _write_outputs(out, planned.source.stem, planned, found, ordered, plot)
    return Outcome(written, found, scoring.total(found), len(ordered), len(todo), workers, seconds, ordered)


def _write_outputs(
    out: Path,
    stem: str,
    planned: Planned,
    found: list[scoring.CriterionScore],
    rows: list[dict[str, str]],
    plot: bool,
) -> list[Path]:
    """scores.json, scores.md and the PNGs; the files written (runs.csv first)."""
    total = scoring.total(found)
    written = [out / "runs.csv"]
    json_name, markdown_name, picture_name = SCORES
    for name, text in (
        (json_name, scoring.as_json(stem, planned.test, found, planned.seed, planned.note)),
        (markdown_name, scoring.as_markdown(stem, planned.test, found, len(rows), planned.note)),
    ):
        with files.replacing(out / name) as partial:
            partial.write_text(text, encoding="utf-8")
        written.append(out / name)
    if plot:
        for s in found:
            if s.criterion.refused or not s.criterion.levels:
                continue
            axes = len(s.criterion.axes)
            picture = out / _picture(s.criterion.name, axes)
            if axes == 1:
                written.append(plots.criterion_plot(s, rows, planned.test, picture))
            elif axes == 2:
                written.append(plots.heatmap(s, picture))
        written.append(plots.scores_plot(found, total, stem, out / picture_name))
    return written
