"""Generate each benchmark scene's model and resolved scene, and compile the work–precision
driver for it (same flags as the simulator's Release build: -O3 -DNDEBUG, no -march=native)."""

from __future__ import annotations

import subprocess
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

from bench.report import BUILD, PYTHON, ROOT
from ipgen.experiment.scene import Scene, load_scene

HERE = Path(__file__).resolve().parent
OUT = BUILD / "workprecision"
COMPILER = "g++"
FLAGS = ("-std=c++17", "-O3", "-DNDEBUG", "-Wall", "-Wextra", "-Wpedantic", "-Werror")
LIBRARIES = (
    *(
        f"-lsundials_{name}"
        for name in (
            "cvode",
            "arkode",
            "nvecserial",
            "sunmatrixdense",
            "sunlinsoldense",
            "sunnonlinsolfixedpoint",
        )
    ),
    "-llapack",  # ipsim's guards (eigenvalues.hpp)
)


def compile_for_model(source: Path, folder: Path, name: str, binary: Path) -> None:
    """Compile `source` against the model header `<folder>/<name>.hpp` and ipsim into `binary`,
    unless `binary` is newer than all of them."""
    sources = [source, folder / f"{name}.hpp", *sorted((ROOT / "cpp/include/ipsim").glob("*.hpp"))]
    if binary.exists() and binary.stat().st_mtime >= max(p.stat().st_mtime for p in sources):
        return
    command = [
        COMPILER,
        *FLAGS,
        f"-I{ROOT / 'cpp/include'}",
        f"-I{folder}",
        "-isystem",
        "/usr/include/eigen3",
        f'-DIPGEN_MODEL_HEADER="{name}.hpp"',
        f"-DIPGEN_MODEL=ipgen::{name}::Model",
        str(source),
        "-o",
        str(binary),
        *LIBRARIES,
    ]
    done = subprocess.run(command, capture_output=True, text=True)
    if done.returncode != 0:
        raise RuntimeError(f"compiling {source.name} for {name} failed:\n{done.stderr[-3000:]}")


def prepare(toml: Path) -> tuple[Scene, Path, Path]:
    """(scene, resolved .cfg, driver executable) for one scene file."""
    scene = load_scene(toml)
    folder = OUT / scene.stem
    folder.mkdir(parents=True, exist_ok=True)
    subprocess.run(
        [PYTHON, "-m", "ipgen", "--scene", str(toml), "-o", str(folder)],
        cwd=ROOT,
        check=True,
        capture_output=True,
        text=True,
    )
    driver = folder / "driver"
    compile_for_model(HERE / "driver.cpp", folder, scene.name, driver)
    return scene, folder / f"{scene.stem}.cfg", driver


def prepare_all(tomls: list[Path], jobs: int = 2) -> list[tuple[Scene, Path, Path]]:
    with ThreadPoolExecutor(jobs) as pool:
        return list(pool.map(prepare, tomls))
