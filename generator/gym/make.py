"""`ipgen.gym.make`: an environment from a pendulum, a scene or a preset, and the registered ids.

The parameter row is built once from the description (the DC motor folded into the direct
model, the links as built filled with the paper's rods where not given); the kernel never sees
an actuator, only the input's gain.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ipgen.gym.sensing import Sensing
from ipgen.gym.spec import GROUPS, EnvSpec, GymError, is_number
from ipgen.model.actuator import Actuator, fold
from ipgen.model.links import resolve_links
from ipgen.model.system import System

# The paper's rigs (Jadlovská & Sarnovský 2013; scenes/cdip_pulse.toml, scenes/rsip_pulse.toml):
# base then every link alike.
PAPER = {
    "classical": {"m": (0.3, 0.275), "l": (0.0, 0.5), "delta": (0.3, 0.1)},
    "rotary": {"m": (0.5, 0.275), "l": (0.6, 0.5), "delta": (0.3, 0.011458)},
}
# Defaults per task: (u_max [N or N m], x_limit [m or rad], dt [s], substeps, max_episode_steps)
TASK_DEFAULTS = {
    ("classical", "balance"): (20.0, 2.4, 0.01, 4, 500),
    ("classical", "swingup"): (50.0, 2.4, 0.01, 4, 1000),
    ("rotary", "balance"): (5.0, math.pi, 0.01, 4, 500),
    ("rotary", "swingup"): (5.0, math.inf, 0.01, 4, 1000),
}
MOTOR_VOLTS = 10.0  # the action's scale with a DC motor (the QUBE-Servo 2's amplifier limit)
CARTPOLE_ANGLE = 12 * 2 * math.pi / 360  # gymnasium's theta_threshold_radians


def parameter_row(
    system: System,
    m: Sequence[float],
    l: Sequence[float],  # noqa: E741
    delta: Sequence[float],
    g: float = 9.81,
    links: Mapping[str, Sequence[float] | None] | None = None,
    actuator: Actuator | None = None,
) -> np.ndarray:
    """The kernel's parameter row of one model: m, l, delta, com, J, J_axial, tip, g, gain."""
    built = resolve_links(system, m, l, dict(links or {}))
    m, delta, J, gain = list(m), list(delta), list(built.J), 1.0
    if actuator is not None and actuator.is_motor:
        m, delta, J, gain = fold(actuator, system, m, delta, J)
    elif actuator is not None and actuator.is_acceleration:
        raise GymError("an acceleration-driven base is not supported by ipgen.gym: use a force or a dc_motor")
    groups = {"m": m, "l": l, "delta": delta, "com": built.com, "J": J, "J_axial": built.J_axial,
              "tip": built.tip}  # fmt: skip
    row = [float(v) for name in GROUPS for v in groups[name]] + [float(g), float(gain)]
    return np.array(row, dtype=np.float64)


def paper_system(type: str, links: int, inertia: str = "pivot") -> tuple[System, np.ndarray]:
    """The paper's rig of `type` with `links` equal links, and its parameter row."""
    system = System(type, links, inertia if type == "rotary" else "pivot")
    values = PAPER[type]
    m, l, delta = ([values[k][0]] + [values[k][1]] * links for k in ("m", "l", "delta"))  # noqa: E741
    return system, parameter_row(system, m, l, delta)


def spec_for(
    system: System,
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
    system = System("classical", 1, "pivot")
    row = parameter_row(system, [1.0, 0.1], [0.0, 1.0], [0.0, 0.0], g=9.8)
    return EnvSpec(system, row, "cartpole", dt=0.02, substeps=1, u_max=10.0, x_limit=2.4,
                   angle_limit=CARTPOLE_ANGLE, integrator="euler", max_episode_steps=500)  # fmt: skip


def spec_from_source(source: Any, task: str, **options: Any) -> EnvSpec:
    """An EnvSpec from a Pendulum, a scene file, a preset name or "cartpole-v1"."""
    if isinstance(source, str) and source.lower() == "cartpole-v1":
        steps = options.pop("max_episode_steps", None)
        if options or task not in ("balance", "cartpole"):
            raise GymError(
                "the cartpole-v1 preset takes only max_episode_steps: it is gymnasium's CartPole-v1"
            )
        spec = cartpole_spec()
        return spec if steps is None else dataclasses.replace(spec, max_episode_steps=steps)
    pendulum = as_pendulum(source)
    system = System(pendulum.type, pendulum.links, pendulum.inertia)
    row = parameter_row(
        system,
        pendulum.m,
        pendulum.l,
        pendulum.delta,
        pendulum.g,
        {"com": pendulum.com, "J": pendulum.J, "J_axial": pendulum.J_axial, "tip": pendulum.tip},
        pendulum.actuator,
    )
    if pendulum.actuator is not None and pendulum.actuator.is_motor:
        options.setdefault("u_max", MOTOR_VOLTS)
    return spec_for(system, row, task, **options)


def as_pendulum(source: Any) -> Any:
    """`source` as an ipgen.Pendulum: itself, a scene file (path) or a preset's name."""
    import ipgen

    pendulum_type = getattr(ipgen, "Pendulum", None)
    if pendulum_type is not None and isinstance(source, pendulum_type):
        return source
    if pendulum_type is None:
        raise GymError("ipgen.Pendulum is not available in this version")
    if isinstance(source, Path) or (isinstance(source, str) and source.endswith(".toml")):
        return pendulum_type.from_scene(source)
    if isinstance(source, str):
        return pendulum_type.preset(source)
    raise GymError(
        f"make() takes an ipgen.Pendulum, a scene file or a preset name, not {type(source).__name__}"
    )
