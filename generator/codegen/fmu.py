"""Renders one model as a Functional Mock-up Unit (`--emit fmu`: FMI 2.0, `--emit fmu3`: FMI 3.0).

A Model Exchange FMU is a zip archive: modelDescription.xml (templates/fmu2.xml.jinja or
fmu3.xml.jinja), the C sources (the model's C99 header exactly as `--emit c` writes it for the
general model, plus the FMI glue rendered from templates/fmu2.c.jinja or fmu3.c.jinja, plus
the Modelica Association's FMI headers, vendored in templates/fmi/ with their BSD licence)
and a Linux x86-64 binary compiled from those sources when the FMU is written.

The FMU is always the general model: every parameter is a tunable FMI parameter, whose start
value is the scene's (or a --fix value), else the paper's. Directional (and, in FMI 3.0,
adjoint) derivatives are exact: the accelerations' from the header's
forward_dynamics_derivatives, the energies' from gradients of T, V and D derived here from the
same polynomials (printed by the same C printer).
"""

from __future__ import annotations

import hashlib
import io
import os
import shlex
import shutil
import subprocess
import tempfile
import uuid
import zipfile
from pathlib import Path
from typing import TYPE_CHECKING

from ipgen.codegen.c_header import render_c_header
from ipgen.codegen.fmu_variables import Layout, layout
from ipgen.codegen.functions import C_SYNTAX, FunctionBody, Output, Syntax, build_body
from ipgen.codegen.header import HeaderRequest, environment, templates_dir
from ipgen.common.safetext import comment_safe
from ipgen.common.version import __version__
from ipgen.errors import Error
from ipgen.model.derivation import Equations
from ipgen.model.specialise import FUNCTIONS, Specialisation

if TYPE_CHECKING:
    from ipgen.codegen.fixed_header import FixedHeaderRequest

PLATFORM = {2: "linux64", 3: "x86_64-linux"}  # binaries/<platform>/ of each FMI version
COMPILERS = ("cc", "gcc")
# No -Werror: the FMU is compiled on the user's machine (tests/test_fmu.py rebuilds its shipped
# sources with -Werror).
CFLAGS = ("-std=c99", "-Wall", "-Wextra", "-Wpedantic", "-O2", "-fPIC", "-shared")
# A fixed timestamp for every archive member, so that the same model gives the same bytes.
_ZIP_TIME = (2020, 1, 1, 0, 0, 0)
STDERR_LINES = 20


class FmuError(Error, RuntimeError):
    """The FMU cannot be built (no C compiler, or its sources do not compile); says why."""


def compiler() -> list[str]:
    """The C compiler command: $CC if set (a program and its options), else the first of cc
    and gcc on PATH; FmuError if none."""
    wanted = os.environ.get("CC", "").strip()
    try:
        words = shlex.split(wanted)
    except ValueError:
        words = [wanted]
    candidates = [words] if words else [[name] for name in COMPILERS]
    for program, *options in candidates:
        found = shutil.which(program)
        if found:
            return [found, *options]
    shown = f"$CC ({wanted[:40]!r})" if wanted else " or ".join(COMPILERS)
    raise FmuError(
        f"--emit fmu/fmu3 compiles the FMU's binary, but no C compiler {shown} is on PATH: "
        "install one (e.g. apt install gcc) or set CC"
    )


def build_command(cc: str | list[str], source: str, output: str) -> list[str]:
    """How the FMU's binary is built from its sources (run in the sources folder)."""
    return [*([cc] if isinstance(cc, str) else cc), *CFLAGS, "-I.", source, "-o", output, "-lm"]


def energy_gradients(eqs: Equations, syntax: Syntax = C_SYNTAX) -> FunctionBody:
    """The C body computing dT/dq, dT/dqd, dV/dq (the gravity vector) and dD/dqd exactly.

    `syntax` is the header's: `C_SYNTAX`, or a fixed chain's (`Syntax.offset` = 1: the
    coordinates are the cart's links, generators 1..n, printed as entries 0..n − 1)."""
    algebra = eqs.algebra
    coordinates = range(syntax.offset, eqs.system.dof)
    kinetic = eqs.poly["kinetic_energy"][0][0]
    dissipation = eqs.poly["dissipation"][0][0]
    slope = algebra.gradient(kinetic)
    columns = {
        "dT_dq": [[slope.get(k, algebra.zero)] for k in coordinates],
        "dT_dqd": [[kinetic.derivative(algebra.qd(k))] for k in coordinates],
        "dV_dq": eqs.poly["gravity"],
        "dD_dqd": [[dissipation.derivative(algebra.qd(k))] for k in coordinates],
    }
    outputs = [Output(name, value, damped=name == "dD_dqd") for name, value in columns.items()]
    extra = tuple(getattr(syntax, "extra_arguments", ()))  # the links struct, where there is one
    return build_body(eqs, outputs, ("q", "qd", "p", *extra), syntax=syntax)


_PLACEHOLDER = "{ipgen-token-placeholder}"


def _token(*parts: str) -> str:
    """A GUID / instantiation token determined by the FMU's contents: "{8-4-4-4-12}"."""
    digest = hashlib.sha256("\0".join(parts).encode()).digest()
    return "{" + str(uuid.UUID(bytes=digest[:16], version=4)) + "}"


def _start_values(request: HeaderRequest) -> dict[str, float]:
    values = {name: float(value) for name, value in request.specialisation.fixed}
    values.update(dict(request.parameters))
    return values


def _verbatim(path: Path) -> str:
    """A vendored file's text exactly as shipped (its line endings kept)."""
    with path.open(encoding="utf-8", newline="") as f:
        return f.read()


def _description(eqs: Equations, request: HeaderRequest) -> str:
    system = eqs.system
    base = (
        "a cart on a rail" if system.type == "classical" else f"a Furuta arm ({system.inertia} link inertia)"
    )
    plural = "s" if system.links > 1 else ""
    return (
        f"{system.type.capitalize()} inverted pendulum: {base} carrying {system.links} rod{plural} "
        "(exact equations of motion by ipgen, Jadlovska & Sarnovsky 2013)"
    )


def check_name(name: str) -> None:
    """FmuError if the model's files would clash with the FMI headers shipped beside them."""
    vendored = {
        path.stem for folder in ("fmi2", "fmi3") for path in (templates_dir() / "fmi" / folder).glob("*.h")
    }
    if name in vendored:
        raise FmuError(
            f"model name {name!r} is the name of an FMI header the FMU ships: choose another --name"
        )


def render_sources(eqs: Equations, request: HeaderRequest, version: int) -> dict[str, str]:
    """The FMU's text files, keyed by their path in the archive."""
    name = request.name
    check_name(name)
    general = HeaderRequest(name, request.command, Specialisation(outputs=FUNCTIONS), None)
    header = render_c_header(eqs, general)
    table: Layout = layout(eqs, _start_values(request), request.initial)
    context: dict[str, object] = {
        "name": name,
        "nameu": name.upper(),
        "version": __version__,
        "command": comment_safe(request.command),
        "description": _description(eqs, request),
        "stop_time": "10",
        "scene": bool(request.parameters),
        "type": eqs.system.type,
        "links": eqs.system.links,
        "dof": eqs.system.dof,
        "inertia": eqs.system.inertia,
        "layout": table,
        "variables": table.variables,
        "links_struct": any(v.c_value.startswith("m->links.") for v in table.variables),
        "gradients": energy_gradients(eqs),
        "fixed_pivot": False,
    }
    return _package(name, header, context, version)


def render_fixed_sources(request: FixedHeaderRequest, version: int) -> dict[str, str]:
    """The text files of a fixed-pivot chain's FMU (`ipgen --type fixed --emit fmu`).

    Its C99 header as `--emit c` writes it and the same glue templates as the cart's and the
    arm's, with m inputs u1..um (`fmu_variables.fixed_layout`), in ipgen's coordinates.

    Parameters
    ----------
    request : FixedHeaderRequest
        The chain's name, links, driven joints and command.
    version : int
        2 (FMI 2.0) or 3 (FMI 3.0).

    Returns
    -------
    dict of str to str
        The archive's text files keyed by their path in it (no binary: `compile_binary`).
    """
    from ipgen.codegen.fixed_header import FIXED_C_SYNTAX, render_fixed
    from ipgen.codegen.fmu_variables import fixed_layout
    from ipgen.model.fixed_poly import fixed_poly_equations

    name = request.name
    check_name(name)
    header = render_fixed(request, "c")[".h"]
    table = fixed_layout(request.joints, request.links, {})
    driven = ", ".join(map(str, request.joints))
    plural = "s" if request.links > 1 else ""
    context: dict[str, object] = {
        "name": name,
        "nameu": name.upper(),
        "version": __version__,
        "command": comment_safe(request.command),
        "description": (
            f"Chain of {request.links} link{plural} on a fixed pivot, driven by torques at joint"
            f"{'s' if len(request.joints) > 1 else ''} {driven} (exact equations of motion by ipgen)"
        ),
        "stop_time": "10",
        "scene": False,
        "type": "fixed-pivot",
        "links": request.links,
        "dof": request.links,
        "inertia": "pivot",
        "layout": table,
        "variables": table.variables,
        "links_struct": True,
        "gradients": energy_gradients(fixed_poly_equations(request.links), FIXED_C_SYNTAX),
        "fixed_pivot": True,
        "inputs": len(request.joints),
        "joints": list(request.joints),
        # (input k, coordinate of link j, coordinate of link j − 1 or None): the rotors
        "slots": [(k, j - 1, j - 2 if j >= 2 else None) for k, j in enumerate(request.joints)],
    }
    return _package(name, header, context, version)


def _package(name: str, header: str, context: dict[str, object], version: int) -> dict[str, str]:
    """The FMU's text files from its C header and the templates' `context`."""
    env = environment()
    context["fmi"] = version
    context["source"] = f"{name}_fmu.c"
    context["build"] = shlex.join(build_command("cc", f"{name}_fmu.c", f"{name}.so"))
    # The GUID / instantiation token is a digest of what the binary and the description are
    # made of: rendered with a placeholder, then filled in.
    context["token"] = _PLACEHOLDER
    glue = env.get_template(f"fmu{version}.c.jinja").render(context)
    description = env.get_template(f"fmu{version}.xml.jinja").render(context)
    token = _token(str(version), header, glue, description)
    glue, description = glue.replace(_PLACEHOLDER, token), description.replace(_PLACEHOLDER, token)
    files = {
        "modelDescription.xml": description,
        f"sources/{name}.h": header,
        f"sources/{name}_fmu.c": glue,
    }
    vendored = templates_dir() / "fmi" / f"fmi{version}"
    for path in sorted(vendored.glob("*.h")):
        files[f"sources/{path.name}"] = _verbatim(path)
    files["documentation/licenses/fmi-standard-LICENSE.txt"] = _verbatim(vendored / "LICENSE.txt")
    if version == 3:
        files["sources/buildDescription.xml"] = env.get_template("fmu3.build.xml.jinja").render(context)
    return files


def compile_binary(files: dict[str, str], name: str) -> bytes:
    """The shared library built from the archive's sources/ with `build_command`."""
    cc = compiler()
    with tempfile.TemporaryDirectory(prefix="ipgen-fmu-") as tmp:
        folder = Path(tmp)
        for path, text in files.items():
            if path.startswith("sources/") and not path.endswith(".xml"):
                (folder / path.removeprefix("sources/")).write_text(text, encoding="utf-8", newline="")
        command = build_command(cc, f"{name}_fmu.c", f"{name}.so")
        try:
            result = subprocess.run(command, cwd=folder, capture_output=True, text=True, check=False)
        except OSError as e:
            raise FmuError(f"cannot run the C compiler {cc[0]}: {e.strerror}; install gcc or set CC") from e
        if result.returncode != 0:
            lines = (result.stderr or result.stdout).splitlines()[:STDERR_LINES]
            raise FmuError(
                f"the FMU's C sources do not compile with {shlex.join(command)}: " + " | ".join(lines)
            )
        return (folder / f"{name}.so").read_bytes()


def _zip(members: dict[str, bytes]) -> bytes:
    """A deterministic zip archive (sorted names, fixed times, deflated)."""
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w") as archive:
        for path in sorted(members, key=lambda p: (p != "modelDescription.xml", p)):
            info = zipfile.ZipInfo(path, _ZIP_TIME)
            info.compress_type = zipfile.ZIP_DEFLATED
            info.external_attr = 0o644 << 16
            archive.writestr(info, members[path])
    return buffer.getvalue()


def render_fmu(eqs: Equations, request: HeaderRequest, version: int) -> bytes:
    """The complete .fmu archive (FMI `version` 2 or 3) of one model."""
    return _archive(render_sources(eqs, request, version), request.name, version)


def render_fixed_fmu(request: FixedHeaderRequest, version: int) -> bytes:
    """The complete .fmu archive (FMI `version` 2 or 3) of a fixed-pivot chain.

    Parameters
    ----------
    request : FixedHeaderRequest
        The chain's name, links, driven joints and command.
    version : int
        2 (FMI 2.0) or 3 (FMI 3.0).

    Returns
    -------
    bytes
        The zip archive, its binary compiled for this platform (`compile_binary`).

    Raises
    ------
    FmuError
        No C compiler, or the sources do not compile.
    """
    return _archive(render_fixed_sources(request, version), request.name, version)


def _archive(files: dict[str, str], name: str, version: int) -> bytes:
    """The archive of the FMU's text `files` and the binary compiled from them."""
    binary = compile_binary(files, name)
    members = {path: text.encode("utf-8") for path, text in files.items()}
    members[f"binaries/{PLATFORM[version]}/{name}.so"] = binary
    return _zip(members)
