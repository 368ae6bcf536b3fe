"""A worked example of ipgen.gym (docs/gym.md): a linear policy for balancing the paper's Furuta
pendulum, trained by the cross-entropy method on 64 environments at once, then run as a
controller in ipgen's simulator with the rig's encoders and rate filter.

    .venv/bin/python examples/gym_cem_balance.py [--out out/gym_example]

The policy is a = clip(w · (q0, sin θ1, θ̇0, θ̇1), −1, 1), the torque u = u_max a: a gain on the
state, so the trained w is the controller gain K = −u_max w of u = −K x near upright, which a
scene's `[controller] kind = "gain"` runs in the simulator.
"""

from __future__ import annotations

import argparse
import csv
import json
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from ipgen.gym.make import paper_system, spec_for
from ipgen.gym.spec import EnvSpec
from ipgen.gym.vector import PendulumVectorEnv
from ipgen.model.paper import paper_pendulum

POPULATION, ELITE, ITERATIONS, SEED = 64, 8, 50, 0
SENSORS = {"resolution": 2048, "delay": 0.01, "cutoff": 50.0}
# The search's objective is the env's return minus ARM_WEIGHT · θ0² per step: the balance task
# rewards only the link, and a policy that holds the link while the arm drifts scores fully in
# its 5 s episodes (without this term the trained gain left an unstable arm pole, +0.34 1/s,
# which the 10 s simulator run below showed as a 1.8 rad drift).
ARM_WEIGHT = 10.0


def features(obs: np.ndarray) -> np.ndarray:
    """(q0, sin θ1, θ̇0, θ̇1) from the observation (q0, sin θ1, cos θ1, θ̇0, θ̇1)."""
    return obs[:, [0, 1, 3, 4]]


def returns(envs: PendulumVectorEnv, weights: np.ndarray, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """The objective of one 500-step episode per candidate (row of `weights`), all envs at once:
    the env's return less ARM_WEIGHT · θ0² per step; and the steps each episode lasted."""
    obs, _ = envs.reset(seed=seed)
    total = np.zeros(envs.num_envs)
    steps = np.zeros(envs.num_envs, dtype=int)
    alive = np.ones(envs.num_envs, dtype=bool)
    for _ in range(envs.ipgen_spec.max_episode_steps):
        actions = np.clip(np.sum(features(obs) * weights, axis=1), -1, 1)
        obs, rewards, terminated, truncated, _ = envs.step(actions.reshape(-1, 1))
        total += (rewards - ARM_WEIGHT * obs[:, 0] ** 2) * alive
        steps += alive
        alive &= ~(terminated | truncated)
        if not alive.any():
            break
    return total, steps


# The same rig, policy and sensing as a scene for ipgen's simulator (CVODE, not the env's RK4):
# the policy is the controller's given gain, sampled every dt, its rates from the same filter.
SCENE = """\
# The paper's rotary single pendulum held by a linear policy trained with ipgen.gym
# (examples/gym_cem_balance.py), with the env's encoders, rate filter and delay.
[system]
type = "rotary"
links = 1
name = "gym_policy"

[parameters]
m = {m}
l = {l}
delta = {delta}

[initial]
theta = [0, 0.1]

[controller]
kind = "gain"
gain = {gain}
saturation = {u_max}
period = {dt}

[sensors]
measured = [0, 1]
resolution = {resolution}
delay = {delay}
seed = 1

[estimator]
kind = "filter"
cutoff = {cutoff}

[simulation]
t_end = 10.0
sample = {dt}
"""


def run_in_simulator(gain: list[float], spec: EnvSpec, out: Path) -> dict[str, float]:
    """`ipgen run` on SCENE with `gain`: the largest |θ0| and |θ1| over the last 5 of 10 s."""
    rig = paper_pendulum("rotary", 1)  # the env's rig (paper_system above)
    values = {name: [float(v) for v in getattr(rig, name)] for name in ("m", "l", "delta")}
    text = SCENE.format(gain=gain, u_max=spec.u_max, dt=spec.dt, **values, **SENSORS)
    scene = out / "gym_policy.toml"
    scene.write_text(text, encoding="utf-8")
    subprocess.run(
        [sys.executable, "-m", "ipgen", "run", str(scene), "-o", str(out / "run"), "--force"], check=True
    )
    with open(out / "run" / "gym_policy.csv", encoding="utf-8") as file:
        rows = [row for row in csv.DictReader(line for line in file if not line.startswith("#"))]
    late = [row for row in rows if float(row["t"]) >= 5.0]
    return {
        f"max_abs_{name}_last_5s": max(abs(float(row[name])) for row in late) for name in ("theta0", "theta1")
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("out/gym_example"))
    args = parser.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    system, row = paper_system("rotary", 1)
    spec = spec_for(system, row, "balance", sensors=SENSORS, initial_noise=0.1)
    envs = PendulumVectorEnv(spec, POPULATION)
    rng = np.random.default_rng(SEED)
    mean, sigma = np.zeros(4), np.full(4, 2.0)
    start = time.perf_counter()
    history = []
    for iteration in range(ITERATIONS):
        candidates = mean + sigma * rng.standard_normal((POPULATION, 4))
        scores, _ = returns(envs, candidates, seed=iteration)
        elite = candidates[np.argsort(scores)[-ELITE:]]
        mean, sigma = elite.mean(axis=0), elite.std(axis=0) + 0.05
        history.append(float(scores.max()))
        print(f"iteration {iteration + 1:2d}: best objective {scores.max():5.0f}, mean {scores.mean():5.0f}")
    seconds = time.perf_counter() - start
    _, final = returns(envs, np.tile(mean, (POPULATION, 1)), seed=1000)
    gain = (-spec.u_max * mean).tolist()  # u = −K x on x = (θ0, θ1, θ̇0, θ̇1), sin θ1 ≈ θ1
    result = {
        "weights": mean.tolist(),
        "gain_K": gain,
        "training_seconds": round(seconds, 2),
        "episodes": POPULATION * ITERATIONS,
        "final_episode_steps_mean": float(final.mean()),
        "final_episode_steps_min": int(final.min()),
        "sensors": SENSORS,
    }
    result["simulator"] = run_in_simulator(gain, spec, args.out)
    (args.out / "policy.json").write_text(json.dumps(result, indent=2) + "\n")
    print(json.dumps(result, indent=2))
    held = (
        result["simulator"]["max_abs_theta1_last_5s"] < 0.05
        and result["simulator"]["max_abs_theta0_last_5s"] < 0.1
    )
    return 0 if final.min() >= spec.max_episode_steps and held else 1


if __name__ == "__main__":
    raise SystemExit(main())
