"""The `ipgen` command: parses options and calls the library; all errors end here as one line."""

from __future__ import annotations

import contextlib
import errno
import os
import sys
import warnings
from pathlib import Path
from typing import TYPE_CHECKING

import click

from ipgen.codegen.emit import DEFAULT_EMIT, TARGETS
from ipgen.command.paths import NonEmptyPath
from ipgen.command.scene_choice import chosen_scene, preset_option
from ipgen.common.install import install_hint
from ipgen.common.safetext import abbreviate, shown_path
from ipgen.common.version import __version__
from ipgen.errors import Error
from ipgen.model.system import INERTIA_VARIANTS, SYSTEM_TYPES, System
from ipgen.pipeline import job
from ipgen.pipeline.job import LINKS_WITHOUT_FORCE

if TYPE_CHECKING:
    from collections.abc import Callable

    from ipgen.model.coordinates import Coordinates
    from ipgen.pipeline.generate import Written

__all__ = ["main", "run"]

EXIT_USAGE = 2
# Generations above these sizes take more than a second or two: show a progress bar.
PROGRESS_FROM_LINKS = {"classical": 20, "rotary": 16}

HELP = """Derive the equations of motion of an n-link inverted pendulum and write a C++ header;
or, with a command, run a scene (ipgen run), plot or animate a simulator's CSV (ipgen plot,
ipgen animate), design a rig's identification experiment (ipgen excite) and fit the model's
parameters to its recording (ipgen identify).

\b
Systems (docs/model.md in the repository has the exact model):
  classical  a cart on a rail carrying a chain of n rods; q(0) = cart position [m]
  rotary     a horizontal arm turning about the vertical (Furuta) carrying n rods;
             q(0) = arm angle [rad]
  fixed      a chain of n rods on a fixed pivot, torques at chosen joints (--joints);
             q(1..n) only (acrobot, pendubot, DFKI's double pendulum)
Link angles q(1..n) are absolute, from the upright vertical, clockwise positive.

\b
The header DIR/NAME.hpp (C++17, Eigen only) defines in namespace ipgen::NAME:
  kLinks, kDof, Params<Scalar>{m, l, delta, g}, Vector<Scalar>, Matrix<Scalar>,
  mass_matrix, bias, gravity, n_matrix, forward_dynamics, kinetic_energy,
  potential_energy, dissipation  (M qdd + bias = (u, 0, ..., 0)^T)

\b
Examples:
  ipgen --type rotary --links 3 -o out/          # writes out/rotary3.hpp
  ipgen --type classical --links 2 --name cdip -o include/
  ipgen --scene scenes/cdip_pulse.toml -o out/    # also writes out/cdip_pulse.cfg
  ipgen --scene scenes/cdip_pulse.toml --describe # one line: name=cdip type=classical ...
  ipgen --type rotary --links 2 --emit equations -o out/  # out/rotary2.md and .tex
  ipgen run my_scene.toml -o out/   # generate, build, simulate: out/my_scene.csv, .png, .txt
  ipgen presets                     # the scenes shipped with ipgen (rigs, the paper's)
  ipgen run --preset qube_servo2 -o out/   # one of them: out/qube_servo2.csv, .png, .txt
  ipgen plot out/my_scene.csv       # out/my_scene.png
  ipgen animate out/my_scene.csv    # out/my_scene.gif, drawn to scale
  ipgen excite rig.toml --u-max 10 --travel 1 -o rig_identify.toml  # a safe experiment
  ipgen identify --scene rig.toml --data rig_identify.csv --free m1,delta0 -o out/  # fit parameters

--preset NAME (ipgen run, excite, identify, sweep) takes one of the scenes shipped with ipgen.
Errors print one line and exit with status 2. An existing file is only replaced if ipgen
wrote it, as the same kind of file (else pass --force); every file is written to a temporary
file, then renamed.
"""


CONTEXT = {"help_option_names": ["-h", "--help"], "max_content_width": 100}


# A group whose own options are the generator's (`ipgen --type ... -o ...` as before), with the
# commands run and plot (later identify, animate) beside them, click's convention for commands
# with subcommands.
@click.group(help=HELP, context_settings=CONTEXT, invoke_without_command=True)
@click.option(
    "--type",
    "system_type",
    type=click.Choice((*SYSTEM_TYPES, "fixed")),
    help="Base of the pendulum: a cart (classical), a rotating arm (rotary), or none: a chain on a fixed "
    "pivot (fixed, driven by torques at --joints).",
)
@click.option("--links", type=int, metavar="N", help="Number of rods in the chain, an integer >= 1.")
@click.option(
    "--joints",
    default=None,
    metavar="J,...",
    help="--type fixed: the driven joints, one input each in this order (1 = shoulder, 2 = elbow, ...)  "
    "[default: 1]",
)
@click.option(
    "-o",
    "--output",
    "directory",
    type=NonEmptyPath(path_type=str),
    default=None,
    metavar="DIR",
    help="Folder for the header; created if needed. Required unless --describe.",
)
@click.option(
    "--name",
    default=None,
    metavar="NAME",
    help="C++ namespace ipgen::NAME and file NAME.hpp  [default: <type><N>, e.g. rotary3]",
)
@click.option(
    "--inertia",
    type=click.Choice(INERTIA_VARIANTS),
    default=None,
    help="Rotary only: 'pivot' counts a link's spin about its pivot axis only (the "
    "published model, default); 'full' uses the complete thin-rod inertia.",
)
@click.option(
    "--scene",
    type=NonEmptyPath(),
    default=None,
    metavar="FILE",
    help="Take the system from a scene file (scenes/*.toml) instead of --type/--links, and also "
    "write DIR/<scene>.cfg, the resolved scene the simulator reads.",
)
@click.option(
    "--describe",
    is_flag=True,
    help="With --scene: print the scene's system as one line `name=... type=... links=... "
    "inertia=... stem=...` (for build tools) and write nothing.",
)
@click.option(
    "--fix",
    default=None,
    metavar="NAME=VALUE,...",
    help="Fold these parameters into the header as exact constants, e.g. --fix m0=0.3,delta2=0 "
    "(a zero damping removes its terms). Names: m<i>, l<i>, delta<i>, g.",
)
@click.option(
    "--outputs",
    default=None,
    metavar="FUNCTION,...",
    help="Emit only these functions, e.g. --outputs forward_dynamics,forward_dynamics_derivatives "
    "(default: all).",
)
@click.option(
    "--emit",
    default=None,
    metavar="TARGET,...",
    help="What to write for the model, one or more of: "
    + "; ".join(f"{target.name} = {target.summary}" for target in TARGETS.values())
    + f"  [default: {','.join(DEFAULT_EMIT)}; with --scene: the scene's [system] emit]",
)
@click.option(
    "--angles",
    default=None,
    metavar="absolute|relative",
    help="The rig's coordinates (docs/model.md): the headers' functions take link angles measured "
    "from the vertical (absolute, ipgen's) or link i from link i - 1 (relative).",
)
@click.option(
    "--zero",
    default=None,
    metavar="upright|hanging",
    help="The rig's coordinates: where the link angles are 0 (upright, ipgen's; or hanging).",
)
@click.option(
    "--positive",
    default=None,
    metavar="clockwise|counterclockwise",
    help="The rig's coordinates: the link angles' positive sense (clockwise, ipgen's).",
)
@click.option(
    "--force",
    is_flag=True,
    help="Overwrite files in DIR even if ipgen did not write them; "
    f"allow more than {LINKS_WITHOUT_FORCE} links.",
)
@click.option(
    "--cmake-dir",
    is_flag=True,
    help="Print the folder of ipgen's CMake package (ipgenConfig.cmake) and exit: "
    "find_package(ipgen CONFIG REQUIRED) with -Dipgen_DIR=$(ipgen --cmake-dir).",
)
@click.option(
    "--scene-schema",
    is_flag=True,
    is_eager=True,
    expose_value=False,
    callback=lambda ctx, _, value: _print_scene_schema(ctx) if value else None,
    help="Print the JSON Schema of scene files and exit (for editors: a scene's first line "
    "#:schema <file> points Taplo / Even Better TOML at it; see docs/scenes.md).",
)
@click.version_option(__version__, "-V", "--version", prog_name="ipgen")
def cli(
    system_type: str | None,
    links: int | None,
    joints: str | None,
    directory: str | None,
    name: str | None,
    inertia: str | None,
    scene: Path | None,
    describe: bool,
    fix: str | None,
    outputs: str | None,
    emit: str | None,
    angles: str | None,
    zero: str | None,
    positive: str | None,
    force: bool,
    cmake_dir: bool,
) -> None:
    context = click.get_current_context()
    given = [
        max(option.opts, key=len)
        for option in context.command.params
        if option.name is not None and context.params.get(option.name) not in _NOT_GIVEN
    ]
    command = context.invoked_subcommand
    if command is not None:
        if given:
            raise job.OptionsError(
                f"{', '.join(given)} belong to header generation, not to `ipgen {command}`: "
                f"give that command's own options after its name (ipgen {command} --help)"
            )
        return
    if not given:  # a bare `ipgen`: its usage first, then what it needs
        click.echo(context.get_usage(), err=True)
        raise job.OptionsError(
            "say what to do: a system (--type classical|rotary --links N -o DIR, or --scene FILE -o DIR), "
            "or a command (ipgen run SCENE.toml -o OUT/); ipgen --help has the rest"
        )
    if system_type == "fixed" or joints is not None:
        _generate_fixed(system_type, links, joints, directory, name, emit, force, context.params)
        return
    if scene is not None and _is_fixed_scene(scene):
        if describe:
            _describe_fixed_scene(scene, context.params)
        else:
            _generate_fixed_scene(scene, directory, emit, force, context.params)
        return
    if cmake_dir:
        from ipgen.common.locations import cmake_dir as folder

        click.echo(str(folder()))
        return
    if describe:
        _describe_scene(scene, system_type, links, name, inertia, fix, outputs)
        return
    planned = job.plan(
        directory,
        system_type=system_type,
        links=links,
        name=name,
        inertia=inertia,
        scene=scene,
        fix=fix,
        outputs=outputs,
        emit=emit,
        force=force,
        angles=angles,
        zero=zero,
        positive=positive,
    )
    written = _generate(planned)
    scene_ = planned.scene
    if scene_ is None:
        _report(planned.system, planned.name, written)
        return
    _report(planned.system, planned.name, written[:-1])
    click.echo(f"{_VERBS[written[-1].status]} {written[-1].path} (resolved scene {scene_.stem})")
    _warn(scene_.warnings)


def _is_fixed_scene(scene: Path) -> bool:
    """Whether the scene file declares `[system] type = "fixed"` (its TOML errors: one line)."""
    from ipgen.scene.fixed import is_fixed_document
    from ipgen.scene.load import parse_document

    return is_fixed_document(parse_document(scene)[1])


def _refuse_others(params: dict[str, object], allowed: set[str], why: str) -> None:
    """One line for the first option given that is not in `allowed`: its name, then `why`."""
    extra = sorted(key for key, value in params.items() if key not in allowed and value not in _NOT_GIVEN)
    if extra:
        raise job.OptionsError(f"--{extra[0].replace('_', '-')} {why}")


def _describe_fixed_scene(scene: Path, params: dict[str, object]) -> None:
    """`ipgen --scene FIXED.toml --describe`: the chain's line for CMake's ipgen_add_scene."""
    from ipgen.pipeline.fixed_generate import describe_fixed_scene

    _refuse_others(
        params, {"scene", "describe", "directory", "emit", "force"},
        "with a fixed scene: the scene says the system (--scene FILE --describe describes it)",
    )  # fmt: skip
    line, warnings = describe_fixed_scene(scene)
    click.echo(line)
    _warn(warnings)


def _generate_fixed_scene(
    scene: Path, directory: str | None, emit: str | None, force: bool, params: dict[str, object]
) -> None:
    """`ipgen --scene FIXED.toml -o DIR`: the chain's files and the scene's resolved config."""
    from ipgen.pipeline.fixed_generate import generate_fixed_scene

    _refuse_others(
        params, {"scene", "directory", "emit", "force"},
        "with a fixed scene: the scene says the system (--scene FILE takes -o, --emit and --force)",
    )  # fmt: skip
    written, warnings = generate_fixed_scene(scene, directory, emit, force)
    for file in written[:-1]:
        click.echo(f"{_VERBS[file.status]} {file.path} (fixed, {file.size // 1024} KiB)")
    click.echo(f"{_VERBS[written[-1].status]} {written[-1].path} (resolved scene {scene.stem})")
    _warn(warnings)


def _generate_fixed(
    system_type: str | None,
    links: int | None,
    joints: str | None,
    directory: str | None,
    name: str | None,
    emit: str | None,
    force: bool,
    params: dict[str, object],
) -> None:
    """`ipgen --type fixed --links N [--joints 1,2] -o DIR`: a fixed-pivot chain's files."""
    from ipgen.pipeline.fixed_generate import generate_fixed

    if system_type != "fixed":
        raise job.OptionsError("--joints is for --type fixed (a chain on a fixed pivot driven at its joints)")
    _refuse_others(
        params, {"system_type", "links", "joints", "directory", "name", "emit", "force"},
        "with --type fixed: not yet supported for fixed-pivot models (they take --links, --joints, "
        "--name, --emit cpp, c, library, equations, fmu or fmu3, --force and -o)",
    )  # fmt: skip
    written = generate_fixed(links, joints, directory, name, emit, force)
    for file in written:
        click.echo(f"{_VERBS[file.status]} {file.path} (fixed, {file.size // 1024} KiB)")


def _print_scene_schema(ctx: click.Context) -> None:
    from ipgen.pipeline.scene_schema import json_schema_text  # pydantic only for scenes

    click.echo(json_schema_text(), nl=False)
    ctx.exit()


def _describe_scene(path: Path | None, *clashing: object) -> None:
    scene = job.describe(path, *clashing)
    click.echo(
        f"name={scene.name} type={scene.type} links={scene.links} inertia={scene.inertia} stem={scene.stem} "
        f"specialise={'true' if scene.specialise else 'false'}"
    )
    _warn(scene.warnings)


def _warn(warnings: tuple[str, ...]) -> None:
    for warning in warnings:
        click.echo(f"ipgen: {warning}", err=True)  # "<file>: warning: ..."


_VERBS = {"created": "wrote", "replaced": "replaced", "unchanged": "unchanged"}


class _NotGiven:
    """`value in _NOT_GIVEN`: an option left at its default (None, or a flag not set)."""

    def __contains__(self, value: object) -> bool:
        return value is None or value is False


_NOT_GIVEN = _NotGiven()


def _report(system: System, name: str, written: list[Written]) -> None:
    links = system.links
    for file in written:
        click.echo(
            f"{_VERBS[file.status]} {file.path} ({system.type}, {links} link{'s' if links > 1 else ''}, "
            f"{file.size // 1024} KiB, model {name})"
        )


def _generate(planned: job.Job) -> list[Written]:
    planned = job.named_by_scene(planned)
    system = planned.system
    if system.links < PROGRESS_FROM_LINKS[system.type]:
        return job.run(planned)
    from ipgen.pipeline.generate import STEPS

    with click.progressbar(
        length=STEPS + len(planned.emit),
        label=f"deriving {system.type}{system.links}",
        file=sys.stderr,
        show_eta=False,
        item_show_func=lambda step: step,
    ) as bar:
        return job.run(planned, progress=lambda step: bar.update(1, step))


RUN_HELP = """Run a scene (a file, or --preset NAME: one shipped with ipgen, ipgen presets
lists them): generate its model, build its simulator (optimised, cached by the
model's content: later runs of the same model do not compile), simulate, and write into OUT:
SCENE.cfg (the resolved scene), SCENE.csv (the trajectory), SCENE.png (a plot; not with
--no-plot) and SCENE.txt (the simulator's summary of the run).

\b
The exit status is the simulator's: 0, or its own non-zero status and message when the run
fails (a plot and summary of what was simulated are still written when it wrote a CSV).
Files in OUT that ipgen did not write are replaced only with --force. Needs a C++ compiler,
Eigen, SUNDIALS and LAPACK (Debian: apt-get install g++ libeigen3-dev libsundials-dev
liblapack-dev).
"""


@cli.command("run", help=RUN_HELP, context_settings=CONTEXT)
@click.argument("scene", type=NonEmptyPath(), metavar="[SCENE.toml]", required=False)
@preset_option
@click.option(
    "-o",
    "--output",
    "directory",
    type=NonEmptyPath(),
    metavar="OUT",
    help="Folder for the results.",
)
@click.option("--force", is_flag=True, help="Replace files in OUT that ipgen did not write.")
@click.option(
    "--cache-dir",
    type=NonEmptyPath(),
    default=None,
    metavar="DIR",
    help="Where compiled simulators are kept [default: $IPGEN_CACHE_DIR, else $XDG_CACHE_HOME/ipgen, "
    "else ~/.cache/ipgen].",
)
@click.option(
    "--divergence-angle",
    type=click.FloatRange(min=0.0, min_open=True),
    default=None,
    metavar="RAD",
    help="Stop a closed loop when a link is farther than RAD from the controller's equilibrium "
    "(a swing-up: from its plan or, holding, from upright) [default: pi/2; inf: never stop].",
)
@click.option(
    "--no-plot",
    is_flag=True,
    help="Do not draw SCENE.png (a run without matplotlib: faster; an older SCENE.png in OUT is left "
    "as it is). ipgen plot OUT/SCENE.csv draws it later.",
)
def run_command(
    scene: Path | None,
    preset: str | None,
    directory: Path | None,
    force: bool,
    cache_dir: Path | None,
    divergence_angle: float | None,
    no_plot: bool,
) -> int:
    from ipgen.pipeline.run import run_scene

    scene = chosen_scene(scene, preset, "ipgen run --preset qube_servo2 -o out/")
    if divergence_angle is not None and divergence_angle != divergence_angle:  # NaN
        raise job.OptionsError("--divergence-angle nan: give an angle > 0 [rad], or inf to never stop")
    if directory is None:
        raise job.OptionsError(
            "missing -o OUT: say where to write the results, e.g. ipgen run SCENE.toml -o out/"
        )
    from ipgen.command.interrupts import interrupted_status, sigterm_interrupts
    from ipgen.pipeline.run import RunInterrupted

    try:
        with sigterm_interrupts():  # SIGTERM ends the simulator too, as Ctrl-C does
            outcome = run_scene(
                scene,
                directory,
                force=force,
                cache=cache_dir,
                announce=lambda line: click.echo(f"ipgen: {line}", err=True),
                divergence_angle=divergence_angle,
                plot=not no_plot,
            )
    except RunInterrupted as interrupt:
        wrote = ", ".join(shown_path(path) for path in interrupt.written)
        simulated = any(path.suffix == ".csv" for path in interrupt.written)
        what = f"wrote {wrote}" if simulated else f"the simulator was stopped, no CSV written; wrote {wrote}"
        if interrupt.earlier:  # a PNG or summary of the run before, which the new CSV no longer matches
            what += f"; still the earlier run's: {', '.join(shown_path(path) for path in interrupt.earlier)}"
        click.echo(f"ipgen: interrupted; {what}", err=True)
        return interrupted_status(interrupt.cause)
    if outcome.simulator.built:
        click.echo(f"ipgen: built {outcome.simulator.path} in {outcome.simulator.seconds:.1f} s", err=True)
    click.echo(f"wrote {', '.join(str(path) for path in outcome.files)}")
    click.echo(outcome.summary)
    for line in outcome.messages.splitlines():
        click.echo(line, err=True)  # the simulator's warnings, or the error that ended the run
    if outcome.status != 0:
        click.echo(f"ipgen: the simulation ended with exit status {outcome.status}", err=True)
    if outcome.status in EXIT_HINTS:
        click.echo(f"ipgen: hint: {EXIT_HINTS[outcome.status]}", err=True)
    return outcome.status


# What to try after a run that ended with one of these exit statuses (measured: docs/swingup.md).
EXIT_HINTS = {
    5: "a swing-up plan the tracking cannot follow: start the run where the plan starts (a fixed chain's "
    "plan at rest hanging, with [initial] left out), or plan another one with a different [swingup] duration "
    "(for a lightly damped cart triple the duration decided; the sample rate and the margin did not: "
    'docs/swingup.md, "When the plan is lost")',
}


def _coordinate_options(command: Callable[..., None]) -> Callable[..., None]:
    """--angles, --zero, --positive of `ipgen plot` and `ipgen animate`: the CSV's convention."""
    options = (
        ("--angles", "absolute|relative"),
        ("--zero", "upright|hanging"),
        ("--positive", "clockwise|counterclockwise"),
    )
    for option, values in reversed(options):
        command = click.option(
            option,
            default=None,
            metavar=values,
            help="The convention of the CSV's link angles (docs/model.md) [default: the .cfg next to "
            "the CSV says, else ipgen's].",
        )(command)
    return command


def _csv_coordinates(csv: Path, angles: str | None, zero: str | None, positive: str | None) -> Coordinates:
    """The .cfg's convention beside the CSV (else ipgen's), with each option given in its place (one
    option alone reset the other two to ipgen's: a QUBE run drawn mirrored)."""
    import dataclasses

    from ipgen.plots.run import coordinates_beside

    checked = job.check_coordinates(angles, zero, positive)  # the options' values checked
    given = {name: getattr(checked, name) for name, value in
             (("angles", angles), ("zero", zero), ("positive", positive)) if value is not None}  # fmt: skip
    return dataclasses.replace(coordinates_beside(csv), **given)


def _not_the_input(target: Path, csv: Path) -> Path:
    """`target`, unless it is the CSV being drawn (never replaced, even with --force)."""
    try:
        same = target.exists() and csv.exists() and target.samefile(csv)
    except OSError:
        same = False  # the output policy reports the path itself
    if same:
        raise job.OptionsError(f"{shown_path(target)} is the CSV being drawn: pass another -o")
    return target


@cli.command("plot", context_settings=CONTEXT)
@click.argument("csv", type=NonEmptyPath(), metavar="CSV")
@click.option(
    "-o",
    "--output",
    "png",
    type=NonEmptyPath(),
    default=None,
    metavar="PNG",
    help="The picture [default: the CSV's path with .png].",
)
@click.option(
    "--type",
    "system_type",
    type=click.Choice((*SYSTEM_TYPES, "fixed")),
    default=None,
    help="Label θ0 as a cart position or an arm angle, or the CSV as a fixed-pivot chain's "
    "[default: from the .cfg next to the CSV].",
)
@_coordinate_options
@click.option("--force", is_flag=True, help="Replace a file that ipgen did not write (or of another kind).")
def plot_command(
    csv: Path, png: Path | None, system_type: str | None, angles: str | None, zero: str | None,
    positive: str | None, force: bool,
) -> None:  # fmt: skip
    """Plot a CSV a simulator wrote (ipgen run, simulate_<model>): the base, the link angles and,
    for a closed loop, the input u against time."""
    from ipgen.plots.run import input_unit_beside, plot_run, read_run, sampled_beside, system_type_beside

    target = _not_the_input(png if png is not None else csv.with_suffix(".png"), csv)
    kind = system_type or system_type_beside(csv)
    run = read_run(csv, fixed=kind == "fixed")  # a fixed chain's CSV has no base column
    plot_run(
        run, target, csv.name, kind, force=force,
        coordinates=_csv_coordinates(csv, angles, zero, positive), sampled=sampled_beside(csv),
        input_unit=input_unit_beside(csv),
    )  # fmt: skip
    click.echo(f"wrote {target}")


IDENTIFY_HELP = """Fit parameters of a scene to measurements from the rig (docs/identify.md).

\b
DATA is a CSV with a header: t, theta0..thetaN (in the scene's coordinates), optionally
dtheta0..dthetaN and u (the simulator's CSV as it is; without u the scene's [input] says it).
--free names the parameters to fit (m1, delta0, com1, J1, kt, Rm, Jm, coulomb0, ...); the
others keep the scene's values. Writes into OUT: STEM_identified.toml (the scene with the
estimates; the input scene is never overwritten), STEM_identify.txt (estimates, standard
errors, 95 % intervals, correlations, what the data cannot determine, the fit residual) and
STEM_identify.png (measured against simulated angles). Record open loop about the hanging
position with a rich input (a multisine). Needs CasADi (pip install casadi).
A fixed-pivot scene ([system] type = "fixed") is fitted to measured joint torques instead:
--data (repeatable) recordings with time, pos_meas1.., tau_meas1.. (DFKI's CSV as it is, or t,
q1.., tau1..), --validate (repeatable) held-out ones; no --free (every base parameter and
each torque's offset; --no-offset without); --fit sequential (tip first, the default) or joint;
STEM_identify.txt, .csv and .png (docs/identify.md, "Fixed-pivot rigs").

\b
Example (the recording simulated: the experiment designed by ipgen excite, run by ipgen run):
  ipgen excite --preset qube_servo2 --u-max 10 --travel 1 -o qube_experiment.toml
  ipgen run qube_experiment.toml -o out/
  ipgen identify --preset qube_servo2 --data out/qube_experiment.csv \\
      --free J1,delta0,delta1,kt -o out/ident/
"""


@cli.command("identify", help=IDENTIFY_HELP, context_settings=CONTEXT)
@click.option("--scene", "scene", type=NonEmptyPath(), default=None, metavar="S.toml",
              help="The scene: the rig's model and the prior values.")  # fmt: skip
@preset_option
@click.option("--data", "data", type=NonEmptyPath(), required=True, multiple=True,
              metavar="D.csv", help="The measurements (CSV); several for a fixed-pivot scene.")  # fmt: skip
@click.option("--validate", "validate", type=NonEmptyPath(), multiple=True, metavar="V.csv",
              help="Fixed-pivot scenes: recordings held out of the fit, to score it on.")  # fmt: skip
@click.option("--cutoff", "cutoff", type=click.FloatRange(min=0, min_open=True), default=None,
              metavar="HZ", help="Fixed-pivot scenes: the low-pass cutoff [default: 6 Hz].")  # fmt: skip
@click.option("--fit", "fit_method", type=click.Choice(("sequential", "joint")), default=None,
              help="Fixed-pivot scenes: tip first, one joint's equation at a time, or all joints "
              "together weighted [default: sequential].")  # fmt: skip
@click.option("--no-offset", "no_offset", is_flag=True,
              help="Fixed-pivot scenes: no constant offset of the measured torques.")  # fmt: skip
@click.option("--free", "free", default=None, metavar="P1,P2,...", help="The parameters to fit.")
@click.option("-o", "--output", "directory", type=NonEmptyPath(), metavar="OUT",
              help="Folder for the results.")  # fmt: skip
@click.option("--equation-error-only", is_flag=True,
              help="Skip the output-error refinement (faster, biased by noise).")  # fmt: skip
@click.option("--force", is_flag=True, help="Replace files in OUT that ipgen did not write.")
def identify_command(
    scene: Path | None, preset: str | None, data: tuple[Path, ...], validate: tuple[Path, ...],
    cutoff: float | None, fit_method: str | None, no_offset: bool, free: str | None, directory: Path | None,
    equation_error_only: bool, force: bool,
) -> None:  # fmt: skip
    from ipgen.pipeline.identify import identify

    example = "ipgen identify --preset qube_servo2 --data rig.csv --free J1 -o out/"
    scene = chosen_scene(scene, preset, example)
    if directory is None:
        raise job.OptionsError("missing -o OUT: say where to write the results, e.g. -o out/identified/")
    if _is_fixed_scene(scene):
        if equation_error_only:
            raise job.OptionsError(
                "--equation-error-only: a fixed-pivot scene's fit is a linear regression on the torques, "
                "with no output-error refinement to skip; leave it out"
            )
        _identify_fixed(scene, data, validate, cutoff, free, directory, force, fit_method, no_offset)
        return
    if validate or cutoff is not None or fit_method is not None or no_offset or len(data) > 1:
        raise job.OptionsError(
            "--validate, --cutoff, --fit, --no-offset and several --data are for fixed-pivot scenes "
            "(joint torques); "
            "this scene takes one --data"
        )
    if free is None:
        raise job.OptionsError(f"missing --free P1,P2,...: name the parameters to fit, e.g. {example}")
    data = data[0]  # type: ignore[assignment]
    try:
        import casadi  # noqa: F401
    except ImportError:
        raise job.OptionsError(f"ipgen identify needs CasADi: {install_hint('casadi')}") from None
    result = identify(
        scene,
        data,
        free,
        directory,
        force=force,
        output_error=not equation_error_only,
        progress=lambda line: click.echo(f"ipgen: {line}", err=True),
    )
    click.echo(result.report, nl=False)
    click.echo(f"wrote {', '.join(str(path) for path in result.files)}")


def _identify_fixed(
    scene: Path, data: tuple[Path, ...], validate: tuple[Path, ...], cutoff: float | None, free: str | None,
    directory: Path, force: bool, fit_method: str | None = None, no_offset: bool = False,
) -> None:  # fmt: skip
    """`ipgen identify` of a fixed-pivot scene: the torque regression (pipeline/identify_torques.py)."""
    from ipgen.identification.recording import DEFAULT_CUTOFF
    from ipgen.identification.torque import DEFAULT_METHOD
    from ipgen.pipeline.identify_torques import identify_torques
    from ipgen.scene.fixed import load_fixed_scene

    if free is not None:
        raise job.OptionsError(
            "--free: a fixed-pivot scene fits every base parameter its data can identify; leave --free out"
        )
    result = identify_torques(
        load_fixed_scene(scene), scene.stem, data, validate, directory,
        cutoff=DEFAULT_CUTOFF if cutoff is None else cutoff, method=fit_method or DEFAULT_METHOD,
        offset=not no_offset, force=force, keep=[scene, *data, *validate],  # inputs, never written
    )  # fmt: skip
    click.echo(result.report, nl=False)
    click.echo(f"wrote {', '.join(str(path) for path in result.files)}")


@cli.command("animate", context_settings=CONTEXT)
@click.argument("csv", type=NonEmptyPath(), metavar="CSV")
@click.option(
    "-o", "--output", "gif", type=NonEmptyPath(), default=None, metavar="GIF",
    help="The animation [default: the CSV's path with .gif].",
)  # fmt: skip
@click.option(
    "--type", "system_type", type=click.Choice((*SYSTEM_TYPES, "fixed")), default=None,
    help="The system [default: from the .cfg next to the CSV, which ipgen run writes].",
)  # fmt: skip
@click.option(
    "--lengths", default=None, metavar="L0,L1,...",
    help="Arm (rotary) and link lengths [m], a fixed chain's link lengths only [default: from the .cfg "
    "next to the CSV].",
)  # fmt: skip
@click.option(
    "--fps", type=float, default=15.0, show_default=True,
    help="Frames per second of the run, 0.1 to 50; a run longer than 400 frames plays time-lapsed.",
)  # fmt: skip
@_coordinate_options
@click.option("--force", is_flag=True, help="Replace a file that ipgen did not write (or of another kind).")
def animate_command(
    csv: Path, gif: Path | None, system_type: str | None, lengths: str | None, fps: float,
    angles: str | None, zero: str | None, positive: str | None, force: bool,
) -> None:  # fmt: skip
    """Animate a CSV a simulator wrote (ipgen run, simulate_<model>), drawn to scale from above and
    from the side: an animated GIF (needs pillow: the extra swingup)."""
    from ipgen.plots.run import scene_beside

    beside = scene_beside(csv)
    kind = system_type or (beside[0] if beside else None)
    if lengths is not None:
        try:
            l_values = [float(value) for value in lengths.split(",")]
        except ValueError:
            raise job.OptionsError(
                f"--lengths {abbreviate(lengths)!r}: expected numbers, e.g. 0.6,0.5,0.5"
            ) from None
    else:
        l_values = beside[1] if beside else None
    if kind is None or l_values is None:
        raise job.OptionsError(
            f"{shown_path(csv)}: no resolved scene (.cfg) next to it says the system: "
            "pass --type and --lengths"
        )
    try:
        import PIL  # noqa: F401  (the GIF writer)

        from ipgen.plots.animation import animate_run
    except ImportError:
        raise job.OptionsError(f"ipgen animate needs pillow: {install_hint('pillow')}") from None
    target = _not_the_input(gif if gif is not None else csv.with_suffix(".gif"), csv)
    frame = _csv_coordinates(csv, angles, zero, positive)
    written = animate_run(
        csv, target, kind, l_values, fps=fps, force=force, coordinates=frame,
        announce=lambda line: click.echo(f"ipgen: {line}", err=True),
    )  # fmt: skip
    click.echo(f"wrote {written}")


@cli.command("presets", context_settings=CONTEXT)
@click.argument("name", required=False, metavar="[NAME]")
def presets_command(name: str | None) -> None:
    """List the preset scenes shipped with ipgen, with where their values come from; with NAME,
    print that preset's scene file (ipgen presets qube_servo2 > my_rig.toml starts your own)."""
    from ipgen.common.presets import preset_path, presets

    if name is not None:
        click.echo(preset_path(name).read_text(encoding="utf-8"), nl=False)
        return
    for preset in presets():
        click.echo(f"{preset.name}  ({preset.system})  {preset.path}")
        click.echo(f"    {preset.title}")
        click.echo(f"    values from: {preset.source}")
    click.echo("Run one: ipgen run --preset NAME -o out/; copy one: ipgen presets NAME > my_scene.toml")


def _register() -> None:
    from ipgen.command.excite import command as excite_command
    from ipgen.command.sweep import command as sweep_command

    cli.add_command(excite_command)
    cli.add_command(sweep_command)


_register()


# numpy's floating-point warnings: "overflow encountered in matmul", "invalid value encountered in ..."
_NUMPY_FLOATING = r"(overflow|underflow|invalid value|divide by zero) encountered"
# scipy's LAPACK QZ giving up on a hostile matrix (a Riccati design at m = 1e308, say): scipy's
# solver then checks its own result and raises, which the design turns into one line.
_QZ_FAILED = r"The QZ iteration failed"


def run(argv: list[str] | None = None) -> int:
    """Run the command; return its exit status instead of exiting (for tests and main).

    numpy's floating-point RuntimeWarnings (an overflow inside an LQR design on a hostile number,
    say) and scipy's failed QZ iteration are not shown: every result is checked for finiteness
    where it is used, and a problem is the command's one line, not a stack of warnings before it."""
    from ipgen.command.interrupts import sigterm_interrupts

    try:
        # SIGTERM ends every command as Ctrl-C does, its clean-up run (temporary files removed):
        # Python's default ended the process at once, leaving them behind
        with warnings.catch_warnings(), sigterm_interrupts():
            if not sys.warnoptions:  # the user's own -W settings stay in force
                warnings.filterwarnings("ignore", category=RuntimeWarning, message=_NUMPY_FLOATING)
                warnings.filterwarnings("ignore", category=RuntimeWarning, message=_QZ_FAILED)
            status = cli.main(args=argv, prog_name="ipgen", standalone_mode=False)
    except click.ClickException as e:
        click.echo(f"ipgen: error: {_one_line(e.format_message())} (see ipgen --help)", err=True)
        return EXIT_USAGE
    except Error as e:  # ipgen.Error: the library's one-line message (job.py and what it calls)
        click.echo(f"ipgen: error: {_one_line(str(e))}", err=True)
        return EXIT_USAGE
    except (KeyboardInterrupt, click.Abort) as interrupt:
        from ipgen.command.interrupts import interrupted_status

        click.echo("ipgen: interrupted; no file was written", err=True)
        return interrupted_status(interrupt)
    except OSError as e:
        if e.errno not in STDOUT_ERRNOS:
            raise
        return _stdout_failed(e)
    return status if isinstance(status, int) else 0


# What writing to standard output meets when it cannot take the text: a full device (> /dev/full),
# a closed pipe (| head), an I/O error, a quota.
STDOUT_ERRNOS = frozenset({errno.ENOSPC, errno.EPIPE, errno.EIO, errno.EDQUOT, errno.EBADF})


def _stdout_failed(error: OSError) -> int:
    """Report that standard output could not be written, in one line on stderr, and point stdout
    at /dev/null so that the interpreter's final flush does not print a second traceback."""
    with contextlib.suppress(OSError, ValueError):
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        os.close(devnull)
    with contextlib.suppress(OSError):
        click.echo(
            f"ipgen: error: cannot write to standard output: {(error.strerror or str(error)).lower()}",
            err=True,
        )
    return EXIT_USAGE


# Longest error message printed: the values in a message are abbreviated where it is made;
# this catches any that is not (click's own messages quote option values in full).
MESSAGE_CHARS = 400


def _one_line(message: str) -> str:
    return abbreviate(" ".join(message.split()), MESSAGE_CHARS)


def main() -> None:
    status = run()
    try:
        sys.stdout.flush()  # here, not at the interpreter's exit: a failure is one line, not a traceback
    except OSError as e:
        status = _stdout_failed(e) if e.errno in STDOUT_ERRNOS else 1
    sys.exit(status)
