"""The paper's two systems as FMUs (`ipgen --emit fmu`), one simulated with FMPy beside ipgen's
own simulator.

    .venv/bin/python tools/fmu_demo.py [--build build | --csv FILE] [--out out/demo] [--fmi 2|3]
                                       [--scene cdip_pulse] [--sizes]

Writes <out>/cdip.fmu and <out>/rsip.fmu (scenes/cdip_pulse.toml, scenes/rsip_pulse.toml: their
parameters are the FMUs' start values), simulates the chosen scene's FMU with FMPy's CVODE
(rtol 1e-10) under the scene's input, and compares it with the simulator's CSV of the same
scene: with --build, build/bin/simulate_<model> is run on build/scenes/<stem>.cfg (as
`make demo` does); with --csv, that file; else the simulator's golden run in tests/data/.
Prints the FMU sizes and the largest difference per angle, and writes
<out>/<model>_fmu.png overlaying both runs (and their difference). With --sizes it also writes
classical and rotary n = 1, 2, 3 in both FMI versions to <out>/sizes/ and prints a Markdown
table of their sizes and write times (docs/fmu.md). Exits 1 on a failure.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
from ipgen.errors import Error  # noqa: E402
from ipgen.experiment.scene import Scene, load_scene  # noqa: E402
from ipgen.pipeline.job import plan, run  # noqa: E402

SCENES = ("cdip_pulse", "rsip_pulse")
RTOL = 1e-10


class DemoError(Exception):
    """A step of the demo failed; the message says which."""


def write_fmus(out: Path, target: str) -> dict[str, Path]:
    """Each scene's FMU in `out`, keyed by scene stem."""
    written = {}
    for stem in SCENES:
        files = run(plan(out, scene=ROOT / "scenes" / f"{stem}.toml", emit=target))
        written[stem] = files[0].path
    return written


def simulator_csv(args: argparse.Namespace, scene: Scene, stem: str) -> Path:
    """The simulator's run of the scene: --csv, a fresh run with --build, or the golden file."""
    if args.csv is not None:
        return args.csv
    if args.build is None:
        return ROOT / "tests" / "data" / f"{stem}.golden.csv"
    csv_path = args.out / f"{scene.name}_ipsim.csv"
    simulator = args.build / "bin" / f"simulate_{scene.name}"
    config = args.build / "scenes" / f"{stem}.cfg"
    result = subprocess.run(
        [str(simulator), str(config), "--csv", str(csv_path)], capture_output=True, text=True
    )
    if result.returncode != 0:
        raise DemoError(f"{simulator} failed: {result.stderr.strip()}")
    return csv_path


def input_table(scene: Scene) -> np.ndarray:
    """The scene's input as FMPy's input table: on the output grid, doubled at each jump."""
    times = sorted({*np.arange(0.0, scene.t_end + scene.sample / 2, scene.sample).round(12), scene.t_end})
    rows = []
    jumps = [t for t in scene.input.breakpoints() if 0.0 < t < scene.t_end]
    for t in sorted({*times, *jumps}):
        if t in jumps:
            rows.append((t, scene.input.value(np.nextafter(t, -np.inf))))
        rows.append((t, scene.input.value(t)))
    return np.array(rows, dtype=[("time", float), ("u", float)])


def simulate(fmu: Path, scene: Scene) -> tuple[np.ndarray, float]:
    from fmpy import simulate_fmu

    started = time.perf_counter()
    result = simulate_fmu(
        str(fmu),
        solver="CVode",
        relative_tolerance=RTOL,
        stop_time=scene.t_end,
        output_interval=scene.sample,
        input=input_table(scene),
    )
    return result, time.perf_counter() - started


def compare(result: np.ndarray, csv_path: Path, scene: Scene, png: Path) -> dict[str, float]:
    """The largest |FMU − simulator| of each angle; the overlay plot in `png`."""
    reference = np.genfromtxt(csv_path, delimiter=",", names=True)
    angles = [n for n in reference.dtype.names if n.startswith("theta")]
    differences = {}
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(8, 6.5), sharex=True, constrained_layout=True)
    for k, name in enumerate(angles):
        colour = f"C{k}"
        expected = np.interp(result["time"], reference["t"], reference[name])
        differences[name] = float(np.max(np.abs(result[name] - expected)))
        top.plot(
            reference["t"], reference[name], color=colour, linewidth=3, alpha=0.35, label=f"{name} ipsim"
        )
        top.plot(
            result["time"],
            result[name],
            color=colour,
            linestyle="--",
            linewidth=1,
            label=f"{name} FMU (FMPy)",
        )
        bottom.semilogy(result["time"], np.abs(result[name] - expected) + 1e-18, color=colour, label=name)
    top.set_ylabel("θ [m or rad]")
    top.set_title(f"{scene.name}: FMU in FMPy (CVODE, rtol {RTOL:g}) over ipgen's simulator")
    top.legend(ncol=2, fontsize=8)
    bottom.set_ylabel("|FMU − ipsim|")
    bottom.set_xlabel("t [s]")
    bottom.legend(fontsize=8)
    fig.savefig(png, dpi=110)
    plt.close(fig)
    return differences


def sizes_table(out: Path) -> str:
    """Markdown: size and write time (derive, render, compile, zip) of each model's FMUs."""
    rows = ["| model | FMI 2.0 | FMI 3.0 |", "| --- | ---: | ---: |"]
    for kind in ("classical", "rotary"):
        for links in (1, 2, 3):
            cells = []
            for target in ("fmu", "fmu3"):
                started = time.perf_counter()
                written = run(plan(out / target, system_type=kind, links=links, emit=target, force=True))
                seconds = time.perf_counter() - started
                cells.append(f"{written[0].size / 1024:.1f} KiB, {seconds:.2f} s")
            rows.append(f"| {kind}{links} | {cells[0]} | {cells[1]} |")
    return "\n".join(rows)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    where = parser.add_mutually_exclusive_group()
    where.add_argument("--build", type=Path, help="CMake build folder: run its simulator")
    where.add_argument("--csv", type=Path, help="the simulator's CSV of the scene")
    parser.add_argument("--out", type=Path, default=ROOT / "out" / "demo", help="output folder")
    parser.add_argument("--fmi", choices=("2", "3"), default="2", help="FMI version (default 2.0)")
    parser.add_argument("--scene", choices=SCENES, default="cdip_pulse", help="the scene to simulate")
    parser.add_argument("--sizes", action="store_true", help="also tabulate n = 1..3 FMU sizes")
    args = parser.parse_args(argv)
    try:
        args.out.mkdir(parents=True, exist_ok=True)
        fmus = write_fmus(args.out, "fmu" if args.fmi == "2" else "fmu3")
        for stem, path in fmus.items():
            print(f"{path}: {path.stat().st_size / 1024:.1f} KiB (FMI {args.fmi}.0, scene {stem})")
        scene = load_scene(ROOT / "scenes" / f"{args.scene}.toml")
        csv_path = simulator_csv(args, scene, args.scene)
        result, seconds = simulate(fmus[args.scene], scene)
        png = args.out / f"{scene.name}_fmu.png"
        differences = compare(result, csv_path, scene, png)
        table = sizes_table(args.out / "sizes") if args.sizes else ""
    except (Error, DemoError, OSError, ValueError) as e:
        print(f"fmu_demo: error: {e}", file=sys.stderr)
        return 1
    shown = ", ".join(f"{name} {value:.1e}" for name, value in differences.items())
    print(f"{scene.name}: FMPy CVODE {seconds:.2f} s; max |FMU - simulator ({csv_path.name})|: {shown}")
    print(f"wrote {png}")
    if table:
        print(table)
    return 0


if __name__ == "__main__":
    sys.exit(main())
