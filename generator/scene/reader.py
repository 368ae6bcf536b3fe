"""Scene files: one experiment per small TOML file, checked and flattened for the simulator.

The format (tables, keys, types, bounds, defaults) is declared once in `schema.py`; the
reference for users is docs/scenes.md. `load_scene` reads a file (at most
`limits.MAX_SCENE_BYTES`, its shape checked by `nesting.py` before parsing), parses it with
numbers kept as exact decimals, refuses unknown tables and keys, validates each table with its
model in the declared order, and builds a `Scene`; every problem is a one-line `SceneError`
naming the file and the dotted key. `resolved_config` writes the flat `key = value` text the
C++ simulator reads.
"""

from __future__ import annotations

import difflib
import functools
import math
import tomllib
from dataclasses import dataclass, field
from decimal import Decimal
from fractions import Fraction
from pathlib import Path
from typing import Any, NoReturn

from ipgen.codegen.emit import DEFAULT_EMIT, unsupported
from ipgen.common import limits
from ipgen.common.safetext import abbreviate, quote_path
from ipgen.common.version import __version__
from ipgen.control import signals
from ipgen.control.controller import Controller
from ipgen.control.coordinates import Coordinates
from ipgen.control.swingup import SwingUpLaw
from ipgen.model.actuator import DIRECT, Actuator
from ipgen.model.links import rod_value
from ipgen.model.pendulum import Pendulum, from_scene_object
from ipgen.model.system import PARAMETER_GROUPS, System, parameter_names, split_parameter
from ipgen.scene import controller as control
from ipgen.scene import schema
from ipgen.scene import swingup as swing
from ipgen.scene.fields import _one_of, _Reader, format_number
from ipgen.scene.fieldtypes import Exact, Kind
from ipgen.scene.nesting import shape_problem


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

    @property
    def system(self) -> System:
        """The system the scene simulates."""
        return System(self.type, self.links, self.inertia)  # type: ignore[arg-type]

    @property
    def pendulum(self) -> Pendulum:
        """The scene's system, parameters, drive and coordinates as one `ipgen.Pendulum`."""
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
        return Fraction(text) if text is not None else Fraction(repr(self.value(name)))

    def link_values(self) -> dict[str, tuple[float, ...]]:
        """{group: values} of the links as built the scene gives (com, J, J_axial, tip)."""
        return dict(self.links_as_built)

    def motor_folded(self) -> dict[str, Fraction]:
        """A dc_motor folded exactly ({} without one): delta0 + c, and m0 (cart) or J0 (arm)
        + the rotor's reflected inertia, as rationals of the decimals written (the motor
        constants by their shortest repr), so that the resolved config and a specialised
        header agree to the last bit (`actuator.fold` in exact arithmetic)."""
        motor = self.actuator
        if not motor.is_motor:
            return {}

        def exact(value: float | None) -> Fraction:
            return Fraction(1) if value is None else Fraction(repr(float(value)))

        radius = exact(motor.r)  # 1 on an arm
        gain = (
            exact(motor.eta_g)
            * exact(motor.Kg)
            * exact(motor.eta_m)
            * exact(motor.kt)
            / (exact(motor.Rm) * radius)
        )
        damping = gain * exact(motor.Kg) * exact(motor.km) / radius
        inertia = exact(motor.eta_g) * exact(motor.Kg) ** 2 * exact(motor.Jm) / radius**2
        folded = {"delta0": self.exact("delta0") + damping}
        if self.type == "classical":
            folded["m0"] = self.exact("m0") + inertia
        else:
            given = "J" in self.link_values()
            base = self.exact("J0") if given else self.exact("m0") * self.exact("l0") ** 2 / 3
            folded["J0"] = base + inertia
        return folded


# ---------------------------------------------------------------------------- public API


def load_scene(path: str | Path) -> Scene:
    """Read, validate and complete a scene file; raises `SceneError` on any problem."""
    path = Path(path)
    reader = _Reader(path)
    if not schema.STEM.match(path.stem):
        reader.fail(
            f"scene file name '{abbreviate(path.stem)}' must be letters, digits, '_', '.', '+' or '-' "
            "(it names the output files)"
        )
    if len(path.stem) > limits.MAX_STEM_LENGTH:
        reader.fail(
            f"scene file name is {len(path.stem)} characters long: use at most {limits.MAX_STEM_LENGTH} "
            "(it names the output files)"
        )
    document = _parse_toml(reader, _read_text(reader))
    _check_keys(reader, document)
    return _build_scene(reader, _validate(reader, document))


def resolved_config(scene: Scene) -> str:
    """The flat `key = value` text the C++ simulator reads (deterministic, numbers exact)."""
    lines = [
        f"# Generated by ipgen {__version__} from {quote_path(scene.path.as_posix())}; do not edit",
        f"name = {scene.stem}",
        f"model = {scene.name}",
        f"type = {scene.type}",
        f"links = {scene.links}",
        f"inertia = {scene.inertia}",
        *_coordinate_lines(scene.coordinates),
        *_parameter_lines(scene),
        f"theta = {_format_list(scene.theta)}",
        f"dtheta = {_format_list(scene.dtheta)}",
        f"input = {scene.input.kind}",
    ]
    lines += [
        f"input.{key} = {value if isinstance(value, str) else format_number(value)}"
        for key, value in scene.input.fields()
    ]
    if scene.input.kind == "multisine":  # the lines the simulator sums (control/signals.py)
        ms = scene.input.lines
        lines += [
            f"input.frequencies = {_format_list(ms.frequencies)}",
            f"input.phases = {_format_list(ms.phases)}",
            f"input.scale = {format_number(ms.scale)}",
        ]
    if scene.travel is not None:
        lines.append(f"limits.travel = {format_number(scene.travel)}")
    lines += [
        f"t_end = {format_number(scene.t_end)}",
        f"sample = {format_number(scene.sample)}",
        f"method = {scene.method}",
    ]
    if scene.jacobian is not None:
        lines.append(f"jacobian = {scene.jacobian}")
    if scene.step is not None:
        lines.append(f"step = {format_number(scene.step)}")
    lines += [
        f"rtol = {format_number(scene.rtol)}",
        f"atol = {format_number(scene.atol)}",
        f"max_steps = {scene.max_steps}",
    ]
    if scene.energy:
        lines.append("energy = true")
    lines += _controller_lines(scene.controller)
    lines += _swingup_lines(scene.swingup)
    return "\n".join(lines) + "\n"


def _coordinate_lines(coordinates: Coordinates) -> list[str]:
    """The rig's convention, when it is not ipgen's (nothing otherwise: the file is as before)."""
    if coordinates.is_canonical:
        return []
    return [
        "# the rig's coordinates (docs/model.md): theta, dtheta, controller.* and the CSV's columns are in",
        "# them; the simulator integrates in ipgen's and maps at the edges (swingup.* are ipgen's)",
        f"angles = {coordinates.angles}",
        f"zero = {coordinates.zero}",
        f"positive = {coordinates.positive}",
    ]


def _rod_inertia(scene: Scene, i: int) -> float:
    """The rod's J[i] from the decimals written, rounded once: what a specialised header folds
    (`specialisation._rod_links`), so that the simulator's check of it agrees to the last bit."""
    exact = [scene.exact(f"{group}{i}") for group in ("m", "l")]
    m, l = [0.0] * i + [exact[0]], [0.0] * i + [exact[1]]  # noqa: E741
    try:
        return float(rod_value(scene.system, "J", i, m, l))
    except OverflowError:  # beyond the doubles: what the float products give (inf)
        return rod_value(scene.system, "J", i, scene.m, scene.l)


def _parameter_lines(scene: Scene) -> list[str]:
    """m, l, delta, g and the links as built; with a dc_motor the equivalent direct model's
    (`actuator.fold`: δ0 + back-EMF damping, m0 or J0 + the rotor's reflected inertia) and
    `actuator.gain`, the force or torque per volt the simulator multiplies u by."""
    m, delta, built = scene.m, scene.delta, dict(scene.links_as_built)
    lines: list[str] = []
    if scene.actuator.is_motor:
        from ipgen.model.actuator import fold

        system = scene.system
        given = built.get("J")
        inertias = list(given) if given is not None else [_rod_inertia(scene, i) for i in range(system.dof)]
        m_, delta_, j_, gain = fold(scene.actuator, system, list(m), list(delta), inertias)
        exact = scene.motor_folded()  # the same values, rounded once (a specialised header folds them)
        delta_[0] = float(exact["delta0"])
        if system.is_rotary:
            j_[0] = float(exact["J0"])
        else:
            m_[0] = float(exact["m0"])
        m, delta = tuple(m_), tuple(delta_)
        if system.is_rotary or given is not None:
            built["J"] = tuple(j_)
        motor = scene.actuator
        lines += [
            "# [actuator] dc_motor, folded into the direct model (docs/model.md): u is the voltage [V],",
            f"# Rm {motor.Rm!r}, kt {motor.kt!r}, km {motor.km!r}, Kg {motor.Kg!r}, eta_g {motor.eta_g!r}, "
            f"eta_m {motor.eta_m!r}, Jm {motor.Jm!r}, r {motor.r!r}",
            "actuator = dc_motor",
            f"actuator.gain = {format_number(gain)}",
        ]
    if scene.actuator.is_acceleration:
        lines += [
            "# [actuator] acceleration (docs/model.md): u is the base's acceleration; the links follow",
            "actuator = acceleration",
        ]
    order = [group for group in ("com", "J", "J_axial", "tip") if group in built]
    return [
        f"m = {_format_list(m)}",
        f"l = {_format_list(scene.l)}",
        f"delta = {_format_list(delta)}",
        f"g = {format_number(scene.g)}",
        *(f"{group} = {_format_list(built[group])}" for group in order),
        *lines,
        *(
            [
                f"coulomb = {_format_list(scene.coulomb)}",
                f"coulomb_speed = {format_number(scene.coulomb_speed)}",
            ]
            if scene.coulomb is not None
            else []
        ),
    ]


def _swingup_lines(law: SwingUpLaw | None) -> list[str]:
    """The swing-up for the simulator: method, limits, hold LQR, and the energy law's constants
    or the plan's inputs, states and gain schedule (one long line each)."""
    if law is None:
        return []
    lines = [
        f"swingup = {law.method}",
        f"swingup.u_max = {format_number(law.u_max)}",
        f"swingup.period = {format_number(law.period)}",
        f"swingup.hold = {format_number(law.hold)}",
        f"swingup.hold_gain = {_format_list(law.hold_gain)}",
        f"swingup.target = {_format_list(law.target)}",
    ]
    lines += [f"swingup.{name} = {format_number(value)}" for name, value in law.energy]
    if law.method == "trajectory":
        lines += [
            f"swingup.steps = {law.steps}",
            f"swingup.inputs = {_format_list(law.inputs)}",
            f"swingup.states = {_format_list(law.states)}",
            f"swingup.gains = {_format_list(law.gains)}",
        ]
    return lines


def _controller_lines(controller: Controller | None) -> list[str]:
    """u = −K (x − x_eq) for the simulator: kind, gain, equilibrium, and saturation and period if set."""
    if controller is None:
        return []
    lines = [
        f"controller = {controller.kind}",
        f"controller.gain = {_format_list(controller.gain)}",
        f"controller.equilibrium = {_format_list(controller.equilibrium)}",
    ]
    if controller.saturation is not None:
        lines.append(f"controller.saturation = {format_number(controller.saturation)}")
    if controller.period is not None:
        lines.append(f"controller.period = {format_number(controller.period)}")
    return lines


def _format_list(values: tuple[float, ...]) -> str:
    return " ".join(format_number(value) for value in values)


# ---------------------------------------------------------------------------- errors


def _hint(key: str, allowed: tuple[str, ...], table: str) -> str:
    """' (did you mean ...?)' or where the key belongs, for an unknown key."""
    homes = [name for name, keys in schema.TABLES.items() if key in keys and name != table]
    if homes:
        return f" (it belongs in [{homes[0]}])"
    array = key.rstrip("0123456789")
    if table == "parameters" and array in PARAMETER_GROUPS:
        return f" (parameters are arrays: {array} = [base, link 1, ...])"
    close = difflib.get_close_matches(key, allowed, n=1)
    if close:
        return f" (did you mean '{close[0]}'?)"
    return f" (expected one of: {', '.join(allowed)})"


# ---------------------------------------------------------------------------- reading


def _read_text(reader: _Reader) -> str:
    try:
        if reader.path.stat().st_size > limits.MAX_SCENE_BYTES:
            reader.fail(
                f"is {reader.path.stat().st_size} bytes, more than a scene needs "
                f"(at most {limits.MAX_SCENE_BYTES} bytes): is it the right file?"
            )
        data = reader.path.read_bytes()
    except FileNotFoundError:
        reader.fail("no such file")
    except IsADirectoryError:
        reader.fail("is a directory, expected a TOML scene file")
    except OSError as exc:
        reader.fail(f"cannot read file: {exc.strerror or exc}")
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        reader.fail(f"not UTF-8 text (bad byte at offset {exc.start})")


def _parse_toml(reader: _Reader, text: str) -> dict[str, Any]:
    """Parse TOML keeping floats as Decimal, i.e. exactly as written; refuse, before parsing,
    nesting deeper than a scene can need and very long dotted keys (`nesting.py`)."""
    problem = shape_problem(text)
    if problem:
        reader.fail(f"line {problem.line}: {problem.message}")
    try:
        return tomllib.loads(text, parse_float=Decimal)
    except tomllib.TOMLDecodeError as exc:
        reader.fail(f"malformed TOML: {abbreviate(str(exc), 120)}")
    except RecursionError:  # not expected after shape_problem: one line all the same
        reader.fail(f"nested too deeply to parse (at most {limits.MAX_SCENE_NESTING} levels)")


def _check_keys(reader: _Reader, document: dict[str, Any]) -> None:
    """Reject unknown tables and keys (before anything else: a typo explains a missing key)."""
    tables = tuple(schema.TABLES)
    for name, table in document.items():
        if name not in schema.TABLES:
            what = "table" if isinstance(table, dict) else "key"
            reader.fail(f"unknown {what} '{abbreviate(name)}'{_hint(name, tables, '')}")
        if not isinstance(table, dict):
            reader.bad(name, table, f"expected a table: [{name}] on a line of its own")
        allowed = schema.TABLES[name]
        for key in table:
            if key not in allowed:
                reader.fail(f"unknown key '{name}.{abbreviate(key)}'{_hint(key, allowed, name)}")


# ---------------------------------------------------------------------------- validation


def _validate(reader: _Reader, document: dict[str, Any]) -> dict[str, Any]:
    """Each table of `schema.SceneDocument` validated by its model, in the declared order,
    with the context the tables before it give; the first problem as one line."""
    from pydantic import ValidationError

    context: dict[str, Any] = {}
    tables: dict[str, Any] = {}
    for name in schema.TABLE_MODELS:
        if name not in document and name in schema.ABSENT_IS_NONE:
            tables[name] = None
            continue
        data = document.get(name) or schema.WHEN_EMPTY.get(name, {})
        try:
            table = _adapter(name).validate_python(data, context=context)
        except ValidationError as error:
            _refuse(reader, name, data, error.errors(include_url=False), context)
        tables[name] = table
        context.update(table.context())
    return tables


@functools.cache
def _adapter(table: str) -> Any:
    """The pydantic validator of a table (built once)."""
    from pydantic import TypeAdapter

    return TypeAdapter(schema.TABLE_MODELS[table])


def _refuse(
    reader: _Reader, table: str, data: dict[str, Any], errors: list[Any], context: dict[str, Any]
) -> NoReturn:
    """The first of pydantic's `errors` for `table` as ipgen's one-line message (an unknown key
    of an input's kind first, like unknown keys everywhere)."""
    error = next((e for e in errors if e["type"] == "extra_forbidden"), errors[0])
    kind, loc, ctx = error["type"], list(error["loc"]), dict(error.get("ctx") or {})
    model = schema.TABLE_MODELS[table]
    if table == "input":
        kind_name = data.get("kind")
        if kind in ("union_tag_not_found", "union_tag_invalid"):
            if "kind" not in data:
                reader.fail(f"missing required key 'input.kind' (one of: {', '.join(schema.INPUTS)})")
            reader.bad("input.kind", kind_name, f"expected {_one_of(tuple(schema.INPUTS))}")
        model = schema.INPUTS[loc.pop(0)]  # the kind's model: loc = [kind, key, ...]
    key = ctx.get("key") or next((part for part in loc if isinstance(part, str)), "")
    indices = [part for part in loc if isinstance(part, int)] + list(ctx.get("index", ()))
    dotted = f"{table}.{key}" + "".join(f"[{i}]" for i in indices)
    if kind == "scene_value":
        value = ctx["value"] if "value" in ctx else error["input"]
        reader.bad(dotted, _written(value), ctx["expected"])
    if kind == "scene_key":
        reader.fail(dotted + ctx["message"])
    if kind == "scene_line":
        reader.fail(ctx["message"])
    if kind == "missing":
        reader.fail(f"missing required key '{dotted}' ({_kind_of(model, key).expected(context)})")
    if kind == "extra_forbidden" and table == "input":
        takes = ", ".join(schema.INPUT_KEYS[kind_name]) or "no other keys"
        reader.fail(f"{dotted} is not used by a '{kind_name}' input ({kind_name} takes {takes})")
    reader.fail(f"{dotted}: {abbreviate(error['msg'])}")  # not expected: every kind is above


def _kind_of(model: Any, key: str) -> Kind:
    """The `fieldtypes.Kind` declared for `key` of a table model."""
    return next(item for item in model.model_fields[key].metadata if isinstance(item, Kind))


def _written(value: object) -> object:
    """A value as the file has it: an `Exact` number as its decimal text."""
    return Decimal(value.text) if isinstance(value, Exact) else value


# ---------------------------------------------------------------------------- the scene


def _build_scene(reader: _Reader, tables: dict[str, Any]) -> Scene:
    system, parameters = tables["system"], tables["parameters"]
    kind, links = system.type, system.links
    name = system.name or System(kind, links, system.inertia).default_name
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
    if tables["controller"] is not None:
        params = _Parameters(
            _floats(parameters.m), lengths, _floats(parameters.delta), parameters.g.value, links_as_built
        )
        try:
            controller = control.controller(tables["controller"], system, params, actuator, coordinates)
        except control.GainError as error:
            reader.fail(str(error))
    theta = zeros if initial.theta is None else _floats(initial.theta)
    dtheta = zeros if initial.dtheta is None else _floats(initial.dtheta)
    law = None
    if tables["swingup"] is not None:
        if not coordinates.is_canonical:
            reader.fail(
                "[swingup] in the rig's coordinates is not supported yet: remove [system] angles, zero "
                "and positive (the swing-up then uses ipgen's, docs/model.md)"
            )
        if initial.theta is None:  # a swing-up starts hanging unless the scene says otherwise
            theta = (0.0,) + (math.pi,) * links
        params = _Parameters(
            _floats(parameters.m), lengths, _floats(parameters.delta), parameters.g.value, links_as_built
        )
        gain = 1.0
        if actuator.is_motor:  # designed on the motor-folded model, in volts (swing.law)
            params, gain = _motor_folded(params, System(kind, links, system.inertia), actuator)
        try:
            law = swing.law(tables["swingup"], system, params, theta + dtheta, gain, actuator.is_acceleration)
        except swing.SwingUpError as error:
            reader.fail(str(error))
    travel = None if tables["limits"].travel is None else tables["limits"].travel.value
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
        m=_floats(parameters.m),
        l=lengths,
        delta=_floats(parameters.delta),
        g=parameters.g.value,
        theta=theta,
        dtheta=dtheta,
        input=InputSpec(
            kind=spec.kind,
            **{
                key: value if isinstance(value := getattr(spec, key), str) else value.value
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
        warnings=_warnings(reader, simulation["rtol"]),
        controller=controller,
        actuator=actuator,
        coulomb=None if parameters.coulomb is None else _floats(parameters.coulomb),
        coulomb_speed=parameters.coulomb_speed.value,
        swingup=law,
        coordinates=coordinates,
        travel=travel,
    )


@dataclass(frozen=True)
class _Parameters:
    """The physical parameters as floats, for the LQR gain."""

    m: tuple[float, ...]
    l: tuple[float, ...]  # noqa: E741
    delta: tuple[float, ...]
    g: float
    links: tuple[tuple[str, tuple[float, ...]], ...] = ()  # com, J, J_axial, tip the scene gives


def _motor_folded(params: _Parameters, system: System, actuator: Actuator) -> tuple[_Parameters, float]:
    """The motor-folded parameters (`actuator.fold`: δ0 + back-EMF, m0 or J0 + the rotor) and b."""
    from ipgen.model.actuator import fold

    built = dict(params.links)
    given = built.get("J")
    inertias = (
        list(given)
        if given is not None
        else [rod_value(system, "J", i, params.m, params.l) for i in range(system.dof)]
    )
    m, delta, j, gain = fold(actuator, system, list(params.m), list(params.delta), inertias)
    if system.is_rotary or given is not None:
        built["J"] = tuple(j)
    order = [group for group in ("com", "J", "J_axial", "tip") if group in built]
    links = tuple((group, tuple(built[group])) for group in order)
    return _Parameters(tuple(m), params.l, tuple(delta), params.g, links), gain


def _floats(numbers: tuple[Exact, ...]) -> tuple[float, ...]:
    return tuple(number.value for number in numbers)


def _warnings(reader: _Reader, rtol: float) -> tuple[str, ...]:
    if rtol < schema.RTOL_ADVISED:
        return (
            reader.warning(
                f"simulation.rtol = {format_number(rtol)} is below 1e-14 and "
                "may not be met in double precision"
            ),
        )
    return ()
