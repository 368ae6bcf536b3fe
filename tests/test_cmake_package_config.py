"""What `find_package(ipgen)` gives a project, configure only (about a second each).

The target ipgen_ipsim_core, which docs/simulator.md says to link for several models, exists after
find_package (before, only after a function such as ipgen_add_simulator; a project linking it
got no include folder) and is built only for a target that links it.

Which Python the CMake package runs the generator with (cmake/ipgen.cmake, _ipgen_require_python):
the one whose ipgen holds the package's folder. Re-configured with another `ipgen_DIR` (a moved or
recreated virtualenv, another installation), the build finds it again; before, the interpreter
found for the first folder stayed cached, and the generator run was the other installation's.
An interpreter the user set with -DIPGEN_PYTHON is kept."""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PROJECT = """\
cmake_minimum_required(VERSION 3.25)
project(probe LANGUAGES CXX)
find_package(ipgen CONFIG REQUIRED)
_ipgen_require_python()
message(STATUS "IPGEN_PYTHON=${IPGEN_PYTHON}")
get_target_property(apart ipgen_ipsim_core EXCLUDE_FROM_ALL)
message(STATUS "ipgen_ipsim_core apart=${apart}")
"""


def _installation(folder: Path) -> tuple[Path, Path]:
    """(its cmake folder, its python): an installed package's layout, <prefix>/lib/python3.11/
    site-packages/ipgen/cmake, whose <prefix>/bin/python3.11 answers `-m ipgen --cmake-dir`."""
    package = folder / "lib" / "python3.11" / "site-packages" / "ipgen"
    package.mkdir(parents=True)
    shutil.copytree(ROOT / "cmake", package / "cmake")
    (package / "cpp").symlink_to(ROOT / "cpp")
    python = folder / "bin" / "python3.11"
    python.parent.mkdir()
    python.write_text(
        f'#!/bin/sh\n[ "$3" = "--cmake-dir" ] && echo "{package / "cmake"}" && exit 0\nexit 1\n'
    )
    python.chmod(0o755)
    return package / "cmake", python


def _configure(project: Path, build: Path, *options: str) -> str:
    done = subprocess.run(
        ["cmake", "-S", str(project), "-B", str(build), *options], capture_output=True, text=True, timeout=120
    )
    assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-2000:]
    return next(line.split("=", 1)[1] for line in done.stdout.splitlines() if "IPGEN_PYTHON=" in line)


@pytest.fixture
def project(tmp_path: Path) -> Path:
    if shutil.which("cmake") is None:
        pytest.fail("cmake is not installed (make deps installs it)")
    if not (ROOT / ".venv" / "bin" / "python").exists():
        pytest.skip("needs the checkout's .venv (make venv)")
    folder = tmp_path / "project"
    folder.mkdir()
    (folder / "CMakeLists.txt").write_text(PROJECT)
    return folder


def test_another_ipgen_dir_finds_its_own_python(project: Path, tmp_path: Path) -> None:
    cmake_dir, python = _installation(tmp_path / "other")
    build = tmp_path / "build"
    assert _configure(project, build, f"-Dipgen_DIR={ROOT / 'cmake'}") == str(
        ROOT / ".venv" / "bin" / "python"
    )
    assert _configure(project, build, f"-Dipgen_DIR={cmake_dir}") == str(python)
    assert _configure(project, build, f"-Dipgen_DIR={ROOT / 'cmake'}") == str(
        ROOT / ".venv" / "bin" / "python"
    )


def test_a_python_the_user_set_is_kept(project: Path, tmp_path: Path) -> None:
    """-DIPGEN_PYTHON given with one package's folder stays when the build moves to another (a
    search there would find the checkout's .venv)."""
    cmake_dir, python = _installation(tmp_path / "other")
    build = tmp_path / "build"
    assert _configure(project, build, f"-Dipgen_DIR={cmake_dir}", f"-DIPGEN_PYTHON={python}") == str(python)
    assert _configure(project, build, f"-Dipgen_DIR={ROOT / 'cmake'}") == str(python)


def test_the_ipsim_core_target_exists_and_builds_only_when_linked(project: Path, tmp_path: Path) -> None:
    done = subprocess.run(
        ["cmake", "-S", str(project), "-B", str(tmp_path / "build"), f"-Dipgen_DIR={ROOT / 'cmake'}"],
        capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-2000:]
    assert "ipgen_ipsim_core apart=TRUE" in done.stdout, done.stdout[-2000:]


def test_two_targets_of_one_model_name_are_named(project: Path, tmp_path: Path) -> None:
    """Two ipgen_add_model targets that would write the same model files: ipgen's message names
    both and the fix (CMake's own named neither: "...rotary2.hpp.rule which already has a custom
    rule")."""
    (project / "CMakeLists.txt").write_text(
        PROJECT
        + "ipgen_add_model(rotary2 TYPE rotary LINKS 2)\n"
        + "ipgen_add_model(other TYPE rotary LINKS 2 NAME rotary2)\n"
    )
    done = subprocess.run(
        ["cmake", "-S", str(project), "-B", str(tmp_path / "build"), f"-Dipgen_DIR={ROOT / 'cmake'}"],
        capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    message = " ".join(done.stderr.split())
    assert done.returncode != 0 and "already has a custom rule" not in message, message[-2000:]
    assert "ipgen_add_model(other): target `rotary2` already generates model `rotary2`" in message, message[
        -2000:
    ]
