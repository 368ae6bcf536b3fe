"""One generation job: the options of an `ipgen` command (or of `ipgen.write_header`), validated
in one place, then run. The command and the Python API share this path, so both refuse the same
input with the same one-line message (an `OptionsError`, or the `Error` a parser raises)."""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING

from ipgen.codegen.emit import DEFAULT_EMIT, parse_emit, unsupported
from ipgen.common.limits import LINKS_WITHOUT_FORCE
from ipgen.common.naming import name_problem
from ipgen.common.safetext import abbreviate, shown_path
from ipgen.errors import Error
from ipgen.model.actuator import DIRECT
from ipgen.model.coordinates import ANGLES, POSITIVE, ZEROS, Coordinates
from ipgen.model.system import System, group_indices, system_problem

if TYPE_CHECKING:
    from ipgen.estimation.printed import PrintedEstimator
    from ipgen.experiment.loop import Loop
    from ipgen.experiment.scene import Scene
    from ipgen.model.specialise import Specialisation
    from ipgen.pipeline.generate import Written

# What a caller may pass for --fix, --outputs and --emit: the command's text, or Python values.
FixOption = str | Mapping[str, object] | None
ListOption = str | Iterable[str] | None


class OptionsError(Error, ValueError):
    """An option value ipgen rejects, or options that clash; the message says how to fix it."""


@dataclass(frozen=True)
class Job:
    """Everything one command writes: `system` as `<name>` files in `directory`."""

    system: System
    name: str
    directory: Path
    force: bool
    spec: Specialisation
    emit: tuple[str, ...]
    scene: Scene | None = None  # a scene job also writes DIR/<stem>.cfg
    # The rig's coordinates the headers' functions take (--angles, --zero, --positive, or a
    # scene's [system] keys); default ipgen's own.
    coordinates: Coordinates = field(default_factory=Coordinates)


def named_by_scene(planned: Job) -> Job:
    """`planned` with its files' "regenerate with" naming its scene (`ipgen --scene S`), which writes
    them again with all they print from it (a controller, an estimator, the rig's coordinates). For
    the files a user asked for (`ipgen --scene`, `write_header(scene=)`); a run's and a sweep's model
    files keep the model's command, so that every scene of one model shares one simulator."""
    if planned.scene is None or planned.spec.scene:
        return planned
    from ipgen.common.safetext import quote_path

    return replace(planned, spec=replace(planned.spec, scene=quote_path(planned.scene.path.as_posix())))


def cost_estimate(links: int) -> str:
    """A rough cost of generating `links` links, scaled from runs on a 2-core machine."""
    # Measured on a shared 2-core machine (classical, docs/bench/baseline.md): n = 50 took 13 s
    # CPU and 1.6 GB. FLINT stores every monomial's exponents packed, one field per generator
    # (~n^2 of them), so time grows about as n^3 and memory as n^4; the header (1.5 MB at n = 50)
    # as n^2.
    if links > 10_000:
        return "expect days and more memory than this machine has"
    scale = links / 50
    seconds, gigabytes, header_mb = 13 * scale**3, 1.6 * scale**4, 1.5 * scale**2
    duration = f"{seconds:.0f} s" if seconds < 90 else f"{seconds / 60:.0f} min"
    memory = f"{gigabytes:.1f} GB" if gigabytes >= 0.1 else f"{gigabytes * 1000:.0f} MB"
    return f"expect roughly {duration} and {memory} of memory, and a header of {header_mb:.1f} MB"


def check_system(system_type: object, links: object, inertia: object = None) -> System:
    """The System these values name, or an OptionsError saying which option is wrong (the check
    is `model.system.system_problem`; here it speaks of --type, --links and --inertia)."""
    problem = system_problem(system_type, links, inertia)
    if problem is None:
        return System(system_type, links, inertia or "pivot")  # type: ignore[arg-type]
    if problem.field == "rotary-only":
        raise OptionsError("--inertia applies to rotary systems only: drop it, or use --type rotary")
    raise OptionsError(f"--{problem}")


def _text(value: str | Iterable[object]) -> str:
    return value if isinstance(value, str) else ",".join(str(item) for item in value)


def _fix_text(fix: str | Mapping[str, object]) -> str:
    if isinstance(fix, str):
        return fix
    for key in fix:
        if not isinstance(key, str) or "," in key or "=" in key:
            raise OptionsError(f"--fix: {key!r:.40} is not a parameter name; use m<i>, l<i>, delta<i> or g")
    return ",".join(f"{key}={value}" for key, value in fix.items())


def _check_no_system_options(*clashing: object) -> None:
    if any(option is not None for option in clashing):
        raise OptionsError(
            "--scene fixes the system and its specialisation: drop --type, --links, --name, --inertia, "
            "--fix and --outputs"
        )


def check_coordinates(angles: object, zero: object, positive: object) -> Coordinates:
    """The convention --angles, --zero, --positive name (None: the default), or an OptionsError."""
    chosen = {}
    for option, value, allowed in (
        ("angles", angles, ANGLES),
        ("zero", zero, ZEROS),
        ("positive", positive, POSITIVE),
    ):
        if value is None:
            continue
        if not isinstance(value, str) or value not in allowed:
            raise OptionsError(
                f"--{option} {abbreviate(str(value))!r}: expected {' or '.join(allowed)} "
                "(the rig's coordinates, docs/model.md)"
            )
        chosen[option] = value
    return Coordinates(**chosen)


def _check_targets(coordinates: Coordinates, targets: tuple[str, ...], scene: Scene | None = None) -> None:
    """`emit.unsupported`, the one check of targets against the model (a scene's keys meet it
    when it is read; --emit overrides them, so the targets meet it again here)."""
    problem = unsupported(
        targets,
        scene.actuator if scene is not None else DIRECT,
        coordinates,
        scene.specialise if scene is not None else False,
    )
    if problem is not None:
        raise OptionsError(problem)


def describe(scene_path: Path | str | None, *clashing: object) -> Scene:
    """The scene `--scene FILE --describe` describes (none of the system options may be given)."""
    if scene_path is None:
        raise OptionsError("--describe needs --scene FILE: it describes a scene's system")
    _check_no_system_options(*clashing)
    from ipgen.experiment.scene import load_scene  # only scene commands need it

    return load_scene(Path(scene_path))


def plan(
    directory: Path | str | None,
    *,
    system_type: object = None,
    links: object = None,
    name: str | None = None,
    inertia: object = None,
    scene: Path | str | None = None,
    fix: FixOption = None,
    outputs: ListOption = None,
    emit: ListOption = None,
    force: bool = False,
    angles: object = None,
    zero: object = None,
    positive: object = None,
) -> Job:
    """Validate one command's options (in the order the command reports them) into a Job."""
    from ipgen.experiment.specialisation import from_scene
    from ipgen.model.specialise import FUNCTIONS, Specialisation, parse_fix, parse_outputs

    if directory is None:
        raise OptionsError("missing -o DIR: say where to write the header")
    if not str(directory).strip():  # "" would silently mean the current folder
        raise OptionsError(
            f"-o {str(directory)!r} is empty: name the output folder, e.g. -o out/ (or -o . for this one)"
        )
    directory = Path(directory)
    targets = parse_emit(emit) if emit is not None else None
    if scene is not None:
        _check_no_system_options(system_type, links, name, inertia, fix, outputs)
        from ipgen.experiment.scene import load_scene  # only scene commands need it

        if any(value is not None for value in (angles, zero, positive)):
            raise OptionsError(
                "--scene says the coordinates in its [system] angles, zero and positive: drop --angles, "
                "--zero and --positive"
            )
        loaded = load_scene(Path(scene))
        if loaded.links > LINKS_WITHOUT_FORCE and not force:
            raise OptionsError(
                f"{shown_path(Path(scene).as_posix())}: system.links = {loaded.links} is large: "
                f"{cost_estimate(loaded.links)}; pass --force to go ahead "
                f"(up to {LINKS_WITHOUT_FORCE} links need no --force)"
            )
        spec = from_scene(loaded) if loaded.specialise else Specialisation()
        _check_targets(loaded.coordinates, targets or loaded.emit, loaded)
        return Job(
            loaded.system,
            loaded.name,
            directory,
            force,
            spec,
            targets or loaded.emit,
            loaded,
            loaded.coordinates,
        )
    if system_type is None or links is None:
        missing = "--type" if system_type is None else "--links"
        raise OptionsError(f"missing {missing}: say which system to derive, e.g. --type rotary --links 3")
    system = check_system(system_type, links, inertia)
    if system.links > LINKS_WITHOUT_FORCE and not force:
        raise OptionsError(
            f"--links {system.links} is large: {cost_estimate(system.links)}; pass --force to go ahead "
            f"(up to {LINKS_WITHOUT_FORCE} links need no --force)"
        )
    name = name if name is not None else system.default_name
    problem = name_problem(name) if isinstance(name, str) else "is not a string"
    if problem:
        raise OptionsError(f"--name {abbreviate(str(name))!r} {problem}; choose another name")
    spec = Specialisation(
        fixed=parse_fix(system, _fix_text(fix)) if fix is not None else (),
        outputs=parse_outputs(_text(outputs)) if outputs is not None else FUNCTIONS,
    )
    coordinates = check_coordinates(angles, zero, positive)
    _check_targets(coordinates, targets or DEFAULT_EMIT)
    return Job(system, name, directory, force, spec, targets or DEFAULT_EMIT, coordinates=coordinates)


def for_the_simulator(job: Job) -> Job:
    """The job whose model library a scene's simulator loads (`--emit library`: the C header and
    its adapter to the C model interface): in ipgen's own coordinates (the
    simulator maps the rig's at run time, from the .cfg) and named after the model alone
    (rotary1, rotary2_full), so that every scene of one model shares one cached binary whatever
    its name or conventions. A specialised scene keeps its name: its header holds its numbers."""
    if job.scene is not None and job.scene.specialise:
        return replace(job, emit=("library",), coordinates=Coordinates())
    system = job.system
    name = system.default_name + ("_full" if system.is_rotary and system.inertia == "full" else "")
    return replace(job, name=name, emit=("library",), coordinates=Coordinates())


def run(job: Job, progress: Callable[[str], None] | None = None) -> list[Written]:
    """Derive, render and write the job's files (all or none); the scene's .cfg comes last."""
    from ipgen.pipeline.generate import generate

    extra: tuple[tuple[str, str], ...] = ()
    parameters: tuple[tuple[str, float], ...] = ()
    initial: tuple[float, ...] = ()
    if job.scene is not None:
        from ipgen.experiment.config import resolved_config

        extra = ((f"{job.scene.stem}.cfg", resolved_config(job.scene, model=job.name)),)
        parameters = tuple((name, job.scene.value(name)) for name in job.scene.parameter_names())
        parameters += tuple(  # the links as built the scene gives (com1, J0, tip1): an FMU's start values
            (f"{group}{i}", float(values[i]))
            for group, values in job.scene.link_values().items()
            for i in group_indices(group, job.scene.links)
        )
        initial = (*job.scene.theta, *job.scene.dtheta)
    return generate(
        job.system,
        job.name,
        job.directory,
        job.force,
        progress=progress,
        spec=job.spec,
        emit=job.emit,
        extra_files=extra,
        controller=job.scene.controller if job.scene is not None else None,
        swingup=job.scene.swingup if job.scene is not None else None,
        parameters=parameters,
        initial=initial,
        coordinates=job.coordinates,
        estimator=printed_estimator(job.scene) if job.scene is not None else None,
        keep=(job.scene.path,) if job.scene is not None else (),
        drive=job.scene.actuator.kind if job.scene is not None else "direct",
    )


def printed_estimator(scene: Scene) -> PrintedEstimator | None:
    """The scene's estimator as the C header prints it (None: no [sensors]/[estimator], or the
    exact state): the numbers of its measured loop (experiment/loop.py), the sampled loop's period
    and, for the EKF, the drive's input gain."""
    from ipgen.estimation.printed import PrintedEstimator  # ipgen.estimation: only a scene's run needs it

    loop = scene.loop
    if loop is None or loop.sensors is None or loop.estimator.kind == "exact":
        return None
    if scene.swingup is not None:  # an MPC catching the swing-up steps every few of its periods
        period = scene.swingup.period
    elif scene.controller is not None and scene.controller.period is not None:
        period = scene.controller.period
    else:  # the scene's checks refuse a measured loop without a sampled controller
        return None
    return PrintedEstimator(
        numbers=loop.estimator,
        sensors=loop.sensors,  # its zero: [sensors] zero, default the rig at rest, as the simulator's
        period=float(period),
        delay=round((loop.delay if loop.assumed_delay is None else loop.assumed_delay) / period),
        input_gain=float(scene.actuator.gain()),
        params=scene.pendulum.folded().params(),
        lag=_compensated_lag(loop),
        lag_limit=command_bound(scene),
    )


def _compensated_lag(loop: Loop) -> float:
    """The drive lag the loop's C header is built for [s]: [estimator] lag, else the rig's; 0 without
    compensate_lag."""
    if not loop.estimator.compensate_lag:
        return 0.0
    return loop.lag if loop.estimator.lag is None else loop.estimator.lag


def command_bound(scene: Scene) -> float:
    """The bound of the sampled law's command [units of u] that a lag's compensation keeps to: the
    swing-up's u_max, else the controller's saturation (an MPC's u_max), else infinity."""
    if scene.swingup is not None:
        return float(scene.swingup.u_max)
    saturation = None if scene.controller is None else scene.controller.saturation
    return float("inf") if saturation is None else float(saturation)
