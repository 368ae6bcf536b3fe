"""The environments by name: `make`, `make_vec` and the ids registered with gymnasium."""

from __future__ import annotations

from typing import Any

import gymnasium
from gymnasium.wrappers import TimeLimit

from ipgen.gym.checks import GymError
from ipgen.gym.env import PendulumEnv
from ipgen.gym.make import paper_system, spec_for, spec_from_source
from ipgen.gym.spec import EnvSpec
from ipgen.gym.vector import PendulumVectorEnv

SIZES = {1: "Single", 2: "Double", 3: "Triple"}
TASK_NAMES = {"balance": "Balance", "swingup": "SwingUp"}


def _spec(
    source: Any = None, task: str | None = None, paper: tuple[str, int] | None = None, **options: Any
) -> EnvSpec:
    if paper is not None:
        system, row = paper_system(*paper)
        return spec_for(system, row, task or "balance", **options)
    return spec_from_source(source, task, **options)


def make(
    source: Any = None,
    task: str | None = None,
    *,
    preset: str | None = None,
    render_mode: str | None = None,
    **options: Any,
) -> gymnasium.Env:
    """An environment of `source` (an ipgen.Pendulum or ipgen.FixedPendulum, a scene file, a
    preset name, "acrobot", "pendubot" or "cartpole-v1") for `task` ("balance" or "swingup"),
    wrapped in gymnasium's TimeLimit.

    Parameters
    ----------
    source : ipgen.Pendulum, ipgen.FixedPendulum, str or pathlib.Path
        What to simulate. "acrobot" and "pendubot" are the presets acrobot_swingup and
        pendubot_swingup (the RealAIGym leaderboard's rigs).
    task : str, optional
        "balance" or "swingup". None (the default): "swingup" for a fixed-pivot scene with a
        [swingup] table, else "balance".
    preset : str, optional
        The same as a preset's name as `source` (e.g. `preset="cartpole-v1"`).
    render_mode : str, optional
        "rgb_array" or None.
    **options
        `EnvSpec` fields: dt, substeps, u_max, x_limit, angle_limit, spread, initial_noise,
        max_episode_steps (a fixed chain: u_max [N m] defaults to the scene's swing-up u_max or
        controller saturation, else 6 N m).

    Returns
    -------
    gymnasium.Env

    Examples
    --------
    >>> env = make("cartpole-v1")
    >>> obs, info = env.reset(seed=0)
    >>> make("acrobot", task="swingup").action_space.shape
    (1,)
    """
    if (source is None) == (preset is None):
        raise GymError("make() takes what to simulate: a Pendulum, a scene file or preset=NAME (one of them)")
    spec = _spec(preset if source is None else source, task, **options)
    return TimeLimit(PendulumEnv(spec, render_mode=render_mode), spec.max_episode_steps)


def make_vec(source: Any, num_envs: int, task: str | None = None, **options: Any) -> PendulumVectorEnv:
    """`num_envs` environments of `source` in one batched kernel (see `make` for the arguments)."""
    return PendulumVectorEnv(_spec(source, task, **options), num_envs)


def _entry(**kwargs: Any) -> gymnasium.Env:
    render_mode = kwargs.pop("render_mode", None)
    return PendulumEnv(_spec(**kwargs), render_mode=render_mode)


def _vector_entry(num_envs: int = 1, **kwargs: Any) -> PendulumVectorEnv:
    kwargs.pop("render_mode", None)
    return PendulumVectorEnv(_spec(**kwargs), num_envs)


def ids() -> dict[str, dict[str, Any]]:
    """Every registered id and its keyword arguments."""
    table: dict[str, dict[str, Any]] = {"ipgen/CartPole-v1": {"source": "cartpole-v1"}}
    for type, base in (("classical", "Cart"), ("rotary", "Rotary")):
        for links, size in SIZES.items():
            for task, task_name in TASK_NAMES.items():
                table[f"ipgen/{base}{size}-{task_name}-v0"] = {"paper": (type, links), "task": task}
    for task, task_name in TASK_NAMES.items():
        table[f"ipgen/QubeServo2-{task_name}-v0"] = {"source": "qube_servo2", "task": task}
    for name, preset in (("Acrobot", "acrobot_swingup"), ("Pendubot", "pendubot_swingup")):
        for task, task_name in TASK_NAMES.items():  # the RealAIGym leaderboard's rigs, ±6 N m
            table[f"ipgen/{name}-{task_name}-v0"] = {"source": preset, "task": task}
    return table


def register_all() -> None:
    """Register `ids()` with gymnasium (idempotent)."""
    for env_id, kwargs in ids().items():
        if env_id in gymnasium.registry:
            continue
        steps = 500 if env_id.endswith("CartPole-v1") or kwargs.get("task") == "balance" else 1000
        gymnasium.register(
            env_id,
            entry_point=_entry,
            vector_entry_point=_vector_entry,
            max_episode_steps=steps,
            kwargs=kwargs,
        )
