"""ipgen: exact equations of motion for n-link inverted pendulums (classical: a cart; rotary: a
Furuta arm), as sympy expressions or as generated C++ headers.

The public API (stable; everything else is internal):

- `Pendulum(type, links, m, l, delta, g=9.81, inertia="pivot", *, com, J, J_axial, tip,
  coulomb, coulomb_speed, actuator, angles, zero, positive)`: one immutable, validated
  description of a system (`Pendulum.preset("qube_servo2")`, `Pendulum.from_scene(path)`,
  `.replace(...)`, `.folded()`, `.params()`), what the functions below take;
- `derive(p)` or `derive(type, links, inertia="pivot") -> Equations`: the equations of motion
  M(θ) θ̈ + N(θ, θ̇) θ̇ + P(θ) = (u, 0, …, 0)ᵀ as sympy matrices and expressions;
- `write_header(output, type, links, ...)`: what the `ipgen` command does, as a call;
- `Error`: the base of every error ipgen raises for bad input (one line: what is wrong and how
  to fix it, the message the command prints);
- `cmake_dir()`: the folder of ipgen's CMake package (`ipgen --cmake-dir`);
- `linearize(p, q=None, qd=None, u=0.0) -> (A, B)` (or the keyword form `linearize(type, links,
  m, l, delta, ...)`): the linear model ẋ = A x + B u about a state (default upright at rest),
  from the exact derivation (control/linear.py, numpy and scipy);
- `lqr(p, Q, R, equilibrium=None) -> K` (or `lqr(type, links, m, l, delta, Q, R, ...)`): an
  LQR gain, a 1 × 2(n+1) array with
  u = −K (x − x_eq) (python-control's convention: A − B @ K is the closed loop);
- `Actuator(kind="dc_motor", Rm=..., kt=..., km=..., ...)`: a DC motor on the base, for the
  `actuator=` argument of `derive`, `linearize` and `lqr` (u is then the motor voltage [V]);
  `Actuator("acceleration")`: the base follows a commanded acceleration (u = θ̈0).
- `excitation(scene, output=None, *, u_max, travel=None, signal="multisine", ...) -> Design`: an
  identification experiment for a rig (a multisine or chirp about hanging, its amplitude scaled so
  that the linear model's predicted base travel stays within the limits), written as a new scene
  (what `ipgen excite` does; docs/excitation.md).
- `identify(scene, data, free=[...], output=None) -> Identified`: the scene's `free` parameters
  fitted to measurements (a CSV), with standard errors, 95 % intervals, correlations and what the
  data cannot determine (`.fit`, `.report`); with `output`, the updated scene, the report and a
  PNG written there (`ipgen identify`, docs/identify.md; needs CasADi).

The model (coordinates, bodies, energies, damping) is specified in docs/model.md of the repository.
Importing ipgen is cheap: the modules behind these functions are imported on first use.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import TYPE_CHECKING

from ipgen.common.locations import cmake_dir
from ipgen.common.version import __version__
from ipgen.errors import Error

if TYPE_CHECKING:
    from ipgen.model.actuator import Actuator
    from ipgen.model.derivation import Equations
    from ipgen.model.pendulum import Pendulum


__all__ = [
    "Actuator",
    "Equations",
    "Error",
    "Pendulum",
    "__version__",
    "cmake_dir",
    "derive",
    "excitation",
    "identify",
    "linearize",
    "lqr",
    "write_header",
]


def derive(
    type: str | Pendulum,
    links: int | None = None,
    inertia: str = "pivot",
    *,
    general: bool = False,
    actuator: Actuator | Mapping[str, object] | None = None,
) -> Equations:
    """The equations of motion M(θ) θ̈ + N(θ, θ̇) θ̇ + P(θ) = (u, 0, …, 0)ᵀ, as sympy views.

    Called as ``derive(p)`` with a `Pendulum` (its type, links, inertia and actuator; its numbers
    are not substituted: the views are symbolic), or as ``derive(type, links, inertia="pivot",
    *, general=False, actuator=None)``.

    Parameters
    ----------
    type : str or Pendulum
        "classical" (a cart) or "rotary" (a Furuta arm), or a Pendulum.
    links : int
        Number of links >= 1 (not with a Pendulum).
    inertia : str, default "pivot"
        Rotary only: "pivot" (the published model: a link's spin about its pivot axis only) or
        "full" (the complete thin-rod inertia).
    general : bool, default False
        True: the links as built, the views also written in `symbols.com` (pivot-to-CoG
        distances), `symbols.J` (inertias about the CoGs; `J[0]` the arm's about the vertical),
        `symbols.J_axial` (about the links' own axes, rotary "full" only) and `symbols.tip`
        (point masses at the far ends); False: the paper's homogeneous rods, in m, l, delta, g.
    actuator : Actuator, dict or None
        What drives the base (not with a Pendulum, which has its own): a "dc_motor" is folded
        into the views (M00, damping, bias, T and D gain the rotor's inertia and the back-EMF,
        and `input_matrix` = (b, 0, …)ᵀ makes u the voltage); for "acceleration",
        `link_equations` are the equations of motion; None: direct.

    Returns
    -------
    Equations
        Its sympy views: `mass_matrix` M, `coriolis` C (Christoffel), `damping` (constant),
        `n_matrix` N = C + damping, `gravity` P = ∂V/∂θ, `bias` N θ̇ + P (matrices; vectors as
        columns), `kinetic_energy`, `potential_energy`, `dissipation` (Rayleigh's D), written in
        `symbols`: `q`, `qd` (θ, θ̇), `m`, `l`, `delta` (tuples, index 0 the base), `g`, `u`.

    Raises
    ------
    Error
        One line naming the bad argument (a `SystemChoiceError` for type, links or inertia).

    Examples
    --------
    >>> import ipgen
    >>> ipgen.derive("classical", 1).mass_matrix.shape
    (2, 2)
    """
    from ipgen.model.actuator import as_actuator
    from ipgen.model.derivation import derive as derive_system
    from ipgen.model.pendulum import Pendulum
    from ipgen.model.system import check_system

    if isinstance(type, Pendulum):
        if links is not None or actuator is not None:
            raise Error("derive(p) takes the links and the actuator from the Pendulum: pass neither")
        system, drive = type.system, type.actuator
        actuator = None if drive.kind == "direct" else drive
    else:
        system = check_system(type, links, None if inertia == "pivot" and type != "rotary" else inertia)
        drive = as_actuator(dict(actuator) if isinstance(actuator, Mapping) else actuator)
        drive.check(system)
    equations = derive_system(system)
    equations = equations if general else equations.rod()
    return equations if actuator is None else equations.driven(drive)


def write_header(
    output: str | Path,
    type: str | None = None,
    links: int | None = None,
    *,
    name: str | None = None,
    inertia: str | None = None,
    scene: str | Path | None = None,
    fix: str | Mapping[str, object] | None = None,
    outputs: str | Iterable[str] | None = None,
    emit: str | Iterable[str] | None = None,
    force: bool = False,
    angles: str | None = None,
    zero: str | None = None,
    positive: str | None = None,
) -> list[Path]:
    """Write the files of `ipgen --type TYPE --links N -o OUTPUT [...]` (or `--scene SCENE`) and
    return their paths: `OUTPUT/<name>.hpp` by default, every file of `emit`, and `<stem>.cfg`
    last for a scene. The keyword arguments are the command's options: `fix` as text
    ("m0=0.3,delta2=0") or a mapping ({"m0": "0.3"}; a float is taken by its shortest repr),
    `outputs` and `emit` as text or a list of names. `angles` ("absolute" | "relative"), `zero`
    ("upright" | "hanging") and `positive` ("clockwise" | "counterclockwise") make every function
    of the headers take and return the rig's coordinates (the canonical ones stay: namespace
    `canonical` in C++, the `_canonical` suffix in C; docs/model.md); a scene says them in its
    [system]. All files are written or none; bad input raises an `Error` with the message the
    command prints.
    """
    from ipgen.command.job import plan, run

    job = plan(
        output,
        system_type=type,
        links=links,
        name=name,
        inertia=inertia,
        scene=scene,
        fix=fix,
        outputs=outputs,
        emit=emit,
        force=force,
        angles=angles,
        zero=zero,
        positive=positive,
    )
    return [written.path for written in run(job)]


def __getattr__(attribute: str) -> object:
    """The lazy part of the API: `Equations`, and `linearize` and `lqr` (control/linear.py, which
    imports numpy and scipy) and `excitation` (command/excite.py), so that `import ipgen` and the
    ipgen command start fast."""
    if attribute == "Equations":
        from ipgen.model.derivation import Equations

        return Equations
    if attribute == "Pendulum":
        from ipgen.model.pendulum import Pendulum

        return Pendulum
    if attribute == "Actuator":
        from ipgen.model.actuator import Actuator

        return Actuator
    if attribute == "excitation":
        from ipgen.command.excite import excitation

        return excitation
    if attribute == "identify":
        from ipgen.command.identify import identify

        return identify
    if attribute in ("linearize", "lqr"):
        from ipgen.control import linear as control

        return getattr(control, attribute)
    raise AttributeError(f"module 'ipgen' has no attribute {attribute!r}")


def __dir__() -> list[str]:
    """The module's names including the lazy ones, so that `help(ipgen)` and `dir(ipgen)` list
    every public function (`help` then imports control/linear.py)."""
    return sorted(set(globals()) | set(__all__))
