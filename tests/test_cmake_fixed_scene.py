"""CMake's ipgen_add_scene with a fixed-pivot scene, as a project using ipgen builds it.

A project without C is refused at configure time in one message (a fixed chain's simulator links
its C adapter). With C (make test-slow: ipsim's runtime compiled at -O2, about a minute), a
project without a build type (ipgen::ipsim's -O2) adds scenes/rigs/dfki_c0.toml (DFKI's double
pendulum let go, its rig's friction): CMake reads `ipgen --scene --describe`, builds the scene's
own model and the simulator linked to its C adapter without a compiler warning, and
`run_scene_dfki_c0` writes the trajectory `ipgen run` writes. ipgen's own build covers the same
path at -Og (ctest ipsim.cli.scene.dfki_c0).
"""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
from run_csv import read_run_csv

import ipgen
from ipgen.command.cli import run

ROOT = Path(__file__).resolve().parent.parent
SCENE = ROOT / "scenes" / "rigs" / "dfki_c0.toml"


def _project(tmp_path: Path, languages: str) -> list[str]:
    """A project adding SCENE, its languages `languages`: the command that configures it."""
    if shutil.which("cmake") is None:
        pytest.fail("cmake is not installed (make deps installs it)")
    project = tmp_path / "project"
    project.mkdir()
    shutil.copy(SCENE, project / SCENE.name)
    (project / "CMakeLists.txt").write_text(
        f"cmake_minimum_required(VERSION 3.25)\nproject(p LANGUAGES {languages})\n"
        "find_package(ipgen CONFIG REQUIRED)\nipgen_add_scene(dfki_c0.toml)\n"
    )
    generator = ["-G", "Ninja"] if shutil.which("ninja") else []
    build = tmp_path / "build"
    return ["cmake", "-S", str(project), "-B", str(build), *generator, f"-Dipgen_DIR={ipgen.cmake_dir()}"]


def test_a_project_without_c_is_told_to_enable_it(tmp_path: Path) -> None:
    result = subprocess.run(_project(tmp_path, "CXX"), capture_output=True, text=True)
    assert result.returncode != 0
    message = " ".join(result.stderr.split())
    assert "a fixed-pivot chain's simulator links its C adapter: enable C in the project" in message


@pytest.mark.user_program  # ipsim's runtime compiled at -O2: about a minute (make test-slow)
def test_a_project_builds_and_runs_a_fixed_scene(tmp_path: Path) -> None:
    build = tmp_path / "build"
    steps = [
        _project(tmp_path, "CXX C"),
        ["cmake", "--build", str(build)],
        ["cmake", "--build", str(build), "--target", "run_scene_dfki_c0"],
    ]
    outputs = []
    for step in steps:
        result = subprocess.run(step, capture_output=True, text=True)
        assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-3000:]
        outputs.append(result.stdout + result.stderr)
    compiled = outputs[1].splitlines()
    assert [line for line in compiled if "warning:" in line and not line.startswith("ipgen:")] == []
    assert "scene dfki_c0: model fixed2 (fixed, 2 links)" in outputs[2]
    with_cmake = read_run_csv(build / "scenes" / "dfki_c0.csv", phase=False).columns()
    assert run(["run", str(SCENE), "-o", str(tmp_path / "run"), "--no-plot"]) == 0
    with_run = read_run_csv(tmp_path / "run" / "dfki_c0.csv", phase=False).columns()
    assert set(with_cmake) == set(with_run) and len(with_cmake["t"]) == 501
    for name, values in with_run.items():  # the same model, method and tolerances: -O2 against -O2
        assert np.max(np.abs(with_cmake[name] - values)) <= 1e-9 * (1 + np.max(np.abs(values))), name
