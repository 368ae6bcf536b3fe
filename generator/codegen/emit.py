"""What ipgen writes (`--emit`): each target renders files from the same derived equations.

A target is a printer plus a template over `Equations`; adding one means adding a renderer
here, never a second derivation. The renderers are imported on use, so that a command pays
only for the targets it asks for.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import TYPE_CHECKING

from ipgen.errors import Error

if TYPE_CHECKING:
    from ipgen.codegen.header import HeaderRequest
    from ipgen.model.actuator import Actuator
    from ipgen.model.coordinates import Coordinates
    from ipgen.model.derivation import Equations

# file suffix -> text (or bytes, for an archive such as the .fmu), for the files of one target
Rendered = dict[str, str | bytes]


class EmitError(Error, ValueError):
    """An unknown or empty --emit / `emit = [...]` value; the message lists the valid ones."""


@dataclass(frozen=True)
class Target:
    """One kind of output: the files `NAME<suffix>` it writes and how to render them."""

    name: str
    suffixes: tuple[str, ...]
    summary: str  # for --help and messages
    render: Callable[[Equations, HeaderRequest], Rendered]


def _cpp(eqs: Equations, request: HeaderRequest) -> Rendered:
    from ipgen.codegen.header import render_header

    return {".hpp": render_header(eqs, request)}


def _c(eqs: Equations, request: HeaderRequest) -> Rendered:
    from ipgen.codegen.c_header import render_c_header

    return {".h": render_c_header(eqs, request)}


def _library(eqs: Equations, request: HeaderRequest) -> Rendered:
    from ipgen.codegen.model_library import render_model_library

    return dict(render_model_library(eqs, request))


def _equations(eqs: Equations, request: HeaderRequest) -> Rendered:
    """The equations of the links as built when the command gives any of their parameters
    (com, J, J_axial, tip, J0 in --fix or a scene), else the familiar ones of the paper's rods."""
    from ipgen.codegen.equations import render_equations
    from ipgen.model.system import LINK_GROUPS, split_parameter

    named = [name for name, _ in request.specialisation.fixed] + [name for name, _ in request.parameters]
    built = any(split_parameter(name)[0] in LINK_GROUPS for name in named)
    return render_equations(eqs if built else eqs.rod(), request)


def _fmu(eqs: Equations, request: HeaderRequest) -> Rendered:
    from ipgen.codegen.fmu import render_fmu

    return {".fmu": render_fmu(eqs, request, 2)}


def _fmu3(eqs: Equations, request: HeaderRequest) -> Rendered:
    from ipgen.codegen.fmu import render_fmu

    return {".fmu": render_fmu(eqs, request, 3)}


# In the order their files are written and listed.
TARGETS: dict[str, Target] = {
    "cpp": Target("cpp", (".hpp",), "the C++17 header (Eigen) NAME.hpp", _cpp),
    "c": Target("c", (".h",), "the C99 header NAME.h (no Eigen; float or double) for embedded targets", _c),
    "library": Target(
        "library",
        (".h", "_model.c"),
        "the model behind ipgen's C model interface (ipgen_model.h): NAME.h and NAME_model.c, "
        "a shared library for ipsim's simulator or ctypes",
        _library,
    ),
    "equations": Target(
        "equations",
        (".md", ".tex"),
        "the equations for people, NAME.md (Markdown) and NAME.tex (LaTeX)",
        _equations,
    ),
    "fmu": Target(
        "fmu",
        (".fmu",),
        "NAME.fmu, an FMI 2.0 Model Exchange FMU (exact Jacobian; compiled with cc or gcc)",
        _fmu,
    ),
    "fmu3": Target("fmu3", (".fmu",), "NAME.fmu as an FMI 3.0 Model Exchange FMU instead", _fmu3),
}
DEFAULT_EMIT: tuple[str, ...] = ("cpp",)
# Targets that write the same file, and what tells them apart (in TARGETS' order).
_OVERLAPS = {
    ("c", "library"): " (library writes the C header NAME.h and its adapter NAME_model.c)",
    ("fmu", "fmu3"): " (fmu is FMI 2.0, fmu3 is FMI 3.0)",
}


def parse_emit(values: str | Iterable[str], where: str = "--emit") -> tuple[str, ...]:
    """`"cpp,equations"` (or a list of names) -> the targets in canonical order, each once."""
    names = values.split(",") if isinstance(values, str) else list(values)
    wanted = [name.strip() if isinstance(name, str) else name for name in names]
    wanted = [name for name in wanted if name != ""]
    valid = ", ".join(TARGETS)
    if not wanted:
        raise EmitError(f"{where} is empty: name what to write, one or more of {valid}")
    for name in wanted:
        if name not in TARGETS:
            shown = repr(name) if isinstance(name, str) else f"{name!r} (not a string)"
            raise EmitError(f"{where}: unknown target {shown[:40]}: choose from {valid}")
    chosen = tuple(name for name in TARGETS if name in wanted)
    for i, first in enumerate(chosen):
        for second in chosen[i + 1 :]:
            shared = set(TARGETS[first].suffixes) & set(TARGETS[second].suffixes)
            if shared:
                hint = _OVERLAPS.get((first, second), "")
                both = f"{first} and {second} both write NAME{min(shared)}"
                raise EmitError(f"{where}: {both}: choose one{hint}")
    return chosen


# Targets whose variables are ipgen's own: the force or torque as the input, ipgen's coordinates.
FMU_TARGETS: tuple[str, ...] = ("fmu", "fmu3")


def unsupported(
    targets: Iterable[str],
    actuator: Actuator,
    coordinates: Coordinates,
    specialise: bool = False,
) -> str | None:
    """Why `targets` cannot be written for a model with this actuator, in these coordinates and
    specialisation (None if they can). The one check of what a model may emit: a scene's
    `emit`/`specialise` keys and the `--emit` option (or `write_header(emit=...)`) both meet it."""
    fmu = next((target for target in targets if target in FMU_TARGETS), None)
    if actuator.is_motor and fmu:
        return (
            f"[actuator] dc_motor with an FMU in emit is not supported yet (--emit or emit = {fmu}: the "
            "FMU's input is the force or torque, not the volts): remove the FMU, or declare the motor-folded "
            "model (docs/rigs.md) without [actuator]"
        )
    if actuator.is_acceleration and (specialise or fmu):
        return (
            "[actuator] acceleration with specialise = true or an FMU in emit is not supported: remove them "
            "(the FMU's input is the force or torque, and --emit fmu or fmu3 is the same; see docs/model.md)"
        )
    if fmu and not coordinates.is_canonical:
        return (
            f"--emit {fmu} in the rig's coordinates is not supported yet: the FMU's variables are ipgen's; "
            "drop the coordinates (--angles, --zero, --positive or the scene's) or the FMU"
        )
    return None
