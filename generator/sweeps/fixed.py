"""Sweeps of fixed-pivot chains (`[system] type = "fixed"`: the acrobot, the pendubot, DFKI's
double pendulum): the keys they take, the scorecard's criteria that apply, a run's resolved
config and its judgement.

A fixed scene runs as `ipgen run` runs it (pipeline/fixed_run.py: `fixed_plan`). As for carts and
arms, the plant changes and the controller does not: a run whose overrides are not design keys
gets the nominal scene's [controller] or [swingup] lines (the LQR gain, or the planned swing-up
with its TVLQR gains and the hold) verbatim, while its chain, initial state and simulation are
the overridden ones; a [controller]/[swingup] key designs anew. The goal is the controller's
equilibrium or the swing-up's target, in the scene's own coordinates (the CSV's). Beyond the
success test (`success.judge`, every link a coordinate: there is no base), a run passes only if
every torque stayed within its bound (the swing-up's u_max, the controller's saturation).

Not yet for fixed chains: the measured loop's criteria (resolution, sensor_noise, delay), the
drive's (drive_noise, lag, pulses): `ipgen run` simulates a fixed chain without [sensors] or
drive effects, so the scorecard records them as refused and `--only` refuses them in one line.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ipgen.common.safetext import abbreviate
from ipgen.model.fixed import FixedPendulum
from ipgen.sweeps import overrides as override
from ipgen.sweeps import scorecard
from ipgen.sweeps.design_model import model_lines
from ipgen.sweeps.spec import Criterion, Key, Level, SweepError, parse_levels, parse_vary, split_key
from ipgen.sweeps.success import Judgement, Success, judge

# The keys a fixed scene's sweep may override, by table (numbers, or one entry of an array).
KEYS: dict[str, tuple[str, ...]] = {
    "parameters": ("m", "l", "delta", "g", "com", "J", "coulomb", "coulomb_speed", "coulomb_gain"),
    "actuator": ("Ir", "gr"),
    "initial": ("theta", "dtheta"),
    "simulation": ("t_end", "sample", "rtol", "atol", "step", "max_steps"),
    "controller": ("q", "r", "saturation", "period"),
    "swingup": ("u_max", "duration", "period", "hold", "margin", "weight_rate", "weight_velocity"),
}
SUPPORTED = ("mass", "com", "inertia", "damping", "coulomb", "period")
NOT_YET = (
    "not yet supported for fixed-pivot chains: ipgen run simulates them without [sensors] or drive "
    f"effects (their criteria: {', '.join(SUPPORTED)})"
)
DESIGN_KEYS = ("controller", "swingup")  # the tables (and the cfg's key prefixes) of the design
# What the success test adds for a fixed chain (scores.md, scores.json).
NOTE = (
    "; a fixed-pivot chain has no base (no travel limit), its angles are compared in the scene's own "
    "coordinates, and a run also fails when a torque exceeds its bound (the swing-up's u_max or the "
    "controller's saturation)"
)


def is_fixed_scene(path: Path) -> bool:
    """Whether the scene file declares a fixed-pivot chain (a file that cannot be read or parsed:
    the SceneError of `parse_document`, one line)."""
    from ipgen.scene.fixed import is_fixed_document
    from ipgen.scene.load import parse_document

    return is_fixed_document(parse_document(path)[1])


@dataclass
class FixedScene:
    """A fixed scene as a sweep needs it: its file, document and chain; in a worker also the
    nominal run's plan (`prepare`: resolved config and model library sources)."""

    path: Path
    document: dict[str, Any]
    chain: FixedPendulum
    plan: Any = None  # pipeline.run_plan.RunPlan of the nominal scene (prepare)
    design: tuple[str, ...] = field(default_factory=tuple)  # its cfg's [controller]/[swingup] lines

    @property
    def controlled(self) -> bool:
        """Whether the scene closes a loop ([controller] or [swingup])."""
        return "controller" in self.document or "swingup" in self.document

    def files(self) -> tuple[tuple[str, str], ...]:
        """The files the scene names beside it (the swing-up's plan CSV), by value: (name, text).
        A plan elsewhere than beside the scene is a SweepError (workers write it beside theirs)."""
        swingup = self.document.get("swingup")
        name = swingup.get("plan") if isinstance(swingup, dict) else None
        if not isinstance(name, str):
            return ()
        if Path(name).name != name or name in ("", ".", ".."):
            raise SweepError(
                f"swingup.plan = {abbreviate(name)!r}: a sweep takes a plan file beside the scene "
                "(a file name without folders)"
            )
        try:
            return ((name, (self.path.parent / name).read_text()),)
        except (OSError, UnicodeDecodeError) as error:
            raise SweepError(f"swingup.plan {abbreviate(name)!r}: cannot read it ({error})") from None


def load_fixed(path: Path) -> FixedScene:
    """The fixed scene at `path` (its chain checked: a SceneError, one line, otherwise)."""
    from ipgen.scene.fixed import KEYS as CHAIN_KEYS
    from ipgen.scene.fixed import fixed_pendulum_of
    from ipgen.scene.load import parse_document

    reader, document = parse_document(path)
    chain = fixed_pendulum_of(reader, {key: value for key, value in document.items() if key in CHAIN_KEYS})
    return FixedScene(path, document, chain)


def plan_run(path: Path, document: dict[str, Any]) -> Any:
    """`ipgen run`'s plan (pipeline/fixed_run.fixed_plan) of the scene `document` at `path`."""
    from ipgen.pipeline.fixed_run import fixed_plan
    from ipgen.scene.load import parse_document

    reader, _ = parse_document(path)
    return fixed_plan(path, document, reader)


def prepare(scene: FixedScene) -> FixedScene:
    """The nominal run planned: its RunPlan and its design's cfg lines (`DESIGN_KEYS`)."""
    scene.plan = plan_run(scene.path, scene.document)
    design = [line for line in scene.plan.cfg.splitlines() if _is_design(line)]
    scene.design = (*design, *model_lines(scene.plan.cfg))  # an MPC predicts with the nominal model
    return scene


def _is_design(line: str) -> bool:
    """Whether a line of a resolved config is the design's: its keys, and its comment."""
    if line.startswith("#"):
        return line.startswith(tuple(f"# [{table}]" for table in DESIGN_KEYS))
    return line.split("=", 1)[0].strip().split(".", 1)[0] in DESIGN_KEYS


def parse_fixed_key(text: str) -> Key:
    """A `Key` a fixed scene's sweep may override (`KEYS`); else a SweepError naming them."""
    key = split_key(text, "parameters.m[1], initial.theta[0], swingup.period")
    table, name = key.table, key.name
    if table not in KEYS:
        raise SweepError(
            f"--vary {abbreviate(text)}: a fixed-pivot scene's sweep takes keys of "
            f"{', '.join(f'[{t}]' for t in KEYS)}, not [{abbreviate(table)}] (docs/sweep.md)"
        )
    if name not in KEYS[table]:
        raise SweepError(
            f"--vary {abbreviate(text)}: [{table}] of a fixed-pivot scene's sweep has "
            f"{', '.join(KEYS[table])} (docs/sweep.md)"
        )
    return key


def nominal_array(scene: FixedScene, key: Key) -> list[float] | None:
    """The resolved value of an array key the scene may not write (None: no default known)."""
    chain = scene.chain
    if key.table == "parameters" and key.name in ("m", "l", "delta"):
        return list(getattr(chain, key.name))
    if key.table == "parameters" and key.name in ("com", "J"):
        return list(chain.resolved(key.name))
    if key.table == "parameters" and key.name == "coulomb":
        return list(chain.coulomb) if chain.coulomb is not None else [0.0] * chain.links
    if key.table == "actuator" and key.name in ("Ir", "gr"):
        return list(chain.motor(key.name))
    if key.table == "initial" and key.name == "theta":  # `ipgen run`'s default
        from ipgen.pipeline.fixed_run import default_theta

        return list(default_theta(chain, scene.document))
    if key.table == "initial" and key.name == "dtheta":
        return [0.0] * chain.links  # `ipgen run`'s default: at rest
    return None


def apply(scene: FixedScene, overrides: tuple[tuple[str, object], ...]) -> dict[str, Any]:
    """A copy of the scene's document with `overrides` set (`overrides.apply` on fixed keys)."""
    return override.apply(
        scene.document,
        None,  # type: ignore[arg-type]
        overrides,
        parse=parse_fixed_key,
        defaults=lambda key: nominal_array(scene, key),
    )


def designs(overrides: tuple[tuple[str, object], ...]) -> bool:
    """Whether an override designs the controller anew (a [controller] or [swingup] key)."""
    return any(text.split(".", 1)[0] in DESIGN_KEYS for text, _ in overrides)


def run_config(scene: FixedScene, path: Path, overrides: tuple[tuple[str, object], ...]) -> str:
    """The resolved config of one run: the overridden scene (written as `path`) planned as `ipgen
    run` plans it; without a design key its [controller]/[swingup] are the nominal scene's lines.
    An `Error` (one line) when the scene format refuses the level."""
    document = apply(scene, overrides)
    if designs(overrides):
        return str(plan_run(path, document).cfg)
    plant = {table: value for table, value in document.items() if table not in DESIGN_KEYS}
    cfg = str(plan_run(path, plant).cfg)
    return cfg + "\n".join(scene.design) + "\n"


def _values(cfg: str, key: str) -> list[float] | None:
    for line in cfg.splitlines():
        name, _, value = line.partition("=")
        if name.strip() == key:
            return [float(v) for v in value.split()]
    return None


def goal_and_limit(cfg: str) -> tuple[tuple[float, ...], tuple[float, ...] | None, bool]:
    """(the goal state, the torque bounds or None, whether it is a balance run) of a resolved
    config: the swing-up's u_max (one for every input), else the controller's saturation (one per
    input, in the order of the CSV's u1..um)."""
    target = _values(cfg, "swingup.target")
    mpc = _values(cfg, "controller.u_max"), _values(cfg, "controller.u_min")
    mpc_bound = max(abs(mpc[0][0]), abs(mpc[1][0])) if mpc[0] and mpc[1] else None
    if target is not None:
        u_max = _values(cfg, "swingup.u_max")
        if u_max and mpc_bound is not None:  # an MPC holds (or tracks): the larger bound
            u_max = [max(u_max[0], mpc_bound)]
        return tuple(target), (tuple(u_max) if u_max else None), False
    if mpc_bound is not None:  # controller = mpc: its reference (ipgen's) in the scene's coordinates
        return _user_state(cfg, _values(cfg, "controller.reference") or []), (mpc_bound,), True
    equilibrium = _values(cfg, "controller.equilibrium") or []
    saturation = _values(cfg, "controller.saturation")
    return tuple(equilibrium), (tuple(saturation) if saturation else None), True


def _user_state(cfg: str, state: list[float]) -> tuple[float, ...]:
    """A state of ipgen's coordinates in the coordinates the config states (angles, zero, positive)."""
    from ipgen.model.coordinates import Coordinates
    from ipgen.model.fixed_equations import state_map

    def word(key: str, default: str) -> str:
        for line in cfg.splitlines():
            name, _, value = line.partition("=")
            if name.strip() == key:
                return value.strip()
        return default

    frame = Coordinates(word("angles", "absolute"), word("zero", "upright"), word("positive", "clockwise"))
    matrix, offset = state_map(frame, len(state) // 2)
    return tuple(float(v) for v in matrix @ np.asarray(state, dtype=float) + offset)


def judge_run(test: Success, csv: Path, cfg: str, links: int, status: int) -> Judgement:
    """The success test on a fixed chain's CSV (t, theta0.., dtheta0.., u or u1.., the rig's
    coordinates), then each input's torque bound; a ValueError or OSError if the CSV cannot be
    read."""
    with csv.open() as f:
        columns = f.readline().strip().split(",")
    wanted = [columns.index("t")] + [columns.index(f"theta{i}") for i in range(links)]
    wanted += [columns.index(f"dtheta{i}") for i in range(links)]
    inputs = [i for i, name in enumerate(columns) if name == "u" or (name[:1] == "u" and name[1:].isdigit())]
    data = np.loadtxt(csv, delimiter=",", skiprows=1, usecols=wanted + inputs, ndmin=2)
    if len(data) == 0:
        raise ValueError("no samples")
    t, states, torques = data[:, 0], data[:, 1 : 1 + 2 * links], data[:, 1 + 2 * links :]
    goal, limits, balance = goal_and_limit(cfg)
    verdict = judge(
        test, t, states, goal, rotary=False, status=status, travel=None, balance=balance, fixed=True
    )
    if not verdict.passed or limits is None or not torques.size:
        return verdict
    # Each input against its own bound (saturations may differ per joint): the worst excess.
    bounds = np.broadcast_to(np.asarray(limits, dtype=float), (torques.shape[1],))
    largest = np.max(np.abs(torques), axis=0)
    excess = largest - bounds * (1 + 1e-9)
    worst = int(np.argmax(excess))
    if excess[worst] > 0:
        return Judgement(
            False, f"exceeded the torque bound ({largest[worst]:.4g} > {bounds[worst]:g} N m)",
            verdict.angle_error, verdict.rate_error, verdict.base_error, verdict.max_travel, verdict.t_final,
        )  # fmt: skip
    return verdict


def _scaled(scene: FixedScene, name: str, factor: float) -> list[float]:
    values = nominal_array(scene, Key("parameters", name))
    assert values is not None
    return [value * factor for value in values]


def _overrides(scene: FixedScene, name: str, value: float) -> tuple[tuple[str, object], ...]:
    if name in ("mass", "com", "inertia", "damping"):
        group = {"mass": "m", "com": "com", "inertia": "J", "damping": "delta"}[name]
        return ((f"parameters.{group}", _scaled(scene, group, value)),)
    if name == "coulomb":
        return (("parameters.coulomb", [value] * scene.chain.links),)
    table = "swingup" if "swingup" in scene.document else "controller"
    return ((f"{table}.period", value),)


def fixed_criteria(
    scene: FixedScene,
    chosen: tuple[str, ...] | None = None,
    levels: Mapping[str, str] | None = None,
    repeat: int | None = None,
) -> list[Criterion]:
    """The scorecard's criteria for a fixed scene: those of `SUPPORTED` run, the others recorded
    as refused (`NOT_YET`); `chosen` naming one of those is a SweepError."""
    levels = dict(levels or {})
    scorecard.check_names(chosen, levels)
    asked = [name for name in [*(chosen or ()), *levels] if name not in SUPPORTED]
    if asked:
        raise SweepError(f"scorecard criterion {asked[0]!r} is {NOT_YET}")
    if not scene.controlled:
        raise SweepError(
            "--scorecard needs a scene with a [controller] or a [swingup]: it scores a closed loop"
        )
    found = []
    for default in scorecard.CRITERIA:
        if chosen is not None and default.name not in chosen:
            continue
        refused = "" if default.name in SUPPORTED else NOT_YET
        design = scene.document.get("swingup") or scene.document.get("controller") or {}
        if default.name == "period" and "period" not in design:
            refused = "the scene's controller is continuous (no controller.period): nothing to vary"
        text = levels.get(default.name, default.levels)
        values = parse_levels(text, f"{default.name}={text}")
        built = tuple(
            Level((value,), _overrides(scene, default.name, value) if not refused else ()) for value in values
        )
        reps = default.repeat if repeat is None or default.repeat == 1 else repeat
        found.append(
            Criterion(default.name, default.label, (default.label,), built, reps, refused, default.repeat > 1)
        )
    return found


def parse_vary_fixed(spec: str) -> tuple[Key, tuple[float, ...]]:
    """`--vary KEY=LO:HI:N` of a fixed scene (keys: `KEYS`)."""
    return parse_vary(spec, parse=parse_fixed_key)


def check_keys(scene: FixedScene, criteria: list[Criterion]) -> None:
    """Every criterion's first level applied to the document: an index the scene cannot have, or
    a key of a [controller] or [swingup] the scene has not, is a SweepError now, not a refusal of
    every run."""
    present = [table for table in DESIGN_KEYS if table in scene.document]
    for criterion in criteria:
        if criterion.refused or not criterion.levels:
            continue
        for text, _ in criterion.levels[0].overrides:
            table = text.split(".", 1)[0]
            if table in DESIGN_KEYS and table not in present:
                loop = f"its loop is its [{present[0]}]: vary {present[0]}.* keys" if present else "no loop"
                raise SweepError(f"--vary {abbreviate(text)}: the scene has no [{table}] ({loop})")
        try:
            apply(scene, criterion.levels[0].overrides)
        except SweepError as error:
            raise SweepError(f"--vary {error}") from None


__all__ = ["FixedScene", "fixed_criteria", "is_fixed_scene", "judge_run", "load_fixed", "run_config"]
