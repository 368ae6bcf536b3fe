"""`ipgen run` of a fixed-pivot scene (`[system] type = "fixed"`): its run plan.

A fixed scene for `ipgen run` has, besides the chain's [system], [parameters] and [actuator]
(scene/fixed.py), the tables of an open-loop run:

    [initial]     theta, dtheta: one entry per link (link 1 first, the rig's coordinates), default 0
    [input]       m = 1 (one driven joint): the torque of that joint, as any scene's [input]
    [[input]]     m > 1: one table per driven joint, in the order of [actuator] joints
                  (one [input] table is refused then, and so is a count other than m)
    [simulation]  as any scene's;  [outputs] energy = true adds the energy ledger

Each input is the torque [N m] of the motor at its joint, in the rig's positive sense (ipgen's:
clockwise; DFKI's: counterclockwise); [initial] and the CSV's columns are in the rig's coordinates
(`angles`, `zero`, `positive`), as for carts and arms. Coulomb friction acts on the joints'
relative rates in either law (tanh, or DFKI's atan); J may be negative where J + m com² > 0.
[controller] (kind = "lqr": q, r, equilibrium, saturation per input, period; or kind = "gain")
closes the loop with u = −K (x − x_eq), K m × 2n (`fixed_controller`), or kind = "mpc" (one driven
joint: pipeline/fixed_mpc.py); [swingup] (method trajectory, one driven joint) plans or reads a
swing-up (`fixed_swingup_law`), tracked by its TVLQR or (`tracking = "mpc"`) by the MPC. What the simulator
does not take for a fixed chain yet is refused in one line: the measured loop's tables ([sensors],
[estimator]).

The resolved config holds `type = fixed`, `joints`, `Ir`, `gr` (one per input), the per-link
parameters and state (no base entry), `input` and `input.*` for the first input, and `input2`,
`input2.*`, ... for the others (the keys of `input` under a numbered prefix).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ipgen.codegen.fixed_header import fixed_library_sources, fixed_model_name
from ipgen.common.arrays import float_or_inf
from ipgen.common.presets import scene_source
from ipgen.common.version import __version__
from ipgen.control.swingup import SwingUpLaw
from ipgen.errors import Error
from ipgen.experiment.config import CFG_KEYS, mpc_entries
from ipgen.experiment.scene import InputSpec
from ipgen.model.fixed import FixedPendulum
from ipgen.pipeline.fixed_fields import (
    FixedController,
    controller_period,
    numbers,
    scalar,
    weight_matrix,
)
from ipgen.pipeline.fixed_mpc import MPC_KEYS, fixed_mpc, swingup_tracking
from ipgen.pipeline.run_plan import RunPlan
from ipgen.scene import schema
from ipgen.scene.checks import csv_size
from ipgen.scene.fields import Reader, format_number
from ipgen.scene.fixed import KEYS as CHAIN_KEYS
from ipgen.scene.fixed import fixed_pendulum_of

# The tables of a fixed scene that `ipgen run` reads beyond the chain's.
RUN_TABLES: tuple[str, ...] = ("initial", "input", "simulation", "outputs", "controller", "swingup")
SUPPORTED = (
    "[system], [parameters], [actuator], [initial], [input] (or [[input]]), [controller], "
    "[swingup] (method trajectory, one driven joint), [simulation], [outputs]"
)


class _Tables(schema.BaseModel):
    """The run's tables of a fixed scene (validated as any scene's, in this order)."""

    model_config = schema.ConfigDict(extra="forbid")

    simulation: schema.SimulationTable
    outputs: schema.OutputsTable
    input: schema.Input


class _InputReader(Reader):
    """A Reader whose messages name the [[input]] table they are about."""

    def __init__(self, path: Path, which: str) -> None:
        super().__init__(path)
        self.which = which

    def fail(self, message: str) -> Any:
        super().fail(f"{self.which}: {message}")


def _validated(reader: Reader, tables: dict[str, Any]) -> _Tables:
    from pydantic import TypeAdapter, ValidationError

    from ipgen.scene.load import refuse

    context: dict[str, Any] = {}
    try:
        return TypeAdapter(_Tables).validate_python(tables, context=context)
    except ValidationError as error:
        refuse(reader, tables, error.errors(include_url=False), context)


def _spec(table: Any) -> InputSpec:
    return InputSpec(
        kind=table.kind,
        **{
            key: value if isinstance(value := getattr(table, key), str) else float(value)
            for key in schema.INPUT_KEYS[table.kind]
        },
    )


def default_theta(chain: FixedPendulum, document: dict[str, Any]) -> tuple[float, ...]:
    """`[initial] theta` when the scene does not write it, in the chain's coordinates: every link
    hanging with a [swingup] (where its plan starts), else 0 (docs/scenes.md)."""
    if "swingup" not in document:
        return (0.0,) * chain.links
    from ipgen.control.fixed_linear import fixed_equilibrium

    return tuple(float(v) + 0.0 for v in fixed_equilibrium(chain, "hanging"))  # + 0.0: no -0


def _state(reader: Reader, initial: Any, key: str, links: int) -> tuple[float, ...]:
    import math
    from decimal import Decimal

    value = initial.get(key)
    if value is None:
        return (0.0,) * links
    if not isinstance(value, list) or len(value) != links:
        reader.bad(
            f"initial.{key}", value, f"expected {links} numbers (one per link, link 1 first; no base entry)"
        )
    numbers = []
    for i, item in enumerate(value):
        if isinstance(item, bool) or not isinstance(item, int | float | Decimal):
            reader.bad(f"initial.{key}[{i}]", item, "expected a number")
        number = float_or_inf(item)
        if not math.isfinite(number):
            reader.bad(f"initial.{key}[{i}]", item, "must be a finite number")
        numbers.append(number)
    return tuple(numbers)


def fixed_inputs(
    reader: Reader, document: dict[str, Any], joints: tuple[int, ...]
) -> tuple[Any, tuple[InputSpec, ...]]:
    """(the [simulation]/[outputs] tables, one InputSpec per driven joint) of a fixed scene;
    `SceneError` (one line) for a bad table."""
    given = document.get("input")
    simulation, outputs = document.get("simulation", {}), document.get("outputs", {})
    m = len(joints)
    if m == 1:
        if isinstance(given, list):
            if len(given) != 1:
                reader.fail(
                    f"[[input]] has {len(given)} tables, this chain has 1 driven joint ({joints[0]}): "
                    "give one [input] table"
                )
            given = given[0]
        tables = _validated(
            reader, {"simulation": simulation, "outputs": outputs, "input": given or {"kind": "zero"}}
        )
        return tables, (_spec(tables.input),)
    if isinstance(given, dict) and given:
        reader.fail(
            f"[input] is one table, this chain has {m} driven joints ({', '.join(map(str, joints))}): "
            f"give one [[input]] table per joint, in the order of [actuator] joints"
        )
    items = given if isinstance(given, list) else [{"kind": "zero"}] * m
    if len(items) != m:
        reader.fail(
            f"[[input]] has {len(items)} tables, this chain has {m} driven joints "
            f"({', '.join(map(str, joints))}): one [[input]] table per joint, in their order"
        )
    _validated(reader, {"simulation": simulation, "outputs": outputs, "input": {"kind": "zero"}})
    specs = []
    tables = None
    for k, (item, joint) in enumerate(zip(items, joints, strict=True), start=1):
        which = _InputReader(reader.path, f"[[input]] {k} (joint {joint})")
        if not isinstance(item, dict):
            which.bad("input", item, "expected a table")
        tables = _validated(
            which, {"simulation": simulation, "outputs": outputs, "input": item or {"kind": "zero"}}
        )
        specs.append(_spec(tables.input))
    assert tables is not None
    return tables, tuple(specs)


def _check_tables(reader: Reader, document: dict[str, Any], chain: FixedPendulum) -> None:
    for table in document:
        if table in CHAIN_KEYS or table in RUN_TABLES:
            continue
        if table in ("sensors", "estimator"):
            reader.fail(
                f"[{table}] on a fixed-pivot chain: ipgen run simulates fixed chains open-loop, under "
                f"LQR or a planned swing-up for now (supported: {SUPPORTED})"
            )
        reader.fail(f"unknown table [{table}] in a fixed scene (ipgen run reads {SUPPORTED})")
    initial = document.get("initial", {})
    if not isinstance(initial, dict):
        reader.bad("initial", initial, "expected a table: [initial] on a line of its own")
    for key in initial:
        if key not in ("theta", "dtheta"):
            reader.fail(f"unknown key 'initial.{key}' (expected: theta, dtheta)")


CONTROLLER_KEYS: tuple[str, ...] = ("kind", "q", "r", "equilibrium", "saturation", "period", "gain")


def fixed_controller(
    reader: Reader, table: Any, chain: FixedPendulum, settings: dict[str, Any]
) -> FixedController:
    """The [controller] of a fixed scene: kind = "lqr" (q: 2n weights or a 2n × 2n matrix, r: one
    number or m weights, equilibrium "upright" | "hanging" | n angles, saturation: one number or
    m, period) designed by control/fixed_linear.lqr_fixed, or kind = "gain" (gain: K, m × 2n)."""
    from ipgen.control.fixed_linear import fixed_equilibrium, lqr_fixed
    from ipgen.control.linear import ControlError

    if not isinstance(table, dict):
        reader.bad("controller", table, "expected a table: [controller] on a line of its own")
    kind = table.get("kind")
    if kind not in ("lqr", "gain", "mpc"):
        reader.bad("controller.kind", kind, 'expected "lqr", "gain" or "mpc"')
    known = CONTROLLER_KEYS + MPC_KEYS if kind == "mpc" else CONTROLLER_KEYS
    for key in table:
        if key not in known:
            reader.fail(
                f"unknown key 'controller.{key}' in a fixed scene's kind = {kind!r} "
                f"(expected: {', '.join(known)})"
            )
    if kind == "mpc":
        return fixed_mpc(reader, table, chain, settings)
    n, m = chain.links, chain.inputs
    saturation = None
    if "saturation" in table:
        values = numbers(
            reader, "controller.saturation", table["saturation"], (1, m), f"1 or {m} numbers > 0 [N m]"
        )
        if np.any(values <= 0):
            reader.bad("controller.saturation", table["saturation"], "the largest |u| must be > 0 N m")
        saturation = tuple(float(v) for v in np.broadcast_to(values, (m,)))
    period = controller_period(reader, table, settings)
    try:
        equilibrium = fixed_equilibrium(chain, table.get("equilibrium"))
        if kind == "gain":
            for key in ("q", "r"):
                if key in table:
                    reader.fail(f'controller.{key}: kind = "gain" takes its gain as given (remove {key})')
            if "gain" not in table:
                reader.fail(
                    "missing required key 'controller.gain' (kind = \"gain\": K, m rows of 2n numbers)"
                )
            gain = numbers(
                reader, "controller.gain", table["gain"], (m * 2 * n,), f"{m} × {2 * n} numbers (K)"
            )
            gain = gain.reshape(m, 2 * n)
        else:
            if "gain" in table:
                reader.fail('controller.gain: kind = "lqr" computes K (remove gain, or kind = "gain")')
            q = weight_matrix(reader, "controller.q", table.get("q", [1.0] * (2 * n)), 2 * n)
            r = numbers(reader, "controller.r", table.get("r", 1.0), (1, m), f"1 or {m} weights > 0")
            gain = lqr_fixed(chain, q, r, equilibrium)
    except ControlError as exc:
        reader.fail(f"[controller]: {exc}")
    state = np.concatenate([equilibrium, np.zeros(n)])
    return FixedController(str(kind), gain, state, saturation, period)


SWINGUP_KEYS: tuple[str, ...] = (
    "method",
    "tracking",
    "u_max",
    "duration",
    "period",
    "hold",
    "plan",
    "margin",
    "weight_rate",
    "weight_velocity",
)


def fixed_swingup_law(
    reader: Reader,
    table: Any,
    chain: FixedPendulum,
    settings: dict[str, Any],
    path: Path,
    start: Callable[[], None] = lambda: None,
) -> Any:
    """The [swingup] of a fixed scene: method = "trajectory" (the only one), u_max [N m] on the
    driven joint, duration [s] of the plan, period [s] (default 0.002), hold [s] (default: up to
    t_end), plan (a CSV of control/fixed_swingup.write_plan, relative to the scene: taken instead
    of planning), margin, weight_rate, weight_velocity (the planner's). Plans with IPOPT when no
    plan file is given (seconds to a minute); `start` is called before, once the table's keys are
    read (the scene's start is checked there)."""
    from ipgen.control.fixed_swingup import MAX_PLAN_ROWS, fixed_swingup, read_plan
    from ipgen.control.linear import ControlError

    if not isinstance(table, dict):
        reader.bad("swingup", table, "expected a table: [swingup] on a line of its own")
    for key in table:
        if key not in SWINGUP_KEYS:
            reader.fail(f"unknown key 'swingup.{key}' in a fixed scene (expected: {', '.join(SWINGUP_KEYS)})")
    if table.get("method") != "trajectory":
        reader.bad("swingup.method", table.get("method"), 'expected "trajectory" (a fixed chain\'s swing-up)')
    if chain.inputs != 1:
        reader.fail(f"[swingup] drives one joint; this chain drives {chain.inputs} ({chain.joints})")

    def number(key: str, default: float | None = None) -> float:
        if key not in table:
            if default is None:
                reader.fail(f"missing required key 'swingup.{key}'")
            return float(default)  # type: ignore[arg-type]
        value = float(numbers(reader, f"swingup.{key}", table[key], (1,), "a number > 0")[0])
        if value <= 0:
            reader.bad(f"swingup.{key}", table[key], "expected a number > 0")
        return value

    u_max, duration = number("u_max"), number("duration")
    period = number("period", 0.002)
    if duration / period > MAX_PLAN_ROWS - 1:  # as a cart's or an arm's swing-up (scene.swingup)
        reader.bad(
            "swingup.duration",
            table["duration"],
            f"more than {MAX_PLAN_ROWS - 1} periods: a shorter duration or a longer period",
        )
    t_end = float(settings.get("t_end") or 0.0)
    hold = max(t_end - duration, 0.0)
    if "hold" in table:  # s held upright after the plan, then the run ends; 0: it ends with the plan
        hold = scalar(reader, "swingup.hold", table["hold"], "a number of seconds >= 0")
        if hold < 0:
            reader.bad("swingup.hold", table["hold"], "expected a number of seconds >= 0")
    options = {key: number(key) for key in ("margin", "weight_rate", "weight_velocity") if key in table}
    start()  # the scene's start checked after the table's keys, before IPOPT plans (seconds)
    try:
        plan = None
        if "plan" in table:
            if not isinstance(table["plan"], str):
                reader.bad("swingup.plan", table["plan"], "expected a file name (a plan CSV)")
            plan = read_plan(chain, path.parent / table["plan"], period)
            if abs(len(plan.inputs) * period - duration) > 1e-9:
                reader.fail(
                    f"swingup.plan lasts {len(plan.inputs) * period:g} s, swingup.duration = {duration:g} s"
                )
            if np.max(np.abs(plan.inputs)) > u_max:
                reader.fail(f"swingup.plan exceeds |u| <= swingup.u_max = {u_max:g} N m")
        law, _ = fixed_swingup(
            chain, duration=duration, u_max=u_max, hold=hold, period=period, plan=plan, **options
        )
    except ControlError as exc:
        reader.fail(f"[swingup]: {exc}")
    return law


def _put(lines: list[str], key: str, value: object) -> None:
    base = key
    if key.startswith("input") and key[5:6].isdigit():  # input2, input2.amplitude: input's keys
        base = "input" + key[5:].lstrip("0123456789")
    if base not in CFG_KEYS:
        raise KeyError(f"{key!r} is not a key of the resolved config (CFG_KEYS)")
    if isinstance(value, bool):
        text = "true" if value else "false"
    elif isinstance(value, float):
        text = format_number(value)
    elif isinstance(value, tuple | list):
        text = " ".join(format_number(float(item)) for item in value)
    else:
        text = str(value)
    lines.append(f"{key} = {text}")


def fixed_config(
    path: Path,
    chain: FixedPendulum,
    name: str,
    theta: tuple[float, ...],
    dtheta: tuple[float, ...],
    inputs: tuple[InputSpec, ...],
    settings: dict[str, Any],
    energy: bool,
    controller: FixedController | None = None,
    swingup: Any = None,
    tracking: str = "lqr",
) -> str:
    """The resolved config of a fixed scene's run (module docstring)."""
    lines = [f"# Generated by ipgen {__version__} from {scene_source(path)}; do not edit"]
    _put(lines, "name", path.stem)
    _put(lines, "model", name)
    _put(lines, "type", "fixed")
    _put(lines, "links", chain.links)
    _put(lines, "joints", [float(j) for j in chain.joints])
    _put(lines, "m", chain.m)
    _put(lines, "l", chain.l)
    _put(lines, "delta", chain.delta)
    _put(lines, "g", chain.g)
    _put(lines, "com", chain.resolved("com"))
    _put(lines, "J", chain.resolved("J"))
    if any(chain.coulomb or ()):
        _put(lines, "coulomb", chain.coulomb)
        if chain.coulomb_law == "atan":
            _put(lines, "coulomb_law", "atan")
            _put(lines, "coulomb_gain", chain.coulomb_gain)
        else:
            _put(lines, "coulomb_speed", chain.coulomb_speed)
    _put(lines, "Ir", chain.motor("Ir"))
    _put(lines, "gr", chain.motor("gr"))
    if not chain.coordinates.is_canonical:
        lines.append(
            "# the rig's coordinates (docs/model.md): theta, dtheta, the inputs' sign and the CSV's "
            "columns are in them"
        )
        _put(lines, "angles", chain.angles)
        _put(lines, "zero", chain.zero)
        _put(lines, "positive", chain.positive)
    _put(lines, "theta", theta)
    _put(lines, "dtheta", dtheta)
    for k, spec in enumerate(inputs, start=1):
        prefix = "input" if k == 1 else f"input{k}"
        _put(lines, prefix, spec.kind)
        for key, value in spec.fields():
            _put(lines, f"{prefix}.{key}", value)
        if spec.kind == "multisine":
            _put(lines, f"{prefix}.frequencies", spec.lines.frequencies)
            _put(lines, f"{prefix}.phases", spec.lines.phases)
            _put(lines, f"{prefix}.scale", spec.lines.scale)
    for key in ("t_end", "sample", "method", "jacobian", "step", "rtol", "atol", "max_steps"):
        if settings.get(key) is not None:
            _put(lines, key, settings[key])
    if energy:
        _put(lines, "energy", True)
    if controller is not None and controller.mpc is not None:
        lines.append(
            "# [controller] kind = mpc: the problem in ipgen's coordinates (u: the joint's torque, clockwise)"
        )
        _put(lines, "controller", "mpc")
        assert controller.period is not None
        for key, value in mpc_entries(controller.period, controller.mpc):
            _put(lines, key, value)
    elif controller is not None:
        _put(lines, "controller", controller.kind)
        _put(lines, "controller.gain", tuple(controller.gain.reshape(-1)))
        _put(lines, "controller.equilibrium", tuple(controller.equilibrium))
        if controller.saturation is not None:
            _put(lines, "controller.saturation", controller.saturation)
        if controller.period is not None:
            _put(lines, "controller.period", controller.period)
    if swingup is not None:
        lines.append(
            "# [swingup]: the plan (control/fixed_swingup.py), its TVLQR gains and the hold LQR, in the "
            "rig's coordinates"
        )
        _put(lines, "swingup", swingup.method)
        for key in ("u_max", "period", "hold", "hold_gain", "target", "steps", "inputs", "states", "gains"):
            _put(lines, f"swingup.{key}", getattr(swingup, key))
        if tracking == "mpc":
            _put(lines, "swingup.tracking", "mpc")
    return "\n".join(lines) + "\n"


@dataclass(frozen=True)
class FixedScene:
    """A fixed scene checked as `ipgen run` checks it: its chain, resolved config, model library's
    name, controller (None without [controller]) and swing-up (None without [swingup])."""

    chain: FixedPendulum
    cfg: str
    library: str
    controller: FixedController | None
    swingup: SwingUpLaw | None  # its tracking the scene's (swingup.tracking)
    warnings: tuple[str, ...] = ()  # announced by `ipgen run`, the run goes on


def fixed_plan(path: Path, document: dict[str, Any], reader: Reader) -> RunPlan:
    """The run plan of a fixed scene (its checks first, each problem one line)."""
    scene = fixed_scene(path, document, reader)
    chain = scene.chain
    try:
        _, sources = fixed_library_sources(chain.links, tuple(chain.joints))
    except Error as exc:  # pragma: no cover - the chain was checked
        reader.fail(str(exc))
    return RunPlan(
        name=scene.library,
        stem=path.stem,
        type="fixed",
        links=chain.links,
        angles=chain.angles,
        zero=chain.zero,
        positive=chain.positive,
        unit=None,
        warnings=scene.warnings,
        cfg=scene.cfg,
        sources=sources,
    )


def _starts_hanging(
    reader: Reader, chain: FixedPendulum, theta: tuple[float, ...], dtheta: tuple[float, ...]
) -> None:
    """A swing-up's plan goes from hanging at rest: an [initial] elsewhere is refused (the run
    tracked a plan from a state it was not in, and ended with exit 5)."""
    import math

    from ipgen.control.fixed_linear import fixed_equilibrium

    hanging = fixed_equilibrium(chain, "hanging")
    off = [math.remainder(angle - rest, 2 * math.pi) for angle, rest in zip(theta, hanging, strict=True)]
    if max(map(abs, off)) > 1e-9 or any(rate != 0 for rate in dtheta):
        shown = ", ".join(f"{angle + 0.0:g}" for angle in hanging)  # + 0.0: no -0
        reader.fail(
            f"[swingup] plans from hanging at rest, [initial] starts elsewhere: remove [initial] or set "
            f"theta = [{shown}] and dtheta = 0 (hanging, in the chain's coordinates)"
        )


def fixed_scene(path: Path, document: dict[str, Any], reader: Reader, model: str | None = None) -> FixedScene:
    """A fixed scene's parts (`FixedScene`), every table checked, each problem one line; its config
    names `model` (`ipgen --scene -o`: the header's), else the library `ipgen run` builds."""
    chain_tables = {table: value for table, value in document.items() if table in CHAIN_KEYS}
    chain = fixed_pendulum_of(reader, chain_tables)
    _check_tables(reader, document, chain)
    initial = document.get("initial", {})
    given = initial.get("theta") is not None
    theta = _state(reader, initial, "theta", chain.links) if given else default_theta(chain, document)
    dtheta = _state(reader, initial, "dtheta", chain.links)
    tables, inputs = fixed_inputs(reader, document, tuple(chain.joints))
    name = fixed_model_name(chain.links, tuple(chain.joints))
    settings = tables.simulation.settings()
    controller = None
    if "controller" in document:
        if any(spec.kind != "zero" for spec in inputs):
            reader.fail(
                '[controller] sets the torques: remove [input] / [[input]] (or make them kind = "zero")'
            )
        controller = fixed_controller(reader, document["controller"], chain, settings)
    swingup, tracking = None, "lqr"
    if "swingup" in document:
        if controller is not None and controller.mpc is None:
            reader.fail(
                '[swingup] has its own controller: remove [controller] (or make it kind = "mpc", which holds)'
            )
        if any(spec.kind != "zero" for spec in inputs):
            reader.fail('[swingup] sets the torque: remove [input] (or make it kind = "zero")')

        def starts_hanging() -> None:  # checked after the table's keys, before IPOPT plans
            _starts_hanging(reader, chain, theta, dtheta)

        swingup = fixed_swingup_law(reader, document["swingup"], chain, settings, path, start=starts_hanging)
        tracking = swingup_tracking(reader, document["swingup"], controller)
    cfg = fixed_config(
        path, chain, model or name, theta, dtheta, inputs, settings, bool(tables.outputs.energy), controller,
        swingup, tracking,
    )  # fmt: skip
    tracked = dataclasses.replace(swingup, tracking=tracking) if swingup is not None else None
    size = csv_size(float(settings["t_end"]), float(settings["sample"]), chain.links)
    return FixedScene(chain, cfg, name, controller, tracked, tuple(map(reader.warning, size)))


__all__ = [
    "FixedController", "FixedScene", "fixed_config", "fixed_controller", "fixed_inputs", "fixed_plan",
    "fixed_scene",
]  # fmt: skip
