"""The scene format, declared once: every table, key, type, bound, default and description.

From this one declaration come both the validation (`load.py` validates the whole document in
one pydantic call and turns the first problem into one line) and the JSON Schema
(`pipeline.scene_schema`, printed by `ipgen --scene-schema`, shipped as docs/scene.schema.json).

A table is a pydantic model (`Table`, `extra="forbid"`); a key is a field annotated with
pydantic's own types and constraints (`Literal`, `Field(strict=True, ge=1)`) or the two of
`values` (`Real(gt=0, says=...)`, `PerLink(...)`), plus a `Field(description=...)`. Rules
between keys of a table are its `model_validator`; rules between tables read the validation
context, which each table extends with `context()` as it is validated, in the order of
`SceneDocument` (e.g. [system] gives `links`, `count` = links + 1 and `type` to the tables after).

Extending (docs/scenes.md, "Extending the format"): a new optional per-link array is one line
in its table, e.g. in `ParametersTable`

    com: Annotated[PerLink(Real(ge=0, says="must be >= 0 m")) | None,
                   Field(description="centre of mass of each link from its pivot [m]")] = None

and a new table is a `Table` subclass with its keys plus one field in `SceneDocument`.
"""

from __future__ import annotations

import math
import re
from decimal import Decimal
from typing import Annotated, Any, Literal, get_args

from pydantic import (
    AfterValidator,
    BaseModel,
    BeforeValidator,
    ConfigDict,
    Field,
    PlainValidator,
    PrivateAttr,
    ValidationInfo,
    model_validator,
)

from ipgen.codegen.emit import DEFAULT_EMIT, TARGETS
from ipgen.common import limits
from ipgen.control import signals
from ipgen.model import coordinates as frame
from ipgen.model import system as model
from ipgen.scene import checks
from ipgen.scene import controller as control
from ipgen.scene import sensors as measuring
from ipgen.scene import swingup as swing
from ipgen.scene.fields import format_number, one_of
from ipgen.scene.values import PerLink, Real, Says, context_of, keyed, refuse, refuse_line

SYSTEM_TYPES = model.SYSTEM_TYPES
ACTUATOR_KINDS: tuple[str, ...] = ("direct", "dc_motor", "acceleration")  # = model.actuator.ACTUATOR_KINDS
MOTOR_KEYS: tuple[str, ...] = ("Rm", "kt", "km", "Kg", "eta_g", "eta_m", "Jm", "r")
INERTIAS = model.INERTIA_VARIANTS
# Integration methods (the C++ simulator's names): CVODE's, ARKODE's explicit Runge-Kutta and a
# fixed-step RK4. Which settings each one uses:
METHODS: tuple[str, ...] = (
    "bdf",
    "adams",
    "adams-fixed-point",
    "erk-dp5",
    "erk-fehlberg8",
    "rk4",
)
JACOBIAN_METHODS: tuple[str, ...] = ("bdf", "adams")  # Newton iteration: jacobian = exact | dq
FIXED_STEP_METHODS: tuple[str, ...] = ("rk4",)  # step required; rtol and atol do not apply
JACOBIANS: tuple[str, ...] = ("exact", "dq")
DEFAULT_JACOBIAN = "exact"

CONTROLLER_KINDS = control.CONTROLLER_KINDS
DEFAULT_EQUILIBRIUM = control.DEFAULT_EQUILIBRIUM
DEFAULT_R = control.DEFAULT_R

# Defaults of optional scalar keys.
DEFAULT_INERTIA = "pivot"
DEFAULT_G = 9.81  # its decimal text "9.81" is kept next to the float (repr)
DEFAULT_SAMPLE = 0.01
DEFAULT_METHOD = "bdf"
DEFAULT_COULOMB_SPEED = 0.01  # m/s or rad/s: the smooth Coulomb law's rate (docs/rigs.md)
DEFAULT_RTOL = 1e-10
DEFAULT_ATOL = 1e-12
DEFAULT_MAX_STEPS = 100_000

# rtol below RTOL_MIN cannot be met in double precision; below RTOL_ADVISED it is unlikely to be.
RTOL_MIN = limits.RTOL_MIN  # shared with the simulator (limits.py)
RTOL_ADVISED = 1e-14

# Scene file stems end up in output file names and in the resolved config. (A single class
# repeated, then the end: linear, and the stem is at most a file name long.)
STEM = re.compile(r"[A-Za-z0-9_][A-Za-z0-9_.+-]*+\Z")


class Table(BaseModel):
    """One table of a scene: unknown keys are refused, values validated once and frozen."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    def context(self) -> dict[str, Any]:
        """What the tables after this one may need to know of it (see the module docstring)."""
        return {}

    @model_validator(mode="after")
    def _tell(self, info: ValidationInfo) -> Table:
        if info.context is not None:
            info.context.update(self.context())
        return self


def _exact(value: float) -> Decimal:
    """A default as the number it stands for written in decimal (9.81 -> Decimal("9.81"))."""
    return Decimal(repr(value))


Flag = Annotated[bool, Field(strict=True)]


def _Count(most: int, what: str) -> Any:
    """An integer in 1 .. most."""
    return Annotated[
        int, Field(strict=True, ge=1, le=most), Says(f"expected an integer in 1 .. {most}", what)
    ]


# ---------------------------------------------------------------------------- [system]


_LINKS = "expected an integer >= 1 (the number of pendulum links)"


class SystemTable(Table):
    """[system]: which pendulum, and what ipgen writes for it."""

    type: Literal[SYSTEM_TYPES] = Field(
        description="classical: a cart on a rail; rotary: a Furuta arm turning about the vertical"
    )
    links: Annotated[int, Says(_LINKS, "an integer >= 1: the number of pendulum links")] = Field(
        strict=True, ge=1, description="the number of pendulum links (rods)"
    )
    inertia: Annotated[Literal[INERTIAS], BeforeValidator(checks.inertia)] = Field(
        DEFAULT_INERTIA,
        description="rotary only: pivot (the published model) or full (complete thin-rod inertia)",
    )
    name: Annotated[str | None, AfterValidator(checks.model_name)] = Field(
        None,
        strict=True,
        description="C++ model name: namespace ipgen::NAME, file NAME.hpp (default: <type><links>)",
        json_schema_extra={"pattern": r"^[A-Za-z][A-Za-z0-9_]*$", "maxLength": limits.MAX_NAME_LENGTH},
    )
    specialise: Flag = Field(
        False, description="fold this scene's parameters into the header as exact constants"
    )
    emit: Annotated[tuple[str, ...], PlainValidator(checks.emit_targets)] = Field(
        DEFAULT_EMIT,
        description="what ipgen writes for the model",
        json_schema_extra={"type": "array", "items": {"type": "string", "enum": list(TARGETS)}}
        | {"minItems": 1, "default": list(DEFAULT_EMIT)},
    )
    # The rig's own coordinates (docs/scenes.md, "The rig's coordinates"): how [initial],
    # [controller], the CSV, the plots and the scene's headers measure the link angles.
    angles: Literal[frame.ANGLES] = Field(
        frame.Coordinates.angles,
        description="link angles: absolute (each from the vertical) or relative (link i from link "
        "i - 1), in [initial], [controller], the CSV, the plots and the headers",
    )
    zero: Literal[frame.ZEROS] = Field(
        frame.Coordinates.zero,
        description="where a link angle is 0: upright or hanging (relative angles: link 1's; "
        "the others are 0 in line with the link below)",
    )
    positive: Literal[frame.POSITIVE] = Field(
        frame.Coordinates.positive,
        description="the link angles' positive sense: clockwise (ipgen's, docs/model.md) or counterclockwise",
    )

    def coordinates(self) -> frame.Coordinates:
        """The convention of the link angles this table declares."""
        return frame.Coordinates(self.angles, self.zero, self.positive)

    def context(self) -> dict[str, Any]:
        unit = "N" if self.type == "classical" else "N m"
        given = {
            "type": self.type,
            "links": self.links,
            "specialise": self.specialise,
            "inertia": self.inertia,
        }
        return given | {"coordinates": self.coordinates(), "count": self.links + 1, "u_unit": unit}


# ---------------------------------------------------------------------------- [parameters]


_PER_LINK = "links + 1 entries: index 0 the base (cart or arm), 1..n the links"
_INERTIA = Real(ge=0, says="an inertia cannot be negative")


class ParametersTable(Table):
    """[parameters]: masses, lengths, damping and gravity (SI units)."""

    m: PerLink(Real(gt=0, says="masses must be > 0 kg")) = Field(description=f"masses [kg], {_PER_LINK}")
    l: PerLink(Real()) = Field(  # noqa: E741 (the paper's name for the lengths)
        description=f"lengths [m], {_PER_LINK}; l[0] is the arm (rotary, > 0), a cart has none: 0"
    )
    delta: PerLink(Real(ge=0, says="damping must be >= 0")) = Field(
        description=f"viscous damping coefficients, {_PER_LINK}"
    )
    g: Real(ge=0, says="gravity must be >= 0 m/s^2 (0 switches it off)", what="gravity in m/s^2") = Field(
        _exact(DEFAULT_G), description="gravity [m/s^2] (0 switches it off)"
    )
    # The links as built (docs/model.md, "Links as built"); absent: the paper's rods.
    com: PerLink(Real()) | None = Field(
        None,
        description=f"pivot-to-CoG distance of each link [m] (any finite number), {_PER_LINK} (0 unused); "
        "default l/2",
    )
    J: PerLink(_INERTIA) | None = Field(
        None,
        description=f"inertia of each link about its CoG, across it [kg m^2], {_PER_LINK}; "
        "J[0]: the rotary arm's about the vertical; default m l^2/12 (J[0]: m0 l0^2/3)",
    )
    J_axial: PerLink(_INERTIA) | None = Field(
        None,
        description=f"inertia of each link about its own axis [kg m^2] (<= 2 J; rotary, inertia full), "
        f"{_PER_LINK}; default 0",
    )
    tip: PerLink(Real(ge=0, says="a mass cannot be negative")) | None = Field(
        None, description=f"point mass at the far end of each link [kg], {_PER_LINK} (0 unused); default 0"
    )
    coulomb: PerLink(Real(ge=0, says="friction must be >= 0")) | None = Field(
        None,
        description=f"Coulomb friction per coordinate [N or N m] (simulator only, not linearised), "
        f"{_PER_LINK}; default 0",
    )
    coulomb_speed: Real(gt=0, says="must be > 0 (m/s or rad/s)") = Field(
        _exact(DEFAULT_COULOMB_SPEED),
        description="the Coulomb law's smoothing rate v_s: f = c tanh(w / v_s) [m/s or rad/s]",
    )
    free: Annotated[tuple[str, ...], PlainValidator(checks.free_names)] = Field(
        (),
        description="with specialise = true: parameters kept symbolic (m0, l1, delta2, g, ...)",
        json_schema_extra={"type": "array", "items": {"type": "string"}, "default": []},
    )

    @model_validator(mode="after")
    def _relations(self, info: ValidationInfo) -> ParametersTable:
        context = context_of(info, "type", "specialise")
        if context is None:
            return self
        checks.lengths(self.l, context["type"])
        checks.links_as_built(self, context)
        if self.free and not context["specialise"]:
            expected = "applies to specialised code only: add specialise = true to [system]"
            refuse(expected, key="free", value=list(self.free))
        if context["specialise"]:
            checks.foldable(self.decimals(context["type"]), self.free, context["type"])
        return self

    def lengths(self, system_type: str) -> tuple[Decimal, ...]:
        """l, with a cart's (ignored) length written as 0."""
        return (Decimal(0), *self.l[1:]) if system_type == "classical" else self.l

    def decimals(self, system_type: str) -> tuple[tuple[str, str], ...]:
        """("m0", "0.3"), ..., ("g", "9.81"): each parameter's decimal text as written."""
        groups = (("m", self.m), ("l", self.lengths(system_type)), ("delta", self.delta))
        named = [(f"{base}{i}", str(x)) for base, values in groups for i, x in enumerate(values)]
        built = [
            (f"{group}{i}", str(x)) for group, values in self.links_as_built() for i, x in enumerate(values)
        ]
        return (*named, ("g", str(self.g)), *built)

    def links_as_built(self) -> tuple[tuple[str, tuple[Decimal, ...]], ...]:
        """(group, values) of the link arrays the scene gives (com, J, J_axial, tip)."""
        return tuple(
            (group, values) for group in model.LINK_GROUPS if (values := getattr(self, group)) is not None
        )


# ---------------------------------------------------------------------------- [actuator]

_POSITIVE = {"gt": 0, "says": "must be > 0"}
_EFFICIENCY = {"gt": 0, "le": 1, "says": "an efficiency is in (0, 1]"}


def _motor(description: str, **bounds: Any) -> Any:
    return Annotated[Real(**bounds) | None, Field(description=description)]


class ActuatorTable(Table):
    """[actuator]: what drives the base. direct: u is the force [N] or torque [N m]; dc_motor:
    u is the motor voltage [V] (docs/model.md, "A DC motor on the base"); acceleration: u is
    the base's acceleration [m/s² or rad/s²], imposed by a servo (docs/model.md, "An
    acceleration-driven base")."""

    kind: Literal[ACTUATOR_KINDS] = Field(
        "direct",
        description="direct: u is the force or torque on the base; dc_motor: u is the motor voltage [V]; "
        "acceleration: u is the base's acceleration [m/s^2 on a cart, rad/s^2 on an arm]",
    )
    Rm: _motor("dc_motor: armature resistance [Ω] (required)", **_POSITIVE) = None
    kt: _motor("dc_motor: torque constant [N m/A] (required)", **_POSITIVE) = None
    km: _motor("dc_motor: back-EMF constant [V s/rad] (required)", **_POSITIVE) = None
    Kg: _motor("dc_motor: gear ratio, motor turns per output turn (default 1)", **_POSITIVE) = None
    eta_g: _motor("dc_motor: gearbox efficiency in (0, 1] (default 1)", **_EFFICIENCY) = None
    eta_m: _motor("dc_motor: motor efficiency in (0, 1] (default 1)", **_EFFICIENCY) = None
    Jm: _motor("dc_motor: rotor inertia [kg m^2] (default 0)", ge=0, says="an inertia cannot be negative") = (
        None
    )
    r: _motor("dc_motor on a cart: pinion radius [m] (required there)", **_POSITIVE) = None
    noise: measuring.DriveNoise = None  # the drive (any kind): sensors.py
    lag: measuring.DriveLag = None
    pulses: measuring.DrivePulses = None
    _rotary: bool = PrivateAttr(default=False)  # the system's type, for u's unit

    @model_validator(mode="after")
    def _relations(self, info: ValidationInfo) -> ActuatorTable:
        from ipgen.model.actuator import ActuatorError

        context = context_of(info, "type", "links")
        if context is None:
            return self
        try:
            self.actuator().check(model.System(context["type"], context["links"]))
        except ActuatorError as exc:
            refuse_line(str(exc))
        self._rotary = context["type"] == "rotary"
        context.update(self.context())  # with _rotary known
        return self

    def actuator(self) -> Any:
        """The `ipgen.model.actuator.Actuator` this table declares."""
        from ipgen.model.actuator import Actuator

        given = {name: float(value) for name in MOTOR_KEYS if (value := getattr(self, name)) is not None}
        return Actuator(self.kind, **given)

    def context(self) -> dict[str, Any]:
        if self.kind == "acceleration":
            return {"u_unit": "rad/s^2" if self._rotary else "m/s^2"}
        return {"u_unit": "V"} if self.kind == "dc_motor" else {}


# ---------------------------------------------------------------------------- [initial]


class InitialTable(Table):
    """[initial]: the state at t = 0 (default: upright, at rest)."""

    theta: PerLink(Real()) | None = Field(
        None, description=f"angles [rad] (the base: position [m] or angle [rad]), {_PER_LINK}"
    )
    dtheta: PerLink(Real()) | None = Field(
        None, description=f"velocities [rad/s] (a cart: [m/s]), {_PER_LINK}"
    )


# ---------------------------------------------------------------------------- [input]

_AMPLITUDE = Annotated[
    Real(what="a number: N on a cart, N m on an arm"),
    Field(description="force on the cart [N] or torque on the arm [N m]"),
]
_START = Annotated[
    Real(ge=0, says="must be >= 0 s (the simulation starts at 0)", what="a time in s"),
    Field(description="[s]"),
]
_FREQUENCY = Real(ge=0, says="must be >= 0 Hz", what="a frequency in Hz, >= 0")
_PEAK = Annotated[
    Real(gt=0, says="must be > 0 {u_unit} (the peak |u|)", what="a number > 0: N on a cart, N m on an arm"),
    Field(
        description="the peak |u|: force on the cart [N] or torque on the arm [N m] (volts with a dc_motor)"
    ),
]


class InputTable(Table):
    """[input]: the force (cart) or torque (arm) on the base over time; `kind` picks the shape."""

    def context(self) -> dict[str, Any]:
        return {"input_kind": getattr(self, "kind")}  # noqa: B009 (each kind declares it)


class ZeroInput(InputTable):
    kind: Literal["zero"] = Field(description="no input")


class ConstantInput(InputTable):
    kind: Literal["constant"] = Field(description="u = amplitude")
    amplitude: _AMPLITUDE


class PulseInput(InputTable):
    kind: Literal["pulse"] = Field(description="u = amplitude for start <= t < start + duration")
    amplitude: _AMPLITUDE
    start: _START = _exact(0.0)
    duration: Real(gt=0, says="a pulse duration must be > 0 s", what="a time in s, > 0") = Field(
        description="[s]"
    )


class StepInput(InputTable):
    kind: Literal["step"] = Field(description="u = amplitude from t = time on")
    amplitude: _AMPLITUDE
    time: _START


class SineInput(InputTable):
    kind: Literal["sine"] = Field(description="u = amplitude sin(2π frequency t + phase)")
    amplitude: _AMPLITUDE
    frequency: _FREQUENCY = Field(description="[Hz]")
    phase: Real(what="an angle in rad") = Field(_exact(0.0), description="[rad]")


class ChirpInput(InputTable):
    kind: Literal["chirp"] = Field(
        description="a swept sine u = amplitude sin φ(t − start) for start <= t < start + duration, "
        "its frequency going from f0 to f1 (docs/excitation.md has φ)"
    )
    amplitude: _PEAK
    f0: _FREQUENCY = Field(description="the frequency at the start [Hz]")
    f1: _FREQUENCY = Field(description="the frequency at the end [Hz], > f0")
    duration: Real(gt=0, says="the sweep's duration must be > 0 s", what="a time in s, > 0") = Field(
        description="the sweep's length [s]"
    )
    start: _START = _exact(0.0)
    sweep: Literal[signals.SWEEPS] = Field(
        "linear", description="linear: f rises linearly in time; logarithmic: exponentially (needs f0 > 0)"
    )

    @model_validator(mode="after")
    def _relations(self) -> ChirpInput:
        if not float(self.f1) > float(self.f0):
            refuse(f"must be > f0 = {self.f0} Hz (the sweep rises from f0 to f1)", key="f1", value=self.f1)
        if self.sweep == "logarithmic" and not float(self.f0) > 0:
            expected = 'a logarithmic sweep starts above 0 Hz: give f0 > 0 or sweep = "linear"'
            refuse(expected, key="f0", value=self.f0)
        return self


class MultisineInput(InputTable):
    kind: Literal["multisine"] = Field(
        description="a periodic sum of cosines at every harmonic of 1/period in [f_min, f_max], "
        "Schroeder phases (low crest factor), scaled so that max |u| = amplitude"
    )
    amplitude: _PEAK
    f_min: _FREQUENCY = Field(description="the band's lowest frequency [Hz]")
    f_max: _FREQUENCY = Field(description="the band's highest frequency [Hz], > f_min")
    period: Real(gt=0, says="the multisine's period must be > 0 s", what="a time in s, > 0") = Field(
        description="the signal's period [s]: its lines are the harmonics k / period in the band"
    )

    @model_validator(mode="after")
    def _relations(self) -> MultisineInput:
        if not float(self.f_max) > float(self.f_min):
            refuse(f"must be > f_min = {self.f_min} Hz", key="f_max", value=self.f_max)
        f_min, f_max, period = float(self.f_min), float(self.f_max), float(self.period)
        k_lo, k_hi = signals.harmonics(f_min, f_max, period)
        lines = k_hi - k_lo + 1
        if k_hi > signals.MAX_HARMONIC:
            expected = f"f_max · period = {f_max * period:g}, more than {signals.MAX_HARMONIC} harmonics"
            expected += ": shorten the period"
        elif lines < 1:
            expected = f"no harmonic k / period lies in [{self.f_min}, {self.f_max}] Hz"
            expected += ": lengthen the period or widen the band"
        elif lines > signals.MAX_LINES:
            expected = f"gives {lines} lines in the band, more than {signals.MAX_LINES}"
            expected += ": shorten the period or narrow the band"
        else:
            return self
        refuse(expected, key="period", value=self.period)


# Each kind of input and its model, in the documented order; `kind` tells them apart.
INPUTS: dict[str, type[InputTable]] = {
    "zero": ZeroInput,
    "constant": ConstantInput,
    "pulse": PulseInput,
    "step": StepInput,
    "sine": SineInput,
    "chirp": ChirpInput,
    "multisine": MultisineInput,
}
Input = Annotated[
    ZeroInput | ConstantInput | PulseInput | StepInput | SineInput | ChirpInput | MultisineInput,
    Field(discriminator="kind"),
]
# The keys each kind uses (in resolved-config order).
INPUT_KEYS: dict[str, tuple[str, ...]] = {
    kind: tuple(key for key in table.model_fields if key != "kind") for kind, table in INPUTS.items()
}


# ---------------------------------------------------------------------------- [limits]

_TRAVEL = "the travel limit must be > 0 (m on a cart, rad on an arm)"


class LimitsTable(Table):
    """[limits]: where the rig ends; the simulator stops a run that goes beyond (exit status 4)."""

    travel: Real(gt=0, says=_TRAVEL, what="a travel limit > 0 (m on a cart, rad on an arm)") | None = Field(
        None,
        description="the base's limit |θ0| <= travel: the cart's position [m] or the arm's angle [rad] "
        "(default: none); checked at every sample",
    )


# ---------------------------------------------------------------------------- [simulation]


class SimulationTable(Table):
    """[simulation]: how long, how often to sample, and how to integrate."""

    t_end: Real(
        ge=limits.MIN_T_END,
        says=f"must be >= {limits.MIN_T_END:g} s",
        what=f"the simulated time in s, >= {limits.MIN_T_END:g}",
    ) = Field(
        description="the simulated time [s]"
    )
    sample: Annotated[Real(), AfterValidator(checks.sample)] = Field(
        _exact(DEFAULT_SAMPLE),
        validate_default=True,  # against t_end
        description="output interval [s], > 0 and <= t_end",
        json_schema_extra={"exclusiveMinimum": 0},
    )
    method: Literal[METHODS] = Field(
        DEFAULT_METHOD, description="integration method: CVODE bdf/adams, ARKODE erk-*, or fixed-step rk4"
    )
    jacobian: Any = Field(  # checked by method (`method_settings`)
        None,
        description="bdf and adams only: exact (generated) or dq (difference quotients)",
        json_schema_extra={"type": "string", "enum": list(JACOBIANS), "default": DEFAULT_JACOBIAN},
    )
    rtol: Annotated[
        Real(gt=0, lt=1, says="must be in (0, 1); 1e-10 is a good choice"), AfterValidator(checks.rtol)
    ] = Field(
        _exact(DEFAULT_RTOL),
        description="relative tolerance (every method but rk4)",
        json_schema_extra={"minimum": RTOL_MIN},
    )
    atol: Real(gt=0, says="must be > 0 (0 makes the error weight of a state that is 0 infinite)") = Field(
        _exact(DEFAULT_ATOL), description="absolute tolerance (every method but rk4)"
    )
    step: Any = Field(  # checked by method (`method_settings`)
        None,
        description="rk4 only (required there): the fixed step [s], > 0 and <= sample",
        json_schema_extra={"type": "number", "exclusiveMinimum": 0},
    )
    max_steps: Annotated[int, Says("must be an integer >= 1 and <= 2^63 - 1024")] = Field(
        DEFAULT_MAX_STEPS,
        strict=True,
        ge=1,
        le=limits.MAX_INTEGER_SETTING,
        description="the integrator's step limit between two samples",
    )

    @model_validator(mode="after")
    def _relations(self) -> SimulationTable:
        self.method_settings()
        return self

    def method_settings(self) -> tuple[str | None, Decimal | None]:
        """(jacobian, step) of `method`, whose keys are checked only when the method uses them:
        a Jacobian choice for bdf and adams (default "exact"); a fixed step for rk4 (required,
        in (0, sample]), which takes no rtol and atol."""
        given, method, jacobian = self.model_fields_set, self.method, None
        if method in JACOBIAN_METHODS:
            jacobian = DEFAULT_JACOBIAN if self.jacobian is None else self.jacobian
            if jacobian not in JACOBIANS:
                refuse(f"expected {one_of(JACOBIANS)}", key="jacobian", value=self.jacobian)
        elif "jacobian" in given:
            expected = f'applies to methods {one_of(JACOBIAN_METHODS)} only (method is "{method}"); remove it'
            refuse(expected, key="jacobian", value=self.jacobian)
        if method not in FIXED_STEP_METHODS:
            if "step" in given:
                expected = (
                    f'applies to method "rk4" only (method "{method}" chooses its own steps); remove it'
                )
                refuse(expected, key="step", value=self.step)
            return jacobian, None
        for key in ("rtol", "atol"):
            if key in given:
                fixed = 'does not apply to method "rk4" (it has a fixed step); remove it'
                refuse(fixed, key=key, value=getattr(self, key))
        if self.step is None:
            missing = "missing required key 'simulation.step'"
            refuse_line(f'{missing} (the fixed step of method "rk4" in s, > 0 and <= sample)')
        step = keyed("step", self.step)
        if not 0 < float(step) <= float(self.sample):
            expected = f"must be > 0 s and <= sample ({format_number(float(self.sample))} s)"
            refuse(expected, key="step", value=step)
        return jacobian, step

    def settings(self) -> dict[str, Any]:
        """The Scene's simulation fields (floats; jacobian and step by method)."""
        jacobian, step = self.method_settings()
        numbers = {key: float(getattr(self, key)) for key in ("t_end", "sample", "rtol", "atol")}
        step_ = None if step is None else float(step)
        return numbers | {
            "method": self.method,
            "max_steps": self.max_steps,
            "jacobian": jacobian,
            "step": step_,
        }

    def context(self) -> dict[str, Any]:
        return {"t_end": float(self.t_end), "sample": float(self.sample)}


# ---------------------------------------------------------------------------- [outputs]


class OutputsTable(Table):
    """[outputs]: extra columns of the simulator's CSV."""

    energy: Flag = Field(
        False, description="add the energy ledger columns (kinetic, potential, dissipated, input work)"
    )


# ---------------------------------------------------------------------------- [controller]


class ControllerTable(Table):
    """[controller]: state feedback u = −K (x − x_eq), K an LQR gain computed by ipgen or given; or
    a constrained nonlinear MPC (kind = "mpc", docs/mpc.md)."""

    kind: Literal[CONTROLLER_KINDS] = Field(
        description="lqr: a linear-quadratic regulator from q and r; gain: the gain K given in `gain`; "
        "mpc: nonlinear model predictive control on the exact model (q, r, p, u_max, travel, ...)"
    )
    gain: Annotated[Any, PlainValidator(control.gain_values)] = Field(
        None,
        description="kind = gain only: the 2 (links + 1) entries of K in u = −K (x − x_eq), in the "
        "scene's coordinates and units of u",
        json_schema_extra={"type": "array", "items": {"type": "number"}, "minItems": 4},
    )
    q: Annotated[Any, PlainValidator(control.weights)] = Field(
        None,
        description="2 (links + 1) weights of x = [θ, θ̇], or a symmetric PSD matrix (default: identity)",
        json_schema_extra=control.WEIGHTS_SCHEMA,
    )
    r: Real(gt=0, says="the weight of u² must be > 0", what="the weight of u², > 0") = Field(
        _exact(DEFAULT_R), description="weight of u²"
    )
    equilibrium: Annotated[Any, PlainValidator(control.equilibrium)] = Field(
        DEFAULT_EQUILIBRIUM,
        description="upright, hanging, or the angles [θ0, θ1, ...] (links at 0 or π)",
        json_schema_extra={**control.EQUILIBRIUM_SCHEMA, "default": DEFAULT_EQUILIBRIUM},
    )
    saturation: Real(gt=0, says="the largest |u| must be > 0 {u_unit}") | None = Field(
        None, description="the largest |u| [N or N m] (default: unbounded)"
    )
    period: Real() | None = Field(  # > 0, <= t_end, commensurate with sample: `controller.relations`
        None,
        description="sampling period [s], a whole multiple or fraction of simulation.sample "
        "(default: continuous)",
        json_schema_extra={"exclusiveMinimum": 0},
    )
    # kind = "mpc" only (docs/mpc.md): the problem over `horizon` samples of `period` and its budget.
    horizon: _Count(control.MAX_HORIZON, "mpc: the samples predicted") | None = Field(
        None, description=f"mpc only: N, the samples predicted (default {control.DEFAULT_HORIZON})"
    )
    p: Annotated[Any, PlainValidator(control.weights)] = Field(
        None,
        description="mpc only: the terminal weight, 2 (links + 1) weights or a symmetric PSD matrix "
        "(default: the discrete LQR's Riccati matrix at the equilibrium)",
        json_schema_extra=control.WEIGHTS_SCHEMA,
    )
    u_max: Real(gt=0, says="the input bound must be > 0 {u_unit}") | None = Field(
        None, description="mpc only (required): the hard bound |u| <= u_max [N, N m, or V with a dc_motor]"
    )
    travel: Real(gt=0, says="the base's bound must be > 0 m or rad") | None = Field(
        None, description="mpc only: the hard bound |θ0| <= travel on the predicted states [m or rad]"
    )
    soft_bounds: Annotated[Any, PlainValidator(control.soft_bounds)] = Field(
        None,
        description="mpc only: soft state bounds [[index, min, max], ...] (index into x = [θ, θ̇])",
        json_schema_extra=control.SOFT_BOUNDS_SCHEMA,
    )
    soft_penalty: Annotated[Any, PlainValidator(control.soft_penalty)] = Field(
        None,
        description="mpc only: [ρ1, ρ2] of a soft bound's violation s, costing ρ1 s + ρ2 s² "
        f"(default {list(control.DEFAULT_SOFT_PENALTY)})",
        json_schema_extra=control.SOFT_PENALTY_SCHEMA,
    )
    mode: Literal[control.MPC_MODES] | None = Field(
        None, description='mpc only: "rti" (one SQP iteration a sample, the default) or "converged"'
    )
    iterations: _Count(control.MAX_ITERATIONS, "mpc: SQP iterations a step") | None = Field(
        None, description="mpc only: SQP iterations a step at most (default: rti 1, converged 500)"
    )
    qp_iterations: _Count(control.MAX_ITERATIONS, "mpc: interior-point iterations a QP") | None = Field(
        None, description="mpc only: interior-point iterations a QP at most (default: rti 20, converged 50)"
    )
    substeps: _Count(control.MAX_SUBSTEPS, "mpc: RK4 steps a sample") | None = Field(
        None, description="mpc only: RK4 steps per sample in the prediction (default 1)"
    )
    barrier: (
        Real(
            ge=0,
            le=limits.MAX_MPC_BARRIER,
            says=f"the barrier weight must be >= 0 and <= {limits.MAX_MPC_BARRIER:g}",
        )
        | None
    ) = Field(
        None,
        description="mpc only (rti): > 0 solves each QP by qp_iterations Newton steps on its log-barrier "
        "problem at this fixed weight, warm-started from the last sample (qp_iterations = 1: one "
        "factorisation a sample, the microcontroller's step); 0 or absent: the interior point to its "
        "tolerance",
    )
    sensitivities: Literal[control.MPC_SENSITIVITIES] | None = Field(
        None,
        description='mpc only (rti): "exact" (the default: dF/dx, dF/du of the RK4 map) or "frozen" (the '
        "model's Jacobians at each stage's start, discretised as RK4 discretises a linear model: one "
        'Jacobian a stage instead of four) or "shifted" (frozen, and each warm step keeps the last '
        "sample's sensitivities of stages 2 .. N-1 for stages 1 .. N-2: the model's Jacobians at the first "
        "and the last stage only)",
    )

    @model_validator(mode="after")
    def _relations(self, info: ValidationInfo) -> ControllerTable:
        context = context_of(info, "count", "input_kind", "t_end", "sample")
        if context is not None:
            control.relations(self, context)
        return self

    def context(self) -> dict[str, Any]:
        period = None if self.period is None else float(self.period)
        return {"controller": True, "controller_kind": self.kind, "controller_period": period}


# ---------------------------------------------------------------------------- [swingup]


class SwingupTable(Table):
    """[swingup]: from the initial state (default hanging) to upright, then held by LQR (or by a
    [controller] kind = "mpc")."""

    method: Literal[swing.METHODS] = Field(
        description="energy: Åström–Furuta energy control (one link); "
        "trajectory: a plan on the exact model tracked by time-varying LQR"
    )
    u_max: Real(gt=0, says="the input limit must be > 0 {u_unit}") = Field(
        description="the input limit |u| <= u_max [N or N m]"
    )
    x_max: Real(gt=0, says=_TRAVEL) | None = Field(
        None, description="trajectory only: the plan keeps |θ0| <= x_max [m or rad] (default: no limit)"
    )
    duration: Real(gt=0, says="the manoeuvre's time must be > 0 s") | None = Field(
        None, description="trajectory only (required there): the manoeuvre's time [s]"
    )
    period: Real(gt=0, says="the sampling period must be > 0 s") = Field(
        _exact(swing.DEFAULT_PERIOD),
        description="controller sampling period [s], a whole multiple or fraction of simulation.sample",
    )
    hold: Real(ge=0, says="must be >= 0 s") = Field(
        _exact(swing.DEFAULT_HOLD), description="seconds held upright (LQR) after arrival; then the run ends"
    )
    tracking: Literal[swing.TRACKINGS] | None = Field(
        None,
        description='trajectory only: what tracks the plan, "lqr" (time-varying LQR on the plan\'s '
        'linearisation, the default) or "mpc" (the [controller] kind = "mpc" with the plan as its '
        "reference per stage, within its bounds; it then holds at the plan's end)",
    )
    margin: Real(gt=0, le=1, says="must be in (0, 1]") | None = Field(
        None,
        description="trajectory only: plan within margin·u_max and margin·x_max, track within the full "
        "limits (default 1)",
    )
    # The energy law's constants (method = "energy" only; docs/swingup.md). Absent: today's defaults.
    law: Literal[swing.LAWS] | None = Field(
        None,
        description='energy only: "energy" (ipgen\'s constants, in the base\'s units) or "proportional" '
        "(Quanser's: μ, a_max at the arm tip in m/s², E_r above hanging)",
    )
    gain_energy: Real(ge=0, says="the energy gain must be >= 0") | None = Field(
        None, description="energy only: k_E [(m/s² or rad/s²)/J] (proportional: μ [m/s² per J], default 50)"
    )
    accel_max: Real(gt=0, says="the acceleration limit must be > 0") | None = Field(
        None,
        description="energy only: a_max of the energy term [m/s² or rad/s²] (proportional: at the arm tip "
        "[m/s²], default 6); default: what u_max buys at design_speed",
    )
    design_speed: Real(ge=0, says="the design speed must be >= 0") | None = Field(
        None,
        description="energy only: base speed [m/s or rad/s] at which a_max is what u_max buys after "
        "back-EMF and damping (default 0: the stall acceleration)",
    )
    energy_target: Real(says="must be a finite number of J") | None = Field(
        None, description="energy only: E0 [J] relative to upright (proportional: E_r above hanging rest)"
    )
    catch_angle: Real(gt=0, lt=math.pi / 2, says="must be > 0 and < π/2 rad") | None = Field(
        None, description="energy only: switch to the hold within this angle of upright [rad] (default 0.3)"
    )
    catch_rate: Real(gt=0, says="must be > 0 rad/s") | None = Field(
        None, description="energy only: ... and within this link rate [rad/s] (default 3)"
    )
    release_angle: Real(gt=0, lt=math.pi / 2, says="must be > 0 and < π/2 rad") | None = Field(
        None,
        description="energy only: a hold that lets the link fall this far [rad] from the upright it "
        "caught gives it back to the swing, for another catch (more than catch_angle, below the "
        "simulator's divergence angle π/2; default: the hold is for good)",
    )
    energy_step: Real(ge=0, says="must be a number of J >= 0") | None = Field(
        None,
        description="energy only: the law learns its target on a rig unlike its model [J]: entering "
        "the catch window faster than catch_rate lowers it by this step, a swing that stalls short "
        "of the window raises it (default 0: the target is fixed)",
    )
    catch_deficit: Real(ge=0, says="must be a number of J >= 0") | None = Field(
        None,
        description="energy only: a catch also needs the link's energy E at most this far below "
        "upright's at rest [J] (E >= -catch_deficit: a link too slow to reach upright is left to the "
        "swing; default 0: any E)",
    )
    catch_base: Real(ge=0, says="must be a number of rad or m >= 0") | None = Field(
        None,
        description="energy only: a catch also needs the base within this of its centre [rad or m] "
        "(|θ0| in ipgen's coordinates: the hold starts with room to brake; default 0: anywhere)",
    )
    gain_position: Real(ge=0, says="must be >= 0") | None = Field(
        None, description="energy only: centring k_x [1/s²] of the base (default 1)"
    )
    gain_velocity: Real(ge=0, says="must be >= 0") | None = Field(
        None, description="energy only: centring k_v [1/s] of the base (default 2)"
    )
    q: Annotated[Any, PlainValidator(control.weights)] = Field(
        None,
        description="energy only: the hold LQR's weights of x = [θ, θ̇] in the scene's coordinates, "
        "2 (links + 1) numbers or a symmetric PSD matrix (default: identity)",
        json_schema_extra=control.WEIGHTS_SCHEMA,
    )
    r: Real(gt=0, says="the weight of u² must be > 0", what="the weight of u², > 0") | None = Field(
        None,
        description="energy only: the hold LQR's weight of u² in the input's units "
        "(V² for a dc_motor; default 1 per (N or N m)²)",
    )

    @model_validator(mode="after")
    def _relations(self, info: ValidationInfo) -> SwingupTable:
        context = context_of(info, "links", "input_kind", "t_end", "sample")
        if context is not None:
            swing.relations(self, context)
        return self

    def context(self) -> dict[str, Any]:
        return {"swingup_method": self.method}


# ---------------------------------------------------------------------------- the document


# Tables that are None when absent (an open loop has no controller, an exact loop no sensors).
ABSENT_IS_NONE: tuple[str, ...] = ("controller", "swingup", "sensors", "estimator")


class SceneDocument(BaseModel):
    """An ipgen scene: one experiment (SI units; arrays have links + 1 entries, index 0 the base).

    The tables are validated in this order; each may use what the ones before it tell
    (`Table.context`).
    """

    model_config = ConfigDict(extra="forbid", title="ipgen scene")

    system: SystemTable
    parameters: ParametersTable
    actuator: ActuatorTable = Field(default=None, description="what drives the base (default: direct)")  # type: ignore[assignment]
    initial: InitialTable = Field(default=None, description="the state at t = 0")  # type: ignore[assignment]
    input: Input = Field(default=None, description="the input on the base")  # type: ignore[assignment]
    limits: LimitsTable = Field(default=None, description="the rig's travel limit")  # type: ignore[assignment]
    simulation: SimulationTable
    outputs: OutputsTable = Field(default=None, description="extra CSV columns")  # type: ignore[assignment]
    controller: ControllerTable | None = Field(default=None, description="closed loop: LQR feedback")
    swingup: SwingupTable | None = Field(default=None, description="swing-up from hanging, then hold")
    sensors: measuring.SensorsTable | None = Field(
        default=None, description="what the rig measures (default: the exact state)"
    )
    estimator: measuring.EstimatorTable | None = Field(
        default=None, description="how the controller's state estimate is made"
    )

    @model_validator(mode="before")
    @classmethod
    def _absent_tables(cls, document: Any) -> Any:
        """An absent table reads as an empty one (validated: its defaults and context, or "missing
        required key"), an absent or empty [input] as a zero input; [controller] and [swingup]
        and the measured loop's tables are None when absent."""
        if not isinstance(document, dict):
            return document
        filled = {name: {} for name in cls.model_fields if name not in ABSENT_IS_NONE} | document
        if not filled.get("input"):
            filled["input"] = {"kind": "zero"}
        return filled


def _keys(name: str, annotation: Any) -> tuple[str, ...]:
    if name == "input":
        return tuple(dict.fromkeys(key for table in INPUTS.values() for key in table.model_fields))
    model_ = next(
        a for a in (*get_args(annotation), annotation) if isinstance(a, type) and issubclass(a, BaseModel)
    )
    return tuple(model_.model_fields)


# Every table a scene may have and its keys (the input kinds' together), in documented order.
TABLES: dict[str, tuple[str, ...]] = {
    name: _keys(name, field.annotation) for name, field in SceneDocument.model_fields.items()
}
