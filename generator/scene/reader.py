"""Scene files: one experiment per small TOML file, checked and flattened for the simulator.

A scene has these tables (SI units throughout; arrays have links + 1 entries, index 0 is the base
— cart or arm — and 1..n are the links):

    [system]      type = "classical" | "rotary" (required); links >= 1 (required);
                  inertia = "pivot" (default) | "full" (rotary only);
                  name = C++ model name (default "<type><links>")
    [parameters]  m, l, delta: arrays (required); g (default 9.81);
                  free = ["m0", "delta1", ...] (optional; names m<i>, l<i>, delta<i>, g)
                  l[0] is the arm length (rotary, > 0); a cart has none: write 0 (it is ignored)
    [initial]     theta, dtheta: arrays (default all zero: upright, at rest)
    [input]       kind = zero (default) | constant | pulse | step | sine, with
                  constant: amplitude; pulse: amplitude, duration, start (default 0);
                  step: amplitude, time; sine: amplitude, frequency [Hz], phase [rad] (default 0)
    [simulation]  t_end (required); sample (0.01); max_steps (100000);
                  method = "bdf" (default) | "adams" | "adams-fixed-point" | "erk-dp5" |
                  "erk-fehlberg8" | "rk4";
                  jacobian = "exact" (default) | "dq" (bdf and adams only);
                  rtol (1e-10), atol (1e-12) (every method but rk4);
                  step = fixed step in s, > 0 and <= sample (rk4 only, required there)
    [outputs]     energy = true | false (default false)
    [controller]  kind = "lqr"; q, r, equilibrium, saturation, period (see scene_controller.py):
                  u = −K (x − x_eq), K computed here and written into the resolved config

`load_scene` reads and validates a file; every problem is a one-line `SceneError` naming the
file and the dotted key. `resolved_config` writes the flat `key = value` text the C++
simulator reads.
"""

from __future__ import annotations

import difflib
import math
import re
import tomllib
from dataclasses import dataclass
from decimal import Decimal
from fractions import Fraction
from pathlib import Path
from typing import Any

from ipgen.codegen.emit import DEFAULT_EMIT, EmitError, parse_emit
from ipgen.common import limits
from ipgen.common.naming import name_problem
from ipgen.common.safetext import abbreviate, quote_path
from ipgen.common.version import __version__
from ipgen.control.controller import Controller
from ipgen.model.links import LinkError, resolve_links
from ipgen.model.system import (
    LINK_GROUPS,
    PARAMETER_GROUPS,
    System,
    parameter_names,
    parameter_range,
    split_parameter,
    unused_parameter,
)
from ipgen.scene import schema
from ipgen.scene.fields import _one_of, _Reader, _Section, _type_name, format_number


@dataclass(frozen=True)
class InputSpec:
    """The input on the base (force on the cart [N] or torque on the arm [N m]) over time."""

    kind: str = "zero"
    amplitude: float = 0.0
    start: float = 0.0  # pulse
    duration: float = 0.0  # pulse
    time: float = 0.0  # step
    frequency: float = 0.0  # sine, Hz
    phase: float = 0.0  # sine, rad

    def fields(self) -> tuple[tuple[str, float], ...]:
        """The (key, value) pairs this kind uses, in resolved-config order."""
        return tuple((key, getattr(self, key)) for key in schema.INPUT_KEYS[self.kind])

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
        return 0.0

    def breakpoints(self) -> tuple[float, ...]:
        """Times where the input jumps: an integrator must stop and restart there."""
        if self.kind == "pulse":
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

    @property
    def system(self) -> System:
        """The system the scene simulates."""
        return System(self.type, self.links, self.inertia)  # type: ignore[arg-type]

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
    return _build_scene(reader, document)


def resolved_config(scene: Scene) -> str:
    """The flat `key = value` text the C++ simulator reads (deterministic, numbers exact)."""
    lines = [
        f"# Generated by ipgen {__version__} from {quote_path(scene.path.as_posix())}; do not edit",
        f"name = {scene.stem}",
        f"model = {scene.name}",
        f"type = {scene.type}",
        f"links = {scene.links}",
        f"inertia = {scene.inertia}",
        f"m = {_format_list(scene.m)}",
        f"l = {_format_list(scene.l)}",
        f"delta = {_format_list(scene.delta)}",
        f"g = {format_number(scene.g)}",
        *(f"{group} = {_format_list(values)}" for group, values in scene.links_as_built),
        f"theta = {_format_list(scene.theta)}",
        f"dtheta = {_format_list(scene.dtheta)}",
        f"input = {scene.input.kind}",
    ]
    lines += [f"input.{key} = {format_number(value)}" for key, value in scene.input.fields()]
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
    return "\n".join(lines) + "\n"


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


# Tokens of a TOML text that matter for its nesting: strings and comments (skipped), brackets
# and braces (counted), and runs of dotted key parts.
_TOML_TOKENS = re.compile(r""""(?:\\.|[^"\\\n])*"|'[^'\n]*'|#[^\n]*|[\[\]{}]""")
_DOTTED_KEY = re.compile(
    r"(?:(?:[A-Za-z0-9_-]+|\"[^\"\n]*\"|'[^'\n]*')[ \t]*\.[ \t]*){" + str(limits.MAX_DOTTED_KEY_PARTS) + "}"
)


def _check_nesting(reader: _Reader, text: str) -> None:
    """Refuse, before parsing, arrays or tables nested deeper than a scene can need and very long
    dotted keys: the TOML parser recurses once per level and spends memory quadratic in a
    dotted key's length."""
    depth = 0
    for token in _TOML_TOKENS.finditer(text):
        bracket = token.group()
        if bracket in "[{":
            depth += 1
            if depth > limits.MAX_SCENE_NESTING:
                line = text.count("\n", 0, token.start()) + 1
                reader.fail(
                    f"line {line}: arrays or tables nested more than {limits.MAX_SCENE_NESTING} "
                    "deep; a scene needs two levels at most"
                )
        elif bracket in "]}":
            depth = max(depth - 1, 0)
    dotted = _DOTTED_KEY.search(text)
    if dotted:
        line = text.count("\n", 0, dotted.start()) + 1
        reader.fail(
            f"line {line}: a dotted key of more than {limits.MAX_DOTTED_KEY_PARTS} parts; "
            "scene keys have two (table.key)"
        )


def _parse_toml(reader: _Reader, text: str) -> dict[str, Any]:
    """Parse TOML keeping floats as Decimal, i.e. exactly as written."""
    _check_nesting(reader, text)
    try:
        return tomllib.loads(text, parse_float=Decimal)
    except tomllib.TOMLDecodeError as exc:
        reader.fail(f"malformed TOML: {abbreviate(str(exc), 120)}")
    except RecursionError:  # not expected after _check_nesting: one line all the same
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


# ---------------------------------------------------------------------------- sections


@dataclass(frozen=True)
class _System:
    type: str
    links: int
    inertia: str
    name: str
    specialise: bool
    emit: tuple[str, ...]


def _build_scene(reader: _Reader, document: dict[str, Any]) -> Scene:
    system = _read_system(_Section(reader, document, "system"))
    parameters = _Section(reader, document, "parameters")
    params = _read_parameters(parameters, system)
    free = _read_free(parameters, system)
    if free and not system.specialise:
        parameters.bad(
            "free", list(free), "applies to specialised code only: add specialise = true to [system]"
        )
    if system.specialise:
        _check_foldable(parameters, system, params, free)
    initial = _Section(reader, document, "initial")
    theta = _floats(initial.numbers("theta", system.links + 1, default=0))
    dtheta = _floats(initial.numbers("dtheta", system.links + 1, default=0))
    spec = _read_input(_Section(reader, document, "input"))
    sim = _read_simulation(_Section(reader, document, "simulation"))
    energy = _Section(reader, document, "outputs").boolean("energy", default=False)
    from ipgen.scene.controller import read_controller  # numpy and scipy only for a [controller]

    controller = None
    if "controller" in document:
        section = _Section(reader, document, "controller")
        controller = read_controller(section, system, params, spec.kind, sim["sample"], sim["t_end"])
    return Scene(
        path=reader.path,
        stem=reader.path.stem,
        type=system.type,
        links=system.links,
        inertia=system.inertia,
        name=system.name,
        m=params.m,
        l=params.l,
        delta=params.delta,
        g=params.g,
        theta=theta,
        dtheta=dtheta,
        input=spec,
        **sim,
        free=free,
        energy=energy,
        specialise=system.specialise,
        emit=system.emit,
        decimals=params.decimals,
        links_as_built=params.links,
        warnings=_warnings(reader, sim["rtol"]),
        controller=controller,
    )


def _read_system(section: _Section) -> _System:
    kind = section.choice("type", schema.SYSTEM_TYPES)
    links = section.integer("links", "an integer >= 1: the number of pendulum links")
    if links < 1:
        section.bad("links", links, "expected an integer >= 1 (the number of pendulum links)")
    if kind == "classical" and section.has("inertia"):
        section.bad(
            "inertia",
            section.data["inertia"],
            "applies to rotary systems only; remove it",
        )
    inertia = section.choice("inertia", schema.INERTIAS, default=schema.DEFAULT_INERTIA)
    name = _read_name(section, System(kind, links, inertia).default_name)  # type: ignore[arg-type]
    specialise = section.boolean("specialise", default=False)
    return _System(kind, links, inertia, name, specialise, _read_emit(section))


def _read_emit(section: _Section) -> tuple[str, ...]:
    if not section.has("emit"):
        return DEFAULT_EMIT
    value = section.data["emit"]
    if not isinstance(value, list):
        section.bad(
            "emit", value, f'expected an array of target names, e.g. ["cpp"], got {_type_name(value)}'
        )
    try:
        return parse_emit(value, where=section.key("emit"))
    except EmitError as e:
        section.reader.fail(str(e))


def _read_name(section: _Section, default: str) -> str:
    if not section.has("name"):
        return default
    name = section.data["name"]
    if not isinstance(name, str):
        section.bad("name", name, f"expected a string, got {_type_name(name)}")
    problem = name_problem(name)
    if problem:
        section.bad("name", name, f"{problem}; choose another model name")
    return name


@dataclass(frozen=True)
class _Parameters:
    m: tuple[float, ...]
    l: tuple[float, ...]  # noqa: E741
    delta: tuple[float, ...]
    g: float
    decimals: tuple[tuple[str, str], ...]  # ("m0", "0.3"), ..., ("g", "9.81"), ("com1", "0.15"), ...
    # The links as built the scene gives (com, J, J_axial, tip; absent: the rods' values)
    links: tuple[tuple[str, tuple[float, ...]], ...] = ()


def _read_parameters(section: _Section, system: _System) -> _Parameters:
    """m, l, delta, g and the decimal text of each (named m0, l1, delta2, g, ...)."""
    count = system.links + 1
    m = section.numbers("m", count)
    l = section.numbers("l", count)  # noqa: E741
    delta = section.numbers("delta", count)
    for i, (value, _) in enumerate(m):
        if value <= 0:
            section.bad(f"m[{i}]", value, "masses must be > 0 kg")
    _check_lengths(section, l, system.type)
    if system.type == "classical":
        l[0] = (0.0, "0")  # a cart has no length: whatever was written is ignored
    for i, (value, _) in enumerate(delta):
        if value < 0:
            section.bad(f"delta[{i}]", value, "damping must be >= 0")
    g = section.exact_number("g", "gravity in m/s^2", default=schema.DEFAULT_G)
    if g[0] < 0:
        section.bad("g", g[0], "gravity must be >= 0 m/s^2 (0 switches it off)")
    decimals = [
        (f"{base}{i}", text)
        for base, values in (("m", m), ("l", l), ("delta", delta))
        for i, (_, text) in enumerate(values)
    ]
    decimals.append(("g", g[1]))
    links = _read_links(section, system, _floats(m), _floats(l))
    for group, values in links:
        decimals += [(f"{group}{i}", text) for i, (_, text) in enumerate(values)]
    built = tuple((group, _floats(list(values))) for group, values in links)
    return _Parameters(_floats(m), _floats(l), _floats(delta), g[0], tuple(decimals), built)


def _read_links(
    section: _Section, system: _System, m: tuple[float, ...], lengths: tuple[float, ...]
) -> tuple[tuple[str, tuple[tuple[float, str], ...]], ...]:
    """The optional arrays com, J, J_axial, tip (docs/model.md, "Links as built"), checked by
    `model.links`: finite; J, J_axial, tip >= 0; J_axial <= 2 J; some inertia about each pivot."""
    count = system.links + 1
    given = {group: tuple(section.numbers(group, count)) for group in LINK_GROUPS if section.has(group)}
    if not given:
        return ()  # the rods: nothing to check
    if "J_axial" in given and not (system.type == "rotary" and system.inertia == "full"):
        section.bad(
            "J_axial",
            [v for v, _ in given["J_axial"]],
            'counts only for a rotary system with inertia = "full"',
        )
    try:
        resolve_links(
            System(system.type, system.links, system.inertia),  # type: ignore[arg-type]
            m,
            lengths,
            {group: [v for v, _ in values] for group, values in given.items()},
        )
    except LinkError as problem:
        section.reader.fail(f"{section.name}: {problem}")
    return tuple((group, values) for group, values in given.items())


def _check_foldable(section: _Section, system: _System, params: _Parameters, free: tuple[str, ...]) -> None:
    """Every parameter a specialised header folds must be in the range folding accepts."""
    for name, text in params.decimals:
        if name in free or unused_parameter(system.type, name):
            continue
        problem = limits.fold_problem(text)
        if problem:
            group, index = split_parameter(name)
            key = group if index is None else f"{group}[{index}]"
            section.bad(key, Decimal(text), f"{problem} (specialise = true folds it; or list it in free)")


def _check_lengths(section: _Section, lengths: list[tuple[float, str]], kind: str) -> None:
    base = lengths[0][0]
    if kind == "rotary" and base <= 0:
        section.bad("l[0]", base, "the arm length must be > 0 m")
    if kind == "classical" and base < 0:
        section.bad("l[0]", base, "a cart has no length: write 0 (it is ignored)")
    for i, (value, _) in enumerate(lengths[1:], start=1):
        if value <= 0:
            section.bad(f"l[{i}]", value, "link lengths must be > 0 m")


def _floats(pairs: list[tuple[float, str]]) -> tuple[float, ...]:
    return tuple(value for value, _ in pairs)


def _read_free(section: _Section, system: _System) -> tuple[str, ...]:
    """Names of parameters a later feature keeps symbolic (validated, then just carried)."""
    if not section.has("free"):
        return ()
    value = section.data["free"]
    if not isinstance(value, list):
        section.bad("free", value, f"expected an array of names, got {_type_name(value)}")
    names = parameter_names(system.links)
    seen: list[str] = []
    for i, name in enumerate(value):
        key = f"free[{i}]"
        if not isinstance(name, str) or name not in names:
            close = difflib.get_close_matches(name, names, n=1) if isinstance(name, str) else []
            hint = f" (did you mean '{close[0]}'?)" if close else ""
            section.bad(
                key,
                name,
                f"expected a parameter name {parameter_range(system.links)}{hint}",
            )
        unused = unused_parameter(system.type, name)
        if unused:
            section.bad(key, name, f"{unused}: it cannot be free")
        if name in seen:
            section.bad(key, name, "is listed twice")
        seen.append(name)
    return tuple(seen)


def _read_input(section: _Section) -> InputSpec:
    kind = section.choice("kind", tuple(schema.INPUT_KEYS), default="zero")
    if section.data and not section.has("kind"):
        section.reader.fail(f"missing required key 'input.kind' (one of: {', '.join(schema.INPUT_KEYS)})")
    used = schema.INPUT_KEYS[kind]
    for key in section.data:
        if key != "kind" and key not in used:
            takes = ", ".join(used) if used else "no other keys"
            section.reader.fail(f"{section.key(key)} is not used by a '{kind}' input ({kind} takes {takes})")
    values: dict[str, float] = {}
    for key in used:
        default = None if key in schema.INPUT_REQUIRED[kind] else schema.INPUT_DEFAULTS[key]
        values[key] = section.number(key, _INPUT_EXPECTED[key], default)
    _check_input(section, kind, values)
    return InputSpec(kind=kind, **values)


_INPUT_EXPECTED = {
    "amplitude": "a number: N on a cart, N m on an arm",
    "start": "a time in s",
    "duration": "a time in s, > 0",
    "time": "a time in s",
    "frequency": "a frequency in Hz, >= 0",
    "phase": "an angle in rad",
}


def _check_input(section: _Section, kind: str, values: dict[str, float]) -> None:
    if kind == "pulse" and values["start"] < 0:
        section.bad("start", values["start"], "must be >= 0 s (the simulation starts at 0)")
    if kind == "pulse" and values["duration"] <= 0:
        section.bad("duration", values["duration"], "a pulse duration must be > 0 s")
    if kind == "step" and values["time"] < 0:
        section.bad("time", values["time"], "must be >= 0 s (the simulation starts at 0)")
    if kind == "sine" and values["frequency"] < 0:
        section.bad("frequency", values["frequency"], "must be >= 0 Hz")


def _read_simulation(section: _Section) -> dict[str, Any]:
    t_end = section.number("t_end", "the simulated time in s, > 0")
    if t_end <= 0:
        section.bad("t_end", t_end, "must be > 0 s")
    sample = section.number("sample", "", default=schema.DEFAULT_SAMPLE)
    if not 0 < sample <= t_end:
        section.bad("sample", sample, f"must be > 0 s and <= t_end ({format_number(t_end)} s)")
    if t_end / sample > limits.MAX_SAMPLES:
        section.bad(
            "sample",
            sample,
            f"t_end / sample = {t_end / sample:.3g} output samples, more than the {limits.MAX_SAMPLES:.0e} "
            "the simulator accepts: sample less often or shorten t_end",
        )
    rtol = section.number("rtol", "", default=schema.DEFAULT_RTOL)
    if not 0 < rtol < 1:
        section.bad("rtol", rtol, "must be in (0, 1); 1e-10 is a good choice")
    if rtol < schema.RTOL_MIN:
        section.bad("rtol", rtol, "cannot be met in double precision; use >= 1e-14")
    atol = section.number("atol", "", default=schema.DEFAULT_ATOL)
    if atol < 0:
        section.bad("atol", atol, "must be >= 0")
    max_steps = section.integer("max_steps", "", default=schema.DEFAULT_MAX_STEPS)
    if max_steps < 1:
        section.bad("max_steps", max_steps, "must be an integer >= 1")
    method = section.choice("method", schema.METHODS, default=schema.DEFAULT_METHOD)
    return {
        "t_end": t_end,
        "sample": sample,
        "method": method,
        "rtol": rtol,
        "atol": atol,
        "max_steps": max_steps,
        "jacobian": _read_jacobian(section, method),
        "step": _read_step(section, method, sample),
    }


def _read_jacobian(section: _Section, method: str) -> str | None:
    """bdf and adams: "exact" (default) or "dq"; any other method has no Jacobian to choose."""
    if method not in schema.JACOBIAN_METHODS:
        if section.has("jacobian"):
            section.bad(
                "jacobian",
                section.data["jacobian"],
                f"applies to methods {_one_of(schema.JACOBIAN_METHODS)} only "
                f'(method is "{method}"); remove it',
            )
        return None
    return section.choice("jacobian", schema.JACOBIANS, default=schema.DEFAULT_JACOBIAN)


def _read_step(section: _Section, method: str, sample: float) -> float | None:
    """rk4: the fixed step, required, in (0, sample]; the other methods choose their own steps."""
    if method not in schema.FIXED_STEP_METHODS:
        if section.has("step"):
            section.bad(
                "step",
                section.data["step"],
                f'applies to method "rk4" only (method "{method}" chooses its own steps); remove it',
            )
        return None
    for key in ("rtol", "atol"):
        if section.has(key):
            fixed = 'does not apply to method "rk4" (it has a fixed step); remove it'
            section.bad(key, section.data[key], fixed)
    step = section.number("step", 'the fixed step of method "rk4" in s, > 0 and <= sample')
    if not 0 < step <= sample:
        section.bad("step", step, f"must be > 0 s and <= sample ({format_number(sample)} s)")
    return step


def _warnings(reader: _Reader, rtol: float) -> tuple[str, ...]:
    if rtol < schema.RTOL_ADVISED:
        return (
            reader.warning(
                f"simulation.rtol = {format_number(rtol)} is below 1e-14 and "
                "may not be met in double precision"
            ),
        )
    return ()
