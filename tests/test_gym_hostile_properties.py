"""ipgen.gym under hostile input (issue 48): accepted options never give a non-finite
observation as valid, a bad action or batch size is a documented error.

- The sensors' options obey a scene's rules ([sensors], [estimator]: the functions of
  `ipgen.estimation.measurement`), a reset whose observation is not finite is a GymError, a step
  whose measured observation is not finite ends the episode as failed;
- an action that is not a number (or N numbers) is a GymError (a ValueError), never an
  IndexError or KeyError;
- `num_envs` is bounded by the memory the batch needs (`gym.budget`), before anything is
  allocated.
"""

from __future__ import annotations

import math
import os
import resource
import subprocess
import sys
from decimal import Decimal

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

pytest.importorskip("gymnasium")

from ipgen.errors import Error
from ipgen.gym.checks import GymError
from ipgen.gym.env import PendulumEnv
from ipgen.gym.make import paper_system, spec_for
from ipgen.gym.vector import PendulumVectorEnv
from ipgen.scene.sensors import SensorsTable

HUGE = st.one_of(
    st.floats(0, 1e308, allow_nan=False),
    st.sampled_from([5e-324, 1e-300, 0.5, 1e100, 1e101, 1e200, 1e300, 1.7e308]),
)
SENSORS = st.fixed_dictionaries(
    {},
    optional={
        "resolution": HUGE,
        "noise": HUGE,
        "cutoff": HUGE.filter(lambda x: x > 0),
        "drive_noise": HUGE,
        "rates": st.sampled_from(["filter", "difference"]),
    },
)
STATES = st.lists(
    st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.sampled_from([1e30, 1e39, -1e300])),
    min_size=4,
    max_size=4,
)


def _scene_accepts_resolution(value: float) -> bool:
    try:
        SensorsTable.model_validate({"resolution": Decimal(repr(value))})
    except Exception:
        return False
    return True


@settings(max_examples=60, deadline=None)
@given(
    sensors=SENSORS,
    initial_noise=st.one_of(st.just(0.05), HUGE),
    state=st.one_of(st.none(), STATES),
    actions=st.lists(st.floats(-1, 1), min_size=1, max_size=5),
)
# issue 48's cases, and one hypothesis found (numpy's uniform overflows past 9e307)
@example(sensors={"resolution": 5e-324}, initial_noise=0.05, state=None, actions=[0.0])
@example(sensors={"cutoff": 1e300}, initial_noise=0.05, state=None, actions=[0.5])
@example(sensors={"noise": 1e300}, initial_noise=0.05, state=None, actions=[0.0])
@example(sensors={}, initial_noise=1e300, state=None, actions=[0.0])
@example(sensors={}, initial_noise=8.98846567431158e307, state=None, actions=[0.0])
@example(sensors={}, initial_noise=0.05, state=[math.nan] * 4, actions=[0.0])
def test_accepted_options_never_give_a_non_finite_observation(
    sensors: dict, initial_noise: float, state: list[float] | None, actions: list[float]
) -> None:
    system, row = paper_system("rotary", 1)
    try:
        spec = spec_for(system, row, "balance", initial_noise=initial_noise, sensors=sensors)
    except GymError as error:
        assert "\n" not in str(error)
        if "resolution" in sensors and "sensors.resolution" in str(error):
            assert not _scene_accepts_resolution(sensors["resolution"])  # refused as a scene does
        return
    if "resolution" in sensors:
        assert _scene_accepts_resolution(sensors["resolution"])  # accepted as a scene does
    env = PendulumEnv(spec)
    try:
        obs, _ = env.reset(seed=1, options=None if state is None else {"state": state})
    except GymError as error:
        assert "\n" not in str(error)
        return
    assert np.isfinite(obs).all()
    for action in actions:
        obs, _, terminated, _, _ = env.step(np.array([action], dtype=np.float32))
        assert terminated or np.isfinite(obs).all()
        if terminated:
            break


def test_a_measured_loop_whose_rates_overflow_ends_the_episode_as_failed() -> None:
    """The guard behind the rules: a step with a non-finite measured observation (rates from a
    state so large that float32 cannot hold them) terminates, marked failed."""
    system, row = paper_system("rotary", 1)
    env = PendulumEnv(spec_for(system, row, "balance", sensors={"resolution": 0}, x_limit=math.inf))
    env.reset(seed=0, options={"state": [0.0, 0.0, 0.0, 0.0]})
    env.state[0] = [1e38, 0.0, 0.0, 0.0]  # the base jumps by 1e38 between two samples
    _, _, terminated, _, info = env.step(np.array([0.0], dtype=np.float32))
    assert terminated and info == {"failed": True}


ACTIONS = st.one_of(
    st.lists(st.floats(allow_nan=True), max_size=3),
    st.dictionaries(st.text(max_size=3), st.floats(), max_size=2),
    st.text(max_size=4),
    st.none(),
    st.floats(allow_nan=True),
    st.lists(st.lists(st.floats(-1, 1), max_size=2), max_size=2),
)


@settings(max_examples=80, deadline=None)
@given(action=ACTIONS, vector=st.booleans())
@example(action=[], vector=False)
@example(action={}, vector=False)
def test_any_action_steps_or_is_a_gym_error(action: object, vector: bool) -> None:
    system, row = paper_system("rotary", 1)
    spec = spec_for(system, row, "balance")
    env: PendulumEnv | PendulumVectorEnv = PendulumVectorEnv(spec, 2) if vector else PendulumEnv(spec)
    env.reset(seed=0)
    try:
        obs, *_ = env.step(action)
    except Error as error:
        assert isinstance(error, ValueError | TypeError) and "\n" not in str(error)
        assert "expected" in str(error)
        return
    assert np.isfinite(obs).all()


def _one_number(action: object) -> bool:
    """What a single environment's Box action is: one number, or an array or sequence holding
    exactly one number (not text, not NaN)."""
    try:
        array = np.asarray(action, dtype=np.float64)
    except (TypeError, ValueError):
        return False
    return np.asarray(action).dtype.kind not in "US" and array.size == 1 and not np.isnan(array).any()


@settings(max_examples=60, deadline=None)
@given(action=st.one_of(ACTIONS, st.sampled_from(["5", "0.5", b"1", [0.5, 0.9], (0.2,), [0.3]])))
def test_an_action_steps_exactly_when_it_is_one_number(action: object) -> None:
    """A single environment takes one number (or a sequence of exactly one) and steps as with
    that number; anything else is a GymError (two numbers used the first, text was read as a
    number)."""
    system, row = paper_system("rotary", 1)
    env, twin = (PendulumEnv(spec_for(system, row, "balance")) for _ in range(2))
    env.reset(seed=0)
    twin.reset(seed=0)
    if not _one_number(action):
        with pytest.raises(GymError, match="expected"):
            env.step(action)
        return
    value = float(np.asarray(action, dtype=np.float64).reshape(1)[0])
    assert np.array_equal(env.step(action)[0], twin.step(np.array([value]))[0])


@settings(max_examples=40, deadline=None)
@given(
    action=st.one_of(
        st.integers(-3, 3), st.floats(allow_nan=True), st.text(max_size=2),
        st.sampled_from([np.int64(1), np.array(0), np.array(1.0), True, None, [1]]),
    ),
    vector=st.booleans(),
)  # fmt: skip
def test_cartpole_takes_0_or_1_only(action: object, vector: bool) -> None:
    """CartPole's Discrete(2): the integers 0 and 1 (Python or numpy), as gymnasium's own; 2, -1,
    0.7, text or NaN are a GymError (they all pushed left). A batch: 0 or 1 each."""
    from ipgen.gym.make import cartpole_spec

    spec = cartpole_spec()
    if vector:
        env: PendulumEnv | PendulumVectorEnv = PendulumVectorEnv(spec, 2)
        batch = [action, 1]
        valid = _one_number(action) and np.ndim(action) == 0  # each environment's entry a number
        valid = valid and float(np.asarray(action, dtype=np.float64)) in (0.0, 1.0)
    else:
        env = PendulumEnv(spec)
        batch = action
        integral = isinstance(action, int | np.integer) or (
            isinstance(action, np.ndarray) and np.issubdtype(action.dtype, np.integer)
        )
        valid = integral and int(action) in (0, 1)  # type: ignore[call-overload]
    env.reset(seed=0)
    if not valid:
        with pytest.raises(GymError, match=r"0 \(push left\) or 1" if not vector else "expected"):
            env.step(batch)
        return
    assert np.isfinite(env.step(batch)[0]).all()


def test_a_vector_reset_takes_a_state_and_one_seed_per_environment() -> None:
    """options={"state": x} starts every environment at x (or row i at x[i]), as a single
    environment's reset does (it was ignored: random starts); a list of seeds has one per
    environment (a short one raised an IndexError, a long one lost its last)."""
    system, row = paper_system("classical", 1)
    spec = spec_for(system, row, "balance")
    single = PendulumEnv(spec)
    vector = PendulumVectorEnv(spec, 3)
    start = [0.0, 0.15, 0.0, 0.0]
    one, _ = single.reset(seed=0, options={"state": start})
    batch, _ = vector.reset(seed=0, options={"state": start})
    assert all(np.array_equal(observation, one) for observation in batch)
    rows = [[0.0, 0.1 * (i + 1), 0.0, 0.0] for i in range(3)]
    batch, _ = vector.reset(seed=0, options={"state": rows})
    for observation, state in zip(batch, rows, strict=True):
        assert np.array_equal(observation, single.reset(seed=0, options={"state": state})[0])
    for seeds in ([1, 2], [1, 2, 3, 4], "7"):
        with pytest.raises(GymError, match="one seed per"):
            vector.reset(seed=seeds)  # type: ignore[arg-type]
    vector.reset(seed=[1, 2, 3])


@settings(max_examples=3, deadline=None)
@given(num_envs=st.integers(10**6, 10**12))
def test_num_envs_is_bounded_by_the_memory_it_needs(num_envs: int) -> None:
    """Under a 2 GB address-space limit, a batch that cannot fit is one GymError naming a count
    that fits, at once, in a process of its own (a MemoryError or the OOM killer otherwise)."""

    def limited() -> None:
        resource.setrlimit(resource.RLIMIT_AS, (2 << 30, 2 << 30))

    code = (
        "import ipgen.gym\n"
        "try:\n"
        f"    ipgen.gym.make_vec('rsip_lqr', {num_envs})\n"
        "except ipgen.gym.checks.GymError as error:\n"
        "    print(error)\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", code],
        capture_output=True,
        text=True,
        timeout=60,
        preexec_fn=limited,
        env={**os.environ, "OPENBLAS_NUM_THREADS": "1"},
    )
    assert done.returncode == 0 and not done.stderr, done.stderr[-2000:]
    assert f"num_envs = {num_envs:,}" in done.stdout and "pass at most" in done.stdout
