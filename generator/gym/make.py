"""`ipgen.gym.make`: an environment from a pendulum, a scene or a preset, and the registered ids.

The parameter row is built once from the description (the DC motor folded into the direct
model, the links as built filled with the paper's rods where not given); the kernel never sees
an actuator, only the input's gain.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from ipgen.gym.checks import GymError, is_number
from ipgen.gym.fixed import ALIASES, LEADERBOARD_TORQUE, FixedSystem, fixed_document, fixed_row, scene_torque
from ipgen.gym.sensing import Sensing
from ipgen.gym.spec import GROUPS, EnvSpec
from ipgen.model.paper import paper_pendulum
from ipgen.model.pendulum import Pendulum, PendulumError
from ipgen.model.system import System

# Defaults per task: (u_max [N or N m], x_limit [m or rad], dt [s], substeps, max_episode_steps)
TASK_DEFAULTS = {
    ("classical", "balance"): (20.0, 2.4, 0.01, 4, 500),
    ("classical", "swingup"): (50.0, 2.4, 0.01, 4, 1000),
    ("rotary", "balance"): (5.0, math.pi, 0.01, 4, 500),
    ("rotary", "swingup"): (5.0, math.inf, 0.01, 4, 1000),
    # a chain on a fixed pivot (no base: x_limit unused); u_max [N m] the RealAIGym leaderboard's
    ("fixed", "balance"): (LEADERBOARD_TORQUE, math.inf, 0.01, 4, 500),
    ("fixed", "swingup"): (LEADERBOARD_TORQUE, math.inf, 0.01, 4, 1000),
}
MOTOR_VOLTS = 10.0  # the action's scale with a DC motor (the QUBE-Servo 2's amplifier limit)
CARTPOLE_ANGLE = 12 * 2 * math.pi / 360  # gymnasium's theta_threshold_radians


def parameter_row(pendulum: Pendulum) -> np.ndarray:
    """The kernel's parameter row of `pendulum`: its direct model (a DC motor folded in once by
    `Pendulum.folded`), m, l, delta, com, J, J_axial, tip with the rods filled in, g, and the
    input's gain."""
    if pendulum.actuator.is_acceleration:
        raise GymError("an acceleration-driven base is not supported by ipgen.gym: use a force or a dc_motor")
    direct = pendulum.folded()
    values = direct.params()
    row = [float(v) for name in GROUPS for v in values[name]]  # type: ignore[union-attr]
    return np.array([*row, float(values["g"]), float(pendulum.gain)], dtype=np.float64)


def paper_system(type: str, links: int, inertia: str = "pivot") -> tuple[System, np.ndarray]:
    """The paper's rig of `type` with `links` equal links (`model.paper`), and its parameter row."""
    pendulum = paper_pendulum(type, links, inertia)
    return pendulum.system, parameter_row(pendulum)


def spec_for(
    system: System | FixedSystem,
    row: np.ndarray,
    task: str = "balance",
    *,
    dt: float | None = None,
    substeps: int | None = None,
    u_max: float | None = None,
    x_limit: float | None = None,
    angle_limit: float = CARTPOLE_ANGLE,
    spread: Mapping[str, float] | None = None,
    initial_noise: float = 0.05,
    max_episode_steps: int | None = None,
    sensors: Mapping[str, object] | None = None,
) -> EnvSpec:
    """An `EnvSpec` with the task's defaults (`TASK_DEFAULTS`) for every option left None."""
    if task == "cartpole":
        raise GymError("task 'cartpole' is a preset: use make('cartpole-v1')")
    if (system.type, task) not in TASK_DEFAULTS:
        raise GymError(f"task {task!r:.40} is unknown: choose balance or swingup")
    default_u, default_x, default_dt, default_sub, default_steps = TASK_DEFAULTS[(system.type, task)]
    interval = default_dt if dt is None else dt
    sensing = None
    if spread is not None and not isinstance(spread, Mapping):
        raise GymError("spread must be a dict of relative half-widths, e.g. {'m': 0.1, 'delta': 0.5}")
    if sensors is not None:
        if not isinstance(sensors, Mapping):
            raise GymError("sensors must be a dict, e.g. {'resolution': 2048, 'delay': 0.01}")
        if not (is_number(interval) and 0 < interval <= 10):
            raise GymError(f"dt = {interval!r:.40} must be a number > 0 (at most 10 s)")
        sensing = Sensing.from_options(sensors, system.type, system.dof, interval)
    return EnvSpec(
        system,
        row,
        task,
        dt=interval,
        substeps=default_sub if substeps is None else substeps,
        u_max=default_u if u_max is None else u_max,
        x_limit=default_x if x_limit is None else x_limit,
        angle_limit=angle_limit,
        spread=dict(spread or {}),
        initial_noise=initial_noise,
        max_episode_steps=default_steps if max_episode_steps is None else max_episode_steps,
        sensing=sensing,
    )


def cartpole_spec() -> EnvSpec:
    """gymnasium's CartPole-v1 on ipgen's exact model: cart 1 kg, a uniform 0.1 kg rod of 1 m
    (gymnasium's `length` 0.5 is half of it), no friction, g = 9.8, ±10 N, explicit Euler at
    50 Hz, ends beyond 2.4 m or 12°, 500 steps."""
    pendulum = Pendulum("classical", 1, m=(1.0, 0.1), l=(0.0, 1.0), delta=(0.0, 0.0), g=9.8)
    row = parameter_row(pendulum)
    return EnvSpec(pendulum.system, row, "cartpole", dt=0.02, substeps=1, u_max=10.0, x_limit=2.4,
                   angle_limit=CARTPOLE_ANGLE, integrator="euler", max_episode_steps=500)  # fmt: skip


def spec_from_source(source: Any, task: str | None, **options: Any) -> EnvSpec:
    """An EnvSpec from a Pendulum, a FixedPendulum, a scene file, a preset name, "acrobot",
    "pendubot" or "cartpole-v1". `task` None: "swingup" for a fixed scene with a [swingup]
    table, else "balance"."""
    fixed = None if isinstance(source, Pendulum) else fixed_document(source)
    if fixed is not None:  # a chain on a fixed pivot: its torques bounded by the scene's limit
        chain, document = fixed
        if "u_max" not in options:  # the scene's limit only where none is given
            options["u_max"] = scene_torque(document)
        chosen = task if task is not None else ("swingup" if "swingup" in document else "balance")
        return spec_for(FixedSystem(chain.links, tuple(chain.joints)), fixed_row(chain), chosen, **options)
    task = "balance" if task is None else task
    if isinstance(source, str) and source.lower() == "cartpole-v1":
        steps = options.pop("max_episode_steps", None)
        if options or task not in ("balance", "cartpole"):
            raise GymError(
                "the cartpole-v1 preset takes only max_episode_steps: it is gymnasium's CartPole-v1"
            )
        spec = cartpole_spec()
        return spec if steps is None else dataclasses.replace(spec, max_episode_steps=steps)
    pendulum = as_pendulum(source)
    system, row = pendulum.system, parameter_row(pendulum)
    if pendulum.actuator.is_motor:
        options.setdefault("u_max", MOTOR_VOLTS)
    return spec_for(system, row, task, **options)


def as_pendulum(source: Any) -> Pendulum:
    """`source` as an ipgen.Pendulum: itself, a scene file (path) or a preset's name."""
    if isinstance(source, Pendulum):
        return source
    if isinstance(source, Path) or (isinstance(source, str) and source.endswith(".toml")):
        return Pendulum.from_scene(source)
    if isinstance(source, str):
        try:
            return Pendulum.preset(source)
        except PendulumError as error:  # the presets it lists, and the names only make() knows
            raise GymError(
                f"{error}; or {', '.join(repr(name) for name in sorted(ALIASES))} (fixed chains), "
                "'cartpole-v1' (gymnasium's CartPole) or a scene file (.toml)"
            ) from None
    raise GymError(
        f"make() takes an ipgen.Pendulum, a scene file or a preset name, not {type(source).__name__}"
    )
