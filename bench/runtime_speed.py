"""Speed at equal error against MuJoCo RK4: the work-precision driver of `make bench` (the
simulation in one process, no files) compiled three ways, on the work-precision bench's scenes.

- before: the commit before issue 45 (BEFORE), its driver against its own ipsim and the model's
  C++ header its generator writes: what `make bench` measured then;
- per model: this checkout's driver against the model's C++ header (`make bench` now);
- runtime: this checkout's driver compiled once for every model (-DIPSIM_RUNTIME_MODEL), on the
  model library `ipgen run` builds (C, its flags): the simulation `ipgen run` runs.

The drivers use the work-precision bench's flags (-O3 -DNDEBUG; the runtime one without
-Werror). Each run of a driver computes its reference (erk-fehlberg8 at rtol 1e-13) and then,
per setting, the median wall time of `simulate()` over repeated runs (at least 0.3 s); the
three drivers and MuJoCo's `rollout` (RK4 at the same steps as ipsim's rk4: the same scheme and
step, so the same error) alternate, and each number is the median over the rounds. Used by
bench/runtime.py.
"""

from __future__ import annotations

import hashlib
import json
import os
import statistics
import subprocess
import sys
import tarfile
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from bench.report import ROOT, table
from bench.workprecision.build import COMPILER, FLAGS, LIBRARIES

BEFORE = "1302ddc"  # the last commit before issue 45: `ipgen run` compiled a simulator per model
# (label, scene file): the work-precision bench's non-stiff scenes (bench/workprecision/run.py)
SCENES = (
    ("CDIP (the paper's Fig. 4)", ROOT / "scenes" / "cdip_pulse.toml"),
    ("RSIP, full inertia", ROOT / "bench" / "workprecision" / "scenes" / "wp_rsip_full.toml"),
    ("classical, n = 5", ROOT / "bench" / "workprecision" / "scenes" / "wp_classical5.toml"),
    ("rotary, n = 3, full inertia", ROOT / "bench" / "workprecision" / "scenes" / "wp_rotary3.toml"),
)
RK4_STEPS = (5e-3, 1e-3)  # 5e-3: the target on CDIP (error about 1e-8 at t = 10 s)
RTOL = 1e-8  # the error-controlled methods' setting shown
ADAPTIVE = ("bdf", "erk-dp5")  # bdf: the scenes' default method
VARIANTS = ("before", "per model", "runtime")
REPEAT_SECONDS = 0.3  # each setting's runs in one driver call: the median of them is its time


@dataclass(frozen=True)
class Built:
    """One scene's three drivers: the command to run each (before its own options) and its .cfg."""

    commands: dict[str, list[str]]
    cfgs: dict[str, Path]


def _compile(source: Path, include: Path, folder: Path, name: str | None, binary: Path) -> None:
    """Compile the driver `source` into `binary` (unless it was compiled from these sources' text
    with this command before: regenerated headers keep their driver): on the model header
    `folder`/`name`.hpp, or with name None on the runtime model."""
    sources = [source, *sorted(include.rglob("*.h*")), *([folder / f"{name}.hpp"] if name else [])]
    model = (
        [f"-I{folder}", f'-DIPGEN_MODEL_HEADER="{name}.hpp"', f"-DIPGEN_MODEL=ipgen::{name}::Model"]
        if name is not None
        else ["-DIPSIM_RUNTIME_MODEL"]
    )
    # -Werror off for the driver on the runtime model: at -O3 GCC 12 warns (-Warray-bounds) inside
    # Eigen's inlined fixed-size solve, a false positive (ipgen run's own build has no -Werror).
    flags = FLAGS if name is not None else tuple(flag for flag in FLAGS if flag != "-Werror")
    command = [COMPILER, *flags, f"-I{include}", "-isystem", "/usr/include/eigen3", *model, str(source),
               "-o", str(binary), *LIBRARIES, *([] if name is not None else ["-ldl"])]  # fmt: skip
    digest = hashlib.sha256(
        b"".join(path.read_bytes() for path in sources) + "\0".join(command).encode()
    ).hexdigest()
    stamp = binary.with_name(binary.name + ".sources")
    if binary.exists() and stamp.is_file() and stamp.read_text() == digest:
        return
    done = subprocess.run(command, capture_output=True, text=True)
    if done.returncode != 0:
        raise RuntimeError(f"compiling {source} failed:\n{done.stderr[-3000:]}")
    stamp.write_text(digest)


def _checkout(commit: str, folder: Path) -> Path:
    """The tree of `commit` (git archive) in `folder`/tree, with an import folder whose `ipgen` is
    its generator/."""
    tree = folder / "tree"
    if (tree / "generator").is_dir() and (folder / "import" / "ipgen").exists():
        return tree  # extracted before (the commit's tree does not change)
    folder.mkdir(parents=True, exist_ok=True)
    archive = folder / "tree.tar"
    with archive.open("wb") as handle:
        subprocess.run(["git", "-C", str(ROOT), "archive", commit], stdout=handle, check=True)
    with tarfile.open(archive) as tar:
        tar.extractall(tree, filter="data")
    (folder / "import").mkdir(exist_ok=True)
    (folder / "import" / "ipgen").symlink_to(tree / "generator")
    return tree


def _generate(scene: Path, out: Path, pythonpath: Path | None = None) -> tuple[str, Path]:
    """The model's C++ header and resolved scene (`ipgen --scene`), by this checkout's ipgen or the
    one at `pythonpath`; (model name, .cfg)."""
    env = dict(os.environ)
    if pythonpath is not None:
        env["PYTHONPATH"] = str(pythonpath)
    out.mkdir(parents=True, exist_ok=True)
    done = subprocess.run([sys.executable, "-m", "ipgen", "--scene", str(scene), "-o", str(out)],
                          capture_output=True, text=True, env=env, cwd=out)  # fmt: skip
    if done.returncode != 0:
        raise RuntimeError(f"ipgen --scene {scene.name} failed: {done.stderr[-2000:]}")
    check = subprocess.run([sys.executable, "-c", "import ipgen; print(ipgen.__file__)"],
                           capture_output=True, text=True, env=env, cwd=out)  # fmt: skip
    expected = (pythonpath / "ipgen") if pythonpath is not None else ROOT / "generator"
    if not Path(check.stdout.strip()).is_relative_to(expected):
        raise RuntimeError(f"ipgen imported from {check.stdout.strip()}, expected {expected}")
    name = next(p.stem for p in out.glob("*.hpp"))
    return name, out / f"{scene.stem}.cfg"


def build_all(work: Path, library_of: dict[Path, tuple[Path, Path]]) -> dict[Path, Built]:
    """The three drivers of every scene; `library_of`: each scene's model library and resolved
    scene as `ipgen run` wrote them (its .cfg names the model library's model, in ipgen's
    coordinates)."""
    before = _checkout(BEFORE, work / "before")
    source, include = ROOT / "bench" / "workprecision" / "driver.cpp", ROOT / "cpp" / "include"
    runtime = work / "driver_runtime"
    _compile(source, include, work, None, runtime)
    built = {}
    for _, scene in SCENES:
        old = work / "before" / scene.stem
        name, old_cfg = _generate(scene, old, work / "before" / "import")
        _compile(before / "bench" / "workprecision" / "driver.cpp", before / "cpp" / "include", old, name,
                 old / "driver")  # fmt: skip
        new = work / "now" / scene.stem
        name, cfg = _generate(scene, new)
        _compile(source, include, new, name, new / "driver")
        library, run_cfg = library_of[scene]
        built[scene] = Built(
            commands={
                "before": [str(old / "driver"), str(old_cfg)],
                "per model": [str(new / "driver"), str(cfg)],
                "runtime": [str(runtime), "--model", str(library), str(run_cfg)],
            },
            cfgs={"before": old_cfg, "per model": cfg, "runtime": run_cfg},
        )
    return built


def _driver(command: list[str], folder: Path) -> dict[str, dict]:
    """One run of a driver: {setting: its JSON line}, setting "rk4 5e-3" or "bdf 1e-8"."""
    options = ["--reference", str(folder / "reference.csv"), "--rtols", repr(RTOL),
               "--rk4-steps", ",".join(repr(s) for s in RK4_STEPS),
               "--repeat-seconds", repr(REPEAT_SECONDS)]  # fmt: skip
    # One OpenBLAS thread (LAPACK: the eigenvalue guards at a run's start): its idle threads spin
    # on sched_yield and took cores from the simulation (runtime rk4 on RSIP 1.2-1.7x between runs).
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1"}
    done = subprocess.run([*command, *options], capture_output=True, text=True, check=True, env=env)
    lines = [json.loads(line) for line in done.stdout.splitlines()]
    return {f"{line['method']} {line['knob']:g}": line for line in lines if line["kind"] == "run"}


def measure(built: dict[Path, Built], rounds: int) -> list[list[str]]:
    """The table's rows: per scene and setting, ms per simulated second of each variant and
    MuJoCo RK4 (medians over `rounds` alternating rounds), the errors and the ratios."""
    from bench.workprecision.mujoco_peer import MujocoPendulum
    from ipgen.experiment.scene import load_scene

    rows = []
    for label, scene_path in SCENES:
        print(f"  {label}: {rounds} alternating rounds…", flush=True)
        drivers = built[scene_path]
        scene = load_scene(scene_path)
        pendulum = MujocoPendulum(scene)
        times: dict[tuple[str, str], list[float]] = {}
        errors: dict[tuple[str, str], float] = {}
        with tempfile.TemporaryDirectory() as scratch:
            folder = Path(scratch)
            reference = None
            for _ in range(rounds):
                for variant in VARIANTS:
                    for setting, line in _driver(drivers.commands[variant], folder).items():
                        times.setdefault((variant, setting), []).append(line["wall_per_second"])
                        errors[(variant, setting)] = line["final_error"]
                    if reference is None:
                        reference = np.loadtxt(folder / "reference.csv", delimiter=",")[:, 1:]
                for step in RK4_STEPS:
                    run = pendulum.run("rk4", step, scene.sample, repeat_seconds=0.1)
                    times.setdefault(("MuJoCo", f"rk4 {step:g}"), []).append(run.wall_per_second)
                    final = float(np.abs(run.states[-1] - reference[-1]).max())
                    errors[("MuJoCo", f"rk4 {step:g}")] = final
        settings = [f"rk4 {s:g}" for s in RK4_STEPS] + [f"{m} {RTOL:g}" for m in ADAPTIVE]
        for setting in settings:
            ms = {v: statistics.median(times[(v, setting)]) * 1e3 for v in VARIANTS}
            # runtime / before of each round (both ran within the round, seconds apart), then the
            # median: a slow spell of the shared machine then slows both sides of a ratio, not one
            # variant's median.
            paired = statistics.median(
                r / b for r, b in zip(times[("runtime", setting)], times[("before", setting)], strict=True)
            )
            key = f"rk4 {setting.split()[1]}" if setting.startswith("rk4") else None
            mujoco = statistics.median(times[("MuJoCo", key)]) * 1e3 if key else None
            same = "yes" if errors[("before", setting)] == errors[("runtime", setting)] else "no"
            rows.append([
                label, setting, f"{errors[('runtime', setting)]:.1e}",
                *(f"{ms[v]:.4f}" for v in VARIANTS),
                f"{paired:.3f}", same,
                f"{mujoco:.3f} ({errors[('MuJoCo', key)]:.1e})" if mujoco else "",
                f"{mujoco / ms['before']:.1f}x" if mujoco else "",
                f"{mujoco / ms['runtime']:.1f}x" if mujoco else "",
            ])  # fmt: skip
    return rows


def section(rows: list[list[str]], rounds: int, load: tuple[str, str]) -> list[str]:
    """The report's section on these rows; `load`: the load averages before and after."""
    header = ["scene", "setting", "error at 10 s", "before [ms/s]", "per model [ms/s]", "runtime [ms/s]",
              "runtime / before", "same error", "MuJoCo RK4 [ms/s]", "ratio to MuJoCo, before",
              "ratio to MuJoCo, runtime"]  # fmt: skip
    return [
        "## Speed at equal error against MuJoCo RK4 (`make bench`'s driver)",
        "",
        "The work-precision driver of `make bench` (bench/workprecision/driver.cpp: `simulate()` in",
        "one process, its median wall time per simulated second over repeated runs of at least",
        f"{REPEAT_SECONDS} s, no files; -O3 -DNDEBUG as in `make bench`; one OpenBLAS thread) compiled",
        "three ways: **before**, the commit before",
        f"issue 45 ({BEFORE}: its driver, its ipsim and the C++ header its generator writes); **per model**,",
        "this commit's driver on the model's C++ header; **runtime**, this commit's driver compiled once",
        "for every model (-DIPSIM_RUNTIME_MODEL) on the model library `ipgen run` builds (C, -O2): the",
        "simulation `ipgen run` runs. MuJoCo RK4 (`mujoco.rollout`) at the same step as ipsim's rk4: the",
        "same scheme and step, so the same error (in brackets, at t = 10 s, against ipsim's reference).",
        f"The drivers and MuJoCo alternate; each time is the median of {rounds} rounds, runtime / before",
        "the median of the rounds' ratios (the two ran within seconds in each round). Same error:",
        "whether before and runtime end at the same error to the last printed digit (the same steps).",
        "The ratio to MuJoCo RK4 is MuJoCo's time over ipgen's (larger: ipgen faster).",
        f"Load average (1, 5, 15 min) before this part: {load[0]}; after: {load[1]} (2 cores, shared).",
        "",
        *table(header, rows),
        "",
    ]
