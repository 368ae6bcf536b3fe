"""ipgen as a user gets it: the README's install lines run verbatim (a fresh virtualenv outside
the checkout, `pip install ./` of a copy of this repository, not editable), then the README's
`ipgen run` line on the README's example scene, then the CMake project of docs/simulator.md
("Using ipgen from CMake") built in a temporary folder against that installation, and run.

Expected duration: 1-3 min on the shared 2-core machine (the install, one simulator compile,
one CMake build); pip takes the dependencies from its cache (PIP_CACHE_DIR, else ~/.cache/pip).
Marked fresh_venv: `make test-slow` runs it (CI runs make test, then make test-slow)."""

from __future__ import annotations

import json
import os
import re
import shlex
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from cxx import require_toolchain

import ipgen

ROOT = Path(__file__).resolve().parents[1]


def readme_block(language: str, marker: str, document: str = "README.md") -> str:
    blocks = re.findall(rf"^```{language}\n(.*?)^```$", (ROOT / document).read_text(), flags=re.S | re.M)
    matching = [block for block in blocks if marker in block]
    assert len(matching) == 1, f"expected one ```{language} block with {marker!r} in {document}"
    return matching[0]


def clean_environment() -> dict[str, str]:
    """This process's environment without anything that points at the checkout's Python."""
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV", "IPGEN_PYTHON")}
    venv_bin = str(Path(sys.prefix) / "bin")
    env["PATH"] = os.pathsep.join(p for p in env.get("PATH", "").split(os.pathsep) if p != venv_bin)
    return env


def install(folder: Path) -> Path:
    """The README's install lines, verbatim, in a copy of the checkout with HOME = `folder`/home
    (so `~/.venvs/ipgen` is a fresh virtualenv outside the checkout), then the README's `ipgen run`
    line on its example scene in `folder`/work; the virtualenv's python."""
    home, work = folder / "home", folder / "work"
    home.mkdir()
    work.mkdir()
    # A copy of the sources without build leftovers, so that the wheel is built from tracked files.
    source = folder / "source" / "ipgen"
    ignore = shutil.ignore_patterns(".venv", "build", "out", ".git", "*.egg-info", "__pycache__", ".*cache")
    shutil.copytree(ROOT, source, ignore=ignore)
    (work / "my_pendulum.toml").write_text(readme_block("toml", "[system]"))
    script = "\n".join(
        [
            readme_block("sh", "pip install ./"),
            f"cd {shlex.quote(str(work))}",
            readme_block("sh", "ipgen run my_pendulum.toml"),
        ]
    )
    env = clean_environment() | {
        "HOME": str(home),
        "PIP_CACHE_DIR": os.environ.get("PIP_CACHE_DIR", str(Path.home() / ".cache" / "pip")),
        "PIP_DISABLE_PIP_VERSION_CHECK": "1",
        "XDG_CACHE_HOME": str(folder / "cache"),  # ipgen run's compiled simulators
    }
    env.pop("IPGEN_CACHE_DIR", None)
    env.pop("IPGEN_SIM_OPT", None)  # the user's -O2, not the test suite's -Og (tests/conftest.py)
    env.pop("IPGEN_SIMULATOR", None)  # the checkout's CMake-built simulator (Makefile): not a user's
    done = subprocess.run(
        ["bash", "-eu", "-o", "pipefail", "-c", script], cwd=source, capture_output=True, text=True, env=env
    )
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
    assert re.search(r"^ipgen, version \S+$", done.stdout, flags=re.M), done.stdout  # ipgen --version
    for suffix in ("csv", "png", "txt", "cfg"):
        assert (work / "out" / f"my_pendulum.{suffix}").is_file(), suffix
    assert (work / "out" / "my_pendulum.csv").read_text().startswith("t,theta0,theta1,theta2,dtheta0,")
    assert list((folder / "cache" / "ipgen" / "simulators").glob("*/simulate_rotary2"))
    shutil.rmtree(source)  # the installation must not depend on the sources
    return home / ".venvs" / "ipgen" / "bin" / "python"


@pytest.mark.fresh_venv  # minutes by design: make test-slow (CI runs it), not make test
def test_installed_package_builds_the_readme_cmake_project(tmp_path: Path) -> None:
    """One test, so that parallel workers do not each install: the README's install and run
    lines, the package's files, then the CMake project. Takes 1-3 min."""
    installed = install(tmp_path)
    check_installed_package(installed, tmp_path)
    build_readme_cmake_project(installed, tmp_path)


def check_installed_package(installed: Path, tmp_path: Path) -> None:
    env = clean_environment()
    code = (
        "import importlib.util, ipgen, sys; "
        "print(ipgen.__file__); print(ipgen.cmake_dir()); "
        "print(importlib.util.find_spec('generator') is None)"
    )
    out = subprocess.run([str(installed), "-c", code], capture_output=True, text=True, cwd=tmp_path, env=env)
    assert out.returncode == 0, out.stderr
    package_file, cmake_dir, no_generator = out.stdout.splitlines()
    site = Path(package_file).parent
    assert site.parent.name == "site-packages" and str(installed.parent.parent) in package_file
    assert Path(cmake_dir) == site / "cmake" and no_generator == "True"
    shipped_files = (
        "cmake/ipgenConfig.cmake",
        "cmake/ipgenConfigVersion.cmake",
        "cmake/ipgen.cmake",
        "cpp/include/ipsim/ipsim.hpp",
        "cpp/include/ipgen_loop.h",  # printed into C headers with a loop (ipgen.common.locations)
        "cpp/src/simulate.cpp",
        "cpp/include/ipgen_loop.h",
        "cpp/src/ipgen_loop_batch.c",
        "templates/model.hpp.jinja",
        "templates/fmu2.c.jinja",
        "templates/fmi/fmi2/fmi2Functions.h",
        "templates/fmi/fmi3/fmi3Functions.h",
        "templates/fmi/fmi3/LICENSE.txt",
    )
    for shipped in shipped_files:
        assert (site / shipped).is_file(), shipped
    command = installed.parent / "ipgen"
    printed = subprocess.run(
        [str(command), "--cmake-dir"], capture_output=True, text=True, cwd=tmp_path, env=env
    )
    assert printed.stdout.strip() == cmake_dir
    module = subprocess.run(
        [str(installed), "-m", "ipgen", "--version"], capture_output=True, text=True, env=env
    )
    assert module.returncode == 0 and "ipgen" in module.stdout


def build_readme_cmake_project(installed: Path, tmp_path: Path) -> None:
    require_toolchain()
    if shutil.which("cmake") is None:
        pytest.fail("cmake is not installed (make deps installs it)")
    env = clean_environment()
    project = tmp_path / "project"
    project.mkdir()
    (project / "CMakeLists.txt").write_text(readme_block("cmake", "find_package(ipgen", "docs/simulator.md"))
    (project / "main.cpp").write_text(readme_block("cpp", "ipgen::furuta::Model", "docs/simulator.md"))
    cmake_dir = subprocess.run(
        [str(installed), "-m", "ipgen", "--cmake-dir"], capture_output=True, text=True, check=True, env=env
    ).stdout.strip()
    generator = ["-G", "Ninja"] if shutil.which("ninja") else []
    build = tmp_path / "build"
    steps = [
        # no CMAKE_BUILD_TYPE, as in the documented command: ipgen::ipsim then adds -O2
        ["cmake", "-S", str(project), "-B", str(build), *generator, f"-Dipgen_DIR={cmake_dir}",
         "-DCMAKE_EXPORT_COMPILE_COMMANDS=ON", "-DCMAKE_CXX_FLAGS=-Wall -Wextra -Wpedantic -Werror"],
        ["cmake", "--build", str(build)],
    ]  # fmt: skip
    for step in steps:
        result = subprocess.run(step, capture_output=True, text=True, env=env)
        assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-3000:]
    cache = (build / "CMakeCache.txt").read_text()
    assert f"IPGEN_PYTHON:FILEPATH={installed}" in cache  # found by the package, not passed in
    assert (build / "ipgen_models" / "furuta.hpp").is_file()
    compiled = json.loads((build / "compile_commands.json").read_text())
    main_command = next(entry["command"] for entry in compiled if entry["file"].endswith("main.cpp"))
    assert " -O2 " in f" {main_command} " and "-DNDEBUG" in main_command  # optimised by default
    ran = subprocess.run([str(build / "sim")], capture_output=True, text=True)
    assert ran.returncode == 0, ran.stderr
    match = re.fullmatch(r"theta\(2 s\) =((?: -?\d+\.\d{6}){3})\n", ran.stdout)
    assert match is not None, ran.stdout
    arm, link1, _ = (float(v) for v in match.group(1).split())
    assert abs(link1) > 0.5 and abs(arm) > 0  # tipped by 0.1 rad, the upright links fall


def test_missing_dependency_names_the_debian_package(tmp_path: Path) -> None:
    """A machine without SUNDIALS (simulated: its config hidden) gets the package to install."""
    if shutil.which("cmake") is None:
        pytest.fail("cmake is not installed (make deps installs it)")
    env = clean_environment()
    cmake_dir = str(ipgen.cmake_dir())  # the same files as installed
    project = tmp_path / "project"
    project.mkdir()
    (project / "CMakeLists.txt").write_text(
        "cmake_minimum_required(VERSION 3.25)\nproject(p LANGUAGES CXX)\n"
        "find_package(ipgen CONFIG REQUIRED)\n"
    )
    result = subprocess.run(
        ["cmake", "-S", str(project), "-B", str(tmp_path / "build"), f"-Dipgen_DIR={cmake_dir}",
         "-DCMAKE_DISABLE_FIND_PACKAGE_SUNDIALS=TRUE"],
        capture_output=True, text=True, env=env,
    )  # fmt: skip
    assert result.returncode != 0
    assert "apt-get install libsundials-dev" in " ".join(result.stderr.split())
