"""One generation job: derive the equations, render the header, write it safely."""

from __future__ import annotations

import contextlib
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from generator.codegen.header import HeaderRequest, render_header
from generator.derive import derive
from generator.model import System
from generator.output import prepare_directory, write_file
from generator.specialise import FUNCTIONS, Specialisation, format_exact

GENERAL = Specialisation()

STEPS = 8  # progress steps reported: six by the derivation, render, write


def canonical_command(system: System, name: str, spec: Specialisation = GENERAL) -> str:
    """The ipgen command that regenerates this header (in any output folder)."""
    if spec.scene:
        return f"ipgen --scene {spec.scene} -o <dir>"
    command = f"ipgen --type {system.type} --links {system.links}"
    if system.is_rotary:
        command += f" --inertia {system.inertia}"
    command += f" --name {name}"
    if spec.fixed:
        command += " --fix " + ",".join(f"{n}={format_exact(v)}" for n, v in spec.fixed)
    if spec.outputs != FUNCTIONS:
        command += " --outputs " + ",".join(spec.outputs)
    return command + " -o <dir>"


@dataclass(frozen=True)
class Written:
    path: Path
    status: str  # created | replaced | unchanged
    size: int


def generate_header(
    system: System,
    name: str,
    directory: Path,
    force: bool = False,
    progress: Callable[[str], None] | None = None,
    spec: Specialisation = GENERAL,
) -> Written:
    """Derive `system`, render `DIR/<name>.hpp` (specialised by `spec`) and write it atomically."""
    report = progress or (lambda step: None)
    equations = derive(system, report)
    report("C++ code")
    text = render_header(equations, HeaderRequest(name, canonical_command(system, name, spec), spec))
    report("writing")
    created = prepare_directory(directory)
    path = directory / f"{name}.hpp"
    try:
        status = write_file(path, text, force)
    except BaseException:
        if created:
            with contextlib.suppress(OSError):
                directory.rmdir()
        raise
    return Written(path, status, len(text.encode()))
