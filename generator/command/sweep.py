"""`ipgen sweep SCENE.toml -o OUT/`: parses the options, shows progress, prints the scores."""

from __future__ import annotations

import math
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import TextIO

import click

from ipgen.command.interrupts import interrupted_status, sigterm_interrupts
from ipgen.command.paths import NonEmptyPath
from ipgen.command.scene_choice import chosen_scene, preset_option
from ipgen.errors import Error

HELP = """Sweep a scene: run it over levels of its keys and score how robust its controller is.

\b
--scorecard runs the robustness criteria (model parameters x0.75..1.25, damping, Coulomb
friction, controller period; encoder resolution, noise, delay, drive noise, lag and pulses
with [sensors] support), --vary KEY=LO:HI:N or KEY=v1,v2,... (repeatable: a 1-D or 2-D grid)
any scene key, e.g. parameters.m[1], initial.theta[1], controller.period; --random N starts
hanging (with a [swingup]) or near upright with masses, damping and a motor's Rm each drawn
within ±SPREAD (its score: the fraction of runs that end upright). The plant changes,
the controller stays the one designed on the scene (unless a [controller]/[swingup] key is
varied). Writes OUT/runs.csv (every run; an interrupted sweep resumes from it), scores.json,
scores.md and PNGs. Runs go to all local cores, or a Dask cluster with --dask ADDRESS
(pip install 'dask[distributed]'); results are the same either way. A fixed-pivot scene
(acrobot, pendubot) takes the model criteria and keys, and fails a run whose torque exceeds
its bound. docs/sweep.md.

\b
Examples:
  ipgen sweep --preset rsip_lqr --scorecard -o out/rsip
  ipgen sweep --preset qube_servo2_mpc_swingup --random 1000 -o out/starts
  ipgen sweep my_scene.toml --vary 'initial.theta[1]=-0.6:0.6:13' \\
              --vary 'initial.dtheta[1]=-3:3:13' -o out/basin
"""


class _Progress:
    """Progress on stderr, opened at the first report: click's bar on a terminal; elsewhere (a log,
    CI, a pipe) a plain line at most every `every` seconds and at the end — runs done of all, the
    rate and the time left at that rate — instead of a bar that is drawn only when it ends."""

    def __init__(
        self, file: TextIO | None = None, every: float = 10.0, clock: Callable[[], float] = time.monotonic
    ) -> None:
        self.file = file
        self.every = every
        self.clock = clock
        self.bar = None
        self.shown = 0
        self.started: tuple[float, int] | None = None  # (time, runs done) at the first report
        self.printed = -math.inf

    def __call__(self, done: int, total: int) -> None:
        file = self.file or sys.stderr
        if file.isatty():
            if self.bar is None:
                self.bar = click.progressbar(length=total, label="runs", file=file, show_pos=True)
                self.bar.__enter__()
            self.bar.update(done - self.shown)
            self.shown = done
            return
        now = self.clock()
        if self.started is None:
            self.started = (now, done)  # runs resumed from an earlier table do not count in the rate
        if done < total and now - self.printed < self.every:
            return
        self.printed = now
        click.echo(f"ipgen: {self._line(done, total, now)}", file=file)

    def _line(self, done: int, total: int, now: float) -> str:
        assert self.started is not None
        percent = 100 * done // total if total else 100
        line = f"runs {done}/{total} ({percent} %)"
        elapsed, ran = now - self.started[0], done - self.started[1]
        if ran > 0 and elapsed > 0:
            rate = ran / elapsed
            line += f", {rate:.3g} runs/s"
            if done < total:
                line += f", about {_duration((total - done) / rate)} left"
            else:
                line += f", {_duration(elapsed)}"
        return line

    def close(self) -> None:
        if self.bar is not None:
            self.bar.__exit__(None, None, None)
            self.bar = None


def _duration(seconds: float) -> str:
    """3 s, 1 min 5 s, 2 h 3 min."""
    seconds = max(0, round(seconds))
    if seconds < 60:
        return f"{seconds} s"
    minutes, seconds = divmod(seconds, 60)
    if minutes < 60:
        return f"{minutes} min {seconds} s"
    hours, minutes = divmod(minutes, 60)
    return f"{hours} h {minutes} min"


def _criterion(spec: str) -> tuple[str, str]:
    name, equals, levels = spec.partition("=")
    if not equals:
        raise click.BadParameter(
            f"{spec!r}: expected NAME=LO:HI:N or NAME=v1,v2,...", param_hint="--criterion"
        )
    return name.strip(), levels


def _criteria_levels(specs: tuple[str, ...]) -> dict[str, str]:
    """--criterion NAME=LEVELS options by name; a name given twice is an error (the last won)."""
    levels: dict[str, str] = {}
    for name, text in map(_criterion, specs):
        if name in levels:
            raise click.BadParameter(f"{name} is given twice: give its levels once", param_hint="--criterion")
        levels[name] = text
    return levels


@click.command("sweep", help=HELP, context_settings={"help_option_names": ["-h", "--help"]})
@click.argument("scene", type=NonEmptyPath(), metavar="[SCENE.toml]", required=False)
@preset_option
@click.option(
    "-o", "--output", "out", type=NonEmptyPath(), metavar="OUT", help="Folder for the results."
)
@click.option("--scorecard", is_flag=True, help="Run the robustness scorecard's criteria.")
@click.option(
    "--only", default=None, metavar="NAMES", help="With --scorecard: these criteria only (comma list)."
)
@click.option(
    "--criterion",
    "criteria",
    multiple=True,
    metavar="NAME=LEVELS",
    help="With --scorecard: a criterion's levels (LO:HI:N or v1,v2,...), e.g. mass=0.5:1.5:11.",
)
@click.option(
    "--vary",
    multiple=True,
    metavar="KEY=LO:HI:N",
    help="A scene key over a range or list (repeatable: the grid of all combinations).",
)
@click.option(
    "--random",
    type=int,
    default=0,
    metavar="N",
    help="N random starts (hanging with a [swingup], near upright) with m, delta and a motor's Rm ± SPREAD.",
)
@click.option(
    "--spread", type=float, default=0.2, show_default=True, help="With --random: the parameters' ± fraction."
)
@click.option("--repeat", type=int, default=None, help="Runs per level (seeded criteria; --vary: default 1).")
@click.option("--seed", type=int, default=0, show_default=True, help="The base of every run's seed.")
@click.option(
    "--angle-tolerance",
    type=float,
    default=0.35,
    show_default=True,
    help="Success: |link angle − goal| [rad].",
)
@click.option(
    "--rate-tolerance", type=float, default=1.0, show_default=True, help="Success: |link rate| [rad/s]."
)
@click.option("--hold", type=float, default=1.0, show_default=True, help="Success: held for the last HOLD s.")
@click.option(
    "--base-tolerance", type=float, default=None, help="Success: |θ0 − goal| [m or rad] (default: unchecked)."
)
@click.option(
    "--travel", type=float, default=None, help="Success: |θ0| limit [default: the scene's limits.travel]."
)
@click.option(
    "--converge",
    type=float,
    default=0.25,
    show_default=True,
    help="Success, balance: every link within CONVERGE × its initial angle error over the hold.",
)
@click.option("--dask", default=None, metavar="ADDRESS", help="A Dask scheduler, e.g. tcp://10.0.0.5:8786.")
@click.option("--jobs", type=int, default=None, help="Local worker processes [default: all cores].")
@click.option(
    "--force", is_flag=True, help="Start over (ignore OUT/runs.csv), write into a folder with other files."
)
@click.option(
    "--cache-dir",
    type=NonEmptyPath(),
    default=None,
    metavar="DIR",
    help="Where compiled simulators are kept [default: ipgen's cache].",
)
def command(
    scene: Path | None,
    preset: str | None,
    out: Path | None,
    scorecard: bool,
    only: str | None,
    criteria: tuple[str, ...],
    vary: tuple[str, ...],
    random: int,
    spread: float,
    repeat: int | None,
    seed: int,
    angle_tolerance: float,
    rate_tolerance: float,
    hold: float,
    base_tolerance: float | None,
    travel: float | None,
    converge: float,
    dask: str | None,
    jobs: int | None,
    force: bool,
    cache_dir: Path | None,
) -> int:
    from ipgen.sweeps.runner import sweep
    from ipgen.sweeps.success import Success

    scene = chosen_scene(scene, preset, "ipgen sweep --preset rsip_lqr --scorecard -o out/")
    if out is None:
        raise Error(
            "missing -o OUT: say where to write the sweep, e.g. ipgen sweep SCENE.toml --scorecard -o out/"
        )
    chosen: bool | tuple[str, ...] = scorecard
    if only is not None:
        if not scorecard:
            raise Error("--only chooses scorecard criteria: add --scorecard")
        chosen = tuple(name.strip() for name in only.split(",") if name.strip())
    test = Success(angle_tolerance, rate_tolerance, hold, base_tolerance, travel, converge)
    progress = _Progress()
    try:
        with sigterm_interrupts():
            outcome = sweep(
                scene,
                out,
                scorecard_criteria=chosen,
                vary=vary,
                levels=_criteria_levels(criteria),
                repeat=repeat,
                seed=seed,
                success=test,
                dask=dask,
                jobs=jobs,
                force=force,
                cache=cache_dir,
                progress=progress,
                random=random,
                spread=spread,
            )
    except KeyboardInterrupt as interrupt:
        progress.close()
        where = (
            f"the finished runs are in {out / 'runs.csv'}: the same command resumes"
            if (out / "runs.csv").is_file()
            else "no run had finished"  # interrupted while planning: nothing written
        )
        click.echo(f"ipgen: interrupted; {where}", err=True)
        return interrupted_status(interrupt)
    finally:
        progress.close()
    resumed = outcome.runs - outcome.ran
    rate = f", {outcome.ran / outcome.seconds:.1f} runs/s" if outcome.ran and outcome.seconds > 0 else ""
    click.echo(
        f"{outcome.runs} runs ({outcome.ran} now on {outcome.workers} workers "
        f"in {outcome.seconds:.1f} s{rate}" + (f"; {resumed} from OUT/runs.csv" if resumed else "") + ")"
    )
    for s in outcome.scores:
        shown = (
            "not run: " + s.criterion.refused
            if s.criterion.refused
            else ("—" if s.score is None else f"{100 * s.score:.0f} %")
        )
        click.echo(f"  {s.criterion.name:<13} {shown}")
    total = "—" if outcome.score is None else f"{100 * outcome.score:.0f} %"
    click.echo(f"score {total}; wrote {', '.join(str(path) for path in outcome.files)}")
    return 0
