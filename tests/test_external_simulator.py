"""`ipgen run` with $IPGEN_SIMULATOR: a simulator built by CMake (target ipsim_simulate) instead of
the cache's. It must tell the digest of the ipsim sources it was built from, which CMake computes
(cmake/ipgen.cmake) and ipgen recomputes (pipeline/simulator.py); anything else is refused in one
line before a file is written."""

from __future__ import annotations

import shutil
import stat
import subprocess
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from ipgen.command.cli import run as cli
from ipgen.pipeline import simulator

ROOT = Path(__file__).resolve().parents[1]
SCENE = ROOT / "scenes" / "rsip_pulse.toml"


def test_cmake_and_ipgen_compute_the_same_sources_digest(tmp_path: Path) -> None:
    """The digest CMake compiles into ipsim_simulate (cmake -P on ipgen.cmake's own function)
    equals the one ipgen checks it against; and it changes with any byte of any source."""
    if shutil.which("cmake") is None:
        pytest.fail("cmake is not installed (make deps installs it)")
    script = tmp_path / "digest.cmake"
    script.write_text(
        f'include("{ROOT / "cmake" / "ipgen.cmake"}")\n_ipgen_ipsim_sources_digest(d)\nmessage("${{d}}")\n'
    )
    done = subprocess.run(["cmake", "-P", str(script)], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    assert done.stderr.strip() == simulator.sources_digest()
    files = simulator.ipsim_source_files()
    assert {path.name for path in files} >= {"simulate.cpp", "ipsim_core.cpp", "ipgen_mpc.h", "scene.hpp"}


def _program(folder: Path, body: str) -> Path:
    path = folder / "ipsim-simulate"
    path.write_text(f"#!/bin/sh\n{body}\n")
    path.chmod(path.stat().st_mode | stat.S_IXUSR)
    return path


KINDS = ("missing", "folder", "not_executable", "other_digest", "fails", "empty_output")


@settings(max_examples=24, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(kind=st.sampled_from(KINDS), text=st.text(alphabet="0123456789abcdef", min_size=0, max_size=64))
def test_a_simulator_not_built_from_these_sources_is_refused_in_one_line(
    tmp_path_factory: pytest.TempPathFactory,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
    kind: str,
    text: str,
) -> None:
    folder = tmp_path_factory.mktemp("simulator")
    if kind == "missing":
        path = folder / "absent"
    elif kind == "folder":
        path = folder
    elif kind == "not_executable":
        path = folder / "plain"
        path.write_text(f"{simulator.sources_digest()}\n")
    elif kind == "other_digest":
        path = _program(folder, f"echo '{text or '0'}'")
    elif kind == "fails":
        path = _program(folder, f"echo '{simulator.sources_digest()}'; exit 3")
    else:
        path = _program(folder, "true")
    monkeypatch.setenv(simulator.SIMULATOR_VARIABLE, str(path))
    out = folder / "out"
    capsys.readouterr()
    assert cli(["run", str(SCENE), "-o", str(out), "--no-plot"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and simulator.SIMULATOR_VARIABLE in err and "unset" in err, err
    assert not (out / "rsip_pulse.csv").exists()


def test_make_tests_runs_go_through_the_cmake_built_simulator(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """Under make test ($IPGEN_SIMULATOR set by the Makefile) a run's launcher executes that
    program on the model's library; without the variable there is nothing to check here."""
    program = simulator.external_program()
    if program is None:
        pytest.skip(f"{simulator.SIMULATOR_VARIABLE} is not set (make test sets it)")
    assert cli(["run", str(SCENE), "-o", str(tmp_path), "--no-plot"]) == 0
    summary = capsys.readouterr().out
    launcher = Path(summary.split("Simulator ", 1)[1].split(" (", 1)[0])
    assert f"exec {program.path} --model " in launcher.read_text()
    assert (tmp_path / "rsip_pulse.csv").stat().st_size > 0
