"""General against scene-specialised headers: what folding the parameters buys, and what it costs.

For the paper's two scenes and a classical n = 5 / rotary n = 3 scene, both headers are
generated and measured side by side in one run:
- operation counts of forward_dynamics and forward_dynamics_derivatives (the "Cost:" lines),
- header size, and the compile time of the scene's simulator (simulate.cpp, -O2),
- ns per forward_dynamics call (both headers in one binary, alternating rounds, medians),
- wall time of the whole simulation (the simulator's own measurement, median of runs).

Run: `python -m bench.specialisation [--out docs/bench] [--rounds 15]`; `make bench` runs it.
`--quick`: the paper's two scenes only, 5 rounds, 3 simulation runs, into build/bench/quick/.
Writes <out>/specialisation.md and prints the table. The two larger scenes are
bench/scenes/classical5_pulse.toml and bench/scenes/rotary3_pulse.toml.
"""

from __future__ import annotations

import argparse
import dataclasses
import re
import statistics
import subprocess
import time
from pathlib import Path

from bench.report import BUILD, ROOT, machine, sundials_version
from bench.workprecision.build import LIBRARIES
from ipgen.experiment.config import resolved_config
from ipgen.experiment.scene import Scene, load_scene
from ipgen.experiment.specialisation import from_scene
from ipgen.model.system import System
from ipgen.pipeline.generate import generate_header

PAPER_SCENES = (ROOT / "scenes" / "cdip_pulse.toml", ROOT / "scenes" / "rsip_pulse.toml")
LARGER_SCENES = (
    ROOT / "bench" / "scenes" / "classical5_pulse.toml",
    ROOT / "bench" / "scenes" / "rotary3_pulse.toml",
)
ROUNDS, QUICK_ROUNDS = 15, 5
SIMULATION_RUNS, QUICK_SIMULATION_RUNS = 7, 3
FLAGS = ["-std=c++17", "-O2", "-DNDEBUG", "-I/usr/include/eigen3", f"-I{ROOT / 'cpp' / 'include'}"]

TIMING = r"""
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <random>
#include <vector>
#include "general.hpp"
#include "special.hpp"
namespace G = ipgen::general;
namespace S = ipgen::special;

template <class F>
double nanoseconds_per_call(F&& call, int calls) {
  const auto start = std::chrono::steady_clock::now();
  double sink = 0;
  for (int c = 0; c < calls; ++c) sink += call(c);
  const auto stop = std::chrono::steady_clock::now();
  volatile double keep = sink;
  (void)keep;
  return std::chrono::duration<double, std::nano>(stop - start).count() / calls;
}

int main(int argc, char** argv) {
  const int rounds = argc > 1 ? std::atoi(argv[1]) : 15;
  G::Params<double> gp;
  for (auto* group : {&gp.m, &gp.l, &gp.delta}) for (double& x : *group) std::scanf("%lf", &x);
  std::scanf("%lf", &gp.g);
  const S::Params<double> sp{gp.m, gp.l, gp.delta, gp.g};
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> draw(-2, 2);
  constexpr int kStates = 64;
  std::vector<G::Vector<double>> q(kStates), qd(kStates);
  for (int k = 0; k < kStates; ++k) {
    for (int i = 0; i < G::kDof; ++i) {
      q[k](i) = draw(rng);
      qd[k](i) = draw(rng);
    }
  }
  const int calls = 20000;
  std::vector<double> general, special;
  for (int r = 0; r < rounds; ++r) {  // alternate, so both see the same machine load
    general.push_back(nanoseconds_per_call(
        [&](int c) { return G::forward_dynamics(q[c % kStates], qd[c % kStates], 0.1, gp)(1); }, calls));
    special.push_back(nanoseconds_per_call(
        [&](int c) { return S::forward_dynamics(q[c % kStates], qd[c % kStates], 0.1, sp)(1); }, calls));
  }
  std::sort(general.begin(), general.end());
  std::sort(special.begin(), special.end());
  std::printf("%.2f %.2f\n", general[general.size() / 2], special[special.size() / 2]);
}
"""


@dataclasses.dataclass
class Row:
    scene: str
    system: str
    ops: dict[str, tuple[int, int]]  # function -> (general, specialised)
    size: tuple[int, int]  # header bytes
    compile_s: tuple[float, float]
    ns_per_call: tuple[float, float]
    simulation_s: tuple[float, float]


def cost(header: Path, function: str) -> int:
    text = header.read_text()
    signature = text.index(f" {function}(const Vector<Scalar>& q")
    match = re.findall(r"Cost: (\d+) arithmetic operations", text[:signature])
    return int(match[-1])


def compile_simulator(header: Path, name: str, output: Path) -> float:
    defines = [f'-DIPGEN_MODEL_HEADER="{name}.hpp"', f"-DIPGEN_MODEL=ipgen::{name}::Model"]
    source = str(ROOT / "cpp" / "src" / "simulate.cpp")
    command = ["g++", *FLAGS, f"-I{header.parent}", *defines, source, "-o", str(output), *LIBRARIES]
    started = time.perf_counter()
    subprocess.run(command, check=True, capture_output=True)
    return time.perf_counter() - started


def simulation_seconds(runs: list[tuple[Path, Path]], repeats: int = SIMULATION_RUNS) -> list[float]:
    """Median wall time (the simulator's own measurement) of each (simulator, config), alternating."""
    times: list[list[float]] = [[] for _ in runs]
    for _ in range(repeats):
        for k, (simulator, config) in enumerate(runs):
            command = [str(simulator), str(config), "--csv", str(config.with_suffix(".csv"))]
            out = subprocess.run(command, check=True, capture_output=True, text=True).stdout
            times[k].append(float(re.search(r"Wall time ([0-9.e+-]+) s", out).group(1)))  # type: ignore[union-attr]
    return [statistics.median(t) for t in times]


def measure(scene: Scene, work: Path, rounds: int, repeats: int = SIMULATION_RUNS) -> Row:
    work.mkdir(parents=True, exist_ok=True)
    system = System(scene.type, scene.links, scene.inertia)  # type: ignore[arg-type]
    general = generate_header(system, "general", work).path
    special = generate_header(system, "special", work, spec=from_scene(scene)).path
    config = work / f"{scene.stem}.cfg"
    config.write_text(resolved_config(dataclasses.replace(scene, name="general")))
    special_config = work / f"{scene.stem}_special.cfg"
    special_config.write_text(resolved_config(dataclasses.replace(scene, name="special")))
    compile_general = compile_simulator(general, "general", work / "simulate_general")
    compile_special = compile_simulator(special, "special", work / "simulate_special")
    timing = work / "timing.cpp"
    timing.write_text(TIMING)
    command = ["g++", *FLAGS, "-O3", "-march=native", f"-I{work}", str(timing), "-o", str(work / "timing")]
    subprocess.run(command, check=True, capture_output=True)
    params = " ".join(repr(x) for x in (*scene.m, *scene.l, *scene.delta, scene.g))
    out = subprocess.run(
        [str(work / "timing"), str(rounds)], input=params, check=True, capture_output=True, text=True
    )
    ns_general, ns_special = (float(x) for x in out.stdout.split())
    functions = ("forward_dynamics", "forward_dynamics_derivatives")
    return Row(
        scene=scene.stem,
        system=f"{scene.type} n={scene.links}",
        ops={f: (cost(general, f), cost(special, f)) for f in functions},
        size=(general.stat().st_size, special.stat().st_size),
        compile_s=(compile_general, compile_special),
        ns_per_call=(ns_general, ns_special),
        simulation_s=tuple(  # type: ignore[arg-type]
            simulation_seconds(
                [(work / "simulate_general", config), (work / "simulate_special", special_config)], repeats
            )
        ),
    )


def markdown(rows: list[Row], repeats: int, total: float) -> str:
    def pair(values: tuple[float, float], unit: str = "", digits: int = 0) -> str:
        general, special = values
        return f"{general:.{digits}f}{unit} → {special:.{digits}f}{unit} ({special / general:.2f}×)"

    lines = [
        "# General vs scene-specialised headers",
        "",
        "Written by `python -m bench.specialisation` (part of `make bench`). Each cell: general →",
        "specialised (ratio). Specialised = every parameter of the scene folded as an exact rational, only",
        "forward_dynamics and forward_dynamics_derivatives emitted. Simulation: the scene's own settings",
        f"(BDF, rtol 1e-10, exact Jacobian), 10 s, wall time measured by the simulator, median of {repeats}",
        "alternating runs.",
        "",
        *machine({"SUNDIALS": sundials_version(), "benchmark wall time": f"{total:.0f} s"}),
        "",
        "| scene | system | ops forward_dynamics | ops derivatives | header bytes | compile [s] "
        "| ns / forward_dynamics | simulation [ms] |",
        "| --- | --- | --- | --- | --- | --- | --- | --- |",
    ]  # fmt: skip
    for r in rows:
        milliseconds = (1e3 * r.simulation_s[0], 1e3 * r.simulation_s[1])
        lines.append(
            f"| {r.scene} | {r.system} | {pair(r.ops['forward_dynamics'])} | "
            f"{pair(r.ops['forward_dynamics_derivatives'])} | {pair(r.size)} | "
            f"{pair(r.compile_s, digits=2)} | {pair(r.ns_per_call, digits=1)} | "
            f"{pair(milliseconds, digits=2)} |"
        )
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--out", type=Path, help="output folder (default docs/bench, or build/bench/quick)")
    parser.add_argument(
        "--rounds", type=int, help=f"timing rounds (default {ROUNDS}, {QUICK_ROUNDS} with --quick)"
    )
    parser.add_argument(
        "--quick",
        action="store_true",
        help=f"the paper's scenes only, {QUICK_ROUNDS} rounds, {QUICK_SIMULATION_RUNS} simulation runs",
    )
    args = parser.parse_args(argv)
    out = args.out or (BUILD / "quick" if args.quick else ROOT / "docs" / "bench")
    rounds = args.rounds or (QUICK_ROUNDS if args.quick else ROUNDS)
    repeats = QUICK_SIMULATION_RUNS if args.quick else SIMULATION_RUNS
    work = BUILD / "specialisation"
    work.mkdir(parents=True, exist_ok=True)
    scenes = PAPER_SCENES if args.quick else PAPER_SCENES + LARGER_SCENES
    started = time.perf_counter()
    rows = []
    for path in scenes:
        scene = load_scene(path)
        print(f"specialisation: {scene.stem} ...", flush=True)
        rows.append(measure(scene, work / scene.stem, rounds, repeats))
    text = markdown(rows, repeats, time.perf_counter() - started)
    out.mkdir(parents=True, exist_ok=True)
    (out / "specialisation.md").write_text(text)
    print(text)


if __name__ == "__main__":
    main()
