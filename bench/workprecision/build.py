"""Generate each benchmark scene's model and resolved scene, and compile the work–precision
driver for it (same flags as the simulator's Release build: -O3 -DNDEBUG, no -march=native)."""

from __future__ import annotations

import subprocess
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

from bench.report import BUILD, PYTHON, ROOT
from ipgen.scene import Scene, load_scene

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
    sources = [
        HERE / "driver.cpp",
        folder / f"{scene.name}.hpp",
        *sorted((ROOT / "cpp/include/ipsim").glob("*.hpp")),
    ]
    if not driver.exists() or driver.stat().st_mtime < max(p.stat().st_mtime for p in sources):
        command = [
            COMPILER,
            *FLAGS,
            f"-I{ROOT / 'cpp/include'}",
            f"-I{folder}",
            "-isystem",
            "/usr/include/eigen3",
            f'-DIPGEN_MODEL_HEADER="{scene.name}.hpp"',
            f"-DIPGEN_MODEL=ipgen::{scene.name}::Model",
            str(HERE / "driver.cpp"),
            "-o",
            str(driver),
            *LIBRARIES,
        ]
        done = subprocess.run(command, capture_output=True, text=True)
        if done.returncode != 0:
            raise RuntimeError(f"compiling the driver for {scene.stem} failed:\n{done.stderr[-3000:]}")
    return scene, folder / f"{scene.stem}.cfg", driver


def prepare_all(tomls: list[Path], jobs: int = 2) -> list[tuple[Scene, Path, Path]]:
    with ThreadPoolExecutor(jobs) as pool:
        return list(pool.map(prepare, tomls))
