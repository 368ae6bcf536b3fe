"""Identify the QUBE-Servo 2 from a simulated noisy experiment (make demo).

The experiment is the preset scenes/rigs/qube_servo2_identify.toml (a multisine in motor volts,
the pendulum hanging, designed by `ipgen excite`). The "rig" is that scene with the numbers a
real unit differs by from the datasheet (damping, torque constant, pendulum inertia): it is run by
ipgen's C++ simulator (`ipgen run`: CVODE, an integrator independent of the fit's own), and its
angles get encoder-like Gaussian noise. `ipgen.identify` then fits the free parameters, starting
from the datasheet's values, and the estimates are printed beside the truth with their 95 %
intervals.

    python tools/identify_demo.py [--out out/demo/identify] [--noise 0.0015] [--seed 1]
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

import ipgen
from ipgen.common.toml_edit import updated_scene_text
from ipgen.experiment.scene import load_scene
from ipgen.identification.data import read_measurements
from ipgen.identification.synthetic import write_csv
from ipgen.pipeline.identify import setup_from_scene

ROOT = Path(__file__).resolve().parent.parent
EXPERIMENT = ROOT / "scenes" / "rigs" / "qube_servo2_identify.toml"
# The rig as it is: what the datasheet (the preset) gets wrong, by how much.
TRUTH_FACTORS = {"delta0": 1.3, "delta1": 0.7, "kt": 0.93, "J1": 1.08}
FREE = ("J1", "delta0", "delta1", "kt")


def truth_scene(values: dict[str, float]) -> str:
    """The experiment scene with the rig's true values in place of the datasheet's."""
    updates: dict[tuple[str, str], float | list[float]] = {
        ("parameters", "delta"): [values["delta0"], values["delta1"]],
        ("parameters", "J"): [values["J0"], values["J1"]],
        ("actuator", "kt"): values["kt"],
    }
    header = "# The demo's 'rig': the experiment with the true values (tools/identify_demo.py)."
    return updated_scene_text(EXPERIMENT.read_text(), updates, header)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=ROOT / "out" / "demo" / "identify")
    parser.add_argument("--noise", type=float, default=0.0015, help="angle noise [rad], std")
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args(argv)

    scene = load_scene(EXPERIMENT)
    prior = setup_from_scene(scene, FREE)
    values = dict(prior.values)
    values.update({name: values[name] * factor for name, factor in TRUTH_FACTORS.items()})
    args.out.mkdir(parents=True, exist_ok=True)
    rig = args.out / "qube_servo2_rig.toml"
    rig.write_text(truth_scene(values))
    ipgen_command = [sys.executable, "-m", "ipgen"]
    run = subprocess.run([*ipgen_command, "run", str(rig), "-o", str(args.out), "--force"])
    if run.returncode != 0:
        print(f"the simulated experiment failed (status {run.returncode})", file=sys.stderr)
        return 1

    recorded = read_measurements(args.out / "qube_servo2_rig.csv", scene.links + 1)
    rng = np.random.default_rng(args.seed)
    theta = recorded.theta + args.noise * rng.standard_normal(recorded.theta.shape)
    csv = args.out / "qube_servo2_experiment.csv"
    write_csv(csv, recorded.t, theta, recorded.u)  # what the encoders and the amplifier log
    print(
        f"\nsimulated {recorded.t[-1]:g} s of {EXPERIMENT.name} on the 'rig' (CVODE), "
        f"angle noise {args.noise:g} rad: {csv}"
    )
    clock = time.perf_counter()
    result = ipgen.identify(EXPERIMENT, csv, FREE, args.out, force=True)
    seconds = time.perf_counter() - clock
    fit = result.fit
    columns = f"{'datasheet':>11} {'truth':>11} {'estimate':>11} {'95 % interval':>27}"
    print(f"\n{'parameter':<9} {columns}  inside")
    inside = 0
    for name in FREE:
        low, high = fit.interval[name]
        ok = low <= values[name] <= high
        inside += ok
        print(
            f"{name:<9} {prior.value(name):11.5g} {values[name]:11.5g} {fit.estimate[name]:11.5g} "
            f"  [{low:10.5g}, {high:10.5g}]  {'yes' if ok else 'no'}"
        )
    print(f"\n{inside} of {len(FREE)} true values inside their 95 % intervals (in {seconds:.1f} s)")
    for statement in fit.statements:
        print(f"identifiability: {statement}")
    print("wrote " + ", ".join(str(p) for p in result.files))
    worst = max(abs(fit.estimate[name] / values[name] - 1) for name in FREE)
    if worst > 0.05:  # the demo fails loudly rather than print a bad fit as if it were fine
        print(f"an estimate is {worst:.1%} from the truth: identification failed", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
