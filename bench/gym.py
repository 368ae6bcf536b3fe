"""`make bench-gym`: ipgen.gym's throughput on one core against gymnasium's CartPole-v1 and MuJoCo's
InvertedDoublePendulum-v5, measured in the same run (docs/bench/gym.md).

Targets (issue 35): a single cart single-pendulum env ≥ 100 k steps/s; batched N = 1024
≥ 1 M env-steps/s for one link and ≥ 300 k for the rotary double. Every figure is the best of
`--repeat` timings of a fixed number of steps with zero or random actions (episodes that end are
reset, as a training loop does). The process is pinned to one core (os.sched_setaffinity) and
the load average is reported with the table: the machine is shared.

    .venv/bin/python -m bench.gym [--quick] [--out docs/bench]
"""

from __future__ import annotations

import argparse
import os
import time
from collections.abc import Callable
from pathlib import Path

import gymnasium
import numpy as np
from tqdm import tqdm

import ipgen.gym
from bench.report import BUILD, ROOT, machine, table, version

TARGETS = {"single cart 1": 100e3, "batched cart 1": 1e6, "batched rotary 1": 1e6, "batched rotary 2": 300e3}


def best_rate(run: Callable[[], int], repeat: int) -> float:
    """The best of `repeat` timings of `run` (which returns how many env-steps it made), in 1/s."""
    rates = []
    for _ in range(repeat):
        start = time.perf_counter()
        count = run()
        rates.append(count / (time.perf_counter() - start))
    return max(rates)


def single(env: gymnasium.Env, steps: int, discrete: bool) -> Callable[[], int]:
    """`steps` steps of one env with alternating actions, reset when an episode ends."""
    env.reset(seed=0)
    actions = [0, 1] if discrete else [np.array([-0.1], np.float32), np.array([0.1], np.float32)]

    def run() -> int:
        for i in range(steps):
            _, _, terminated, truncated, _ = env.step(actions[i & 1])
            if terminated or truncated:
                env.reset()
        return steps

    return run


def batched(env: gymnasium.vector.VectorEnv, steps: int) -> Callable[[], int]:
    """`steps` batch steps with random actions in [−0.2, 0.2] (autoreset NEXT_STEP)."""
    env.reset(seed=0)
    shape = (16, *env.action_space.shape)
    actions = np.random.default_rng(0).uniform(-0.2, 0.2, size=shape).astype(np.float32)

    def run() -> int:
        for i in range(steps):
            env.step(actions[i & 15])
        return steps * env.num_envs

    return run


def vector(env_id: str) -> gymnasium.vector.VectorEnv:
    """The id's native vector environment with N = 1024."""
    return gymnasium.make_vec(env_id, num_envs=1024, vectorization_mode="vector_entry_point")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer steps; write to build/bench/quick/")
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--out", type=Path, default=None)
    args = parser.parse_args(argv)
    out = args.out or (BUILD / "quick" if args.quick else ROOT / "docs" / "bench")
    out.mkdir(parents=True, exist_ok=True)
    scale = 0.1 if args.quick else 1.0
    os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})
    load_before = os.getloadavg()[0]

    n_single, n_batch, n_mujoco = int(200_000 * scale), int(200 * scale) or 1, int(20_000 * scale)
    cases: list[tuple[str, str, Callable[[], Callable[[], int]]]] = [
        ("single cart 1", "ipgen/CartSingle-Balance-v0, unwrapped",
         lambda: single(gymnasium.make("ipgen/CartSingle-Balance-v0").unwrapped, n_single, False)),
        ("single cart 1 (gymnasium.make)", "ipgen/CartSingle-Balance-v0 with gymnasium's wrappers",
         lambda: single(gymnasium.make("ipgen/CartSingle-Balance-v0"), n_single, False)),
        ("single cartpole-v1 preset", "ipgen.gym.make('cartpole-v1'), unwrapped",
         lambda: single(ipgen.gym.make("cartpole-v1").unwrapped, n_single, True)),
        ("gymnasium CartPole-v1", "gymnasium.make('CartPole-v1'), unwrapped",
         lambda: single(gymnasium.make("CartPole-v1").unwrapped, n_single, True)),
    ]  # fmt: skip
    for env_id, label in (
        ("ipgen/CartSingle-Balance-v0", "batched cart 1"),
        ("ipgen/RotarySingle-SwingUp-v0", "batched rotary 1"),
        ("ipgen/RotaryDouble-SwingUp-v0", "batched rotary 2"),
        ("ipgen/CartDouble-SwingUp-v0", "batched cart 2"),
        ("ipgen/CartTriple-SwingUp-v0", "batched cart 3"),
        ("ipgen/RotaryTriple-SwingUp-v0", "batched rotary 3"),
    ):
        cases.append(
            (label, f"{env_id}, make_vec N = 1024",
             lambda env_id=env_id: batched(vector(env_id), n_batch))
        )  # fmt: skip
    try:
        import mujoco  # noqa: F401

        cases.append(
            ("MuJoCo InvertedDoublePendulum-v5", "gymnasium.make('InvertedDoublePendulum-v5'), unwrapped",
             lambda: single(gymnasium.make("InvertedDoublePendulum-v5").unwrapped, n_mujoco, False))
        )  # fmt: skip
    except ImportError:
        print("MuJoCo not installed: its row is left out (make bench-gym installs it)")

    rows = []
    for label, what, make in tqdm(cases, desc="bench-gym", unit="case"):
        rate = best_rate(make(), args.repeat)
        target = TARGETS.get(label)
        verdict = "" if target is None else "met" if rate >= target else f"**missed** (target {target:,.0f})"
        rows.append([label, what, f"{rate:,.0f}", verdict])
        print(f"{label}: {rate:,.0f} steps/s {verdict}", flush=True)
    load_after = os.getloadavg()[0]

    lines = [
        "# ipgen.gym throughput",
        "",
        "Written by `make bench-gym` (bench/gym.py); do not edit. One process pinned to one core, the best",
        f"of {args.repeat} timings per row; a step is one control interval of one environment (dt = 0.01 s,",
        "4 RK4 substeps for ipgen's tasks; CartPole: Euler at 0.02 s; MuJoCo: its own 5 × 0.01 s).",
        f"Load average (1 min) before / after: {load_before:.2f} / {load_after:.2f} on "
        f"{os.cpu_count()} cores — other processes shared the machine, so the rates are lower bounds",
        "of what an idle core gives; compare rows with each other (same run, same load).",
        "",
        *table(["case", "environment", "env-steps/s", "target"], rows),
        "",
        *machine({"gymnasium": version("gymnasium"), "mujoco": version("mujoco")}),
        "",
    ]
    (out / "gym.md").write_text("\n".join(lines))
    print(f"wrote {out / 'gym.md'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
