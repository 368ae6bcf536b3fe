"""`ipgen --type fixed --links N --joints 1,2 -o DIR`: write a fixed-pivot chain's files.

The targets are the cart's and the arm's (`--emit cpp, c, library, equations, fmu, fmu3`),
rendered by the same printers and templates over the chain's equations (`render_target`). The
options are checked in the order the command reports them, each problem one line
(`job.OptionsError`); the files are written all or none (`files.write_files`), as for the
cart's and the arm's.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from ipgen.codegen.emit import EmitError, parse_emit
from ipgen.codegen.fixed_header import FixedFeedback, FixedHeaderRequest, fixed_command, render_fixed
from ipgen.common.files import prepare_directory, removed_if_left_empty, write_files
from ipgen.common.naming import name_problem
from ipgen.common.safetext import abbreviate, shown_path
from ipgen.model.fixed import joints_problem
from ipgen.pipeline.generate import Written
from ipgen.pipeline.job import LINKS_WITHOUT_FORCE, OptionsError

FIXED_TARGETS: tuple[str, ...] = ("cpp", "c", "library", "equations", "fmu", "fmu3")


def parse_joints(text: str | None, links: int) -> tuple[int, ...]:
    """`"1,2"` -> (1, 2); None -> (1,); checked against the chain (`fixed.joints_problem`)."""
    if text is None:
        return (1,)
    joints: list[object] = []
    for part in text.split(","):
        part = part.strip()
        try:
            joints.append(int(part))
        except ValueError:
            raise OptionsError(
                f"--joints {abbreviate(text)!r}: expected joint numbers 1..{links} separated by commas, "
                "e.g. --joints 1,2"
            ) from None
    problem = joints_problem(joints, links)
    if problem:
        raise OptionsError(f"--{problem}")
    return tuple(joints)  # type: ignore[arg-type]


def plan_fixed(
    links: object,
    joints: str | None,
    directory: str | Path | None,
    name: str | None,
    emit: str | None,
    force: bool,
) -> tuple[FixedHeaderRequest, Path, tuple[str, ...]]:
    """The request, the folder and the targets of one command, or an OptionsError."""
    if links is None:
        raise OptionsError(
            "missing --links: say how many links hang from the pivot, e.g. --type fixed --links 2"
        )
    if isinstance(links, bool) or not isinstance(links, int) or links < 1:
        raise OptionsError(
            f"--links must be an integer >= 1 (got {abbreviate(repr(links))}): it counts the links"
        )
    if links > LINKS_WITHOUT_FORCE and not force:
        raise OptionsError(
            f"--links {links} is large; pass --force to go ahead (up to {LINKS_WITHOUT_FORCE} need none)"
        )
    chosen = parse_joints(joints, links)
    folder = _folder(directory)
    name = name if name is not None else f"fixed{links}"
    problem = name_problem(name)
    if problem:
        raise OptionsError(f"--name {abbreviate(name)!r} {problem}; choose another name")
    targets = _fixed_targets(emit, "--emit") if emit is not None else ("cpp",)
    request = FixedHeaderRequest(name, links, chosen, fixed_command(name, links, chosen, targets))
    return request, folder, targets


def _folder(directory: str | Path | None) -> Path:
    """The output folder of -o, or an OptionsError (missing, or empty)."""
    if directory is None:
        raise OptionsError("missing -o DIR: say where to write the header")
    if not str(directory).strip():
        raise OptionsError(f"-o {str(directory)!r} is empty: name the output folder, e.g. -o out/")
    return Path(directory)


def _fixed_targets(values: str | list[str], where: str) -> tuple[str, ...]:
    """`parse_emit`'s targets, each one a fixed chain takes (`FIXED_TARGETS`); `EmitError` (one
    line, naming `where`) otherwise."""
    targets = parse_emit(values, where)
    others = [target for target in targets if target not in FIXED_TARGETS]
    if others:
        choices = ", ".join(FIXED_TARGETS)
        raise EmitError(
            f"{where} {others[0]}: not yet supported for fixed-pivot models; choose from {choices}"
        )
    return targets


def render_target(request: FixedHeaderRequest, target: str) -> dict[str, str | bytes]:
    """{suffix: text or bytes} of one target of the chain (`FIXED_TARGETS`); deterministic.

    Parameters
    ----------
    request : FixedHeaderRequest
        The chain's name, links, driven joints and command.
    target : str
        One of `FIXED_TARGETS`.

    Returns
    -------
    dict of str to str or bytes
        File suffix -> contents (bytes for the .fmu archive).
    """
    if target == "equations":
        from ipgen.codegen.equations import render_fixed_equations

        return dict(render_fixed_equations(request.name, request.command, request.joints, request.links))
    if target in ("fmu", "fmu3"):
        from ipgen.codegen.fmu import render_fixed_fmu

        return {".fmu": render_fixed_fmu(request, 2 if target == "fmu" else 3)}
    return dict(render_fixed(request, target))


@dataclass(frozen=True)
class FixedScenePlan:
    """What `ipgen --scene FIXED.toml -o DIR` writes: the chain's request and targets, the folder,
    the resolved config and the warnings to print (one line each)."""

    request: FixedHeaderRequest
    folder: Path
    targets: tuple[str, ...]
    cfg: str
    warnings: tuple[str, ...]


def plan_fixed_scene(scene: Path, directory: str | Path | None, emit: str | None) -> FixedScenePlan:
    """`ipgen --scene FIXED.toml -o DIR` planned: the scene checked as `ipgen run` checks it; the
    header named by `[system] name` (default fixed<links>); the targets `--emit` or `[system]
    emit` names (default cpp); a scene's MPC and swing-up printed into the C header, in ipgen's
    coordinates (a warning when the scene's are others); its LQR or gain as `P_control`."""
    from ipgen.control.fixed_linear import canonical_gains, canonical_states
    from ipgen.control.fixed_swingup import canonical_law
    from ipgen.pipeline.fixed_run import fixed_scene
    from ipgen.scene.load import parse_document

    folder = _folder(directory)
    reader, document = parse_document(scene)
    system = document["system"]
    name = system.get("name", f"fixed{system.get('links')}")  # links: fixed_scene checks them first
    # the .cfg names the model these files are (a simulator linked to DIR/<name>_model.c takes it)
    parts = fixed_scene(scene, document, reader, model=name if isinstance(name, str) else None)
    chain = parts.chain
    problem = name_problem(name) if isinstance(name, str) else "is not a string"
    if problem:
        reader.bad("system.name", name, f"this name {problem}; choose another")
    listed = system.get("emit", ["cpp"])
    if emit is None and not (isinstance(listed, list) and all(isinstance(item, str) for item in listed)):
        choices = ", ".join(FIXED_TARGETS)
        reader.bad("system.emit", listed, f'expected a list of targets, e.g. ["c"] (of {choices})')
    given, where = (emit, "--emit") if emit is not None else (listed, "system.emit")
    try:
        targets = _fixed_targets(given, where)
    except EmitError as exc:
        reader.fail(str(exc))
    if not chain.coordinates.is_canonical and any(target in ("fmu", "fmu3") for target in targets):
        reader.fail(
            f"{where}: an FMU's variables are ipgen's "
            f"coordinates, not this scene's (angles = {chain.angles!r}, zero = {chain.zero!r}, "
            f"positive = {chain.positive!r}): emit it from ipgen --type fixed, or drop fmu"
        )
    controller = parts.controller
    mpc = controller.mpc if controller is not None else None
    period = float(controller.period or 0.0) if controller is not None and mpc is not None else 0.0
    swingup = canonical_law(parts.swingup, chain) if parts.swingup is not None else None
    emitting = f" --emit {','.join(targets)}" if emit is not None else ""
    command = f"ipgen --scene {scene.name}{emitting} -o <dir>"
    feedback = None
    if controller is not None and mpc is None:  # kind = "lqr" or "gain": u = −K (x − x_eq), mapped
        feedback = FixedFeedback(
            controller.kind,
            tuple(tuple(float(v) for v in row) for row in canonical_gains(chain, controller.gain)),
            tuple(float(v) for v in canonical_states(chain, controller.equilibrium)[0]),
            controller.saturation,
            controller.period,
        )
    request = FixedHeaderRequest(
        name, chain.links, tuple(chain.joints), command, mpc, period, swingup, feedback, chain.coordinates
    )
    warn = f"{shown_path(scene.as_posix())}: warning:"
    warnings = []
    if not chain.coordinates.is_canonical:
        warnings.append(
            f"{warn} angles = {chain.angles!r}, zero = {chain.zero!r}, positive = {chain.positive!r}; "
            "the headers are in ipgen's coordinates (absolute, from upright, clockwise): "
            + (f"{name}.h's ipgen_{name}_to_canonical, _rates_to_canonical and _torque_from_canonical "
               "map x and u" if "c" in targets else "map x and u at the boundary")
            + ' (docs/mpc.md, "On a fixed pivot")'
        )
    if (controller is not None or swingup is not None) and "c" not in targets:
        warnings.append(
            f"{warn} its [controller] and [swingup] go into the C header only: add c to the targets "
            '(emit = ["c"] or --emit c)'
        )
    return FixedScenePlan(request, folder, targets, parts.cfg, tuple(warnings))


def describe_fixed_scene(scene: Path) -> tuple[str, tuple[str, ...]]:
    """`ipgen --scene FIXED.toml --describe`: the scene checked as `--scene FILE -o DIR` checks it
    (`plan_fixed_scene`, nothing written) and its line for CMake's ipgen_add_scene,
    `name=<header> type=fixed links=<n> inertia=full stem=<file stem> specialise=true` (the header
    is the scene's own: its driven joints, rotors and controller are in it; inertia is full: each
    link's J is its own), with the warnings to print."""
    plan = plan_fixed_scene(scene, ".", None)
    system = f"name={plan.request.name} type=fixed links={plan.request.links} inertia=full"
    return f"{system} stem={scene.stem} specialise=true", plan.warnings


def _files(
    request: FixedHeaderRequest, folder: Path, targets: tuple[str, ...]
) -> list[tuple[Path, str | bytes]]:
    """(path, contents) of every target of the chain, DIR/<name><suffix>."""
    return [
        (folder / f"{request.name}{suffix}", text)
        for target in targets
        for suffix, text in render_target(request, target).items()
    ]


def generate_fixed_scene(
    scene: Path, directory: str | Path | None, emit: str | None = None, force: bool = False
) -> tuple[list[Written], tuple[str, ...]]:
    """`ipgen --scene FIXED.toml -o DIR`: every target of the scene's chain as DIR/<name><suffix>
    (the C header with the scene's MPC and swing-up) and DIR/<stem>.cfg last, all or none; and the
    warnings to print (`plan_fixed_scene`)."""
    plan = plan_fixed_scene(scene, directory, emit)
    files = _files(plan.request, plan.folder, plan.targets)
    files.append((plan.folder / f"{scene.stem}.cfg", plan.cfg))
    return _write(plan.folder, files, force, keep=(Path(scene),)), plan.warnings


def generate_fixed(
    links: object,
    joints: str | None,
    directory: str | Path | None,
    name: str | None = None,
    emit: str | None = None,
    force: bool = False,
) -> list[Written]:
    """Render every target of `emit` for the chain as DIR/<name><suffix> and write them all or none."""
    request, folder, targets = plan_fixed(links, joints, directory, name, emit, force)
    return _write(folder, _files(request, folder, targets), force)


def _write(
    folder: Path, files: list[tuple[Path, str | bytes]], force: bool, keep: tuple[Path, ...] = ()
) -> list[Written]:
    """`files` written all or none (a folder this call made removed again on failure); `keep`:
    the command's inputs, never written (a scene named like its .cfg), even with force."""
    with removed_if_left_empty():
        prepare_directory(folder)
        statuses = write_files(files, force, keep)
    return [
        Written(path, status, len(text.encode() if isinstance(text, str) else text))
        for (path, text), status in zip(files, statuses, strict=True)
    ]
