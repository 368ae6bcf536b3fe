"""The headers of a fixed-pivot chain (`ipgen --type fixed`): C++, C99 and the model library.

The same printer, common-subexpression elimination and damping-as-joint-torques as the cart's
and the arm's headers (`functions.build_body`), over the chain's polynomials
(`model/fixed_poly.py`: the cart's links block), printed with `Syntax.offset` = 1 so that link i
is entry i − 1 of q, qd and the parameter arrays. Their own templates (templates/fixed.hpp.jinja,
fixed.h.jinja, fixed_model_library.c.jinja) hold what a fixed chain has and a cart has not: m
inputs (B n × m), the rotors' constant inertia, no base. Headers in ipgen's coordinates only.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

from ipgen.codegen.c_header import (
    FIXED_STRUCTS,
    c_number,
    mpc_context,
    printed,
    runtime_name_clash,
    swingup_context,
)
from ipgen.codegen.functions import C_SYNTAX, CPP_SYNTAX, Syntax, params_field
from ipgen.codegen.header import environment, function_bodies
from ipgen.common.locations import loop_runtime, mpc_runtime
from ipgen.common.safetext import comment_safe
from ipgen.common.version import __version__
from ipgen.control.controller import MpcDesign
from ipgen.control.swingup import SwingUpLaw
from ipgen.model.coordinates import Coordinates
from ipgen.model.fixed_poly import fixed_poly_equations
from ipgen.model.specialise import FUNCTIONS

__all__ = ["FIXED_CPP_SYNTAX", "FIXED_C_SYNTAX", "FixedFeedback", "FixedHeaderRequest", "render_fixed"]

FIXED_CPP_SYNTAX: Syntax = replace(CPP_SYNTAX, offset=1)
FIXED_C_SYNTAX: Syntax = replace(C_SYNTAX, offset=1, resolved=("com", "J"))
_C_LATE = {"forward_dynamics_derivatives": "qdd"}
_CPP_LATE = {"forward_dynamics_derivatives": "d.qdd"}


@dataclass(frozen=True)
class FixedFeedback:
    """A fixed scene's state feedback u = −K (x − x_eq) as the C header prints it, in ipgen's
    coordinates and torque sense: K one row per input, x_eq (2n), |u_k| bounds (None: none) and
    the sampling period [s] (None: continuous)."""

    kind: str
    gain: tuple[tuple[float, ...], ...]
    equilibrium: tuple[float, ...]
    saturation: tuple[float, ...] | None
    period: float | None


@dataclass(frozen=True)
class FixedHeaderRequest:
    """What determines a fixed chain's headers: its name, links, driven joints and command; and
    a scene's MPC (`[controller] kind = "mpc"`, one driven joint), which the C header prints with
    its sample period [s], and its swing-up (a plan tracked by its gains or by the MPC)."""

    name: str
    links: int
    joints: tuple[int, ...]
    command: str
    mpc: MpcDesign | None = None
    mpc_period: float = 0.0
    swingup: SwingUpLaw | None = None  # a scene's [swingup] (its plan), which the C header prints
    control: FixedFeedback | None = None  # a scene's [controller] kind = "lqr" or "gain"
    rig: Coordinates | None = None  # a scene's coordinates, when not ipgen's: the C header maps them


def fixed_model_name(links: int, joints: tuple[int, ...]) -> str:
    """The model (library) name of a chain: fixed<n>_j<joints>, e.g. fixed2_j1_2."""
    return f"fixed{links}_j{'_'.join(map(str, joints))}"


def fixed_library_sources(links: int, joints: tuple[int, ...]) -> tuple[str, dict[str, str]]:
    """(the model's name, {file name: text}) of a chain's model library (`--emit library`): what
    `ipgen run` compiles for a fixed scene and `ipgen.mpc` loads for a fixed chain."""
    name = fixed_model_name(links, joints)
    request = FixedHeaderRequest(name, links, joints, fixed_command(name, links, joints, ("library",)))
    return name, {f"{name}{suffix}": text for suffix, text in render_fixed(request, "library").items()}


def fixed_command(name: str, links: int, joints: tuple[int, ...], emit: tuple[str, ...]) -> str:
    """The ipgen command that regenerates these files (in any output folder)."""
    emitting = "" if emit == ("cpp",) else " --emit " + ",".join(emit)
    chosen = ",".join(map(str, joints))
    return f"ipgen --type fixed --links {links} --joints {chosen} --name {name}{emitting} -o <dir>"


def _context(
    request: FixedHeaderRequest, template: str, syntax: Syntax, late: dict[str, str]
) -> dict[str, object]:
    eqs = fixed_poly_equations(request.links)
    rod_fills = []  # (field, its rod value): as the functions' per-call fallback prints it, bit for bit
    for i in range(1, request.links + 1):
        m, length = params_field(f"m{i}", syntax), params_field(f"l{i}", syntax)
        one, two, twelve = (syntax.literal.format(value=v) for v in (1, 2, 12))
        rod_fills.append((params_field(f"com{i}", syntax), f"{one}/{two}*{length}"))
        rod_fills.append((params_field(f"J{i}", syntax), f"{one}/{twelve}*{m}*{length}*{length}"))
    return {
        "name": request.name,
        "nameu": request.name.upper(),
        "command": comment_safe(request.command),
        "version": __version__,
        "template": template,
        "type": "fixed",
        "links": request.links,
        "dof": request.links,
        "inputs": len(request.joints),
        "joints": list(request.joints),
        # (input k, coordinate of link j, coordinate of link j − 1 or None): B's columns and the rotors
        "slots": [(k, j - 1, j - 2 if j >= 2 else None) for k, j in enumerate(request.joints)],
        # B's rows as C initialisers (the model library's constant input_matrix)
        "input_rows": [
            ", ".join("1" if r == j - 1 else "-1" if r == j - 2 else "0" for j in request.joints)
            for r in range(request.links)
        ],
        "fn": function_bodies(eqs, FUNCTIONS, syntax=syntax, late=late),
        "rod_fills": rod_fills,
        "mpc": None,
        "mpc_runtime": "",
        "swingup": None,
        "loop_runtime": "",
        "control": None,
        "rig": None,
    }


def _scene_parts(request: FixedHeaderRequest) -> dict[str, object]:
    """What a scene adds to the C header: its MPC (mpc_step.h.jinja), its state feedback, the map
    from its coordinates, its swing-up (swingup_step.h.jinja); the runtimes they print."""
    parts: dict[str, object] = {}
    if request.mpc is not None:
        u_what = f"the torque [N m] at joint {request.joints[0]}, clockwise positive"
        parts["mpc"] = mpc_context(
            request.mpc, request.mpc_period, request.links, FUNCTIONS, FIXED_STRUCTS, u_what
        )
        parts["mpc_runtime"] = printed(mpc_runtime())
    if request.control is not None:
        feedback = request.control
        parts["control"] = {
            "kind": comment_safe(feedback.kind),
            "gain": [", ".join(c_number(v) for v in row) for row in feedback.gain],
            "equilibrium": ", ".join(c_number(v) for v in feedback.equilibrium),
            "saturation": ", ".join(c_number(v) for v in feedback.saturation) if feedback.saturation else "",
            "period": repr(float(feedback.period)) if feedback.period else "",
        }
    if request.rig is not None and not request.rig.is_canonical:
        parts["rig"] = _rig_context(request.rig, request.links)
    if request.swingup is not None:
        law = request.swingup
        catch_every = round(request.mpc_period / law.period) if request.mpc is not None else None
        parts["swingup"] = swingup_context(law, request.links, catch_every)
        parts["loop_runtime"] = printed(loop_runtime())
    return parts


def _rig_context(coordinates: Coordinates, links: int) -> dict[str, object]:
    """The scene's coordinates for the C header: θ = R q + z (`fixed_equations.angle_map`) as one
    C expression per link, θ̇ = R q̇ likewise, and the torque's sign (u_rig = sign u)."""
    from ipgen.model.fixed_equations import angle_map

    rotation, zero = angle_map(coordinates, links)

    def expression(variable: str, offset: float, i: int) -> str:
        """Row i of R times `variable`, plus `offset`: one C expression."""
        parts = [c_number(offset)] if offset else []
        for j, k in enumerate(float(v) for v in rotation[i]):
            if k:
                term = f"{variable}[{j}]" if abs(k) == 1 else f"{c_number(abs(k))} * {variable}[{j}]"
                parts.append((("- " if k < 0 else "+ ") if parts else ("-" if k < 0 else "")) + term)
        return " ".join(parts) or c_number(0.0)

    described = f"angles = {coordinates.angles}, zero = {coordinates.zero}, positive = {coordinates.positive}"
    return {
        "describe": described,
        "angles": [expression("q_rig", zero, i) for i in range(links)],
        "rates": [expression("qd_rig", 0.0, i) for i in range(links)],
        "sign": int(coordinates.sign),
    }


def render_fixed(request: FixedHeaderRequest, target: str) -> dict[str, str]:
    """{suffix: text} of one target ("cpp", "c" or "library") for the chain; deterministic."""
    if target == "cpp":
        context = _context(request, "fixed.hpp.jinja", FIXED_CPP_SYNTAX, _CPP_LATE)
        return {".hpp": environment().get_template("fixed.hpp.jinja").render(context)}
    context = _context(request, "fixed.h.jinja", FIXED_C_SYNTAX, _C_LATE)
    if target == "c":
        context |= _scene_parts(request)
    header = environment().get_template("fixed.h.jinja").render(context)
    if target == "c":
        runtime_name_clash(request.name, header, (context["mpc_runtime"], context["loop_runtime"]))
        return {".h": header}
    if target == "library":
        context["template"] = "fixed_model_library.c.jinja"
        adapter = environment().get_template("fixed_model_library.c.jinja").render(context)
        return {".h": header, "_model.c": adapter}
    raise ValueError(
        f"--emit {target}: render_fixed writes cpp, c or library (fixed_generate.render_target the rest)"
    )
