"""Identify the QUBE-Servo 2 preset from a simulated noisy experiment (make demo).

The "rig" is the preset scenes/rigs/qube_servo2.toml with the numbers a real unit differs by
from the datasheet (damping, torque constant, pendulum inertia), driven about the hanging position
by a multisine voltage and measured by encoders
with noise. `ipgen.identify` fits the free parameters, starting from the preset's values, and
the estimates are printed beside the truth with their 95 % intervals.

    python tools/identify_demo.py [--out out/identify_demo] [--seconds 20] [--noise 0.0015]
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np

import ipgen
from ipgen.command.identify import setup_from_scene
from ipgen.identification.model import Setup
from ipgen.identification.synthetic import measure, multisine, write_csv
from ipgen.scene.reader import load_scene

ROOT = Path(__file__).resolve().parent.parent
SCENE = ROOT / "scenes" / "rigs" / "qube_servo2.toml"
# The rig as it is: what the datasheet (the preset) gets wrong, by how much.
TRUTH_FACTORS = {"delta0": 1.3, "delta1": 0.7, "kt": 0.93, "J1": 1.08}
FREE = ("J1", "delta0", "delta1", "kt")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=ROOT / "out" / "identify_demo")
    parser.add_argument("--seconds", type=float, default=20.0)
    parser.add_argument("--rate", type=float, default=500.0, help="samples per second")
    parser.add_argument("--noise", type=float, default=0.0015, help="angle noise [rad], std")
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args(argv)

    scene = load_scene(SCENE)
    prior = setup_from_scene(scene, FREE)
    values = dict(prior.values)
    values.update({name: values[name] * factor for name, factor in TRUTH_FACTORS.items()})
    truth = Setup(prior.system, prior.actuator_kind, tuple(values.items()), prior.explicit)
    t = np.arange(0.0, args.seconds, 1.0 / args.rate)
    rng = np.random.default_rng(args.seed)
    data = measure(truth, t, multisine, np.array([0.0, math.pi + 0.05, 0.0, 0.0]), args.noise, rng)
    args.out.mkdir(parents=True, exist_ok=True)
    csv = args.out / "qube_servo2_experiment.csv"
    coordinates = getattr(scene, "coordinates", None)  # the rig's own convention, if the scene has one
    theta = data.theta
    if coordinates is not None and not coordinates.is_canonical:
        state = np.hstack([theta, np.zeros_like(theta)])
        theta = np.array([coordinates.to_user(x, scene.links) for x in state])[:, : scene.links + 1]
    write_csv(csv, t, theta, data.u)
    print(
        f"simulated {args.seconds:g} s at {args.rate:g} Hz of {SCENE.name} about the hanging position, "
        f"multisine voltage, angle noise {args.noise:g} rad: {csv}"
    )
    clock = time.perf_counter()
    result = ipgen.identify(SCENE, csv, FREE, args.out, force=True)
    seconds = time.perf_counter() - clock
    fit = result.fit
    print(f"\n{'parameter':<9} {'preset':>11} {'truth':>11} {'estimate':>11} {'95 % interval':>27}  inside")
    inside = 0
    for name in FREE:
        low, high = fit.interval[name]
        ok = low <= values[name] <= high
        inside += ok
        print(
            f"{name:<9} {prior.value(name):11.5g} {values[name]:11.5g} {fit.estimate[name]:11.5g} "
            f"  [{low:10.5g}, {high:10.5g}]  {'yes' if ok else 'no'}"
        )
    print(
        f"\n{inside} of {len(FREE)} true values inside their 95 % intervals (identified in {seconds:.1f} s)"
    )
    for statement in fit.statements:
        print(f"identifiability: {statement}")
    print("wrote " + ", ".join(str(p) for p in result.files))
    return 0


if __name__ == "__main__":
    sys.exit(main())
