"""The scene format, declared once: every table, key, type, bound, default and description.

From this one declaration come both the validation (`reader.load_scene` validates each table
with its model, in the order of `SceneDocument`, and turns the first problem into one line)
and the JSON Schema (`json_schema()`, printed by `ipgen --scene-schema`, shipped as
docs/scene.schema.json for editors).

A table is a pydantic model (`Table`); a key is an annotated field whose annotation is a kind
of value from `fieldtypes` (`Number`, `Integer`, `Choice`, `Flag`, `Text`, `PerLink`, `Custom`)
carrying its bounds and messages, plus a `Field(description=...)` for the schema. Rules
between keys of a table are its `model_validator`; rules between tables read the validation
context, which each table extends with `context()` (e.g. [system] gives `links`, `count` =
links + 1 and `type` to the tables after it).

Extending (docs/scenes.md, "Extending the format"): a new optional per-link array is one line
in its table, e.g. in `ParametersTable`

    com: Annotated[tuple[Exact, ...] | None, PerLink(Number(bounds=(Ge(0, "must be >= 0 m"),))),
                   Field(description="centre of mass of each link from its pivot [m]")] = None

and a new table is a `Table` subclass with its keys plus one field in `SceneDocument`.
"""

from __future__ import annotations

import re
from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field, PrivateAttr, model_validator

from ipgen.codegen.emit import DEFAULT_EMIT, TARGETS
from ipgen.common import limits
from ipgen.control import coordinates as frame
from ipgen.control import signals
from ipgen.model import system as model
from ipgen.scene import checks
from ipgen.scene import controller as control
from ipgen.scene import sensors as measuring
from ipgen.scene import swingup as swing
from ipgen.scene.fieldtypes import (
    Choice,
    Custom,
    Exact,
    Flag,
    Ge,
    Gt,
    Integer,
    Le,
    Lt,
    Number,
    PerLink,
    Text,
    refuse,
    refuse_line,
)

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
# Which keys of [simulation] each method uses (see `checks.method_settings`).
METHOD_KEYS = checks.MethodKeys(JACOBIAN_METHODS, JACOBIANS, DEFAULT_JACOBIAN, FIXED_STEP_METHODS)

CONTROLLER_KINDS = control.CONTROLLER_KINDS
EQUILIBRIA = control.EQUILIBRIA
DEFAULT_EQUILIBRIUM = control.DEFAULT_EQUILIBRIUM
DEFAULT_R = control.DEFAULT_R
COMMENSURATE_TOLERANCE = control.COMMENSURATE_TOLERANCE

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


def _default(value: Any) -> Any:
    """A default that is validated like a written value (numbers become `Exact`)."""
    return Field(default=value, validate_default=True)


# ---------------------------------------------------------------------------- [system]


class SystemTable(Table):
    """[system]: which pendulum, and what ipgen writes for it."""

    type: Annotated[
        str,
        Choice(options=SYSTEM_TYPES),
        Field(description="classical: a cart on a rail; rotary: a Furuta arm turning about the vertical"),
    ]
    links: Annotated[
        int,
        Integer(
            "an integer >= 1: the number of pendulum links",
            (Ge(1, "expected an integer >= 1 (the number of pendulum links)"),),
        ),
        Field(description="the number of pendulum links (rods)"),
    ]
    inertia: Annotated[
        str,
        Custom(validate=checks.inertia, schema={"type": "string", "enum": list(INERTIAS)}),
        Field(description="rotary only: pivot (the published model) or full (complete thin-rod inertia)"),
    ] = DEFAULT_INERTIA
    name: Annotated[
        str | None,
        Text(
            problem=checks.model_name_problem,
            fix="choose another model name",
            pattern=r"^[A-Za-z][A-Za-z0-9_]*$",
            max_length=limits.MAX_NAME_LENGTH,
        ),
        Field(description="C++ model name: namespace ipgen::NAME, file NAME.hpp (default: <type><links>)"),
    ] = None
    specialise: Annotated[
        bool,
        Flag(),
        Field(description="fold this scene's parameters into the header as exact constants"),
    ] = False
    emit: Annotated[
        tuple[str, ...],
        Custom(
            validate=checks.emit_targets,
            schema={"type": "array", "items": {"type": "string", "enum": list(TARGETS)}, "minItems": 1},
        ),
        Field(
            description="what ipgen writes for the model", json_schema_extra={"default": list(DEFAULT_EMIT)}
        ),
    ] = DEFAULT_EMIT
    # The rig's own coordinates (docs/scenes.md, "The rig's coordinates"): how [initial],
    # [controller], the CSV, the plots and the scene's headers measure the link angles.
    angles: Annotated[
        str,
        Choice(options=frame.ANGLES),
        Field(
            description="link angles: absolute (each from the vertical) or relative (link i from link "
            "i - 1), in [initial], [controller], the CSV, the plots and the headers"
        ),
    ] = frame.Coordinates.angles
    zero: Annotated[
        str,
        Choice(options=frame.ZEROS),
        Field(
            description="where a link angle is 0: upright or hanging (relative angles: link 1's; "
            "the others are 0 in line with the link below)"
        ),
    ] = frame.Coordinates.zero
    positive: Annotated[
        str,
        Choice(options=frame.POSITIVE),
        Field(
            description="the link angles' positive sense: clockwise (ipgen's, docs/model.md) or "
            "counterclockwise"
        ),
    ] = frame.Coordinates.positive

    def coordinates(self) -> frame.Coordinates:
        """The convention of the link angles this table declares."""
        return frame.Coordinates(self.angles, self.zero, self.positive)

    def context(self) -> dict[str, Any]:
        return {
            "coordinates": self.coordinates(),
            "type": self.type,
            "links": self.links,
            "count": self.links + 1,
            "specialise": self.specialise,
            "inertia": self.inertia,
            "u_unit": "N" if self.type == "classical" else "N m",
        }


# ---------------------------------------------------------------------------- [parameters]


_PER_LINK = "links + 1 entries: index 0 the base (cart or arm), 1..n the links"


class ParametersTable(Table):
    """[parameters]: masses, lengths, damping and gravity (SI units)."""

    m: Annotated[
        tuple[Exact, ...],
        PerLink(Number(bounds=(Gt(0, "masses must be > 0 kg"),))),
        Field(description=f"masses [kg], {_PER_LINK}"),
    ]
    l: Annotated[  # noqa: E741 (the paper's name for the lengths)
        tuple[Exact, ...],
        PerLink(Number()),
        Field(description=f"lengths [m], {_PER_LINK}; l[0] is the arm (rotary, > 0), a cart has none: 0"),
    ]
    delta: Annotated[
        tuple[Exact, ...],
        PerLink(Number(bounds=(Ge(0, "damping must be >= 0"),))),
        Field(description=f"viscous damping coefficients, {_PER_LINK}"),
    ]
    g: Annotated[
        Exact,
        Number("gravity in m/s^2", (Ge(0, "gravity must be >= 0 m/s^2 (0 switches it off)"),)),
        Field(description="gravity [m/s^2] (0 switches it off)"),
    ] = _default(DEFAULT_G)
    # The links as built (docs/model.md, "Links as built"); absent: the paper's rods.
    com: Annotated[
        tuple[Exact, ...] | None,
        PerLink(Number()),
        Field(
            description=f"pivot-to-CoG distance of each link [m] (any finite number), {_PER_LINK} "
            "(0 unused); default l/2"
        ),
    ] = None
    J: Annotated[
        tuple[Exact, ...] | None,
        PerLink(Number(bounds=(Ge(0, "an inertia cannot be negative"),))),
        Field(
            description=f"inertia of each link about its CoG, across it [kg m^2], {_PER_LINK}; "
            "J[0]: the rotary arm's about the vertical; default m l^2/12 (J[0]: m0 l0^2/3)"
        ),
    ] = None
    J_axial: Annotated[
        tuple[Exact, ...] | None,
        PerLink(Number(bounds=(Ge(0, "an inertia cannot be negative"),))),
        Field(
            description=f"inertia of each link about its own axis [kg m^2] (<= 2 J; rotary, inertia full), "
            f"{_PER_LINK}; default 0"
        ),
    ] = None
    tip: Annotated[
        tuple[Exact, ...] | None,
        PerLink(Number(bounds=(Ge(0, "a mass cannot be negative"),))),
        Field(description=f"point mass at the far end of each link [kg], {_PER_LINK} (0 unused); default 0"),
    ] = None
    coulomb: Annotated[
        tuple[Exact, ...] | None,
        PerLink(Number(bounds=(Ge(0, "friction must be >= 0"),))),
        Field(
            description=f"Coulomb friction per coordinate [N or N m] (simulator only, not linearised), "
            f"{_PER_LINK}; default 0"
        ),
    ] = None
    coulomb_speed: Annotated[
        Exact,
        Number(bounds=(Gt(0, "must be > 0 (m/s or rad/s)"),)),
        Field(description="the Coulomb law's smoothing rate v_s: f = c tanh(w / v_s) [m/s or rad/s]"),
    ] = _default(DEFAULT_COULOMB_SPEED)
    free: Annotated[
        tuple[str, ...],
        Custom(validate=checks.free_names, schema={"type": "array", "items": {"type": "string"}}),
        Field(
            description="with specialise = true: parameters kept symbolic (m0, l1, delta2, g, ...)",
            json_schema_extra={"default": []},
        ),
    ] = ()

    @model_validator(mode="after")
    def _relations(self, info: Any) -> ParametersTable:
        context = info.context
        checks.lengths(self.l, context["type"])
        checks.links_as_built(self, context)
        if self.free and not context["specialise"]:
            refuse(
                "applies to specialised code only: add specialise = true to [system]",
                key="free",
                value=list(self.free),
            )
        if context["specialise"]:
            checks.foldable(self.decimals(context["type"]), self.free, context["type"])
        return self

    def lengths(self, system_type: str) -> tuple[Exact, ...]:
        """l, with a cart's (ignored) length written as 0."""
        return (Exact(0.0, "0"), *self.l[1:]) if system_type == "classical" else self.l

    def decimals(self, system_type: str) -> tuple[tuple[str, str], ...]:
        """("m0", "0.3"), ..., ("g", "9.81"): each parameter's decimal text as written."""
        groups = (("m", self.m), ("l", self.lengths(system_type)), ("delta", self.delta))
        named = [(f"{base}{i}", number.text) for base, values in groups for i, number in enumerate(values)]
        built = [
            (f"{group}{i}", number.text)
            for group, values in self.links_as_built()
            for i, number in enumerate(values)
        ]
        return (*named, ("g", self.g.text), *built)

    def links_as_built(self) -> tuple[tuple[str, tuple[Exact, ...]], ...]:
        """(group, values) of the link arrays the scene gives (com, J, J_axial, tip)."""
        return tuple(
            (group, values) for group in model.LINK_GROUPS if (values := getattr(self, group)) is not None
        )


# ---------------------------------------------------------------------------- [actuator]


def _motor_constant(description: str, bounds: tuple = ()) -> Any:
    return Annotated[Exact | None, Number(bounds=bounds), Field(description=description)]


_POSITIVE = (Gt(0, "must be > 0"),)
_EFFICIENCY = (Gt(0, "an efficiency is in (0, 1]"), Le(1, "an efficiency is in (0, 1]"))


class ActuatorTable(Table):
    """[actuator]: what drives the base. direct: u is the force [N] or torque [N m]; dc_motor:
    u is the motor voltage [V] (docs/model.md, "A DC motor on the base"); acceleration: u is
    the base's acceleration [m/s² or rad/s²], imposed by a servo (docs/model.md, "An
    acceleration-driven base")."""

    kind: Annotated[
        str,
        Choice(options=ACTUATOR_KINDS),
        Field(
            description="direct: u is the force or torque on the base; dc_motor: u is the motor voltage [V]; "
            "acceleration: u is the base's acceleration [m/s^2 on a cart, rad/s^2 on an arm]"
        ),
    ] = "direct"
    Rm: _motor_constant("dc_motor: armature resistance [Ω] (required)", _POSITIVE) = None
    kt: _motor_constant("dc_motor: torque constant [N m/A] (required)", _POSITIVE) = None
    km: _motor_constant("dc_motor: back-EMF constant [V s/rad] (required)", _POSITIVE) = None
    Kg: _motor_constant("dc_motor: gear ratio, motor turns per output turn (default 1)", _POSITIVE) = None
    eta_g: _motor_constant("dc_motor: gearbox efficiency in (0, 1] (default 1)", _EFFICIENCY) = None
    eta_m: _motor_constant("dc_motor: motor efficiency in (0, 1] (default 1)", _EFFICIENCY) = None
    Jm: _motor_constant(
        "dc_motor: rotor inertia [kg m^2] (default 0)", (Ge(0, "an inertia cannot be negative"),)
    ) = None
    r: _motor_constant("dc_motor on a cart: pinion radius [m] (required there)", _POSITIVE) = None
    noise: measuring.DriveNoise = None  # the drive (any kind): sensors.py
    lag: measuring.DriveLag = None
    pulses: measuring.DrivePulses = None
    _rotary: bool = PrivateAttr(default=False)  # the system's type, for u's unit

    @model_validator(mode="after")
    def _relations(self, info: Any) -> ActuatorTable:
        from ipgen.model.actuator import ActuatorError

        try:
            self.actuator().check(model.System(info.context["type"], info.context["links"]))
        except ActuatorError as exc:
            refuse_line(str(exc))
        self._rotary = info.context["type"] == "rotary"
        return self

    def actuator(self) -> Any:
        """The `ipgen.model.actuator.Actuator` this table declares."""
        from ipgen.model.actuator import Actuator

        given = {name: value.value for name in MOTOR_KEYS if (value := getattr(self, name)) is not None}
        return Actuator(self.kind, **given)

    def context(self) -> dict[str, Any]:
        if self.kind == "acceleration":
            return {"u_unit": "rad/s^2" if self._rotary else "m/s^2"}
        return {"u_unit": "V"} if self.kind == "dc_motor" else {}


# ---------------------------------------------------------------------------- [initial]


class InitialTable(Table):
    """[initial]: the state at t = 0 (default: upright, at rest)."""

    theta: Annotated[
        tuple[Exact, ...] | None,
        PerLink(Number()),
        Field(description=f"angles [rad] (the base: position [m] or angle [rad]), {_PER_LINK}"),
    ] = None
    dtheta: Annotated[
        tuple[Exact, ...] | None,
        PerLink(Number()),
        Field(description=f"velocities [rad/s] (a cart: [m/s]), {_PER_LINK}"),
    ] = None


# ---------------------------------------------------------------------------- [input]

_AMPLITUDE = Annotated[
    Exact,
    Number("a number: N on a cart, N m on an arm"),
    Field(description="force on the cart [N] or torque on the arm [N m]"),
]
_NOT_BEFORE_START = "must be >= 0 s (the simulation starts at 0)"


class InputTable(Table):
    """[input]: the force (cart) or torque (arm) on the base over time; `kind` picks the shape."""

    def context(self) -> dict[str, Any]:
        return {"input_kind": getattr(self, "kind")}  # noqa: B009 (each kind declares it)


class ZeroInput(InputTable):
    kind: Annotated[Literal["zero"], Field(description="no input")]


class ConstantInput(InputTable):
    kind: Annotated[Literal["constant"], Field(description="u = amplitude")]
    amplitude: _AMPLITUDE


class PulseInput(InputTable):
    kind: Annotated[Literal["pulse"], Field(description="u = amplitude for start <= t < start + duration")]
    amplitude: _AMPLITUDE
    start: Annotated[Exact, Number("a time in s", (Ge(0, _NOT_BEFORE_START),)), Field(description="[s]")] = (
        _default(0.0)
    )
    duration: Annotated[
        Exact,
        Number("a time in s, > 0", (Gt(0, "a pulse duration must be > 0 s"),)),
        Field(description="[s]"),
    ]


class StepInput(InputTable):
    kind: Annotated[Literal["step"], Field(description="u = amplitude from t = time on")]
    amplitude: _AMPLITUDE
    time: Annotated[Exact, Number("a time in s", (Ge(0, _NOT_BEFORE_START),)), Field(description="[s]")]


class SineInput(InputTable):
    kind: Annotated[Literal["sine"], Field(description="u = amplitude sin(2π frequency t + phase)")]
    amplitude: _AMPLITUDE
    frequency: Annotated[
        Exact, Number("a frequency in Hz, >= 0", (Ge(0, "must be >= 0 Hz"),)), Field(description="[Hz]")
    ]
    phase: Annotated[Exact, Number("an angle in rad"), Field(description="[rad]")] = _default(0.0)


_PEAK = Annotated[
    Exact,
    Number("a number > 0: N on a cart, N m on an arm", (Gt(0, "must be > 0 {u_unit} (the peak |u|)"),)),
    Field(
        description="the peak |u|: force on the cart [N] or torque on the arm [N m] (volts with a dc_motor)"
    ),
]
_FREQUENCY = Number("a frequency in Hz, >= 0", (Ge(0, "must be >= 0 Hz"),))


class ChirpInput(InputTable):
    kind: Annotated[
        Literal["chirp"],
        Field(
            description="a swept sine u = amplitude sin φ(t − start) for start <= t < start + duration, "
            "its frequency going from f0 to f1 (docs/excitation.md has φ)"
        ),
    ]
    amplitude: _PEAK
    f0: Annotated[Exact, _FREQUENCY, Field(description="the frequency at the start [Hz]")]
    f1: Annotated[Exact, _FREQUENCY, Field(description="the frequency at the end [Hz], > f0")]
    duration: Annotated[
        Exact,
        Number("a time in s, > 0", (Gt(0, "the sweep's duration must be > 0 s"),)),
        Field(description="the sweep's length [s]"),
    ]
    start: Annotated[Exact, Number("a time in s", (Ge(0, _NOT_BEFORE_START),)), Field(description="[s]")] = (
        _default(0.0)
    )
    sweep: Annotated[
        str,
        Choice(options=signals.SWEEPS),
        Field(description="linear: f rises linearly in time; logarithmic: exponentially (needs f0 > 0)"),
    ] = "linear"

    @model_validator(mode="after")
    def _relations(self) -> ChirpInput:
        if not self.f1.value > self.f0.value:
            refuse(
                f"must be > f0 = {self.f0.text} Hz (the sweep rises from f0 to f1)", key="f1", value=self.f1
            )
        if self.sweep == "logarithmic" and not self.f0.value > 0:
            refuse(
                'a logarithmic sweep starts above 0 Hz: give f0 > 0 or sweep = "linear"',
                key="f0",
                value=self.f0,
            )
        return self


class MultisineInput(InputTable):
    kind: Annotated[
        Literal["multisine"],
        Field(
            description="a periodic sum of cosines at every harmonic of 1/period in [f_min, f_max], "
            "Schroeder phases (low crest factor), scaled so that max |u| = amplitude"
        ),
    ]
    amplitude: _PEAK
    f_min: Annotated[Exact, _FREQUENCY, Field(description="the band's lowest frequency [Hz]")]
    f_max: Annotated[Exact, _FREQUENCY, Field(description="the band's highest frequency [Hz], > f_min")]
    period: Annotated[
        Exact,
        Number("a time in s, > 0", (Gt(0, "the multisine's period must be > 0 s"),)),
        Field(description="the signal's period [s]: its lines are the harmonics k / period in the band"),
    ]

    @model_validator(mode="after")
    def _relations(self) -> MultisineInput:
        if not self.f_max.value > self.f_min.value:
            refuse(f"must be > f_min = {self.f_min.text} Hz", key="f_max", value=self.f_max)
        k_lo, k_hi = signals.harmonics(self.f_min.value, self.f_max.value, self.period.value)
        if k_hi > signals.MAX_HARMONIC:
            refuse(
                f"f_max · period = {self.f_max.value * self.period.value:g}, more than "
                f"{signals.MAX_HARMONIC} harmonics: shorten the period",
                key="period",
                value=self.period,
            )
        if k_hi - k_lo + 1 < 1:
            refuse(
                f"no harmonic k / period lies in [{self.f_min.text}, {self.f_max.text}] Hz: "
                "lengthen the period or widen the band",
                key="period",
                value=self.period,
            )
        if k_hi - k_lo + 1 > signals.MAX_LINES:
            refuse(
                f"gives {k_hi - k_lo + 1} lines in the band, more than {signals.MAX_LINES}: "
                "shorten the period or narrow the band",
                key="period",
                value=self.period,
            )
        return self


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
# The keys each kind uses (in resolved-config order) and which of them are required.
INPUT_KEYS: dict[str, tuple[str, ...]] = {
    kind: tuple(key for key in table.model_fields if key != "kind") for kind, table in INPUTS.items()
}
INPUT_REQUIRED: dict[str, tuple[str, ...]] = {
    kind: tuple(key for key in INPUT_KEYS[kind] if table.model_fields[key].is_required())
    for kind, table in INPUTS.items()
}


# ---------------------------------------------------------------------------- [limits]


class LimitsTable(Table):
    """[limits]: where the rig ends; the simulator stops a run that goes beyond (exit status 4)."""

    travel: Annotated[
        Exact | None,
        Number(
            "a travel limit > 0 (m on a cart, rad on an arm)",
            (Gt(0, "the travel limit must be > 0 (m on a cart, rad on an arm)"),),
        ),
        Field(
            description="the base's limit |θ0| <= travel: the cart's position [m] or the arm's angle [rad] "
            "(default: none); checked at every sample"
        ),
    ] = None


# ---------------------------------------------------------------------------- [simulation]


class SimulationTable(Table):
    """[simulation]: how long, how often to sample, and how to integrate."""

    t_end: Annotated[
        Exact,
        Number("the simulated time in s, > 0", (Gt(0, "must be > 0 s"),)),
        Field(description="the simulated time [s]"),
    ]
    sample: Annotated[
        Exact,
        Custom(validate=checks.sample, schema={"type": "number", "exclusiveMinimum": 0}),
        Field(description="output interval [s], > 0 and <= t_end"),
    ] = _default(DEFAULT_SAMPLE)
    method: Annotated[
        str,
        Choice(options=METHODS),
        Field(description="integration method: CVODE bdf/adams, ARKODE erk-*, or fixed-step rk4"),
    ] = DEFAULT_METHOD
    jacobian: Annotated[
        str | None,
        Custom(validate=checks.raw, schema={"type": "string", "enum": list(JACOBIANS)}),  # method_settings
        Field(
            description="bdf and adams only: exact (generated) or dq (difference quotients)",
            json_schema_extra={"default": DEFAULT_JACOBIAN},
        ),
    ] = None
    rtol: Annotated[
        Exact,
        Number(
            bounds=(
                Gt(0, "must be in (0, 1); 1e-10 is a good choice"),
                Lt(1, "must be in (0, 1); 1e-10 is a good choice"),
                Ge(RTOL_MIN, "cannot be met in double precision; use >= 1e-14"),
            )
        ),
        Field(description="relative tolerance (every method but rk4)"),
    ] = _default(DEFAULT_RTOL)
    atol: Annotated[
        Exact,
        Number(bounds=(Ge(0, "must be >= 0"),)),
        Field(description="absolute tolerance (every method but rk4)"),
    ] = _default(DEFAULT_ATOL)
    step: Annotated[
        Exact | None,
        Custom(validate=checks.raw, schema={"type": "number", "exclusiveMinimum": 0}),  # method_settings
        Field(description="rk4 only (required there): the fixed step [s], > 0 and <= sample"),
    ] = None
    max_steps: Annotated[
        int,
        Integer(bounds=(Ge(1, "must be an integer >= 1"),)),
        Field(description="the integrator's step limit between two samples"),
    ] = DEFAULT_MAX_STEPS

    @model_validator(mode="after")
    def _relations(self) -> SimulationTable:
        checks.method_settings(self, self.model_fields_set, METHOD_KEYS)
        return self

    def settings(self) -> dict[str, Any]:
        """The Scene's simulation fields (floats; jacobian and step by method)."""
        jacobian, step = checks.method_settings(self, self.model_fields_set, METHOD_KEYS)
        return {
            "t_end": self.t_end.value,
            "sample": self.sample.value,
            "method": self.method,
            "rtol": self.rtol.value,
            "atol": self.atol.value,
            "max_steps": self.max_steps,
            "jacobian": jacobian,
            "step": None if step is None else step.value,
        }

    def context(self) -> dict[str, Any]:
        return {"t_end": self.t_end.value, "sample": self.sample.value}


# ---------------------------------------------------------------------------- [outputs]


class OutputsTable(Table):
    """[outputs]: extra columns of the simulator's CSV."""

    energy: Annotated[
        bool,
        Flag(),
        Field(description="add the energy ledger columns (kinetic, potential, dissipated, input work)"),
    ] = False


# ---------------------------------------------------------------------------- [controller]


class ControllerTable(Table):
    """[controller]: state feedback u = −K (x − x_eq), K an LQR gain computed by ipgen."""

    kind: Annotated[
        str, Choice(options=CONTROLLER_KINDS), Field(description="lqr: a linear-quadratic regulator")
    ]
    q: Annotated[
        Any,
        Custom(validate=control.weights, schema=control.WEIGHTS_SCHEMA),
        Field(
            description="2 (links + 1) weights of x = [θ, θ̇], or a symmetric PSD matrix (default: identity)"
        ),
    ] = None
    r: Annotated[
        Exact,
        Number("the weight of u², > 0", (Gt(0, "the weight of u² must be > 0"),)),
        Field(description="weight of u²"),
    ] = _default(DEFAULT_R)
    equilibrium: Annotated[
        Any,
        Custom(validate=control.equilibrium, schema=control.EQUILIBRIUM_SCHEMA),
        Field(
            description="upright, hanging, or the angles [θ0, θ1, ...] (links at 0 or π)",
            json_schema_extra={"default": DEFAULT_EQUILIBRIUM},
        ),
    ] = DEFAULT_EQUILIBRIUM
    saturation: Annotated[
        Exact | None,
        Number(bounds=(Gt(0, "the largest |u| must be > 0 {u_unit}"),)),
        Field(description="the largest |u| [N or N m] (default: unbounded)"),
    ] = None
    period: Annotated[
        Exact | None,
        Number(),  # > 0, <= t_end and commensurate with sample: `controller.relations`
        Field(
            description="sampling period [s], a whole multiple or fraction of simulation.sample "
            "(default: continuous)",
            json_schema_extra={"exclusiveMinimum": 0},
        ),
    ] = None

    @model_validator(mode="after")
    def _relations(self, info: Any) -> ControllerTable:
        control.relations(self, info.context)
        return self

    def context(self) -> dict[str, Any]:
        return {"controller": True}


# ---------------------------------------------------------------------------- [swingup]


class SwingupTable(Table):
    """[swingup]: from the initial state (default hanging) to upright, then held by LQR."""

    method: Annotated[
        str,
        Choice(options=swing.METHODS),
        Field(
            description="energy: Åström–Furuta energy control (one link); "
            "trajectory: a plan on the exact model tracked by time-varying LQR"
        ),
    ]
    u_max: Annotated[
        Exact,
        Number(bounds=(Gt(0, "the input limit must be > 0 {u_unit}"),)),
        Field(description="the input limit |u| <= u_max [N or N m]"),
    ]
    x_max: Annotated[
        Exact | None,
        Number(bounds=(Gt(0, "the travel limit must be > 0 (m on a cart, rad on an arm)"),)),
        Field(description="trajectory only: the plan keeps |θ0| <= x_max [m or rad] (default: no limit)"),
    ] = None
    duration: Annotated[
        Exact | None,
        Number(bounds=(Gt(0, "the manoeuvre's time must be > 0 s"),)),
        Field(description="trajectory only (required there): the manoeuvre's time [s]"),
    ] = None
    period: Annotated[
        Exact,
        Number(bounds=(Gt(0, "the sampling period must be > 0 s"),)),
        Field(
            description="controller sampling period [s], a whole multiple or fraction of simulation.sample"
        ),
    ] = _default(swing.DEFAULT_PERIOD)
    hold: Annotated[
        Exact,
        Number(bounds=(Ge(0, "must be >= 0 s"),)),
        Field(description="seconds held upright (LQR) after arrival; then the run ends"),
    ] = _default(swing.DEFAULT_HOLD)

    @model_validator(mode="after")
    def _relations(self, info: Any) -> SwingupTable:
        swing.relations(self, info.context)
        return self


# ---------------------------------------------------------------------------- the document


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
    controller: ControllerTable = Field(default=None, description="closed loop: LQR feedback")  # type: ignore[assignment]
    swingup: SwingupTable = Field(default=None, description="swing-up from hanging, then hold")  # type: ignore[assignment]
    sensors: measuring.SensorsTable = Field(
        default=None, description="what the rig measures (default: the exact state)"
    )  # type: ignore[assignment]
    estimator: measuring.EstimatorTable = Field(
        default=None, description="how the controller's state estimate is made"
    )  # type: ignore[assignment]


# Every table a scene may have, its model (`Input` for [input]) and its keys, documented order.
TABLE_MODELS: dict[str, Any] = {
    "system": SystemTable,
    "parameters": ParametersTable,
    "actuator": ActuatorTable,
    "initial": InitialTable,
    "input": Input,
    "limits": LimitsTable,
    "simulation": SimulationTable,
    "outputs": OutputsTable,
    "controller": ControllerTable,
    "swingup": SwingupTable,
    "sensors": measuring.SensorsTable,
    "estimator": measuring.EstimatorTable,
}
assert tuple(TABLE_MODELS) == tuple(SceneDocument.model_fields)  # one order, checked at import
TABLES: dict[str, tuple[str, ...]] = {
    name: (
        tuple(dict.fromkeys(key for table in INPUTS.values() for key in table.model_fields))
        if name == "input"
        else tuple(table.model_fields)
    )
    for name, table in TABLE_MODELS.items()
}
# Tables that are None when absent (an open loop has no controller), and what an absent or
# empty table reads as where that is not {} (no [input] is a zero input).
ABSENT_IS_NONE: tuple[str, ...] = ("controller", "swingup", "sensors", "estimator")
WHEN_EMPTY: dict[str, dict[str, Any]] = {"input": {"kind": "zero"}}


def json_schema() -> dict[str, Any]:
    """The JSON Schema of scene files, for editors: draft 4, the draft Taplo (and so Even Better
    TOML) implements; newer validators read it too."""
    schema = SceneDocument.model_json_schema(ref_template="#/definitions/{model}")
    schema["definitions"] = schema.pop("$defs")
    # An empty [input] table is no input, like none at all.
    schema["properties"]["input"]["oneOf"].append(
        {"type": "object", "maxProperties": 0, "description": "an empty table: no input"}
    )
    _draft4(schema)
    return {
        "$schema": "http://json-schema.org/draft-04/schema#",
        **schema,
        "description": (
            "An ipgen scene: one experiment of an n-link inverted pendulum (TOML, SI units). "
            "Arrays of the parameters and the initial state have links + 1 entries: index 0 the "
            "base (cart or arm), 1..n the links. ipgen checks more than this schema can say "
            "(array lengths, relations between keys); docs/scenes.md is the reference."
        ),
    }


def _draft4(node: Any) -> None:
    """Say in draft 4 what pydantic writes in draft 2020-12: exclusive bounds as booleans,
    `const` as a one-value `enum`; drop OpenAPI's `discriminator` and null defaults."""
    if isinstance(node, list):
        for item in node:
            _draft4(item)
        return
    if not isinstance(node, dict):
        return
    for bound, inclusive in (("exclusiveMinimum", "minimum"), ("exclusiveMaximum", "maximum")):
        limit = node.get(bound)
        if isinstance(limit, (int, float)) and not isinstance(limit, bool):
            tighter = max if bound == "exclusiveMinimum" else min
            if inclusive in node and tighter(node[inclusive], limit) == node[inclusive] != limit:
                del node[bound]  # the inclusive bound is the tighter one (rtol >= 1e-15 > 0)
            else:
                node[inclusive], node[bound] = limit, True
    if "const" in node:
        value = node.pop("const")
        node["enum"] = [value]
        if isinstance(value, str):
            node.setdefault("type", "string")
    if len(node.get("allOf", ())) == 1 and list(node["allOf"][0]) == ["$ref"]:
        node["$ref"] = node.pop("allOf")[0]["$ref"]  # older pydantic: the same as a plain $ref
    node.pop("discriminator", None)
    if "default" in node and node["default"] is None:
        del node["default"]
    for value in node.values():
        _draft4(value)


def json_schema_text() -> str:
    """`json_schema()` as the text `ipgen --scene-schema` prints and docs/scene.schema.json holds."""
    import json

    return json.dumps(_canonical(json_schema()), indent=2, ensure_ascii=False) + "\n"


def _canonical(node: Any, names: bool = False) -> Any:
    """The keywords of each schema in sorted order (the same text from any pydantic version);
    the members of `properties` and `definitions` in declaration order."""
    if isinstance(node, list):
        return [_canonical(item) for item in node]
    if not isinstance(node, dict):
        return node
    if names:
        return {name: _canonical(value) for name, value in node.items()}
    return {
        key: _canonical(node[key], names=key in ("properties", "definitions"))
        for key in sorted(node, key=lambda key: (key != "$schema", key))
    }
