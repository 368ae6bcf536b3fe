"""Renders the C++ header of one model from its equations (templates/model.hpp.jinja)."""

from __future__ import annotations

import contextlib
from dataclasses import dataclass, field
from pathlib import Path

import jinja2

from generator import __version__
from generator.codegen.functions import FunctionBody, Output, build_body
from generator.derive import Equations
from generator.specialise import FUNCTIONS, Specialisation, specialise

TEMPLATE = "model.hpp.jinja"

# (function, arguments of its C++ signature that the body may use)
_ARGS_Q_P = ("q", "p")
_ARGS_Q_QD_P = ("q", "qd", "p")


@dataclass(frozen=True)
class HeaderRequest:
    """Everything that determines a header's bytes."""

    name: str  # C++ namespace ipgen::<name> and file <name>.hpp
    command: str  # the canonical ipgen command that regenerates it
    specialisation: Specialisation = field(default_factory=Specialisation)


def templates_dir() -> Path:
    """The templates shipped with the package, or the source tree's `templates/`."""
    packaged = Path(__file__).resolve().parent.parent / "templates"
    if packaged.is_dir():
        return packaged
    source = Path(__file__).resolve().parents[2] / "templates"
    if source.is_dir():
        return source
    raise FileNotFoundError("ipgen's templates folder is missing: reinstall ipgen")


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


def _environment() -> jinja2.Environment:
    return jinja2.Environment(
        loader=jinja2.FileSystemLoader(templates_dir()),
        bytecode_cache=_template_cache(),
        undefined=jinja2.StrictUndefined,
        trim_blocks=True,
        lstrip_blocks=True,
        keep_trailing_newline=True,
        autoescape=False,
    )


def function_bodies(eqs: Equations, wanted: tuple[str, ...] = FUNCTIONS) -> dict[str, FunctionBody]:
    """The body of every generated function in `wanted`, keyed by its C++ name."""
    poly = eqs.poly
    mass, bias = poly["mass_matrix"], poly["bias"]
    outputs: dict[str, tuple[list[Output], tuple[str, ...]]] = {
        "mass_matrix": ([Output("M", mass, symmetric=True)], _ARGS_Q_P),
        "bias": ([Output("b", bias)], _ARGS_Q_QD_P),
        "gravity": ([Output("P", poly["gravity"])], _ARGS_Q_P),
        "n_matrix": ([Output("N", poly["n_matrix"])], _ARGS_Q_QD_P),
        "forward_dynamics": ([Output("M", mass, lower_only=True), Output("b", bias)], _ARGS_Q_QD_P),
        "forward_dynamics_derivatives": (
            [
                Output("M", mass, lower_only=True),
                Output("b", bias),
                Output("Rq", poly["residual_dq"]),
                Output("Rqd", poly["residual_dqd"]),
            ],
            _ARGS_Q_QD_P,
        ),
        "kinetic_energy": ([Output("T", poly["kinetic_energy"], scalar=True)], _ARGS_Q_QD_P),
        "potential_energy": ([Output("V", poly["potential_energy"], scalar=True)], _ARGS_Q_P),
        "dissipation": ([Output("D", poly["dissipation"], scalar=True)], ("qd", "p")),
    }
    late = {"forward_dynamics_derivatives": "d.qdd"}
    return {
        name: build_body(eqs, outputs[name][0], outputs[name][1], late_source=late.get(name, ""))
        for name in wanted
    }


def _params_field(name: str) -> str:
    """C++ access to parameter `name` in a Params p: m1 -> p.m[1], g -> p.g."""
    if name == "g":
        return "p.g"
    kind = name.rstrip("0123456789")
    return f"p.{kind}[{name[len(kind):]}]"


def render_header(eqs: Equations, request: HeaderRequest) -> str:
    """The complete header text; deterministic for the same equations and request."""
    system = eqs.system
    spec = request.specialisation
    eqs = specialise(eqs, spec)
    context = {
        "name": request.name,
        "command": request.command,
        "version": __version__,
        "template": TEMPLATE,
        "type": system.type,
        "links": system.links,
        "dof": system.dof,
        "inertia": system.inertia,
        "fn": function_bodies(eqs, spec.outputs),
        "input_used": not spec.zero_input,
        "specialisation": spec.notes(),
        "folded": [(name, _params_field(name), repr(float(value))) for name, value in spec.fixed],
        "origin": spec.origin,
    }
    return _environment().get_template(TEMPLATE).render(context)
