"""N environments in one kernel call: a native gymnasium VectorEnv (autoreset NEXT_STEP).

Sub-environment i with reset(seed=s) draws from `seeding.np_random(s + i)` exactly as a single
`PendulumEnv` reset with seed s + i does, and the kernel computes each row with the same code:
the vector environment equals N single environments bitwise (tests/test_gym.py checks it).
"""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np
from gymnasium.utils import seeding
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from ipgen.common.safetext import abbreviate
from ipgen.gym.budget import check_num_envs
from ipgen.gym.checks import GymError
from ipgen.gym.env import (
    action_count,
    action_space,
    actions_of,
    check_observation,
    initial_state_of,
    observation_space,
)
from ipgen.gym.fixed import FixedSystem
from ipgen.gym.kernel import load
from ipgen.gym.sensing import MeasuredLoop
from ipgen.gym.spec import EnvSpec


class PendulumVectorEnv(VectorEnv):
    """`num_envs` copies of an `EnvSpec` environment, stepped together in C.

    Parameters
    ----------
    spec : EnvSpec
        The model, task, interval and randomisation (each sub-environment draws its own).
    num_envs : int
        The batch size N.

    Notes
    -----
    Autoreset NEXT_STEP: the step after a sub-environment terminated or was truncated resets it
    (its action ignored, reward 0, neither flag set) and returns its first observation.
    Truncation after `spec.max_episode_steps` steps is built in (no TimeLimit wrapper needed).
    """

    metadata: ClassVar[dict[str, Any]] = {"autoreset_mode": AutoresetMode.NEXT_STEP, "render_modes": []}

    def __init__(self, spec: EnvSpec, num_envs: int = 1) -> None:
        single = observation_space(spec)
        check_num_envs(num_envs, spec.system.dof, single.shape[0])  # before anything is allocated
        self.ipgen_spec = spec
        self.num_envs = num_envs
        self.single_observation_space = single
        self.single_action_space = action_space(spec)
        self.observation_space = batch_space(self.single_observation_space, num_envs)
        self.action_space = batch_space(self.single_action_space, num_envs)
        self.kernel = load(spec.system)
        self.cfg = spec.cfg
        dof = spec.system.dof
        self.params = np.tile(spec.nominal, (num_envs, 1))
        self.state = np.zeros((num_envs, 2 * dof))
        self._fixed = isinstance(spec.system, FixedSystem)
        self._inputs = action_count(spec)
        # A fixed chain's actions: N × m torques (row-major, as the kernel reads them).
        self.actions = np.zeros((num_envs, self._inputs)) if self._fixed else np.zeros(num_envs)
        self.obs = np.zeros((num_envs, self.single_observation_space.shape[0]), dtype=np.float32)
        self.rewards = np.zeros(num_envs)
        self.ended = np.zeros(num_envs, dtype=np.uint8)
        self.elapsed = np.zeros(num_envs, dtype=np.int64)
        self.needs_reset = np.zeros(num_envs, dtype=bool)
        self.generators = [seeding.np_random(None)[0] for _ in range(num_envs)]
        self.loop = MeasuredLoop(spec.sensing, dof, num_envs, spec.dt) if spec.sensing is not None else None
        # Without a spread, a row holds the nominal parameters unless reset(options=...) set others
        # for its current episode (`_overridden`): an autoreset need not rewrite a nominal row.
        self._overridden = np.zeros(num_envs, dtype=bool)
        self._kernel_step = self.kernel.bound_step(
            self.params, self.state, self.actions, self.cfg, self.obs, self.rewards, self.ended
        )

    def _reset_one(self, i: int, overrides: Any = None, params: bool = True) -> None:
        """Sub-environment i's new episode; `params=False` keeps its (nominal) parameter row,
        which a draw without spread or overrides would rewrite unchanged, drawing nothing."""
        rng = self.generators[i]
        if params:
            self.params[i] = self.ipgen_spec.draw(rng, overrides)
        self.state[i] = self.ipgen_spec.initial_state(rng)
        self.elapsed[i] = 0

    def _states(self, value: Any) -> np.ndarray:
        """options['state'] for every row: one state (broadcast) or N × its size."""
        size = self.state.shape[1]
        if np.ndim(value) == 2 and len(value) == self.num_envs:
            return np.array([initial_state_of(row, size) for row in value])
        return np.broadcast_to(initial_state_of(value, size), self.state.shape)

    def _params_info(self, mask: np.ndarray) -> dict[str, Any]:
        """`info["params"]`: each group as an N × entries array (rows of the envs in `mask` valid)."""
        return {"params": self.ipgen_spec.params_info(self.params), "_params": mask.copy()}

    def reset(
        self, *, seed: int | list[int | None] | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        seeds = [None] * self.num_envs if seed is None else seed
        if isinstance(seeds, int):
            seeds = [seeds + i for i in range(self.num_envs)]
        if not isinstance(seeds, list | tuple) or len(seeds) != self.num_envs:
            raise GymError(
                f"reset(seed={abbreviate(repr(seed))}): give an integer, None, or a list of one seed per "
                f"environment ({self.num_envs})"
            )
        if seed is not None or not hasattr(self, "_seeded"):
            self.generators = [seeding.np_random(s)[0] for s in seeds]
            self._seeded = True
        overrides = (options or {}).get("params")
        for i in range(self.num_envs):
            self._reset_one(i, overrides)
        if "state" in (options or {}):  # one state for every environment, or a row each
            self.state[:] = self._states((options or {})["state"])
        self._overridden[:] = bool(overrides)
        self.needs_reset[:] = False
        if self.loop is None:
            self.kernel.observe(self.state, self.cfg, self.obs)
        else:
            self.loop.reset(np.arange(self.num_envs), self.state, self.generators, self.obs)
        check_observation(self.obs)
        return self.obs.copy(), self._params_info(np.ones(self.num_envs, dtype=bool))

    def step(self, actions: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        if self._fixed:  # N × m torques [N m]
            shape = (self.num_envs, self._inputs)
            self.actions[:] = actions_of(actions, self.num_envs * self._inputs, shape).reshape(shape)
        else:
            given = actions_of(actions, self.num_envs)
            if self.ipgen_spec.task == "cartpole":
                if not np.isin(given, (0.0, 1.0)).all():
                    raise GymError(
                        f"actions {abbreviate(repr(actions))}: expected 0 (push left) or 1 (push right) each"
                    )
                given = np.where(given == 1, 1.0, -1.0)
            self.actions[:] = given
        if self.loop is not None:  # the rows being reset draw nothing this step (as a single env)
            active = np.flatnonzero(~self.needs_reset)
            self.actions[active] = self.loop.apply(active, self.actions[active], self.generators)
        self._kernel_step()
        if self.loop is not None:
            not_finite = self.loop.observe(active, self.state, self.generators, self.obs)
            self.ended[not_finite] = 2  # a non-finite observation: that episode failed
        self.elapsed += 1
        terminations = self.ended.astype(bool)
        truncations = self.elapsed >= self.ipgen_spec.max_episode_steps
        rewards = self.rewards.copy()
        infos: dict[str, Any] = {}
        resetting = self.needs_reset
        if resetting.any():
            rows = np.flatnonzero(resetting)
            for i in rows:
                self._reset_one(int(i), params=bool(self.ipgen_spec.spread) or bool(self._overridden[i]))
            self._overridden[rows] = False
            if self.loop is None:  # the first observations of the reset rows only
                fresh = np.empty((len(rows), self.obs.shape[1]), dtype=np.float32)
                self.kernel.observe(np.ascontiguousarray(self.state[rows]), self.cfg, fresh)
                self.obs[rows] = fresh
            else:
                self.loop.reset(rows, self.state, self.generators, self.obs)
            rewards[resetting] = 0.0
            terminations[resetting] = False
            truncations[resetting] = False
            self.elapsed[resetting] = 0
            infos = self._params_info(resetting)
        self.needs_reset = terminations | truncations
        return self.obs.copy(), rewards, terminations, truncations, infos
