"""Write the golden trajectories of the paper's experiments, after checking them independently.

Run after the CMake build (this script builds nothing):

    .venv/bin/python tools/make_golden.py --build build            # cdip_pulse and rsip_pulse
    .venv/bin/python tools/make_golden.py --build build --check    # compare only, write nothing

For each scene it runs BUILD/bin/simulate_<model> on BUILD/scenes/<stem>.cfg at rtol 1e-12,
atol 1e-14, for 10 s sampled every 0.01 s. It integrates the same experiment again with scipy's
solve_ivp (DOP853, rtol 1e-13, atol 1e-14) on equations derived independently of ipgen
(tests/independent_model.py: sympy.physics.mechanics, Kane's method; M θ̈ = forcing solved with
numpy), one interval between input discontinuities at a time (the pulse ends at t = 1 s), at the
simulator's sample times. It prints the largest difference per column and writes
tests/data/<stem>.golden.csv (the simulator's trajectory, %.17g) only if no difference exceeds
1e-8. ctest's paper.<model>.golden tests compare the simulator at the scene's own tolerances with
these files.
"""

from __future__ import annotations

import argparse
import itertools
import math
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
from scipy.integrate import solve_ivp

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT), str(ROOT / "tests"), str(ROOT / "tools")]
from compare_csv import read as read_csv  # noqa: E402
from independent_model import reference  # noqa: E402

from ipgen.experiment.scene import Scene, load_scene  # noqa: E402

SCENES = ("cdip_pulse", "rsip_pulse")
T_END, SAMPLE = 10.0, 0.01
SIMULATOR_TOLERANCES = ("--rtol", "1e-12", "--atol", "1e-14")
SCIPY_RTOL, SCIPY_ATOL = 1e-13, 1e-14
LIMIT = 1e-8


def simulate(build: Path, scene: Scene, csv: Path) -> tuple[list[str], np.ndarray]:
    simulator = build / "bin" / f"simulate_{scene.name}"
    config = build / "scenes" / f"{scene.stem}.cfg"
    for path in (simulator, config):
        if not path.is_file():
            sys.exit(f"make_golden: {path} not found: build first (make build, or cmake --build {build})")
    command = [str(simulator), str(config), *SIMULATOR_TOLERANCES, "--t-end", str(T_END)]
    command += ["--sample", str(SAMPLE), "--csv", str(csv)]
    result = subprocess.run(command, capture_output=True, text=True)
    if result.returncode != 0:
        sys.exit(f"make_golden: {' '.join(command)} failed: {result.stderr.strip()}")
    return read_csv(csv)


def independent(scene: Scene, times: np.ndarray) -> np.ndarray:
    """Rows [θ, θ̇] at `times` from Kane's equations integrated by DOP853."""
    model = reference(scene.type, scene.links, scene.inertia)
    params = (scene.m, scene.l, scene.delta, scene.g)
    size = scene.links + 1
    cuts = sorted({0.0, T_END, *(b for b in scene.input.breakpoints() if 0 < b < T_END)})
    state = np.array(scene.theta + scene.dtheta, dtype=float)
    rows = []
    for start, end in itertools.pairwise(cuts):
        # The input as it is strictly inside (start, end): a pulse's value at its own end
        # point belongs to the next interval, but DOP853 evaluates there.
        inside = (math.nextafter(start, end), math.nextafter(end, start))

        def rhs(t: float, x: np.ndarray, inside: tuple[float, float] = inside) -> np.ndarray:
            u = scene.input.value(min(max(t, inside[0]), inside[1]))
            angles, rates = x[:size], x[size:]
            mass = np.asarray(model.mass_matrix(angles, rates, u, params), dtype=float)
            forcing = np.ravel(model.forcing(angles, rates, u, params)).astype(float)
            return np.concatenate([rates, np.linalg.solve(mass, forcing)])

        wanted = times[(times > start) & (times <= end)] if rows else times[times <= end]
        solution = solve_ivp(
            rhs, (start, end), state, method="DOP853", rtol=SCIPY_RTOL, atol=SCIPY_ATOL, dense_output=True
        )
        if not solution.success:
            sys.exit(f"make_golden: {scene.stem}: solve_ivp failed on [{start}, {end}]: {solution.message}")
        rows.append(solution.sol(wanted).T)
        state = solution.y[:, -1]  # the last step ends exactly at `end`
    return np.vstack(rows)


def write_golden(path: Path, header: list[str], data: np.ndarray) -> None:
    lines = [",".join(header)] + [",".join(f"{value:.17g}" for value in row) for row in data]
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("\n".join(lines) + "\n")


def main() -> int:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--build", type=Path, required=True, help="CMake build folder (holds bin/, scenes/)")
    parser.add_argument("--out", type=Path, default=ROOT / "tests" / "data", help="where goldens go")
    parser.add_argument("--check", action="store_true", help="compare only, write no golden")
    parser.add_argument(
        "scenes", nargs="*", default=SCENES, help="scene stems (default: " + " ".join(SCENES) + ")"
    )
    args = parser.parse_args()
    failed = False
    for stem in args.scenes:
        scene = load_scene(ROOT / "scenes" / f"{stem}.toml")
        with tempfile.TemporaryDirectory() as tmp:
            header, data = simulate(args.build, scene, Path(tmp) / f"{stem}.csv")
        expected = independent(scene, data[:, 0])
        if expected.shape != data[:, 1:].shape:
            sys.exit(f"make_golden: {stem}: scipy gave {expected.shape}, the simulator {data[:, 1:].shape}")
        differences = np.max(np.abs(data[:, 1:] - expected), axis=0)
        worst = float(np.max(differences))
        columns = ", ".join(f"{name} {d:.2e}" for name, d in zip(header[1:], differences, strict=True))
        print(f"{stem}: max |simulator (rtol 1e-12) - scipy DOP853 (rtol 1e-13)| = {worst:.3e}  ({columns})")
        if worst > LIMIT:
            print(f"{stem}: difference above {LIMIT:g}: golden NOT written", file=sys.stderr)
            failed = True
        elif not args.check:
            path = args.out / f"{stem}.golden.csv"
            write_golden(path, header, data)
            print(f"{stem}: wrote {path} ({len(data)} rows)")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
