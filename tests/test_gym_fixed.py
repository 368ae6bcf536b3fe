"""ipgen.gym's fixed-pivot chains (issue 46): the acrobot and pendubot environments, their m
torques, a step against the chain's equations integrated by scipy, vector = single, seeds."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

gymnasium = pytest.importorskip("gymnasium")

import ipgen.gym  # noqa: E402  (registers the ids)
from ipgen.gym.checks import GymError  # noqa: E402
from ipgen.gym.env import PendulumEnv  # noqa: E402
from ipgen.gym.fixed import FixedSystem, fixed_row  # noqa: E402
from ipgen.gym.make import spec_for  # noqa: E402
from ipgen.gym.vector import PendulumVectorEnv  # noqa: E402
from ipgen.model.fixed import FixedPendulum  # noqa: E402

DATA = Path(__file__).parent / "data" / "dfki"


def _dfki() -> FixedPendulum:
    """DFKI's double pendulum with both joints driven and its rotors (gr = −6), no friction."""
    return FixedPendulum.preset("dfki_c1").replace(coulomb=None)


@pytest.mark.parametrize("env_id", ["ipgen/Acrobot-SwingUp-v0", "ipgen/Pendubot-Balance-v0"])
def test_the_fixed_environments_pass_gymnasiums_env_checker(env_id: str) -> None:
    from gymnasium.utils.env_checker import check_env

    env = gymnasium.make(env_id, render_mode="rgb_array" if "Acrobot" in env_id else None)
    check_env(env.unwrapped)  # the acrobot's with the rgb_array render check
    assert env.action_space.shape == (1,) and env.action_space.high[0] == 6.0  # N m
    assert env.observation_space.shape == (6,)  # sin, cos of each link, the two rates


def test_make_takes_the_presets_names_and_the_chain_and_defaults_to_the_scenes_task() -> None:
    swing = ipgen.gym.make(preset="acrobot_swingup").unwrapped.ipgen_spec
    assert (swing.task, swing.system, swing.u_max, swing.max_episode_steps) == (
        "swingup", FixedSystem(2, (2,)), 6.0, 1000)  # fmt: skip
    assert ipgen.gym.make("pendubot", task="balance").unwrapped.ipgen_spec.system.joints == (1,)
    two = ipgen.gym.make(_dfki(), u_max=10.0)
    assert two.action_space.shape == (2,) and two.unwrapped.ipgen_spec.task == "balance"


def test_ten_steps_equal_dfkis_closed_form_integrated_by_scipy() -> None:
    """Ten steps (dt 0.01 s, 4 RK4 substeps) of DFKI's double pendulum driven at both joints, its
    rotors included (gr = −6), from near hanging with the torques held, against DFKI's own closed
    form (tests/fixed_reference.py: not ipgen's derivation) in DFKI's coordinates (q1 from
    hanging, q2 relative, counterclockwise) integrated by scipy's DOP853 at rtol 1e-12."""
    from fixed_reference import dfki_closed_form
    from scipy.integrate import solve_ivp

    from ipgen.model.dfki import dfki_pendulum, read_model_parameters

    values = read_model_parameters(DATA / "design_C.1_model_1.0.yml") | {"cf1": 0.0, "cf2": 0.0}
    spec = spec_for(FixedSystem(2, (1, 2)), fixed_row(dfki_pendulum(values)), "swingup", u_max=10.0)
    env = PendulumEnv(spec)
    theta = np.array([math.pi - 0.4, math.pi + 0.3, 1.0, -2.0])  # ipgen's: absolute, from upright, clockwise
    env.reset(seed=0, options={"state": theta})
    torque = np.array([1.5, -0.8])  # ipgen's sense (clockwise); DFKI's is the opposite

    def to_dfki(x: np.ndarray) -> np.ndarray:  # θ1 = π − q1, θ2 = π − (q1 + q2)
        return np.array([math.pi - x[0], x[0] - x[1], -x[2], x[2] - x[3]])

    def rhs(_t: float, x: np.ndarray) -> np.ndarray:
        mass, bias = dfki_closed_form(values, x[:2], x[2:])
        return np.concatenate([x[2:], np.linalg.solve(mass, -torque - bias)])

    x, worst = to_dfki(theta), 0.0
    for _ in range(10):
        obs, reward, *_ = env.step(torque.astype(np.float32))
        x = solve_ivp(rhs, (0.0, spec.dt), x, method="DOP853", rtol=1e-12, atol=1e-12).y[:, -1]
        worst = max(worst, float(np.max(np.abs(to_dfki(env.state[0]) - x))))
    print(f"largest state error over 10 steps: {worst:.2e}")
    assert worst < 1e-6
    angles = env.state[0, :2]
    np.testing.assert_allclose(obs, [*np.ravel(np.column_stack([np.sin(angles), np.cos(angles)])),
                                     *env.state[0, 2:]], rtol=1e-6, atol=1e-7)  # fmt: skip
    assert math.isclose(reward, float(np.mean((1 + np.cos(angles)) / 2)), rel_tol=1e-12)


def test_the_vector_env_equals_single_envs_with_two_inputs_spread_and_autoreset() -> None:
    spec = spec_for(FixedSystem(2, (1, 2)), fixed_row(_dfki()), "balance", u_max=10.0,
                    spread={"m": 0.1, "Ir": 0.5}, max_episode_steps=30)  # fmt: skip
    n, steps, seed = 3, 70, 4
    actions = np.random.default_rng(0).uniform(-10, 10, size=(steps, n, 2))
    vector = PendulumVectorEnv(spec, n)
    rows = [vector.reset(seed=seed)[0]]
    resets = 0
    for k in range(steps):
        obs, _, terminations, truncations, _ = vector.step(actions[k])
        resets += int(np.sum(terminations | truncations))
        rows.append(obs)
    assert resets >= n
    for i in range(n):
        env = PendulumEnv(spec)
        expected, ended, elapsed = [env.reset(seed=seed + i)[0]], False, 0
        for k in range(steps):
            if ended:
                obs, _ = env.reset()
                ended, elapsed = False, 0
            else:
                obs, _, terminated, truncated, _ = env.step(actions[k, i])
                elapsed += 1
                ended = terminated or truncated or elapsed >= spec.max_episode_steps
            expected.append(obs)
        np.testing.assert_array_equal(np.array([r[i] for r in rows]), np.array(expected))


def test_seeded_episodes_repeat_bitwise() -> None:
    def episode() -> np.ndarray:
        env = gymnasium.make("ipgen/Pendubot-SwingUp-v0")
        env.action_space.seed(5)
        rows = [env.reset(seed=9)[0]]
        rows += [env.step(env.action_space.sample())[0] for _ in range(50)]
        return np.array(rows)

    np.testing.assert_array_equal(episode(), episode())


@pytest.mark.parametrize(
    ("make", "action", "message"),
    [
        (lambda: ipgen.gym.make("acrobot"), np.array([1.0, 2.0]), r"expected shape \(1,\)"),
        (lambda: ipgen.gym.make("acrobot"), 1.0, r"expected shape \(1,\)"),
        (lambda: ipgen.gym.make("acrobot"), [math.nan], "not NaN"),
        (lambda: ipgen.gym.make_vec(_dfki(), 2), np.zeros(2), r"expected shape \(2, 2\)"),
    ],
)
def test_a_wrong_action_is_one_line(make: object, action: object, message: str) -> None:
    env = make()  # type: ignore[operator]
    env.reset(seed=0)
    with pytest.raises(GymError, match=message) as caught:
        env.step(action)
    assert "\n" not in str(caught.value)


@pytest.mark.parametrize(
    ("source", "options", "message"),
    [
        ("dfki_c1", {}, "does not model Coulomb friction"),
        ("acrobot", {"sensors": {"resolution": 2048}}, "sensors are not supported for fixed-pivot"),
        ("acrobot", {"x_limit": 1.0}, "x_limit = 1.0: a fixed-pivot chain has no base; leave x_limit out"),
        (
            "acrobot",
            {"spread": {"J_axial": 0.1}},
            "spread names 'J_axial': choose from m, l, delta, com, J, g, Ir, gr",
        ),
    ],
)
def test_what_a_fixed_chain_does_not_take_is_one_line(source: str, options: dict, message: str) -> None:
    with pytest.raises(GymError, match=message) as caught:
        ipgen.gym.make(source, **options)
    assert "\n" not in str(caught.value)


def test_the_scenes_torque_limit_is_checked_unless_u_max_is_given(tmp_path: Path) -> None:
    """u_max defaults to the scene's [swingup] u_max: one that is not a number > 0 is a one-line
    GymError naming the key (not float()'s ValueError), unless u_max is given."""
    from ipgen.common.presets import preset_path

    text = preset_path("acrobot_swingup").read_text()
    assert "\nu_max = 6.0\n" in text
    scene = tmp_path / "acrobot.toml"
    scene.write_text(text.replace("\nu_max = 6.0\n", '\nu_max = "big"\n'))
    with pytest.raises(
        GymError, match=r"the scene's swingup.u_max = 'big': expected finite numbers > 0"
    ) as caught:
        ipgen.gym.make(scene)
    assert "\n" not in str(caught.value)
    assert ipgen.gym.make(scene, u_max=3.0).action_space.high[0] == 3.0
    scene.write_text(text.replace("\nu_max = 6.0\n", "\nu_max = 4.5\n"))
    assert ipgen.gym.make(scene).unwrapped.ipgen_spec.u_max == 4.5
