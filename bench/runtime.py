"""The simulator compiled once against a simulator compiled per model (issue 45).

    .venv/bin/python -m bench.runtime [--repeat N] [--rounds N] [--quick] [--out FILE]

Measures, on this machine, in a fresh cache:

1. the one-time build of ipsim's simulator (its CPU time: the compiler's, user + system, of
   every process `ipgen run` started), with the first model;
2. per scene, the first `ipgen run` of a model never built before (the simulator already in the
   cache: what a new model costs) and cached runs, as CPU time of `ipgen run` and every process
   it starts (user + system): with the PNG, without it (--no-plot), and without it with the run's
   plan made again (the cache's runs/ emptied before each: the scene's checks, the derivation and
   the design as every cached run did before the plan was kept, pipeline/run_plan.py); the three
   alternate, median of N each; and the simulator's own run alone;
3. per scene, the simulation's own wall time, the runtime simulator against the per-model
   simulator compiled from the model's C++ header exactly as before issue 45 (same flags), on the
   same .cfg, alternating, median of N runs each; and whether the two CSVs are byte-identical
   (then both took the same steps: equal error, and the ratio is the cost per step);
4. speed at equal error against MuJoCo RK4 with `make bench`'s work-precision driver, before
   issue 45 and now, per model and on ipgen run's model library (bench/runtime_speed.py; needs
   mujoco, the extra `workprecision`), medians of --rounds alternating rounds.

Writes docs/bench/runtime.md (with --quick: build/bench/quick/runtime.md: two scenes, three
repeats, no MuJoCo part).
"""

from __future__ import annotations

import argparse
import filecmp
import os
import re
import resource
import shlex
import shutil
import statistics
import subprocess
import sys
import tempfile
from dataclasses import dataclass, replace
from pathlib import Path

from bench.report import BUILD, ROOT, machine, table
from ipgen.pipeline.simulator import (
    LIBRARIES,
    SEPARATE,
    compiled_core,
    compiler,
    simulator_sources,
)

# (label, scene file or generated text): both types, a DC motor, sensors with a Kalman filter, n = 10.
SCENES = (
    ("rsip_pulse (rotary, 1 link)", ROOT / "scenes" / "rsip_pulse.toml"),
    ("cdip_pulse (classical, 2 links)", ROOT / "scenes" / "cdip_pulse.toml"),
    ("ctip_pulse (classical, 3 links)", ROOT / "scenes" / "ctip_pulse.toml"),
    ("qube_servo2 (rotary 1, DC motor)", ROOT / "scenes" / "rigs" / "qube_servo2.toml"),
    ("qube_servo2_sensors (encoders, Kalman)", ROOT / "scenes" / "rigs" / "qube_servo2_sensors.toml"),
    ("classical10 (10 links)", None),
)
TEN_LINKS = """\
[system]
type = "classical"
links = 10
[parameters]
m = [1.0, 0.1, 0.1, 0.1, 0.1, 0.1, 0.1, 0.1, 0.1, 0.1, 0.1]
l = [0.0, 0.1, 0.1, 0.1, 0.1, 0.1, 0.1, 0.1, 0.1, 0.1, 0.1]
delta = [0.1, 0.001, 0.001, 0.001, 0.001, 0.001, 0.001, 0.001, 0.001, 0.001, 0.001]
[initial]
theta = [0, 0.05, 0, 0, 0, 0, 0, 0, 0, 0, 0]
[simulation]
t_end = 2
"""


@dataclass(frozen=True)
class Cpu:
    seconds: float  # user + system of the child processes
    wall: float


def cpu_of(command: list[str], env: dict[str, str]) -> tuple[Cpu, subprocess.CompletedProcess[str]]:
    """CPU time (user + system) of `command` and every process it waited for."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = os.times().elapsed
    done = subprocess.run(command, capture_output=True, text=True, env=env)
    wall = os.times().elapsed - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    used = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return Cpu(used, wall), done


def ipgen_run(scene: Path, out: Path, cache: Path, *options: str) -> tuple[Cpu, str]:
    env = {**os.environ, "IPGEN_CACHE_DIR": str(cache)}
    env.pop("IPGEN_SIM_OPT", None)  # the default, -O2
    env.pop("PYTHONDONTWRITEBYTECODE", None)  # ipgen's .pyc files written once, as an installed one has them
    command = [sys.executable, "-m", "ipgen", "run", str(scene), "-o", str(out), "--force", *options]
    cpu, done = cpu_of(command, env)
    if done.returncode != 0:
        raise RuntimeError(f"ipgen run {scene.name} failed: {done.stderr[-2000:]}")
    return cpu, (out / f"{scene.stem}.txt").read_text()


def cached_runs(scene: Path, out: Path, cache: Path, repeat: int) -> dict[str, float]:
    """Median CPU seconds of cached runs: with the PNG, without (--no-plot), and without with the
    plan made again; the three alternate."""
    runs: dict[str, list[float]] = {"png": [], "no png": [], "planned again": []}
    for _ in range(repeat):
        runs["png"].append(ipgen_run(scene, out, cache)[0].seconds)
        runs["no png"].append(ipgen_run(scene, out, cache, "--no-plot")[0].seconds)
        shutil.rmtree(cache / "runs", ignore_errors=True)
        runs["planned again"].append(ipgen_run(scene, out, cache, "--no-plot")[0].seconds)
    return {kind: statistics.median(seconds) for kind, seconds in runs.items()}


def launcher_of(summary: str) -> list[str]:
    """The launcher's command: [simulator, --model, library]."""
    launcher = Path(re.search(r"Simulator (.+?) \((built in|taken from the cache)", summary).group(1))
    words = shlex.split(launcher.read_text().splitlines()[1])  # exec PROGRAM --model LIBRARY "$@"
    return words[1:4]


def per_model_simulator(scene: Path, folder: Path, cache: Path) -> Path:
    """The simulator of the scene's model compiled from its C++ header as `ipgen run` did before
    issue 45 (simulate.cpp + the header + ipsim's compiled core, -O2)."""
    from ipgen.pipeline import job

    planned = replace(job.for_the_simulator(job.plan(folder, scene=scene, force=True)), emit=("cpp",))
    job.run(planned)
    source, include = simulator_sources()
    binary = folder / f"simulate_{planned.name}"
    command = [compiler(), "-std=c++17", "-O2", "-DNDEBUG", SEPARATE, f"-I{include}", f"-I{folder}",
               "-isystem", "/usr/include/eigen3", f'-DIPGEN_MODEL_HEADER="{planned.name}.hpp"',
               f"-DIPGEN_MODEL=ipgen::{planned.name}::Model", str(source), str(compiled_core(cache)),
               "-o", str(binary), *LIBRARIES]  # fmt: skip
    subprocess.run(command, check=True, capture_output=True, text=True)
    return binary


def simulation_seconds(command: list[str], cfg: Path, csv: Path) -> float:
    done = subprocess.run([*command, str(cfg), "--csv", str(csv), "--force"], capture_output=True, text=True)
    if done.returncode not in (0, 3, 4, 5):
        raise RuntimeError(done.stderr)
    return float(re.search(r"Wall time ([0-9.e+-]+) s", done.stdout).group(1))


SPEED_HEADING = "## Speed at equal error against MuJoCo RK4"


def mujoco_part(work: Path, cache: Path, rounds: int) -> list[str]:
    """The MuJoCo part (bench/runtime_speed.py) in `work`, the model libraries built by `ipgen run`
    in `cache`: the report's section, with the load average before and after."""
    from bench import runtime_speed

    before = " ".join(f"{value:.2f}" for value in os.getloadavg())
    print("speed against MuJoCo RK4: the work-precision drivers, before and now…", flush=True)
    libraries: dict[Path, tuple[Path, Path]] = {}
    for _, scene in runtime_speed.SCENES:  # their model libraries, as ipgen run builds them
        _, summary = ipgen_run(scene, work / "wp", cache, "--no-plot")
        libraries[scene] = (Path(launcher_of(summary)[2]), work / "wp" / f"{scene.stem}.cfg")
    built = runtime_speed.build_all(work, libraries)
    rows = runtime_speed.measure(built, rounds)
    after = " ".join(f"{value:.2f}" for value in os.getloadavg())
    return runtime_speed.section(rows, rounds, (before, after))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=7)
    parser.add_argument("--rounds", type=int, default=5, help="rounds of the MuJoCo part")
    parser.add_argument("--quick", action="store_true", help="two scenes, three repeats, no MuJoCo part")
    parser.add_argument(
        "--part",
        choices=("all", "mujoco"),
        default="all",
        help="mujoco: only the MuJoCo part, its section of the report replaced (a cache and the drivers "
        "kept in build/bench/runtime_speed/)",
    )
    parser.add_argument("--out", type=Path)
    args = parser.parse_args()
    if args.part == "mujoco":
        out = args.out or ROOT / "docs" / "bench" / "runtime.md"
        work = BUILD / "runtime_speed"
        lines = mujoco_part(work, work / "cache", args.rounds)
        previous = out.read_text() if out.is_file() else ""
        kept = previous.split(SPEED_HEADING)[0].rstrip("\n")
        out.write_text((kept + "\n\n" if kept else "") + "\n".join(lines))
        print(f"wrote {out}")
        return
    scenes = SCENES[:2] if args.quick else SCENES
    repeat = 3 if args.quick else args.repeat
    out = args.out or (
        BUILD / "quick" / "runtime.md" if args.quick else ROOT / "docs" / "bench" / "runtime.md"
    )
    rows, speed = [], []
    mujoco: list[str] = []
    with tempfile.TemporaryDirectory(prefix="ipgen-bench-runtime.") as scratch:
        work, cache = Path(scratch), Path(scratch) / "cache"
        (work / "classical10.toml").write_text(TEN_LINKS)
        # The one-time build: a fresh cache, ipsim's core and simulator, with a first model (rdip,
        # not measured below) and its run.
        print("the one-time build…", flush=True)
        once, _ = ipgen_run(ROOT / "scenes" / "rdip_pulse.toml", work / "once", cache)
        for label, path in scenes:
            scene = path or work / "classical10.toml"
            print(f"{label}: first run, cached runs…", flush=True)
            first, summary = ipgen_run(scene, work / "out", cache)
            cached = cached_runs(scene, work / "out", cache, repeat)
            cfg = work / "out" / f"{scene.stem}.cfg"
            runtime = launcher_of(summary)
            plain = [*runtime, str(cfg), "--csv", str(work / "plain.csv"), "--force"]
            alone = [cpu_of(plain, dict(os.environ))[0].seconds for _ in range(repeat)]
            rows.append([label, f"{first.seconds:.2f}", f"{cached['png']:.2f}", f"{cached['no png']:.2f}",
                         f"{cached['planned again']:.2f}", f"{statistics.median(alone):.3f}"])  # fmt: skip
            print(f"  speed: per-model simulator against the runtime one ({repeat} runs each)…", flush=True)
            folder = work / f"static_{scene.stem}"
            folder.mkdir()
            static = [str(per_model_simulator(scene, folder, cache))]
            times: dict[str, list[float]] = {"static": [], "runtime": []}
            for _ in range(repeat):
                times["static"].append(simulation_seconds(static, cfg, work / "static.csv"))
                times["runtime"].append(simulation_seconds(runtime, cfg, work / "runtime.csv"))
            same = filecmp.cmp(work / "static.csv", work / "runtime.csv", shallow=False)
            s, r = statistics.median(times["static"]), statistics.median(times["runtime"])
            speed.append([label, f"{s * 1e3:.2f}", f"{r * 1e3:.2f}", f"{r / s:.3f}", "yes" if same else "no"])
        if not args.quick:
            mujoco = mujoco_part(work / "workprecision", cache, args.rounds)
    lines = [
        "# The simulator compiled once (issue 45)",
        "",
        "`python -m bench.runtime` (make bench-runtime). ipsim's simulator is compiled once per",
        "installation; each model is a C library behind the C model interface, compiled in about",
        "a second and loaded at run time (docs/simulator.md).",
        "",
        *machine(),
        "",
        "## What a run costs (CPU time of `ipgen run` and every process it starts, user + system)",
        "",
        f"The one-time build (a fresh cache: ipsim's core and simulator, then a first model, rdip_pulse, "
        f"with its run): {once.seconds:.1f} s of CPU ({once.wall:.1f} s wall).",
        "",
        f"Cached runs: the median of {repeat} runs each, the three kinds alternating; the simulator alone:",
        f"the median of {repeat} runs of the launcher on the .cfg.",
        "",
        *table(
            [
                "scene",
                "first run of a new model [s CPU]",
                "cached run [s CPU]",
                "cached run without the PNG [s CPU]",
                "the same, its plan made again [s CPU]",
                "the simulator alone [s CPU]",
            ],
            rows,
        ),
        "",
        "A first run: the scene's checks, the derivation, a controller's and an estimator's design,",
        "the model library's compile (C, -O2), the simulation, the plot. A cached run takes the",
        "model library and the run's plan (the resolved scene and the library's sources:",
        "pipeline/run_plan.py) from the cache: what remains besides the simulation is Python's",
        "start-up and imports, the cache's look-ups (the key hashes the scene and ipgen's sources)",
        "and, unless --no-plot, the PNG (matplotlib). With the plan made again (the last column but",
        "one: the cache's runs/ emptied first) a run checks the scene, derives the model and designs",
        "its controller and estimator (sympy, scipy) again, as every cached run did before the plan",
        "was kept.",
        "",
        "## Simulation speed: the runtime simulator against one compiled for the model",
        "",
        f"The scene's own simulation (the summary's wall time), median of {repeat} alternating runs",
        "each; the per-model simulator is simulate.cpp compiled against the model's C++ header with",
        "the same flags (-O2), as `ipgen run` built it before. Byte-identical CSVs: both took the",
        "same steps, so the ratio is the cost of a step at equal error.",
        "",
        *table(["scene", "per model [ms]", "runtime [ms]", "ratio", "same CSV"], speed),
        "",
    ]
    lines += mujoco
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text("\n".join(lines))
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
