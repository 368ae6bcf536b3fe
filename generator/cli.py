"""The `ipgen` command: parses options and calls the library; all errors end here as one line."""

from __future__ import annotations

import sys
from pathlib import Path

import click
from ipgen import __version__
from ipgen.emit import DEFAULT_EMIT, TARGETS, EmitError, parse_emit
from ipgen.errors import SceneError
from ipgen.generate import STEPS, Written, generate
from ipgen.model import INERTIA_VARIANTS, SYSTEM_TYPES, System
from ipgen.naming import name_problem
from ipgen.output import OutputError
from ipgen.specialise import (
    FUNCTIONS,
    Specialisation,
    SpecialisationError,
    from_scene,
    parse_fix,
    parse_outputs,
)

EXIT_USAGE = 2
# Generations above these sizes take more than a second or two: show a progress bar.
PROGRESS_FROM_LINKS = {"classical": 20, "rotary": 16}
# Above this many links the header is several MB (and slow to compile): ask for --force first.
LINKS_WITHOUT_FORCE = 30

HELP = """Derive the equations of motion of an n-link inverted pendulum and write a C++ header.

\b
Systems (MODEL.md has the exact model):
  classical  a cart on a rail carrying a chain of n rods; q(0) = cart position [m]
  rotary     a horizontal arm turning about the vertical (Furuta) carrying n rods;
             q(0) = arm angle [rad]
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

Errors print one line and exit with status 2. An existing file is only replaced if ipgen
wrote it (else pass --force); the header is written to a temporary file, then renamed.
"""


class InvalidOptions(click.UsageError):
    """An option value ipgen rejects; the message already says how to fix it."""


@click.command(help=HELP, context_settings={"help_option_names": ["-h", "--help"], "max_content_width": 100})
@click.option(
    "--type",
    "system_type",
    type=click.Choice(SYSTEM_TYPES),
    help="Base of the pendulum: a cart (classical) or a rotating arm (rotary).",
)
@click.option("--links", type=int, metavar="N", help="Number of rods in the chain, an integer >= 1.")
@click.option(
    "-o",
    "--output",
    "directory",
    type=click.Path(path_type=Path),
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
    type=click.Path(path_type=Path),
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
    "--force",
    is_flag=True,
    help="Overwrite files in DIR even if ipgen did not write them; "
    f"allow more than {LINKS_WITHOUT_FORCE} links.",
)
@click.version_option(__version__, "-V", "--version", prog_name="ipgen")
def cli(
    system_type: str | None,
    links: int | None,
    directory: Path | None,
    name: str | None,
    inertia: str | None,
    scene: Path | None,
    describe: bool,
    fix: str | None,
    outputs: str | None,
    emit: str | None,
    force: bool,
) -> None:
    if describe:
        _describe_scene(scene, system_type, links, name, inertia, fix, outputs)
        return
    if directory is None:
        raise InvalidOptions("missing -o DIR: say where to write the header")
    try:
        targets = parse_emit(emit) if emit is not None else None
    except EmitError as e:
        raise InvalidOptions(str(e)) from None
    if scene is not None:
        _generate_scene(scene, directory, force, targets, system_type, links, name, inertia, fix, outputs)
        return
    if system_type is None or links is None:
        missing = "--type" if system_type is None else "--links"
        raise InvalidOptions(f"missing {missing}: say which system to derive, e.g. --type rotary --links 3")
    if links < 1:
        raise InvalidOptions(
            f"--links must be an integer >= 1 (got {links}): it counts the rods in the chain"
        )
    if inertia is not None and system_type != "rotary":
        raise InvalidOptions("--inertia applies to rotary systems only: drop it, or use --type rotary")
    if links > LINKS_WITHOUT_FORCE and not force:
        raise InvalidOptions(
            f"--links {links} is large: {cost_estimate(links)}; pass --force to go ahead "
            f"(up to {LINKS_WITHOUT_FORCE} links need no --force)"
        )
    system = System(system_type, links, inertia or "pivot")  # type: ignore[arg-type]
    name = name if name is not None else system.default_name
    problem = name_problem(name)
    if problem:
        raise InvalidOptions(f"--name {name!r} {problem}; choose another name")
    try:
        spec = Specialisation(
            fixed=parse_fix(system, fix) if fix is not None else (),
            outputs=parse_outputs(outputs) if outputs is not None else FUNCTIONS,
        )
    except SpecialisationError as e:
        raise InvalidOptions(str(e)) from None
    _report(system, name, _generate(system, name, directory, force, spec, targets or DEFAULT_EMIT))


def cost_estimate(links: int) -> str:
    """A rough cost of generating `links` links, scaled from runs on a 2-core machine."""
    # Measured on a shared 2-core machine (classical, docs/bench/baseline.md): n = 50 took 13 s
    # CPU and 1.6 GB. FLINT stores every monomial's exponents packed, one field per generator
    # (~n^2 of them), so time grows about as n^3 and memory as n^4; the header (1.5 MB at n = 50)
    # as n^2.
    scale = links / 50
    seconds, gigabytes, header_mb = 13 * scale**3, 1.6 * scale**4, 1.5 * scale**2
    duration = f"{seconds:.0f} s" if seconds < 90 else f"{seconds / 60:.0f} min"
    memory = f"{gigabytes:.1f} GB" if gigabytes >= 0.1 else f"{gigabytes * 1000:.0f} MB"
    return f"expect roughly {duration} and {memory} of memory, and a header of {header_mb:.1f} MB"


def _check_no_system_options(*clashing: object) -> None:
    if any(option is not None for option in clashing):
        raise InvalidOptions(
            "--scene fixes the system and its specialisation: drop --type, --links, --name, --inertia, "
            "--fix and --outputs"
        )


def _describe_scene(path: Path | None, *clashing: object) -> None:
    if path is None:
        raise InvalidOptions("--describe needs --scene FILE: it describes a scene's system")
    _check_no_system_options(*clashing)
    from ipgen.scene import load_scene  # only scene commands need it

    scene = load_scene(path)
    click.echo(
        f"name={scene.name} type={scene.type} links={scene.links} inertia={scene.inertia} stem={scene.stem} "
        f"specialise={'true' if scene.specialise else 'false'}"
    )
    _warn(scene.warnings)


def _generate_scene(
    path: Path, directory: Path, force: bool, targets: tuple[str, ...] | None, *clashing: object
) -> None:
    _check_no_system_options(*clashing)
    from ipgen.scene import load_scene, resolved_config  # only scene commands need it

    scene = load_scene(path)
    system = scene.system
    spec = from_scene(scene) if scene.specialise else Specialisation()
    config = (f"{scene.stem}.cfg", resolved_config(scene))
    written = _generate(system, scene.name, directory, force, spec, targets or scene.emit, (config,))
    _report(system, scene.name, written[:-1])
    click.echo(f"{_VERBS[written[-1].status]} {written[-1].path} (resolved scene {scene.stem})")
    _warn(scene.warnings)


def _warn(warnings: tuple[str, ...]) -> None:
    for warning in warnings:
        click.echo(f"ipgen: {warning}", err=True)  # "<file>: warning: ..."


_VERBS = {"created": "wrote", "replaced": "replaced", "unchanged": "unchanged"}


def _report(system: System, name: str, written: list[Written]) -> None:
    links = system.links
    for file in written:
        click.echo(
            f"{_VERBS[file.status]} {file.path} ({system.type}, {links} link{'s' if links > 1 else ''}, "
            f"{file.size // 1024} KiB, model {name})"
        )


def _generate(
    system: System,
    name: str,
    directory: Path,
    force: bool,
    spec: Specialisation,
    emit: tuple[str, ...],
    extra_files: tuple[tuple[str, str], ...] = (),
) -> list[Written]:
    if system.links < PROGRESS_FROM_LINKS[system.type]:
        return generate(system, name, directory, force, spec=spec, emit=emit, extra_files=extra_files)
    with click.progressbar(
        length=STEPS + len(emit),
        label=f"deriving {system.type}{system.links}",
        file=sys.stderr,
        show_eta=False,
        item_show_func=lambda step: step,
    ) as bar:
        return generate(
            system,
            name,
            directory,
            force,
            progress=lambda step: bar.update(1, step),
            spec=spec,
            emit=emit,
            extra_files=extra_files,
        )


def run(argv: list[str] | None = None) -> int:
    """Run the command; return its exit status instead of exiting (for tests and main)."""
    try:
        status = cli.main(args=argv, prog_name="ipgen", standalone_mode=False)
    except click.ClickException as e:
        message = " ".join(e.format_message().split())
        hint = "" if isinstance(e, InvalidOptions) else " (see ipgen --help)"
        click.echo(f"ipgen: error: {message}{hint}", err=True)
        return EXIT_USAGE
    except (OutputError, SceneError) as e:
        click.echo(f"ipgen: error: {e}", err=True)
        return EXIT_USAGE
    except (KeyboardInterrupt, click.Abort):
        click.echo("ipgen: interrupted; no file was written", err=True)
        return 130
    return status if isinstance(status, int) else 0


def main() -> None:
    sys.exit(run())
