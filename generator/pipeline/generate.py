"""One generation job: derive the equations once, render every requested target, write them safely."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from ipgen.codegen.emit import DEFAULT_EMIT, TARGETS
from ipgen.codegen.header import HeaderRequest
from ipgen.common.files import prepare_directory, removed_if_left_empty, write_files
from ipgen.control.controller import Controller
from ipgen.estimation.printed import PrintedEstimator
from ipgen.model.coordinates import Coordinates
from ipgen.model.derivation import derive
from ipgen.model.specialise import FUNCTIONS, Specialisation, format_exact
from ipgen.model.system import System

if TYPE_CHECKING:
    from ipgen.control.swingup import SwingUpLaw

GENERAL = Specialisation()

STEPS = 7  # progress steps reported besides one per target: six by the derivation, write


def canonical_command(
    system: System,
    name: str,
    spec: Specialisation = GENERAL,
    emit: tuple[str, ...] = DEFAULT_EMIT,
    coordinates: Coordinates | None = None,
) -> str:
    """The ipgen command that regenerates these files (in any output folder)."""
    emitting = "" if emit == DEFAULT_EMIT else " --emit " + ",".join(emit)
    if spec.scene:
        return f"ipgen --scene {spec.scene}{emitting} -o <dir>"
    command = f"ipgen --type {system.type} --links {system.links}"
    if system.is_rotary:
        command += f" --inertia {system.inertia}"
    command += f" --name {name}"
    if spec.fixed:
        command += " --fix " + ",".join(f"{n}={format_exact(v)}" for n, v in spec.fixed)
    if spec.outputs != FUNCTIONS:
        command += " --outputs " + ",".join(spec.outputs)
    default = Coordinates()
    for option in ("angles", "zero", "positive"):
        value = getattr(coordinates or default, option)
        if value != getattr(default, option):
            command += f" --{option} {value}"
    return command + emitting + " -o <dir>"


@dataclass(frozen=True)
class Written:
    path: Path
    status: str  # created | replaced | unchanged
    size: int


def generate(
    system: System,
    name: str,
    directory: Path,
    force: bool = False,
    progress: Callable[[str], None] | None = None,
    spec: Specialisation = GENERAL,
    emit: tuple[str, ...] = DEFAULT_EMIT,
    extra_files: tuple[tuple[str, str], ...] = (),
    controller: Controller | None = None,
    parameters: tuple[tuple[str, float], ...] = (),
    initial: tuple[float, ...] = (),
    swingup: SwingUpLaw | None = None,
    coordinates: Coordinates | None = None,
    estimator: PrintedEstimator | None = None,
    keep: tuple[Path, ...] = (),
    drive: str = "direct",
) -> list[Written]:
    """Derive `system` once, render every target of `emit` (specialised by `spec`) as
    `DIR/<name><suffix>`, plus `extra_files` ((file name, text), e.g. a resolved scene), and
    write them all or none (`output.write_files`). `controller` (a scene's) is handed to the
    targets that print it; `parameters` (name, value) and `initial` (θ then θ̇), a scene's, to
    the targets that carry start values (the FMU); `swingup` (a scene's) to the C header;
    `coordinates` (default ipgen's) are those the headers' functions take and return;
    `estimator` (a scene's sampled loop's) to the C header; `keep`: the command's inputs (its
    scene), never written, even with force; `drive` (a scene's [actuator] kind) to the equations
    documents, which name it."""
    report = progress or (lambda step: None)
    equations = derive(system, report)
    frame = coordinates if coordinates is not None else Coordinates()
    request = HeaderRequest(
        name,
        canonical_command(system, name, spec, emit, frame),
        spec,
        controller,
        parameters,
        initial,
        swingup,
        frame,
        estimator,
        drive,
    )
    files: list[tuple[Path, str | bytes]] = []
    for target in emit:
        report(f"writing {target}")
        rendered = TARGETS[target].render(equations, request)
        files += [(directory / f"{name}{suffix}", text) for suffix, text in rendered.items()]
    files += [(directory / file_name, text) for file_name, text in extra_files]
    report("writing")
    with removed_if_left_empty():
        prepare_directory(directory)
        statuses = write_files(files, force, keep)
    return [
        Written(path, status, len(text.encode() if isinstance(text, str) else text))
        for (path, text), status in zip(files, statuses, strict=True)
    ]


def generate_header(
    system: System,
    name: str,
    directory: Path,
    force: bool = False,
    progress: Callable[[str], None] | None = None,
    spec: Specialisation = GENERAL,
) -> Written:
    """Derive `system` and write only its C++ header `DIR/<name>.hpp` (`generate` with cpp)."""
    return generate(system, name, directory, force, progress, spec)[0]
