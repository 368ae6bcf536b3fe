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
import json
import time
from pathlib import Path

import numpy as np

import ipgen.gym
from ipgen.gym.make import paper_system, spec_for
from ipgen.gym.vector import PendulumVectorEnv

POPULATION, ELITE, ITERATIONS, SEED = 64, 8, 25, 0
SENSORS = {"resolution": 2048, "delay": 0.01, "cutoff": 50.0}


def features(obs: np.ndarray) -> np.ndarray:
    """(q0, sin θ1, θ̇0, θ̇1) from the observation (q0, sin θ1, cos θ1, θ̇0, θ̇1)."""
    return obs[:, [0, 1, 3, 4]]


def returns(envs: PendulumVectorEnv, weights: np.ndarray, seed: int) -> np.ndarray:
    """The return of one 500-step episode per candidate (row of `weights`), all envs at once."""
    obs, _ = envs.reset(seed=seed)
    total = np.zeros(envs.num_envs)
    alive = np.ones(envs.num_envs, dtype=bool)
    for _ in range(envs.ipgen_spec.max_episode_steps):
        actions = np.clip(np.sum(features(obs) * weights, axis=1), -1, 1)
        obs, rewards, terminated, truncated, _ = envs.step(actions.reshape(-1, 1))
        total += rewards * alive
        alive &= ~(terminated | truncated)
        if not alive.any():
            break
    return total


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
        scores = returns(envs, candidates, seed=iteration)
        elite = candidates[np.argsort(scores)[-ELITE:]]
        mean, sigma = elite.mean(axis=0), elite.std(axis=0) + 0.05
        history.append(float(scores.max()))
        print(f"iteration {iteration + 1:2d}: best return {scores.max():5.0f}, mean {scores.mean():5.0f}")
    seconds = time.perf_counter() - start
    final = returns(envs, np.tile(mean, (POPULATION, 1)), seed=1000)
    gain = (-spec.u_max * mean).tolist()  # u = −K x on x = (θ0, θ1, θ̇0, θ̇1), sin θ1 ≈ θ1
    result = {
        "weights": mean.tolist(),
        "gain_K": gain,
        "training_seconds": round(seconds, 2),
        "episodes": POPULATION * ITERATIONS,
        "final_returns_mean": float(final.mean()),
        "final_returns_min": float(final.min()),
        "sensors": SENSORS,
    }
    (args.out / "policy.json").write_text(json.dumps(result, indent=2) + "\n")
    print(json.dumps(result, indent=2))
    return 0 if final.min() >= spec.max_episode_steps else 1


if __name__ == "__main__":
    raise SystemExit(main())
