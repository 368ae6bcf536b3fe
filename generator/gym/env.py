"""One environment (gymnasium.Env) on the batched kernel with N = 1.

The hot path of `step` is one ctypes call into preallocated arrays: the kernel integrates,
observes, rewards and checks the limits in C, so a step costs a few microseconds of Python.
"""

from __future__ import annotations

import ctypes
from typing import Any, ClassVar

import gymnasium
import numpy as np
from gymnasium import spaces

from ipgen.common.arrays import float_array
from ipgen.common.safetext import abbreviate
from ipgen.gym.checks import GymError
from ipgen.gym.fixed import FixedSystem
from ipgen.gym.kernel import load, observation_size
from ipgen.gym.sensing import MeasuredLoop
from ipgen.gym.spec import EnvSpec

OBS_BOUND = np.float32(np.finfo(np.float32).max)


def observation_space(spec: EnvSpec) -> spaces.Box:
    """float32 Box: (q0, sin/cos of each link, rates) (a fixed chain: no q0), or CartPole-v1's
    four entries."""
    size = 4 if spec.task == "cartpole" else observation_size(spec.system)
    if spec.task == "cartpole":  # gymnasium's own bounds
        high = np.array([spec.x_limit * 2, OBS_BOUND, spec.angle_limit * 2, OBS_BOUND], dtype=np.float32)
        return spaces.Box(-high, high, dtype=np.float32)
    return spaces.Box(-OBS_BOUND, OBS_BOUND, shape=(size,), dtype=np.float32)


def action_space(spec: EnvSpec) -> spaces.Space:
    """Box [−1, 1] (scaled to ±u_max), or CartPole-v1's Discrete(2) (0: −u_max, 1: +u_max); a
    fixed chain's m torques [N m]: Box [−u_max, u_max]^m."""
    if spec.task == "cartpole":
        return spaces.Discrete(2)
    if isinstance(spec.system, FixedSystem):
        return spaces.Box(-spec.u_max, spec.u_max, shape=(spec.system.inputs,), dtype=np.float32)
    return spaces.Box(-1.0, 1.0, shape=(1,), dtype=np.float32)


def action_count(spec: EnvSpec) -> int:
    """The numbers one action holds: the fixed chain's m inputs, else 1."""
    return spec.system.inputs if isinstance(spec.system, FixedSystem) else 1


def actions_of(actions: Any, count: int, shape: tuple[int, ...] | None = None) -> np.ndarray:
    """`actions` as `count` float64 numbers, not NaN (the kernel clips them); otherwise the
    GymError (a ValueError) saying what to pass. `shape`: the shape the actions must have
    (a fixed chain's (m,) or (N, m)); None: any with `count` entries."""
    try:
        array = float_array(actions)  # "5", b"1", ["0.5"]: text, not a number
        given = array.reshape(count) if shape is None or array.shape == shape else None
    except (TypeError, ValueError):
        given = None
    if given is None or np.isnan(given).any():
        what = f"shape {shape}" if shape is not None else f"{count} number{'s' if count > 1 else ''}"
        raise GymError(
            f"action {abbreviate(repr(actions))}: expected {what} (not NaN), "
            "e.g. an element of env.action_space"
        )
    return given


def discrete_action(action: Any) -> int:
    """A Discrete(2) action (CartPole's): the integer 0 (push left) or 1 (push right), a Python or
    numpy integer as gymnasium's space holds it; anything else the GymError saying what to pass."""
    integral = isinstance(action, int | np.integer) or (
        isinstance(action, np.ndarray) and action.shape == () and np.issubdtype(action.dtype, np.integer)
    )
    if not integral or int(action) not in (0, 1):
        raise GymError(f"action {abbreviate(repr(action))}: expected 0 (push left) or 1 (push right)")
    return int(action)


def check_observation(obs: np.ndarray) -> None:
    """A GymError unless every entry of the observation(s) at reset is finite: a state or option
    so large that its observation overflows is never handed out as valid."""
    if not np.isfinite(obs).all():
        raise GymError(
            "reset gave a non-finite observation: the initial state (options['state'], initial_noise) "
            "or the sensors' noise is too large for float32; give smaller values"
        )


def initial_state_of(value: Any, size: int) -> np.ndarray:
    """options['state'] as `size` finite float64 numbers, or the GymError saying what to pass."""
    try:
        state = np.asarray(value, dtype=np.float64).reshape(size)
    except (TypeError, ValueError):
        state = None
    if state is None or not np.isfinite(state).all():
        raise GymError(
            f"options['state'] = {abbreviate(repr(value))}: expected {size} finite numbers "
            "(the coordinates, then their rates: θ0..θn, θ̇0..θ̇n; a fixed chain's θ1..θn, θ̇1..θ̇n)"
        )
    return state


class PendulumEnv(gymnasium.Env):
    """An exact n-link cart or Furuta pendulum, or a chain on a fixed pivot (`EnvSpec`), as a
    gymnasium environment.

    Parameters
    ----------
    spec : EnvSpec
        The model, task, interval and randomisation.
    render_mode : str, optional
        "rgb_array" (a drawing of the links) or None.

    Notes
    -----
    `reset(options={"params": {"m": [...], ...}})` sets this episode's parameters (absolute, by
    group) instead of drawing them; `options={"state": x}` sets the initial state
    (θ0..θn, θ̇0..θ̇n; a fixed chain's θ1..θn, θ̇1..θ̇n). `info["params"]` records the
    episode's parameters.
    """

    metadata: ClassVar[dict[str, Any]] = {"render_modes": ["rgb_array"], "render_fps": 50}

    def __init__(self, spec: EnvSpec, render_mode: str | None = None) -> None:
        self.ipgen_spec = spec
        self.render_mode = render_mode
        self.observation_space = observation_space(spec)
        self.action_space = action_space(spec)
        self.metadata = {**self.metadata, "render_fps": max(1, round(1 / spec.dt))}
        dof = spec.system.dof
        self.kernel = load(spec.system)
        self.cfg = spec.cfg
        self.params = spec.nominal.copy()[None, :]
        self.state = np.zeros((1, 2 * dof))
        self.obs = np.zeros((1, self.observation_space.shape[0]), dtype=np.float32)
        self._obs_row = self.obs[0]
        # Scalars as ctypes objects: reading and writing them costs far less than numpy indexing.
        self._action = ctypes.c_double(0.0)
        self._reward = ctypes.c_double(0.0)
        self._ended = ctypes.c_ubyte(0)
        self._call = self.kernel.bound_step(
            self.params, self.state, self._action, self.cfg, self.obs, self._reward, self._ended
        )
        self._discrete = spec.task == "cartpole"
        self._inputs = action_count(spec) if isinstance(spec.system, FixedSystem) else 0
        if self._inputs:  # a fixed chain: m torques, through an array the kernel reads
            self._torques = np.zeros(self._inputs)
            self._call = self.kernel.bound_step(
                self.params, self.state, self._torques, self.cfg, self.obs, self._reward, self._ended
            )
        self.loop = MeasuredLoop(spec.sensing, dof, 1, spec.dt) if spec.sensing is not None else None
        self._row = np.array([0])

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        super().reset(seed=seed)
        options = options or {}
        self.params[0] = self.ipgen_spec.draw(self.np_random, options.get("params"))
        start = self.ipgen_spec.initial_state(self.np_random)
        if "state" in options:
            start = initial_state_of(options["state"], self.state.shape[1])
        self.state[0] = start
        if self.loop is None:
            self.kernel.observe(self.state, self.cfg, self.obs)
        else:
            self.loop.reset(self._row, self.state, [self.np_random], self.obs)
        check_observation(self.obs)
        return self._obs_row.copy(), {"params": self.ipgen_spec.params_info(self.params[0])}

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        if self._inputs:
            self._torques[:] = actions_of(action, self._inputs, (self._inputs,))
            self._call()
            ended = self._ended.value
            info = {"failed": True} if ended == 2 else {}
            return self._obs_row.copy(), self._reward.value, ended != 0, False, info
        if self._discrete:
            self._action.value = 1.0 if discrete_action(action) == 1 else -1.0
        else:
            try:  # the fast path: a number, or a sequence of one number
                if hasattr(action, "__len__") and (len(action) != 1 or isinstance(action, str | bytes)):
                    raise TypeError  # two numbers, text: refused below
                value = action[0] if hasattr(action, "__len__") else action
                self._action.value = value
            except (IndexError, KeyError, TypeError, ValueError):
                value = actions_of(action, 1)[0]  # raises the GymError saying what to pass
                self._action.value = value
            if value != value:  # NaN
                actions_of(action, 1)
        if self.loop is not None:  # the rig's sensors: the delayed, noisy action, then the measurement
            rngs = [self.np_random]
            self._action.value = float(self.loop.apply(self._row, np.array([self._action.value]), rngs)[0])
            self._call()
            if len(self.loop.observe(self._row, self.state, rngs, self.obs)):
                self._ended.value = 2  # a non-finite observation: the episode failed
        else:
            self._call()
        ended = self._ended.value
        return (
            self._obs_row.copy(),
            self._reward.value,
            ended != 0,
            False,
            {"failed": True} if ended == 2 else {},
        )

    def render(self) -> np.ndarray | None:
        if self.render_mode != "rgb_array":
            return None
        from ipgen.gym.render import draw

        return draw(self.ipgen_spec, self.state[0], self.params[0])
