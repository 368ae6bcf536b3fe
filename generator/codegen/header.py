"""Renders the C++ header of one model from its equations (templates/model.hpp.jinja)."""

from __future__ import annotations

import contextlib
import functools
from collections.abc import Callable
from dataclasses import dataclass, field
from fractions import Fraction
from pathlib import Path
from typing import TYPE_CHECKING

import jinja2

from ipgen.codegen.functions import (
    CPP_SYNTAX,
    FunctionBody,
    Output,
    Syntax,
    build_body,
    params_field,
)
from ipgen.codegen.motor import motor_functions
from ipgen.common.install import REINSTALL
from ipgen.common.safetext import comment_safe
from ipgen.common.version import __version__
from ipgen.control.controller import Controller
from ipgen.estimation.printed import PrintedEstimator
from ipgen.model.coordinates import Coordinates
from ipgen.model.derivation import Equations
from ipgen.model.specialise import FUNCTIONS, Specialisation, specialise
from ipgen.model.system import System, split_parameter

if TYPE_CHECKING:
    from ipgen.control.swingup import SwingUpLaw

TEMPLATE = "model.hpp.jinja"


@dataclass(frozen=True)
class _Read:
    """One output of a function: its C++ name and the `Equations.poly` matrix it computes."""

    cpp: str
    key: str
    scalar: bool = False
    symmetric: bool = False
    lower_only: bool = False
    damped: bool = False  # generalised forces including the damping (`functions.Output.damped`)
    rayleigh: bool = False  # the Rayleigh function D (`functions.Output.rayleigh`)


_ARGS_Q_P = ("q", "p")
_ARGS_Q_QD_P = ("q", "qd", "p")
_M_LOWER, _B = _Read("M", "mass_matrix", lower_only=True), _Read("b", "bias", damped=True)
# Each function's outputs, and the arguments of its C++ signature that the body may use.
_FUNCTIONS: dict[str, tuple[tuple[_Read, ...], tuple[str, ...]]] = {
    "mass_matrix": ((_Read("M", "mass_matrix", symmetric=True),), _ARGS_Q_P),
    "bias": ((_B,), _ARGS_Q_QD_P),
    "gravity": ((_Read("P", "gravity"),), _ARGS_Q_P),
    "n_matrix": ((_Read("N", "n_matrix"),), _ARGS_Q_QD_P),
    "forward_dynamics": ((_M_LOWER, _B), _ARGS_Q_QD_P),
    "forward_dynamics_derivatives": (
        (_M_LOWER, _B, _Read("Rq", "residual_dq"), _Read("Rqd", "residual_dqd")),
        _ARGS_Q_QD_P,
    ),
    "kinetic_energy": ((_Read("T", "kinetic_energy", scalar=True),), _ARGS_Q_QD_P),
    "potential_energy": ((_Read("V", "potential_energy", scalar=True),), _ARGS_Q_P),
    "dissipation": ((_Read("D", "dissipation", scalar=True, rayleigh=True),), ("qd", "p")),
}
# Functions whose outputs use θ̈, and the C++ vector holding it once solved for.
_LATE = {"forward_dynamics_derivatives": "d.qdd"}


@dataclass(frozen=True)
class HeaderRequest:
    """Everything that determines a header's bytes."""

    name: str  # C++ namespace ipgen::<name> and file <name>.hpp
    command: str  # the canonical ipgen command that regenerates it
    specialisation: Specialisation = field(default_factory=Specialisation)
    controller: Controller | None = None  # a scene's feedback controller, for targets that print it
    # A scene's parameter values (name -> value) and initial state (θ then θ̇), for targets that
    # carry start values (the FMU); empty: the targets' defaults.
    parameters: tuple[tuple[str, float], ...] = ()
    initial: tuple[float, ...] = ()
    swingup: SwingUpLaw | None = None  # a scene's swing-up (control.swingup), for the C header
    # The rig's coordinates the headers' functions take and return (default: ipgen's own; the
    # canonical functions stay in them, docs/model.md "The rig's coordinates").
    coordinates: Coordinates = field(default_factory=Coordinates)
    # A scene's state estimator for the sampled loop ([sensors], [estimator]), for the C header.
    estimator: PrintedEstimator | None = None
    # A scene's drive ([actuator] kind: "direct", "dc_motor" or "acceleration"), which the
    # equations documents name (their u is the direct force or torque whatever the drive).
    drive: str = "direct"


def templates_dir() -> Path:
    """The templates shipped with the package, or the source tree's `templates/`."""
    packaged = Path(__file__).resolve().parent.parent / "templates"
    if packaged.is_dir():
        return packaged
    source = Path(__file__).resolve().parents[2] / "templates"
    if source.is_dir():
        return source
    raise FileNotFoundError(f"ipgen's templates folder is missing: {REINSTALL}")


class _TemplateCache(jinja2.FileSystemBytecodeCache):
    """Jinja's cache of compiled templates (per user, in the temporary directory), so that a
    run does not recompile the template, which costs about as much as deriving a small model.
    Entries are keyed by the template's checksum and written atomically; a cache that cannot be
    read or written is skipped."""

    def load_bytecode(self, bucket: jinja2.bccache.Bucket) -> None:
        with contextlib.suppress(OSError):
            super().load_bytecode(bucket)

    def dump_bytecode(self, bucket: jinja2.bccache.Bucket) -> None:
        with contextlib.suppress(OSError):
            super().dump_bytecode(bucket)


def _template_cache() -> jinja2.BytecodeCache | None:
    try:
        return _TemplateCache()
    except (OSError, RuntimeError):  # no safe per-user temporary directory: compile every time
        return None


@functools.cache
def environment() -> jinja2.Environment:
    """The Jinja environment of ipgen's templates (strict: an undefined name is an error), one
    per process: a new one each header loaded every template again and kept about 0.5 kB. Shared
    by every thread: not to be changed (`new_environment` gives one of a caller's own)."""
    return new_environment()


def new_environment() -> jinja2.Environment:
    """A new Jinja environment of ipgen's templates (`environment`'s settings)."""
    return jinja2.Environment(
        loader=jinja2.FileSystemLoader(templates_dir()),
        bytecode_cache=_template_cache(),
        undefined=jinja2.StrictUndefined,
        trim_blocks=True,
        lstrip_blocks=True,
        keep_trailing_newline=True,
        autoescape=False,
    )


def poly_keys(wanted: tuple[str, ...] = FUNCTIONS) -> tuple[str, ...]:
    """The `Equations.poly` matrices the functions `wanted` read, in first-use order."""
    return tuple(dict.fromkeys(read.key for name in wanted for read in _FUNCTIONS[name][0]))


def function_outputs(eqs: Equations, name: str) -> tuple[list[Output], tuple[str, ...]]:
    """The outputs the generated function `name` assigns (from `eqs.poly`) and its arguments."""
    reads, arguments = _FUNCTIONS[name]
    outputs = [
        Output(
            r.cpp,
            eqs.poly[r.key],
            scalar=r.scalar,
            symmetric=r.symmetric,
            lower_only=r.lower_only,
            damped=r.damped,
            rayleigh=r.rayleigh,
        )
        for r in reads
    ]
    return outputs, arguments


def function_bodies(
    eqs: Equations,
    wanted: tuple[str, ...] = FUNCTIONS,
    syntax: Syntax = CPP_SYNTAX,
    late: dict[str, str] = _LATE,
) -> dict[str, FunctionBody]:
    """The body of every generated function in `wanted`, keyed by its name; `syntax` and `late`
    (the vector holding θ̈ where a function needs it) choose the language, C++ by default."""
    bodies = {}
    for name in wanted:
        outputs, arguments = function_outputs(eqs, name)
        if name != "dissipation":  # Rayleigh's D reads the damping only: no links argument
            arguments = (*arguments, *syntax.extra_arguments)
        bodies[name] = build_body(eqs, outputs, arguments, late_source=late.get(name, ""), syntax=syntax)
    return bodies


def header_context(eqs: Equations, request: HeaderRequest, template: str) -> dict[str, object]:
    """What the C++ and the C header templates share: the model, the command and the
    specialisation notes (user text made comment-safe). `eqs` are the general equations."""
    system = eqs.system
    spec = request.specialisation
    return {
        "name": request.name,
        "command": comment_safe(request.command),  # paths are quoted already; this guards the rest
        "version": __version__,
        "template": template,
        "type": system.type,
        "links": system.links,
        "dof": system.dof,
        "inertia": system.inertia,
        "input_used": not spec.zero_input,
        "specialisation": [comment_safe(note) for note in spec.notes()],
        "origin": comment_safe(spec.origin),
        "frame": frame_context(request.coordinates),
    }


def frame_context(coordinates: Coordinates) -> dict[str, object] | None:
    """The rig's coordinates for the templates, or None for ipgen's own (the header is then as
    it always was)."""
    if coordinates.is_canonical:
        return None
    return {
        "angles": coordinates.angles,
        "zero": coordinates.zero,
        "positive": coordinates.positive,
        "relative": coordinates.angles == "relative",
        "hanging": coordinates.zero == "hanging",
        "counterclockwise": coordinates.positive == "counterclockwise",
    }


def render_header(eqs: Equations, request: HeaderRequest) -> str:
    """The complete header text; deterministic for the same equations and request."""
    spec = request.specialisation
    context = header_context(eqs, request, TEMPLATE)
    eqs = specialise(eqs, spec, poly_keys(spec.outputs))
    context["fn"] = function_bodies(eqs, spec.outputs)
    context["folded"] = folded_entries(eqs.system, spec, CPP_SYNTAX, lambda v: repr(float(v)))
    context["rod_fills"] = rod_fills(eqs.system, spec)
    context["motor"] = motor_functions(eqs.system, "cpp")  # DcMotor, with_motor (actuator.motor_terms)
    return environment().get_template(TEMPLATE).render(context)


def _cast(syntax: Syntax, value: int) -> str:
    """An integer constant of the scalar type: Scalar(12) in C++, (IPGEN_SCALAR)12 in C."""
    return f"({syntax.scalar}){value}" if syntax.c_arrays else f"{syntax.scalar}({value})"


def rod_fills(system: System, spec: Specialisation, syntax: Syntax = CPP_SYNTAX) -> list[tuple[str, str]]:
    """(Params field, its rod value from m and l) of every com and J entry a header reads and
    falls back on when unset (a cart's J0 is unused; folded entries are not read), for
    `with_rod_links` (in C, `syntax` C_SYNTAX: for the model library's adapter)."""
    fixed = {name for name, _ in spec.fixed}
    names = [f"{group}{i}" for i in range(1, system.dof) for group in ("com", "J")]
    if system.is_rotary:
        names.insert(0, "J0")
    fills = []
    for name in names:
        if name in fixed:
            continue
        group, index = split_parameter(name)
        m, length = params_field(f"m{index}", syntax), params_field(f"l{index}", syntax)
        # The same expression, operation for operation, as the per-call fallback in the functions
        # (so a run with the fills gives the same bits as one without).
        if group == "com":
            rod = f"{_cast(syntax, 1)}/{_cast(syntax, 2)}*{length}"
        else:
            rod = f"{_cast(syntax, 1)}/{_cast(syntax, 3 if index == 0 else 12)}*{m}*{length}*{length}"
        fills.append((params_field(name, syntax), rod))
    return fills


def folded_entries(
    system: System, spec: Specialisation, syntax: Syntax, number: Callable[[Fraction], str]
) -> list[tuple[str, str, str, str]]:
    """(name, Params field, folded value as `number` prints it, rod default) per fixed parameter,
    for check_folded; the rod default (in the Params entries m and l) only for com and J, which
    may be left unset (C++: NaN; C: no links struct, where tip and J_axial are then 0)."""
    entries = []
    for name, value in spec.fixed:
        group, index = split_parameter(name)
        rod = ""
        if group in ("com", "J") and index is not None:
            m, length = params_field(f"m{index}", syntax), params_field(f"l{index}", syntax)
            if group == "com":
                rod = f"{length} / {syntax.literal.format(value=2)}"
            else:
                divisor = 3 if index == 0 else 12
                rod = f"{m} * {length} * {length} / {syntax.literal.format(value=divisor)}"
        entries.append((name, params_field(name, syntax), number(value), rod))
    return entries
