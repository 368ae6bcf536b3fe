"""One generation job: derive the equations, render the header, write it safely."""

from __future__ import annotations

import contextlib
import re
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from generator.codegen.header import HeaderRequest, render_header
from generator.derive import derive
from generator.model import System
from generator.output import prepare_directory, write_file

CPP_KEYWORDS = frozenset(
    """alignas alignof and and_eq asm auto bitand bitor bool break case catch char char8_t
    char16_t char32_t class compl concept const consteval constexpr constinit const_cast
    continue co_await co_return co_yield decltype default delete do double dynamic_cast else
    enum explicit export extern false float for friend goto if inline int long mutable
    namespace new noexcept not not_eq nullptr operator or or_eq private protected public
    register reinterpret_cast requires return short signed sizeof static static_assert
    static_cast struct switch template this thread_local throw true try typedef typeid
    typename union unsigned using virtual void volatile wchar_t while xor xor_eq""".split()
)
# Names that would shadow or break what the header itself uses inside namespace ipgen::<name>.
RESERVED_NAMES = frozenset({"std", "Eigen", "ipgen", "Model", "Params", "Vector", "Matrix"})
STEPS = 7  # progress steps reported: five by the derivation, render, write


def name_problem(name: str) -> str | None:
    """Why `name` cannot be a C++ namespace and file name, or None if it can."""
    if not re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", name):
        return "must be a C++ identifier: a letter or _, then letters, digits or _"
    if name in CPP_KEYWORDS:
        return "is a C++ keyword"
    if name in RESERVED_NAMES:
        return "is a name the generated header uses itself"
    if "__" in name or re.match(r"_[A-Z]", name):
        return "is reserved by the C++ standard (double underscore, or _ and a capital)"
    return None


def default_name(system: System) -> str:
    return f"{system.type}{system.links}"


def canonical_command(system: System, name: str) -> str:
    """The ipgen command that regenerates this header (in any output folder)."""
    command = f"ipgen --type {system.type} --links {system.links}"
    if system.is_rotary:
        command += f" --inertia {system.inertia}"
    return command + f" --name {name} -o <dir>"


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
) -> Written:
    """Derive `system`, render `DIR/<name>.hpp` and write it atomically."""
    report = progress or (lambda step: None)
    equations = derive(system, report)
    report("C++ code")
    text = render_header(equations, HeaderRequest(name, canonical_command(system, name)))
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
