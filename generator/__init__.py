"""ipgen: exact equations of motion for n-link inverted pendulums (classical: a cart; rotary: a
Furuta arm), as sympy expressions or as generated C++ headers.

The public API (stable; everything else is internal):

- `Pendulum(type, links, m, l, delta, g=9.81, inertia="pivot", *, com, J, J_axial, tip,
  coulomb, coulomb_speed, actuator, angles, zero, positive)`: one immutable, validated
  description of a system (`Pendulum.preset("qube_servo2")`, `Pendulum.from_scene(path)`,
  `.replace(...)`, `.folded()`, `.params()`), what the functions below take;
- `FixedPendulum(links, m, l, delta, g=9.81, *, com, J, coulomb, coulomb_law, coulomb_speed,
  coulomb_gain, joints, Ir, gr, angles, zero, positive)`: a chain on a fixed pivot driven by
  torques at chosen joints (the pendubot, the acrobot, the DFKI double pendulum); `derive`,
  `linearize` (B 2n × m) and `lqr` (K m × 2n) take it too (docs/model.md, "A fixed pivot");
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
- `mpc(p, *, horizon=30, period=0.01, Q, R, P, u_max, travel, bounds, soft_bounds, mode="rti", ...)
  -> Mpc`: a constrained nonlinear MPC on the exact model (`.step(x)` → u, the C step of
  cpp/include/ipgen_mpc.h through ctypes; real-time iteration or converged; docs/mpc.md);
- `kalman(pendulum, period, Qn, Rn, *, measured=None, equilibrium=None) -> Kalman`: the
  steady-state discrete Kalman filter on the ZOH-discretised exact linearisation (`.L`, `.P` in
  python-control's `dlqe` convention, `.M` the current-form gain, `.A`, `.B`, `.C`;
  estimation/kalman.py; the estimators that run on a recording are in `ipgen.estimation`);
- `Actuator(kind="dc_motor", Rm=..., kt=..., km=..., ...)`: a DC motor on the base, for the
  `actuator=` argument of `derive`, `linearize` and `lqr` (u is then the motor voltage [V]);
  `Actuator("acceleration")`: the base follows a commanded acceleration (u = θ̈0).
- `excitation(scene, output=None, *, u_max, travel=None, signal="multisine", ...) -> Design`: an
  identification experiment for a rig (a multisine or chirp about hanging, its amplitude scaled so
  that the linear model's predicted base travel stays within the limits), written as a new scene
  (what `ipgen excite` does; docs/excitation.md).
- `identify(scene, data, free=[...], output=None) -> Identified` (or `identify(p, data, free)
  -> Fit` for a Pendulum; for a FixedPendulum or a fixed scene, `identify(p, [data, ...],
  validate=[...])`: its base parameters from joint torques): the `free` parameters fitted to
  measurements (a CSV), with standard
  errors, 95 % intervals, correlations and what the data cannot determine (`.fit`, `.report`);
  with `output`, the updated scene, the report and a PNG written there (`ipgen identify`,
  docs/identify.md; needs CasADi).
- `sweep(scene, out, *, scorecard=False, vary=(), ...) -> Outcome`: the scene run over levels of
  its keys (the robustness scorecard, or grids of any scene key), scored, with runs.csv,
  scores.json, scores.md and PNGs written into `out` (`ipgen sweep`, docs/sweep.md).

The model (coordinates, bodies, energies, damping) is specified in docs/model.md of the repository.
Importing ipgen is cheap: the modules behind these functions are imported on first use.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any, overload

from ipgen.common.locations import cmake_dir
from ipgen.common.version import __version__
from ipgen.errors import Error

if TYPE_CHECKING:  # the lazy names (module __getattr__ below), as type checkers see them
    from ipgen.control.api import linearize, lqr
    from ipgen.model.actuator import Actuator
    from ipgen.model.derivation import Equations
    from ipgen.model.fixed import FixedPendulum
    from ipgen.model.fixed_equations import FixedEquations
    from ipgen.model.pendulum import Pendulum
    from ipgen.sweeps.runner import Outcome


__all__ = [
    "Actuator",
    "Equations",
    "Error",
    "FixedPendulum",
    "Pendulum",
    "__version__",
    "cmake_dir",
    "derive",
    "excitation",
    "identify",
    "kalman",
    "linearize",
    "lqr",
    "mpc",
    "sweep",
    "write_header",
]


@overload
def derive(
    type: FixedPendulum,
    links: None = None,
    inertia: None = None,
    *,
    general: bool = False,
    actuator: None = None,
    force: bool = False,
) -> FixedEquations: ...


@overload
def derive(
    type: str | Pendulum,
    links: int | None = None,
    inertia: str | None = None,
    *,
    general: bool = False,
    actuator: Actuator | Mapping[str, object] | None = None,
    force: bool = False,
) -> Equations: ...


def derive(
    type: str | Pendulum | FixedPendulum,
    links: int | None = None,
    inertia: str | None = None,
    *,
    general: bool = False,
    actuator: Actuator | Mapping[str, object] | None = None,
    force: bool = False,
) -> Equations | FixedEquations:
    """The equations of motion M(θ) θ̈ + N(θ, θ̇) θ̇ + P(θ) = (u, 0, …, 0)ᵀ, as sympy views.

    Called as ``derive(p)`` with a `Pendulum` (its type, links, inertia and actuator, and its
    links as built: `general` is implied when it sets com, J, J_axial or tip; its numbers are not
    substituted: the views are symbolic), or as ``derive(type, links, inertia="pivot", *,
    general=False, actuator=None)``. The views are in ipgen's coordinates (absolute angles from
    upright, clockwise) whatever a Pendulum's own are (`p.coordinates` maps them; docs/model.md).

    Parameters
    ----------
    type : str, Pendulum or FixedPendulum
        "classical" (a cart) or "rotary" (a Furuta arm), or a Pendulum; a FixedPendulum gives
        its `FixedEquations` (M q̈ + bias + friction = B u in its coordinates, B n × m).
    links : int
        Number of links >= 1 (not with a Pendulum).
    inertia : str, default "pivot"
        Rotary only: "pivot" (the published model: a link's spin about its pivot axis only) or
        "full" (the complete thin-rod inertia); not with a Pendulum (which has its own).
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
    force : bool, default False
        More than 30 links (`limits.LINKS_WITHOUT_FORCE`) take minutes and gigabytes: refused
        without it, as the command refuses them without --force.

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
    from ipgen.common.limits import LINKS_WITHOUT_FORCE
    from ipgen.model.fixed import FixedPendulum
    from ipgen.model.pendulum import Pendulum

    count = type.links if isinstance(type, Pendulum | FixedPendulum) else links
    if isinstance(count, int) and not isinstance(count, bool) and count > LINKS_WITHOUT_FORCE and not force:
        from ipgen.pipeline.job import cost_estimate

        shown = "p" if isinstance(type, Pendulum | FixedPendulum) else f"{type!r}, {count}"
        raise Error(
            f"derive({shown}) of {count} links is large: {cost_estimate(count)}; pass force=True to go "
            f"ahead (up to {LINKS_WITHOUT_FORCE} links need none)"
        )
    if isinstance(type, FixedPendulum):
        if links is not None or actuator is not None or inertia is not None:
            raise Error(
                "derive(p) takes the links and the joints from the FixedPendulum: pass no links, inertia "
                "or actuator"
            )
        from ipgen.model.fixed_equations import equations_of

        return equations_of(type)
    from ipgen.model.actuator import as_actuator
    from ipgen.model.derivation import derive as derive_system
    from ipgen.model.system import check_system

    if isinstance(type, Pendulum):
        if links is not None or actuator is not None or inertia is not None:
            raise Error(
                "derive(p) takes the links, the inertia and the actuator from the Pendulum: pass none of them"
            )
        system, drive = type.system, type.actuator
        actuator = None if drive.kind == "direct" else drive
        # a Pendulum with links as built: rod equations (general=False) would not describe it
        general = general or any(group is not None for group in (type.com, type.J, type.J_axial, type.tip))
    else:
        inertia = "pivot" if inertia is None else inertia
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
    """Write the files of `ipgen --type TYPE --links N -o OUTPUT [...]` (or `--scene SCENE`).

    The keyword arguments are the command's options. All files are written or none.

    Parameters
    ----------
    output : str or Path
        The folder to write into (created if missing).
    type : {"classical", "rotary"}, optional
        A cart (classical) or a Furuta arm (rotary); with `links`, unless `scene` names the system.
    links : int, optional
        The number of pendulum links, >= 1.
    name : str, optional
        The model's name: namespace ``ipgen::NAME`` and file ``NAME.hpp`` (default
        ``<type><links>``).
    inertia : {"pivot", "full"}, optional
        Rotary only: the published model (pivot, default) or the complete thin-rod inertia.
    scene : str or Path, optional
        A scene file (TOML): its [system] names the model, its [parameters] can be folded in, and
        its resolved ``<stem>.cfg`` for the simulator is written last.
    fix : str or mapping, optional
        Parameters folded into the header as exact constants: text ("m0=0.3,delta2=0") or a
        mapping ({"m0": "0.3"}; a float is taken by its shortest repr).
    outputs : str or iterable of str, optional
        With `fix`: only these functions (text "mass_matrix,bias" or a list of names).
    emit : str or iterable of str, optional
        The targets: "cpp" (default), "c", "equations", "fmu" ... as text or a list of names.
    force : bool, optional
        Replace files ipgen did not write, and allow more than 30 links (a header of several MB).
    angles : {"absolute", "relative"}, optional
        The rig's link angles: each from the vertical, or link i from link i - 1.
    zero : {"upright", "hanging"}, optional
        Where a link angle is 0.
    positive : {"clockwise", "counterclockwise"}, optional
        The link angles' positive sense. With `angles` and `zero`, every function of the headers
        takes and returns the rig's coordinates (the canonical ones stay: namespace
        ``canonical`` in C++, the ``_canonical`` suffix in C; docs/model.md); a scene says them
        in its [system].

    Returns
    -------
    list of Path
        The files written: ``OUTPUT/<name>.hpp`` by default, every file of `emit`, and
        ``<stem>.cfg`` last for a scene.

    Raises
    ------
    Error
        Bad input, with the one-line message the command prints; nothing is written then.

    Examples
    --------
    >>> import tempfile, ipgen
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     print([path.name for path in ipgen.write_header(folder, "rotary", 1)])
    ['rotary1.hpp']
    >>> try:
    ...     ipgen.write_header("out", "rotory", 1)
    ... except ipgen.Error as error:
    ...     print(error)
    --type must be one of classical, rotary (got 'rotory')
    """
    from ipgen.pipeline.job import named_by_scene, plan, run

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
    return [written.path for written in run(named_by_scene(job))]


def identify(
    scene: str | Path | Pendulum | FixedPendulum,
    data: str | Path | Iterable[str | Path],
    free: str | Iterable[str] | None = None,
    output: str | Path | None = None,
    *,
    force: bool = False,
    output_error: bool = True,
    progress: Callable[[str], None] | None = None,
    validate: Iterable[str | Path] = (),
    fit: str | None = None,
    offset: bool = True,
) -> Any:
    """Fit the `free` parameters of a rig to measurements (docs/identify.md; needs CasADi).

    A fixed-pivot chain (a `FixedPendulum` or a scene with `[system] type = "fixed"`) is fitted
    to measured joint torques instead (docs/identify.md, "Fixed-pivot rigs: joint torques"):
    `data` one or several recordings, `validate` held-out ones, no `free`; the result is a
    `TorqueIdentified` (`.fit`, `.scores`, `.report`, `.files`; no CasADi needed).

    Parameters
    ----------
    scene : str, Path, Pendulum or FixedPendulum
        A scene file (the prior, the drive, the input, the coordinates), or a `Pendulum` (the
        data must then have a u column), or a fixed-pivot chain's scene file or `FixedPendulum`.
    data : str, Path or iterable of str or Path
        The measurements: a CSV in the simulator's format, in the rig's coordinates (a
        fixed-pivot chain: one recording or several).
    free : str or iterable of str, optional
        The parameters to fit, "m1,delta0" or ["m1", "delta0"] (required but for a fixed-pivot
        chain, which takes none).
    output : str or Path, optional
        Scene files only: the folder to write the updated scene, the report and a PNG into.
    force : bool, default False
        Replace files of an earlier run in `output`.
    output_error : bool, default True
        Refine the equation-error estimate by simulation.
    progress : callable, optional
        Called with a short message at each stage.
    validate : iterable of str or Path, default ()
        Fixed-pivot chains only: held-out recordings, scored but not fitted.
    fit : {"sequential", "joint"}, optional
        Fixed-pivot chains only (`ipgen identify --fit`): tip first, one joint's equation at a
        time (the default), or all equations together, weighted.
    offset : bool, default True
        Fixed-pivot chains only (`--no-offset` for False): fit a constant offset of each measured
        torque.

    Returns
    -------
    Identified, Fit or TorqueIdentified
        For a scene file an `Identified` (`.fit`, `.report`, `.files`, `.scene`); for a
        Pendulum its `Fit` (`.table()`, `.estimate`, `.stderr`, `.statements`); for a
        fixed-pivot chain a `TorqueIdentified`.

    Raises
    ------
    Error
        One line: a bad scene or data file, a free name the model has not, data that cannot
        identify the free parameters, an output that would overwrite without `force`.

    Examples
    --------
    >>> import ipgen  # doctest: +SKIP
    >>> from ipgen.common.presets import preset_path  # doctest: +SKIP
    >>> ipgen.identify(preset_path("qube_servo2"), "rig.csv", "J1,delta0", "out").report  # doctest: +SKIP
    """
    from ipgen.model.pendulum import Pendulum

    fixed = _fixed_identification(scene, data, free, output, force, validate, fit, offset)
    if fixed is not None:
        return fixed
    if fit is not None or not offset:
        raise Error("identify: fit and offset are for fixed-pivot chains (joint torques); leave them out")
    if free is None:
        raise Error("identify: name the parameters to fit (free), e.g. 'J1,delta0'")
    if not isinstance(data, str | Path):
        raise Error("identify: one data file for this system (several are for fixed-pivot chains)")
    if isinstance(scene, Pendulum):
        if output is not None:
            raise Error("identify(p, ...) writes no files: pass a scene file to write the updated scene")
        from ipgen.identification.fit import identify_pendulum

        return identify_pendulum(
            scene,
            data,
            free if isinstance(free, str) else list(free),
            output_error=output_error,
            progress=progress,
        )
    from ipgen.pipeline.identify import identify as identify_scene

    return identify_scene(
        scene, data, free if isinstance(free, str) else list(free), output,
        force=force, output_error=output_error, progress=progress,
    )  # fmt: skip


def _fixed_identification(
    scene: object,
    data: object,
    free: object,
    output: str | Path | None,
    force: bool,
    validate: Iterable,
    fit: str | None,
    offset: bool,
) -> Any:
    """`identify` of a fixed-pivot chain (a FixedPendulum or a fixed scene file), or None."""
    from ipgen.model.fixed import FixedPendulum

    if isinstance(scene, FixedPendulum):
        chain, stem, keep = scene, "fixed", []
    elif isinstance(scene, str | Path):
        from ipgen.scene.fixed import is_fixed_document, load_fixed_scene
        from ipgen.scene.load import parse_document

        if not is_fixed_document(parse_document(Path(scene))[1]):
            return None
        chain, stem, keep = load_fixed_scene(scene), Path(scene).stem, [Path(scene)]
    else:
        return None
    if free is not None:
        raise Error("identify: a fixed-pivot chain fits every base parameter the data identify: no free")
    from ipgen.identification.torque import DEFAULT_METHOD
    from ipgen.pipeline.identify_torques import identify_torques

    recordings = [data] if isinstance(data, str | Path) else list(data)  # type: ignore[call-overload]
    method = DEFAULT_METHOD if fit is None else fit
    return identify_torques(
        chain, stem, recordings, list(validate), output, method=method, offset=offset, force=force, keep=keep
    )


def sweep(
    scene: str | Path,
    out: str | Path,
    *,
    scorecard: bool | Iterable[str] = False,
    vary: Iterable[str] = (),
    levels: Mapping[str, str] | None = None,
    repeat: int | None = None,
    seed: int = 0,
    angle_tolerance: float = 0.35,
    rate_tolerance: float = 1.0,
    hold: float = 1.0,
    base_tolerance: float | None = None,
    travel: float | None = None,
    dask: str | None = None,
    jobs: int | None = None,
    force: bool = False,
    cache_dir: str | Path | None = None,
    plots: bool = True,
    converge: float = 0.25,
    random: int = 0,
    spread: float = 0.2,
) -> Outcome:
    """Run `scene` over levels of its keys and score its controller, as `ipgen sweep` does.

    Each run is the scene with some keys overridden in memory: the plant changes, the controller
    stays the one designed on the nominal scene (a [controller]/[swingup] key designs it anew).
    docs/sweep.md is the guide.

    Parameters
    ----------
    scene : str or Path
        The scene file (TOML) with a [controller] or a [swingup]; a fixed-pivot chain's too
        (`[system] type = "fixed"`: its model criteria and keys, docs/sweep.md).
    out : str or Path
        The folder for runs.csv, scores.json, scores.md and the PNGs; its runs.csv, if there, is
        resumed.
    scorecard : bool or iterable of str, optional
        True: the robustness scorecard's criteria; or some of their names (mass, com, inertia,
        damping, coulomb, period, resolution, sensor_noise, delay, drive_noise, lag, pulses).
    vary : iterable of str, optional
        "KEY=LO:HI:N" or "KEY=v1,v2,..." (e.g. "initial.theta[1]=-1:1:21"); several make the grid
        of all their combinations.
    levels : mapping of str to str, optional
        A scorecard criterion's levels in the same notation, e.g. {"mass": "0.5:1.5:11"}.
    repeat : int, optional
        Runs per level (the seeded criteria; `vary`: default 1).
    seed : int, optional
        The base of every run's seed (each run's seed is written in runs.csv).
    angle_tolerance, rate_tolerance, hold : float, optional
        The success test: every link within `angle_tolerance` rad of the goal and `rate_tolerance`
        rad/s over the last `hold` s (defaults 0.35, 1, 1).
    base_tolerance : float, optional
        The base's tolerance about the goal [m or rad] (default: not checked).
    travel : float, optional
        The base's travel limit |θ0| (default: the scene's limits.travel).
    dask : str, optional
        A Dask scheduler's address: run there (needs ``pip install 'dask[distributed]'``).
    jobs : int, optional
        Local worker processes (default: all cores).
    force : bool, optional
        Start over (ignore an earlier runs.csv), write into a folder holding other files.
    cache_dir : str or Path, optional
        The compiled simulators' cache (default: ipgen's).
    plots : bool, optional
        Write the PNGs (default True).
    converge : float, optional
        A balance run (no [swingup]) must also converge: every link within `converge` times its
        largest initial angle error over the last `hold` s (default 0.25), so that a controller
        that does nothing cannot pass from a start inside the tolerance.
    random : int, optional
        That many random starts (criterion "random"; default none): with a [swingup] even ones
        hanging (links at π ± 0.1 rad) and odd ones near upright (±0.2 rad, rates ±0.5 rad/s), a
        balance scene near upright only; the base within ±0.1, every entry of m and delta and a
        dc_motor's Rm times U(1 − spread, 1 + spread); each drawn from its run's seed. Its score
        is the fraction of runs that pass.
    spread : float, optional
        The parameters' relative spread of `random` (default 0.2: ±20 %).

    Returns
    -------
    Outcome
        `.score` (the mean of the criteria's scores), `.scores` (per criterion), `.rows` (the
        table), `.files`, `.runs`, `.ran` (run now), `.workers`, `.seconds`.

    Raises
    ------
    Error
        A one-line message for a bad specification (unknown key, empty range, ...), a scene ipgen
        refuses, an unreachable scheduler; nothing is written then.

    Examples
    --------
    The mass criterion of the scorecard on a preset (compiles the simulator once, then runs):

    >>> import ipgen
    >>> from ipgen.common.presets import preset_path
    >>> outcome = ipgen.sweep(preset_path("qube_servo2"), "qube_sweep", scorecard=["mass"])  # doctest: +SKIP
    >>> 0 <= outcome.score <= 1  # doctest: +SKIP
    True
    """
    from ipgen.sweeps.runner import sweep as run_sweep
    from ipgen.sweeps.success import Success

    chosen = scorecard if isinstance(scorecard, bool) else tuple(scorecard)
    return run_sweep(
        scene,
        out,
        scorecard_criteria=chosen,
        vary=(vary,) if isinstance(vary, str) else tuple(vary),
        levels=dict(levels or {}),
        repeat=repeat,
        seed=seed,
        success=Success(angle_tolerance, rate_tolerance, hold, base_tolerance, travel, converge),
        dask=dask,
        jobs=jobs,
        force=force,
        cache=cache_dir,
        plot=plots,
        random=random,
        spread=spread,
    )


def __getattr__(attribute: str) -> object:
    """The lazy part of the API, imported on first use so that `import ipgen` and the ipgen command
    start fast: `Equations`, `Pendulum`, `FixedPendulum` and `Actuator` (the model), `linearize`,
    `lqr` and `mpc` (control/: numpy, scipy, the compiled MPC), `kalman` (estimation/) and
    `excitation` (pipeline/excite.py)."""
    if attribute == "Equations":
        from ipgen.model.derivation import Equations

        return Equations
    if attribute == "Pendulum":
        from ipgen.model.pendulum import Pendulum

        return Pendulum
    if attribute == "FixedPendulum":
        from ipgen.model.fixed import FixedPendulum

        return FixedPendulum
    if attribute == "Actuator":
        from ipgen.model.actuator import Actuator

        return Actuator
    if attribute == "excitation":
        from ipgen.pipeline.excite import excitation

        return excitation
    if attribute == "kalman":
        from ipgen.estimation.kalman import kalman

        return kalman
    if attribute in ("linearize", "lqr"):
        from ipgen.control import api

        return getattr(api, attribute)
    if attribute == "mpc":
        from ipgen.control.mpc import mpc

        return mpc
    raise AttributeError(f"module 'ipgen' has no attribute {attribute!r}")


def __dir__() -> list[str]:
    """The module's names including the lazy ones, so that `help(ipgen)` and `dir(ipgen)` list
    every public function (`help` then imports control/linear.py)."""
    return sorted(set(globals()) | set(__all__))
