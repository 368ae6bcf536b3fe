"""A scene file resolved for use: `load_scene(path)` reads and validates it (`scene.load`) and
returns the `Scene` (every default filled in, numbers as floats with their decimal text kept for
exact folding) with its input (`InputSpec`) and what is designed from it: the [controller]'s gain
(`feedback`), the [swingup]'s plan (`swingup`) and the measured loop (`loop`). Rules between
tables that need them (a dc_motor with an FMU, the start within the travel) are checked here.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from decimal import Decimal
from fractions import Fraction
from pathlib import Path
from typing import Any

from ipgen.codegen.emit import DEFAULT_EMIT, unsupported
from ipgen.common.limits import exact_problem
from ipgen.common.safetext import abbreviate, shown_path
from ipgen.control import signals
from ipgen.control.controller import Controller
from ipgen.control.swingup import SwingUpLaw
from ipgen.errors import SceneError
from ipgen.experiment import feedback
from ipgen.experiment import loop as measuring
from ipgen.experiment import swingup as swing
from ipgen.experiment.plausibility import unit_slips
from ipgen.model.actuator import DIRECT, Actuator
from ipgen.model.coordinates import Coordinates
from ipgen.model.pendulum import Pendulum, from_scene_object
from ipgen.model.system import System, parameter_names, split_parameter
from ipgen.scene import checks, schema
from ipgen.scene.fields import Reader, format_number
from ipgen.scene.load import load_document, parse_document, validate_document
from ipgen.scene.schema import SceneDocument


@dataclass(frozen=True)
class InputSpec:
    """The input on the base (force on the cart [N] or torque on the arm [N m]) over time."""

    kind: str = "zero"
    amplitude: float = 0.0
    start: float = 0.0  # pulse, chirp
    duration: float = 0.0  # pulse, chirp
    time: float = 0.0  # step
    frequency: float = 0.0  # sine, Hz
    phase: float = 0.0  # sine, rad
    f0: float = 0.0  # chirp, Hz
    f1: float = 0.0  # chirp, Hz
    sweep: str = "linear"  # chirp: linear | logarithmic
    f_min: float = 0.0  # multisine, Hz
    f_max: float = 0.0  # multisine, Hz
    period: float = 0.0  # multisine, s

    def fields(self) -> tuple[tuple[str, float | str], ...]:
        """The (key, value) pairs this kind uses, in resolved-config order."""
        return tuple((key, getattr(self, key)) for key in schema.INPUT_KEYS[self.kind])

    @functools.cached_property
    def lines(self) -> signals.Multisine:
        """A multisine's lines: frequencies, Schroeder phases and the scale (`control.signals`)."""
        if self.kind != "multisine":
            raise ValueError(f"a {self.kind!r} input has no multisine lines")
        return signals.multisine(self.f_min, self.f_max, self.period)

    def value(self, t: float) -> float:
        """The input at time t (pulses are on for start <= t < start + duration)."""
        if self.kind == "constant":
            return self.amplitude
        if self.kind == "pulse":
            on = self.start <= t < self.start + self.duration
            return self.amplitude if on else 0.0
        if self.kind == "step":
            return self.amplitude if t >= self.time else 0.0
        if self.kind == "sine":
            return self.amplitude * math.sin(2.0 * math.pi * self.frequency * t + self.phase)
        if self.kind == "chirp":
            return signals.chirp_value(
                t, self.amplitude, self.f0, self.f1, self.duration, self.start, self.sweep
            )
        if self.kind == "multisine":
            return signals.multisine_value(t, self.amplitude, self.lines)
        return 0.0

    def breakpoints(self) -> tuple[float, ...]:
        """Times where the input jumps (or its slope does): an integrator must stop and restart there."""
        if self.kind in ("pulse", "chirp"):
            return (self.start, self.start + self.duration)
        if self.kind == "step":
            return (self.time,)
        return ()


@dataclass(frozen=True)
class Scene:
    """A validated scene with every default filled in."""

    path: Path
    stem: str
    type: str
    links: int
    inertia: str
    name: str
    m: tuple[float, ...]
    l: tuple[float, ...]  # noqa: E741 (the paper's name for the lengths)
    delta: tuple[float, ...]
    g: float
    theta: tuple[float, ...]
    dtheta: tuple[float, ...]
    input: InputSpec
    t_end: float
    sample: float
    method: str
    rtol: float
    atol: float
    max_steps: int
    jacobian: str | None = None  # bdf and adams: "exact" or "dq"; None for the other methods
    step: float | None = None  # rk4: the fixed step [s]; None for the other methods
    free: tuple[str, ...] = ()
    energy: bool = False
    specialise: bool = False  # generate a header specialised to this scene (see specialise.py)
    emit: tuple[str, ...] = DEFAULT_EMIT  # what ipgen writes for the model (emit.py)
    # Each physical parameter's decimal text as written in the file ("m0" -> "0.3", "g" ->
    # "9.81"), so that it can be used as an exact rational; see `exact`.
    decimals: tuple[tuple[str, str], ...] = ()
    # The links as built the scene gives: (group, values) for com, J, J_axial, tip (absent: rods)
    links_as_built: tuple[tuple[str, tuple[float, ...]], ...] = ()
    # Non-fatal advice (e.g. a very tight rtol); one line each, prefixed with the file.
    warnings: tuple[str, ...] = ()
    controller: Controller | None = None  # [controller]: feedback u = −K (x − x_eq), gain computed
    actuator: Actuator = (
        DIRECT  # [actuator]: what u is (direct: N, N m; dc_motor: V; acceleration: m/s², rad/s²)
    )
    coulomb: tuple[float, ...] | None = None  # Coulomb friction per coordinate (simulator only)
    coulomb_speed: float = schema.DEFAULT_COULOMB_SPEED  # the tanh law's rate
    swingup: SwingUpLaw | None = None  # [swingup]: the planned swing-up and its gains
    # [system] angles, zero, positive: the rig's convention, in which `theta`, `dtheta`, the
    # controller's gain and equilibrium, the CSV and the plots are (default: ipgen's own).
    coordinates: Coordinates = field(default_factory=Coordinates)
    travel: float | None = None  # [limits] travel: |θ0| limit [m or rad]; the simulator stops beyond it
    loop: measuring.Loop | None = None  # [sensors], [estimator], drive keys: the measured loop (None: exact)

    @property
    def system(self) -> System:
        """The system the scene simulates."""
        return System(self.type, self.links, self.inertia)  # type: ignore[arg-type]

    @functools.cached_property
    def pendulum(self) -> Pendulum:
        """The scene's system, parameters, drive and coordinates as one `ipgen.Pendulum`: built
        and validated once per scene (immutable, so every use shares it)."""
        return from_scene_object(self)

    def parameter_names(self) -> tuple[str, ...]:
        """m0..mn, l0..ln, delta0..deltan, g: the names `free`, `value` and `exact` use."""
        return parameter_names(self.links)

    def value(self, name: str) -> float:
        """A parameter by name, e.g. "m1", "delta0", "g", as a float; KeyError if unknown."""
        if name not in self.parameter_names():
            raise KeyError(f"unknown parameter {name!r}")
        group, index = split_parameter(name)
        return self.g if index is None else getattr(self, group)[index]

    def exact(self, name: str) -> Fraction:
        """A parameter by name as an exact rational of its decimal text (0.1 -> 1/10)."""
        text = dict(self.decimals).get(name)
        too_large = exact_problem(text) if text is not None else None
        if too_large:  # before the Fraction, which would take minutes
            raise SceneError(f"{shown_path(self.path)}: parameter {name} = {abbreviate(text)}: {too_large}")
        return Fraction(text) if text is not None else Fraction(repr(self.value(name)))

    def link_values(self) -> dict[str, tuple[float, ...]]:
        """{group: values} of the links as built the scene gives (com, J, J_axial, tip)."""
        return dict(self.links_as_built)

    def motor_folded(self) -> dict[str, Fraction]:
        """A dc_motor folded exactly ({} without one): delta0 + c, and m0 (cart) or J0 (arm)
        + the rotor's reflected inertia, as rationals of the decimals written (the motor
        constants by their shortest repr), so that the resolved config and a specialised
        header agree to the last bit (`Pendulum.folded` of the exact pendulum)."""
        if not self.actuator.is_motor:
            return {}
        folded = from_scene_object(self, exact=True).folded()
        if self.type == "classical":
            return {"delta0": Fraction(folded.delta[0]), "m0": Fraction(folded.m[0])}
        assert folded.J is not None  # an arm's folded J has every entry
        return {"delta0": Fraction(folded.delta[0]), "J0": Fraction(folded.J[0])}


def build_scene(reader: Reader, document: SceneDocument, designed: Scene | None = None) -> Scene:
    """The `Scene` of a validated document: defaults filled in, the controller's gain and the
    swing-up's plan computed; what no table can say alone refused in one line. With `designed`,
    the controller and swing-up law are that scene's (designed on its model) instead of designed
    anew on this document's parameters: the plant changes, the controller does not (`ipgen sweep`)."""
    tables = dict(document)
    system, parameters = tables["system"], tables["parameters"]
    kind, links = system.type, system.links
    name = system.name or System(kind, links, system.inertia).default_name
    for key, text in parameters.decimals(kind):  # each may be made exact (a motor's fold, specialise)
        if problem := exact_problem(text):
            reader.fail(f"parameter {key} = {abbreviate(text)}: {problem}")
    masses, damping = _floats(parameters.m), _floats(parameters.delta)
    lengths = _floats(parameters.lengths(kind))
    initial = tables["initial"]
    zeros = (0.0,) * (links + 1)
    spec = tables["input"]
    simulation = tables["simulation"].settings()
    links_as_built = tuple((group, _floats(values)) for group, values in parameters.links_as_built())
    controller = None
    actuator = tables["actuator"].actuator()
    coordinates = system.coordinates()
    problem = unsupported(system.emit, actuator, coordinates, system.specialise)
    if problem is not None:
        reader.fail(problem)

    @functools.cache
    def pendulum() -> Pendulum:
        """What the controller, the swing-up and the estimator are designed on (the scene's floats)."""
        return Pendulum(
            kind, links, masses, lengths, damping, float(parameters.g),
            system.inertia, actuator=actuator, angles=coordinates.angles, zero=coordinates.zero,
            positive=coordinates.positive, **dict(links_as_built),
        )  # fmt: skip

    if tables["controller"] is not None and designed is not None:
        controller = designed.controller
    elif tables["controller"] is not None:
        try:
            controller = feedback.controller(tables["controller"], pendulum())
        except feedback.GainError as error:
            reader.fail(str(error))
    upright = coordinates.user_state((0.0,) * 2 * (links + 1), links)[: links + 1]  # 0 unless from hanging
    theta = upright if initial.theta is None else _floats(initial.theta)
    dtheta = zeros if initial.dtheta is None else _floats(initial.dtheta)
    law = None
    if tables["swingup"] is not None:
        import numpy as np

        # theta, dtheta are in the rig's coordinates (as the .cfg and CSV); the law is ipgen's
        hanging = (0.0,) + (math.pi,) * links
        if initial.theta is None:  # a swing-up starts hanging unless the scene says otherwise
            theta = hanging
            if not coordinates.is_canonical:
                user = coordinates.to_user(np.array(hanging + (0.0,) * (links + 1)), links)
                theta = tuple(float(v) for v in user[: links + 1])
        start = tuple(float(v) for v in coordinates.to_canonical(np.array(theta + dtheta), links))
    if tables["swingup"] is not None and designed is not None:
        law = designed.swingup
    elif tables["swingup"] is not None:
        try:
            law = swing.law(tables["swingup"], pendulum(), start)
        except swing.SwingUpError as error:
            reader.fail(str(error))
    loop = _loop(reader, tables, controller, law, pendulum)
    travel = None if tables["limits"].travel is None else float(tables["limits"].travel)
    if travel is not None and abs(theta[0]) > travel:
        reader.fail(
            f"initial.theta[0] = {format_number(theta[0])} is beyond limits.travel = {format_number(travel)} "
            "(the base starts outside its travel): move it inside or widen the limit"
        )
    return Scene(
        path=reader.path,
        stem=reader.path.stem,
        type=kind,
        links=links,
        inertia=system.inertia,
        name=name,
        m=masses,
        l=lengths,
        delta=damping,
        g=float(parameters.g),
        theta=theta,
        dtheta=dtheta,
        input=InputSpec(
            kind=spec.kind,
            **{
                key: value if isinstance(value := getattr(spec, key), str) else float(value)
                for key in schema.INPUT_KEYS[spec.kind]
            },
        ),
        **simulation,
        free=parameters.free,
        energy=tables["outputs"].energy,
        specialise=system.specialise,
        emit=system.emit,
        decimals=parameters.decimals(kind),
        links_as_built=links_as_built,
        warnings=_warnings(reader, simulation["rtol"])
        + tuple(map(reader.warning, checks.csv_size(simulation["t_end"], simulation["sample"], links + 1)))
        + tuple(map(reader.warning, unit_slips(kind, masses, lengths, theta))),
        controller=controller,
        actuator=actuator,
        coulomb=None if parameters.coulomb is None else _floats(parameters.coulomb),
        coulomb_speed=float(parameters.coulomb_speed),
        swingup=law,
        coordinates=coordinates,
        travel=travel,
        loop=loop,
    )


def _floats(numbers: tuple[Decimal, ...]) -> tuple[float, ...]:
    return tuple(float(number) for number in numbers)


def _loop(
    reader: Reader,
    tables: dict[str, Any],
    controller: Controller | None,
    law: SwingUpLaw | None,
    pendulum: Callable[[], Pendulum],
) -> measuring.Loop | None:
    """The scene's measured loop (`loop.loop`), its kalman or ekf numbers from the exact
    linearisation of `pendulum()` at the controller's (or the swing-up's hold) equilibrium. With
    a swing-up the loop runs at its period (an MPC catching it steps every few of them)."""
    period = law.period if law is not None else (controller.period if controller is not None else None)
    if controller is not None:
        equilibrium, scale = controller.equilibrium, controller.saturation
    elif law is not None:  # the hold's target is in ipgen's coordinates, the loop in the scene's
        system = tables["system"]
        equilibrium, scale = system.coordinates().user_state(law.target, system.links), law.u_max
    else:
        equilibrium, scale = (), None

    def design(loop: measuring.Loop, table: Any) -> measuring.Loop:
        return measuring.design(
            loop, table, pendulum=pendulum(), equilibrium=tuple(equilibrium), period=float(period or 0.0),
            input_scale=1.0 if scale is None else float(scale),
        )  # fmt: skip

    try:
        return measuring.loop(
            tables["sensors"], tables["estimator"], tables["actuator"], links=tables["system"].links,
            period=period, acceleration=tables["actuator"].kind == "acceleration", design=design,
            coordinates=tables["system"].coordinates(), cart=tables["system"].type == "classical",
        )  # fmt: skip
    except measuring.SensorsError as error:
        reader.fail(str(error))


def _warnings(reader: Reader, rtol: float) -> tuple[str, ...]:
    if rtol < schema.RTOL_ADVISED:
        return (
            reader.warning(
                f"simulation.rtol = {format_number(rtol)} is below 1e-14 and "
                "may not be met in double precision"
            ),
        )
    return ()


def load_scene(path: str | Path) -> Scene:
    """Read, validate and complete a scene file; raises `SceneError` on any problem."""
    reader, document = load_document(Path(path))
    return build_scene(reader, document)


def read_document(path: str | Path) -> dict[str, Any]:
    """The scene file's TOML document (numbers as exact `Decimal`s), not yet validated: what
    `scene_from_document` reads after a sweep changed some values."""
    return parse_document(Path(path))[1]


def scene_from_document(
    path: str | Path, document: dict[str, Any], *, designed: Scene | None = None
) -> Scene:
    """The scene of a TOML `document` (as `read_document` gives it, possibly changed), its
    messages naming `path`. With `designed`, the controller and swing-up law are that scene's
    instead of designed anew on this document's parameters (`ipgen sweep`)."""
    reader = Reader(Path(path))
    return build_scene(reader, validate_document(reader, document), designed)
