"""ipgen.gym: gymnasium's CartPole-v1 reproduced step for step, the env checker, the vector
environment equal to N single ones bitwise, and one step against ipgen's CVODE simulator."""

from __future__ import annotations

import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

gymnasium = pytest.importorskip("gymnasium")

import ipgen.gym  # noqa: E402  (registers the ids)
from ipgen.gym.checks import GymError  # noqa: E402
from ipgen.gym.make import paper_system, spec_for  # noqa: E402
from ipgen.gym.vector import PendulumVectorEnv  # noqa: E402


def test_cartpole_preset_reproduces_gymnasiums_cartpole_step_for_step() -> None:
    ours, theirs = ipgen.gym.make(preset="cartpole-v1"), gymnasium.make("CartPole-v1")
    actions = np.random.default_rng(7)
    steps = worst = 0
    for episode in range(40):
        mine, info = ours.reset(seed=episode)
        reference, _ = theirs.reset(seed=episode)
        np.testing.assert_array_equal(mine, reference)
        assert set(info["params"]) >= {"m", "l", "delta", "g"}
        while True:
            action = int(actions.integers(2))
            mine, reward, terminated, truncated, _ = ours.step(action)
            reference, reward_ref, terminated_ref, truncated_ref, _ = theirs.step(action)
            worst = max(worst, float(np.max(np.abs(mine - reference))))
            assert (reward, terminated, truncated) == (reward_ref, terminated_ref, truncated_ref), episode
            steps += 1
            if terminated or truncated:
                break
    assert steps > 400
    assert worst <= 1e-6  # float32 observations; the accelerations differ only in rounding


def test_cartpole_preset_balanced_by_a_fixed_policy_is_truncated_at_500_steps() -> None:
    env = ipgen.gym.make("cartpole-v1")
    obs, _ = env.reset(seed=3)
    for step in range(1, 501):  # a hand-tuned linear policy on (x, ẋ, θ, θ̇)
        obs, _, terminated, truncated, _ = env.step(int(obs @ np.array([0.1, 0.5, 10.0, 2.0]) > 0))
        assert not terminated, step
    assert truncated


@pytest.mark.parametrize(
    "source",
    ["cartpole-v1", ("classical", 2, "swingup"), ("rotary", 1, "balance"), ("rotary", 2, "swingup")],
)
def test_the_environments_pass_gymnasiums_env_checker(source: object) -> None:
    from gymnasium.utils.env_checker import check_env

    if source == "cartpole-v1":
        env = gymnasium.make("ipgen/CartPole-v1", render_mode="rgb_array")
    else:
        type, links, task = source  # type: ignore[misc]
        env = gymnasium.make(
            f"ipgen/{'Cart' if type == 'classical' else 'Rotary'}"
            f"{['', 'Single', 'Double'][links]}-{'SwingUp' if task == 'swingup' else 'Balance'}-v0",
            render_mode="rgb_array",
        )
    check_env(env.unwrapped)  # with its rgb_array render check


def _run_singles(spec: object, seed: int, actions: np.ndarray) -> list[list[np.ndarray]]:
    """Each sub-environment as a single env seeded seed + i, reset when it ended (NEXT_STEP)."""
    from ipgen.gym.env import PendulumEnv

    outputs = []
    for i in range(actions.shape[1]):
        env = PendulumEnv(spec)  # type: ignore[arg-type]
        obs, _ = env.reset(seed=seed + i)
        rows, ended, elapsed = [obs], False, 0
        for k in range(actions.shape[0]):
            if ended:
                obs, _ = env.reset()
                ended, elapsed = False, 0
                rows.append(obs)
                continue
            obs, _, terminated, truncated, _ = env.step(actions[k, i : i + 1])
            elapsed += 1
            ended = terminated or truncated or elapsed >= spec.max_episode_steps  # type: ignore[attr-defined]
            rows.append(obs)
        outputs.append(rows)
    return outputs


def test_the_vector_env_equals_n_single_envs_bitwise_with_spread_and_autoreset() -> None:
    system, row = paper_system("classical", 2)
    spec = spec_for(system, row, "balance", spread={"m": 0.1, "delta": 0.5}, max_episode_steps=40)
    n, steps, seed = 5, 150, 11
    actions = np.random.default_rng(0).uniform(-1, 1, size=(steps, n))
    vector = PendulumVectorEnv(spec, n)
    obs, info = vector.reset(seed=seed)
    rows = [obs]
    assert info["params"]["m"].shape == (n, 3)
    resets = 0
    for k in range(steps):
        obs, _, terminations, truncations, _ = vector.step(actions[k].reshape(n, 1))
        resets += int(np.sum(terminations | truncations))
        rows.append(obs)
    assert resets >= n  # every sub-environment ended at least once: autoreset was exercised
    singles = _run_singles(spec, seed, actions)
    for i in range(n):
        np.testing.assert_array_equal(np.array([r[i] for r in rows]), np.array(singles[i]))


def test_without_a_spread_the_rows_stay_nominal_and_overrides_last_one_episode() -> None:
    """The fast path of the autoreset (no spread: the parameter rows are not rewritten) equals
    single envs bitwise, parameters set by
    reset(options=...) hold for that episode only, as in a single env, and each info is the
    caller's own (writing into one changes no other)."""
    from ipgen.gym.env import PendulumEnv

    system, row = paper_system("classical", 1)
    spec = spec_for(system, row, "balance", max_episode_steps=25)
    n, steps, seed, heavy = 4, 80, 3, {"m": [0.6, 0.4]}
    actions = np.random.default_rng(1).uniform(-1, 1, size=(steps, n))
    vector = PendulumVectorEnv(spec, n)
    obs, info = vector.reset(seed=seed, options={"params": heavy})
    np.testing.assert_array_equal(info["params"]["m"], [heavy["m"]] * n)
    rows, seen = [obs], []
    for k in range(steps):
        obs, _, _, _, info = vector.step(actions[k].reshape(n, 1))
        rows.append(obs)
        if info:
            seen.append(info)
    assert seen and all(np.array_equal(i["params"]["m"][i["_params"]], [row[:2]] * int(i["_params"].sum()))
                        for i in seen)  # fmt: skip
    seen[0]["params"]["m"][:] = -1.0
    assert np.all(seen[-1]["params"]["m"][seen[-1]["_params"]] > 0)
    np.testing.assert_array_equal(vector.params, np.tile(spec.nominal, (n, 1)))  # back to nominal
    for i in range(n):
        env = PendulumEnv(spec)
        single, _ = env.reset(seed=seed + i, options={"params": heavy})
        expected, ended, elapsed = [single], False, 0
        for k in range(steps):
            if ended:
                single, _ = env.reset()
                ended, elapsed = False, 0
            else:
                single, _, terminated, truncated, _ = env.step(actions[k, i : i + 1])
                elapsed += 1
                ended = terminated or truncated or elapsed >= spec.max_episode_steps
            expected.append(single)
        np.testing.assert_array_equal(np.array([r[i] for r in rows]), np.array(expected))


def test_a_spread_draws_new_parameters_each_episode_and_options_set_them() -> None:
    system, row = paper_system("rotary", 1)
    from ipgen.gym.env import PendulumEnv

    spec = spec_for(system, row, "swingup", spread={"m": 0.1, "delta": 0.5})
    single = PendulumEnv(spec)
    _, first = single.reset(seed=1)
    _, second = single.reset()
    assert not np.array_equal(first["params"]["m"], second["params"]["m"])
    assert np.all(np.abs(first["params"]["m"] / np.array([0.5, 0.275]) - 1) <= 0.1)
    assert np.all(np.abs(first["params"]["delta"] / np.array([0.3, 0.011458]) - 1) <= 0.5)
    _, fixed = single.reset(options={"params": {"m": [0.4, 0.3]}})
    np.testing.assert_array_equal(fixed["params"]["m"], [0.4, 0.3])
    with pytest.raises(GymError, match="must be 2 finite numbers"):
        single.reset(options={"params": {"m": [0.4, math.nan]}})


@pytest.mark.parametrize(
    ("options", "message"),
    [
        ({"dt": 0.0}, "dt = 0.0 must be a number > 0"),
        ({"substeps": 0}, "substeps = 0 must be an integer"),
        ({"spread": {"mass": 0.1}}, "spread names 'mass'"),
        ({"spread": {"m": 1.5}}, "relative half-width"),
        ({"max_episode_steps": 0}, "max_episode_steps = 0"),
    ],
)
def test_bad_options_are_one_line_errors(options: dict, message: str) -> None:
    system, row = paper_system("classical", 1)
    with pytest.raises(GymError, match=message.replace("(", r"\(")) as caught:
        spec_for(system, row, "balance", **options)
    assert "\n" not in str(caught.value)


SCENE = """\
[system]
type = "{type}"
links = {links}
name = "{name}"

[parameters]
m = {m}
l = {l}
delta = {delta}

[initial]
theta = {theta}
dtheta = {dtheta}

[input]
kind = "constant"
amplitude = {u}

[simulation]
t_end = {t_end}
sample = {dt}
rtol = 1e-12
atol = 1e-14
"""


# The shipped scenes' models (cart double, rotary single): their simulators are built by other tests too.
@pytest.mark.parametrize(("type", "links", "name"), [("classical", 2, "cdip"), ("rotary", 1, "rsip")])
def test_env_steps_agree_with_ipgens_cvode_simulator(
    tmp_path: Path, type: str, links: int, name: str
) -> None:
    """Ten steps with the action held equal the simulator (BDF, rtol 1e-12) with the input held
    over the same ten intervals: the RK4 substeps' error, stated in docs/gym.md."""
    from ipgen.gym.env import PendulumEnv

    system, row = paper_system(type, links)
    spec = spec_for(system, row, "swingup", x_limit=math.inf)
    env = PendulumEnv(spec)
    start = np.random.default_rng(links).uniform(-0.5, 0.5, size=2 * system.dof)
    start[1 : system.dof] += math.pi  # near hanging: the swing-up's regime, large motions
    env.reset(seed=0, options={"state": start})
    action, steps = 0.4, 10
    states = []
    for _ in range(steps):
        env.step(np.array([action], dtype=np.float32))
        states.append(env.state[0].copy())
    dof = system.dof
    value = lambda group: spec.group(row, group).tolist()  # noqa: E731
    scene = tmp_path / "truth.toml"
    scene.write_text(
        SCENE.format(
            type=type,
            links=links,
            name=name,
            m=value("m"),
            l=value("l"),
            delta=value("delta"),
            theta=start[:dof].tolist(),
            dtheta=start[dof:].tolist(),
            u=action * spec.u_max,
            t_end=steps * spec.dt,
            dt=spec.dt,
        )
    )
    done = subprocess.run(
        [sys.executable, "-m", "ipgen", "run", str(scene), "-o", str(tmp_path / "out"), "--no-plot"],
        capture_output=True,
        text=True,
        env=os.environ.copy(),
    )
    assert done.returncode == 0, done.stderr
    header, *lines = (tmp_path / "out" / "truth.csv").read_text().splitlines()
    table = np.array([[float(v) for v in line.split(",")] for line in lines])
    columns = header.split(",")
    wanted = [f"theta{i}" for i in range(dof)] + [f"dtheta{i}" for i in range(dof)]
    simulated = table[1 : steps + 1, [columns.index(c) for c in wanted]]
    error = np.max(np.abs(np.array(states) - simulated))
    print(f"{type}{links}: largest state error over {steps} steps {error:.2e}")
    assert error < 1e-6, error


def test_measured_observations_vector_equals_singles_with_delay_noise_and_spread() -> None:
    system, row = paper_system("rotary", 2)
    sensors = {"resolution": 2048, "noise": 0.002, "delay": 0.02, "drive_noise": 0.05}
    spec = spec_for(system, row, "balance", spread={"J": 0.2}, max_episode_steps=30, sensors=sensors)
    n, steps, seed = 4, 100, 5
    actions = np.random.default_rng(1).uniform(-1, 1, size=(steps, n))
    vector = PendulumVectorEnv(spec, n)
    rows = [vector.reset(seed=seed)[0]]
    for k in range(steps):
        rows.append(vector.step(actions[k].reshape(n, 1))[0])
    singles = _run_singles(spec, seed, actions)
    for i in range(n):
        np.testing.assert_array_equal(np.array([r[i] for r in rows]), np.array(singles[i]))


def test_encoder_filter_and_delay_by_hand() -> None:
    """2048 counts: y = Δ floor(θ/Δ + 1/2); rates from v_k = e^(−ωc dt) v_(k−1) + ωc (y_k − y_(k−1));
    an action delayed by two intervals leaves the first two steps unforced."""
    from ipgen.gym.env import PendulumEnv

    system, row = paper_system("classical", 1)
    quantum_x, quantum_angle = 1 / 1000, 2 * math.pi / 2048
    sensors = {"resolution": [1000, 2048], "delay": 0.02, "cutoff": 50.0}
    env = PendulumEnv(spec_for(system, row, "balance", sensors=sensors))
    start = np.array([0.01234, 0.05, 0.0, 0.0])
    obs, _ = env.reset(seed=0, options={"state": start})
    y0 = [
        quantum_x * math.floor(start[0] / quantum_x + 0.5),
        quantum_angle * math.floor(0.05 / quantum_angle + 0.5),
    ]
    np.testing.assert_allclose(obs[:3], [y0[0], math.sin(y0[1]), math.cos(y0[1])], rtol=1e-6)
    assert np.all(obs[3:] == 0)
    free = PendulumEnv(spec_for(system, row, "balance"))
    free.reset(seed=0, options={"state": start})
    for _ in range(2):  # the first two actions are not yet applied: the same as no input
        obs, *_ = env.step(np.array([1.0], np.float32))
        free.step(np.array([0.0], np.float32))
        np.testing.assert_array_equal(env.state, free.state)
    theta = env.state[0, 1]
    y2 = quantum_angle * math.floor(theta / quantum_angle + 0.5)
    assert math.isclose(math.atan2(obs[1], obs[2]), y2, rel_tol=1e-6, abs_tol=1e-7)
    # the filter's rates over ten more steps, recomputed by hand from the quantised states
    a, wc = math.exp(-50.0 * 0.01), 50.0
    quanta = np.array([quantum_x, quantum_angle])
    previous = quanta * np.floor(env.state[0, :2] / quanta + 0.5)
    rates = env.loop.rates[0].copy()  # type: ignore[union-attr]
    for _ in range(10):
        obs, *_ = env.step(np.array([0.3], np.float32))
        y = quanta * np.floor(env.state[0, :2] / quanta + 0.5)
        rates = a * rates + wc * (y - previous)
        previous = y
        np.testing.assert_allclose(obs[3:], rates.astype(np.float32), rtol=1e-6, atol=1e-6)
    assert np.any(rates != 0)


def test_the_python_examples_of_docs_gym_md_run() -> None:
    text = (Path(__file__).resolve().parents[1] / "docs" / "gym.md").read_text()
    blocks = [b.split("```", 1)[0] for b in text.split("```python\n")[1:]]
    assert blocks
    for block in blocks:
        namespace: dict[str, object] = {}
        exec(compile(block, "docs/gym.md", "exec"), namespace)  # the reader's copy, verbatim
        assert "obs" in namespace


from hypothesis import given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

ANY_VALUE = st.one_of(
    st.none(),
    st.integers(-(10**30), 10**30),
    st.floats(allow_nan=True, allow_infinity=True),
    st.text(max_size=5),
    st.lists(st.floats(), max_size=3),
)


@settings(max_examples=150, deadline=None)
@given(
    key=st.sampled_from(
        ["dt", "substeps", "u_max", "x_limit", "angle_limit", "initial_noise", "max_episode_steps"]
    ),
    value=ANY_VALUE,
    spread_key=st.sampled_from(["m", "J", "mass", "g", 3]),
    spread_value=ANY_VALUE,
    sensors=st.one_of(
        st.none(),
        st.dictionaries(
            st.sampled_from(["resolution", "noise", "delay", "rates", "cutoff", "drive_noise", "bogus"]),
            ANY_VALUE,
            max_size=3,
        ),
    ),
)
def test_any_option_makes_an_environment_or_one_line_gym_error(
    key: str, value: object, spread_key: object, spread_value: object, sensors: object
) -> None:
    system, row = paper_system("rotary", 1)
    try:
        spec = spec_for(
            system, row, "balance", **{key: value}, spread={spread_key: spread_value}, sensors=sensors
        )
    except GymError as e:
        assert "\n" not in str(e) and len(str(e)) < 300
        return
    assert spec.dt > 0 and spec.substeps >= 1 and 0 <= spec.spread[spread_key] < 1  # type: ignore[index]


def test_a_preset_with_a_dc_motor_is_folded_once_and_driven_in_volts() -> None:
    """The QUBE-Servo 2: the kernel's row is the Pendulum's direct model (back-EMF in delta[0],
    gain kt/Rm N m per volt) and action +1 is 10 V."""
    qube = ipgen.Pendulum.preset("qube_servo2")
    env = gymnasium.make("ipgen/QubeServo2-Balance-v0").unwrapped
    spec = env.ipgen_spec
    assert spec.u_max == 10.0
    np.testing.assert_allclose(spec.group(spec.nominal, "gain"), [0.042 / 8.4])
    np.testing.assert_allclose(spec.group(spec.nominal, "delta"), [0.0015 + 0.042 * 0.042 / 8.4, 0.0005])
    np.testing.assert_allclose(spec.group(spec.nominal, "m"), qube.m)
    env.reset(seed=0)
    obs, *_ = env.step(np.array([1.0], np.float32))
    assert obs.shape == (5,)


@settings(max_examples=25, deadline=None)
@given(st.text(min_size=1, max_size=30).filter(lambda s: not s.endswith(".toml")))
def test_an_unknown_name_lists_every_name_make_takes(name: str) -> None:
    """A name that is no preset (e.g. "Acrobot", capitalised): one line naming the presets and the
    names only make() knows ("acrobot", "pendubot", "cartpole-v1")."""
    from ipgen.common.presets import preset_path
    from ipgen.errors import Error
    from ipgen.gym.fixed import ALIASES

    try:
        preset_path(ALIASES.get(name, name))
        return  # a preset or an alias: made elsewhere
    except Error:
        pass
    if name.lower() == "cartpole-v1":
        return
    with pytest.raises(GymError) as info:
        ipgen.gym.make(name)
    message = str(info.value)
    names = ("'acrobot'", "'pendubot'", "'cartpole-v1'")
    assert "\n" not in message and all(word in message for word in names), message


@pytest.mark.parametrize("system", ["classical2", "fixed2"])
def test_the_kernels_sources_compile_without_a_warning(tmp_path: Path, system: str) -> None:
    """The kernel's build leaves -Werror out (the user's compiler may warn where ours does not);
    with it, the generated header and kernel of a cart and of a fixed chain compile here."""
    import shutil

    from ipgen.gym.fixed import FixedSystem
    from ipgen.gym.kernel import FLAGS, model_name, sources

    chosen = paper_system("classical", 2)[0] if system == "classical2" else FixedSystem(2, (1, 2))
    header, kernel = sources(chosen)
    name = model_name(chosen)
    (tmp_path / f"{name}.h").write_text(header)
    (tmp_path / f"gym_{name}.c").write_text(kernel)
    cc = shutil.which("cc") or shutil.which("gcc")
    assert cc is not None
    source, library = tmp_path / f"gym_{name}.c", tmp_path / "kernel.so"
    command = [cc, *FLAGS, "-Werror", f"-I{tmp_path}", str(source), "-o", str(library), "-lm"]
    result = subprocess.run(command, capture_output=True, text=True, check=False)
    assert result.returncode == 0 and "warning" not in result.stderr, result.stderr
    assert "-Werror" not in FLAGS
