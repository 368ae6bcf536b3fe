"""What an environment simulates and rewards: the model, its nominal parameters, the task and the
parameter spread drawn per episode. Plain data, shared by the single and the vector environment.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from functools import cache
from typing import TYPE_CHECKING

import numpy as np

from ipgen.gym.checks import GymError, is_integer, is_number
from ipgen.gym.fixed import FixedSystem, fixed_layout
from ipgen.gym.kernel import CFG_FIELDS, INTEGRATOR_CODES, TASK_CODES, row_size
from ipgen.model.system import System

if TYPE_CHECKING:
    from ipgen.gym.sensing import Sensing

# The parameter groups of one row, in the kernel's order (each has dof entries), then g and gain.
GROUPS = ("m", "l", "delta", "com", "J", "J_axial", "tip")
TASKS = ("balance", "swingup", "cartpole")
FLOAT32_MAX = float(np.finfo(np.float32).max)  # the observation's largest entry


def layout(system: System | FixedSystem) -> tuple[tuple[str, int], ...]:
    """The parameter row's groups and their sizes, in the kernel's order: `GROUPS` (dof entries
    each), g and the input's gain; a fixed chain's `fixed.fixed_layout`."""
    if isinstance(system, FixedSystem):
        return fixed_layout(system)
    return (*((name, system.dof) for name in GROUPS), ("g", 1), ("gain", 1))


@cache
def slices(system: System | FixedSystem) -> dict[str, slice]:
    """Each group's slice of the parameter row (`layout`), computed once per model."""
    found, start = {}, 0
    for name, size in layout(system):
        found[name] = slice(start, start + size)
        start += size
    return found


@cache
def spreadable(system: System | FixedSystem) -> tuple[str, ...]:
    """The groups a spread or `options["params"]` may set, in the order they are drawn."""
    return tuple(name for name, _ in layout(system) if name != "gain")


@dataclass(frozen=True)
class EnvSpec:
    """One environment's model, task and randomisation.

    Attributes
    ----------
    system : System or FixedSystem
        The pendulum's type, links and inertia, or a fixed chain's links and driven joints (one
        compiled kernel each).
    nominal : numpy.ndarray
        The parameter row (`layout`: `GROUPS`, then g and the input's gain, the motor already
        folded in; a fixed chain's m, l, delta, com, J, g, Ir, gr).
    task : str
        "balance" (reward 1 a step until a link leaves `angle_limit` or the base `x_limit`),
        "swingup" (reward the links' mean upright-ness (1 + cos θi)/2, ends only at `x_limit`),
        or "cartpole" (gymnasium's CartPole-v1: Discrete(2) actions, its observation).
    dt, substeps : float, int
        The control interval [s] and the RK4 steps inside it.
    u_max : float
        The input for action +1: N, N m, or V with a DC motor; a fixed chain's actions are
        torques [N m] in [−u_max, u_max].
    x_limit, angle_limit : float
        Termination bounds [m or rad] (inf: none).
    spread : Mapping[str, float]
        Relative half-widths per parameter group drawn uniformly each episode, e.g. {"m": 0.1}.
    initial_noise : float
        Half-width of the uniform draw added to every state entry at reset.
    max_episode_steps : int
        Truncation (gymnasium's TimeLimit).
    """

    system: System | FixedSystem
    nominal: np.ndarray
    task: str = "balance"
    dt: float = 0.01
    substeps: int = 4
    u_max: float = 10.0
    x_limit: float = math.inf
    angle_limit: float = 0.2095
    integrator: str = "rk4"
    spread: Mapping[str, float] = field(default_factory=dict)
    initial_noise: float = 0.05
    max_episode_steps: int = 500
    sensing: Sensing | None = None  # None: the exact state; else what the rig measures

    def __post_init__(self) -> None:
        if self.task not in TASKS:
            raise GymError(f"task {self.task!r:.40} is unknown: choose one of {', '.join(TASKS)}")
        if self.integrator not in INTEGRATOR_CODES:
            raise GymError(f"integrator {self.integrator!r:.40} is unknown: choose rk4 or euler")
        if not (is_number(self.dt) and 0 < self.dt <= 10):
            raise GymError(f"dt = {self.dt!r:.40} must be a number > 0 (at most 10 s)")
        for key in ("u_max", "x_limit", "angle_limit"):
            value = getattr(self, key)
            if not (is_number(value) and value > 0):
                raise GymError(f"{key} = {value!r:.40} must be a number > 0 (inf: no limit)")
        if not (is_number(self.u_max) and math.isfinite(self.u_max)):
            raise GymError(f"u_max = {self.u_max!r:.40} must be a finite number > 0")
        if not (is_integer(self.substeps) and 1 <= self.substeps <= 10_000):
            raise GymError(f"substeps = {self.substeps!r:.40} must be an integer in 1..10000")
        if not (is_integer(self.max_episode_steps) and self.max_episode_steps >= 1):
            raise GymError(f"max_episode_steps = {self.max_episode_steps!r:.40} must be an integer >= 1")
        if not (is_number(self.initial_noise) and 0 <= self.initial_noise <= FLOAT32_MAX):
            raise GymError(
                f"initial_noise = {self.initial_noise!r:.40} must be a number >= 0 and at most "
                f"{FLOAT32_MAX:.3g} (the observation is float32)"
            )
        names = spreadable(self.system)
        for key, width in self.spread.items():
            if key not in names:
                raise GymError(f"spread names {key!r:.40}: choose from {', '.join(names)}")
            if not (is_number(width) and 0 <= width < 1):
                raise GymError(f"spread[{key!r}] = {width!r:.40} must be a relative half-width in [0, 1)")
        if self.sensing is not None and self.task == "cartpole":
            raise GymError("the cartpole-v1 preset observes the exact state: sensors are not supported there")
        if self.system.type == "fixed":
            if self.task == "cartpole" or self.integrator != "rk4":
                raise GymError("a fixed-pivot chain's tasks are balance and swingup (RK4)")
            if self.x_limit != math.inf:  # the kernel has no base to bound
                raise GymError(
                    f"x_limit = {self.x_limit!r:.40}: a fixed-pivot chain has no base; leave x_limit out"
                )
            if self.sensing is not None:
                raise GymError(
                    "sensors are not supported for fixed-pivot chains yet: the observation is the exact state"
                )
        if self.nominal.shape != (row_size(self.system),):
            raise GymError("the parameter row has the wrong length for this model")

    @property
    def cfg(self) -> np.ndarray:
        """The kernel's constants (`CFG_FIELDS` order)."""
        values = {
            "dt": self.dt,
            "substeps": float(self.substeps),
            "u_max": self.u_max,
            "x_limit": self.x_limit,
            "angle_limit": self.angle_limit if self.task != "swingup" else math.inf,
            "task": float(TASK_CODES[self.task]),
            "integrator": float(INTEGRATOR_CODES[self.integrator]),
        }
        return np.array([values[name] for name in CFG_FIELDS], dtype=np.float64)

    def group(self, row: np.ndarray, name: str) -> np.ndarray:
        """The view of parameter group `name` (`layout`: "m", ..., "g", "gain"; a fixed chain's
        "Ir", "gr") in a parameter row (or in the last axis of a stack of rows)."""
        return row[..., slices(self.system)[name]]

    def draw(self, rng: np.random.Generator, overrides: Mapping[str, object] | None = None) -> np.ndarray:
        """One episode's parameter row: the nominal one, each group in `spread` scaled by
        1 + U(−w, w) per entry (drawn in the row's order, `spreadable`: `GROUPS` then g; a fixed
        chain's m … J, g, Ir, gr), then `overrides` (absolute values by group name) applied."""
        row = self.nominal.copy()
        if not self.spread and not overrides:  # the common case, without the loop (an autoreset)
            return row
        names = spreadable(self.system)
        for name in names:
            width = self.spread.get(name, 0.0)
            if width:
                view = self.group(row, name)
                view *= 1.0 + rng.uniform(-width, width, size=view.shape)
        for name, value in (overrides or {}).items():
            if name not in names:
                raise GymError(f"options['params'] names {name!r:.40}: choose from {', '.join(names)}")
            view = self.group(row, name)
            given = np.asarray(value, dtype=np.float64).reshape(-1)
            if given.shape != view.shape or not np.all(np.isfinite(given)):
                raise GymError(f"options['params'][{name!r}] must be {view.size} finite numbers")
            view[:] = given
        return row

    def initial_state(self, rng: np.random.Generator) -> np.ndarray:
        """The state at reset: upright (balance) or hanging (swing-up), plus U(−noise, noise)."""
        dof = self.system.dof
        first = 0 if self.system.type == "fixed" else 1  # the first link's coordinate
        if self.task == "cartpole":  # gymnasium's draw: (x, x_dot, theta, theta_dot)
            x, x_dot, theta, theta_dot = rng.uniform(low=-0.05, high=0.05, size=(4,))
            return np.array([x, theta, x_dot, theta_dot])
        state = rng.uniform(-self.initial_noise, self.initial_noise, size=2 * dof)
        if self.task == "swingup":
            state[first:dof] += math.pi
        return state

    def params_info(self, row: np.ndarray) -> dict[str, np.ndarray]:
        """The row (or stack of rows) as a dict for `info["params"]`, the caller's own: views of
        one copy of `row` (one copy per group, strided, costs several times more for N rows)."""
        own = row.copy()
        return {name: own[..., part] for name, part in slices(self.system).items()}
