"""Where ipgen's compiled files go: a command's --cache-dir holds everything it builds on its way
(the MPC's and the loop's runtime libraries, the model library), not only its simulator; the
folder is absolute (a launcher that names it runs from anywhere); a machine without a home
folder, a cache that cannot be written, a $CC that is no program and a model name that would
hide a C header are each one line naming the fix."""

from __future__ import annotations

import io
import os
from contextlib import redirect_stderr, redirect_stdout
from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st

from ipgen.command.cli import run
from ipgen.common import build_cache
from ipgen.common.build_cache import CacheError, Recipe, cache_folder, cache_root, cached_build
from ipgen.common.naming import HEADER_STEMS, name_problem
from ipgen.common.presets import preset_path
from ipgen.pipeline import model_library, simulator
from ipgen.pipeline import run as run_module
from ipgen.sweeps import execute


def test_a_commands_folder_is_the_cache_of_everything_it_builds(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Inside `cache_folder` the runtime libraries and the model library are built there; a
    relative folder is made absolute; outside it the default holds again."""
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("IPGEN_CACHE_DIR", str(tmp_path / "default"))
    folders: list[Path] = []

    def record(folder: Path, key: str, target: str, recipe: Recipe, *_: object) -> build_cache.Built:
        folders.append(folder)
        raise recipe.error("recorded")

    monkeypatch.setattr(build_cache, "cached_build", record)
    monkeypatch.setattr(model_library, "cached_build", record)
    with cache_folder(Path("mine")):
        assert cache_root() == tmp_path / "mine"
        with pytest.raises(Exception, match="recorded"):
            build_cache.runtime_library("mpc", {"a.h": ""}, "a.h", (), "liba.so", CacheError, "a", "a")
        with pytest.raises(Exception, match="recorded"):
            model_library.compiled_model_library(simulator_system())
    assert folders == [tmp_path / "mine" / "mpc", tmp_path / "mine" / "models"]
    assert cache_root() == tmp_path / "default"


def simulator_system():  # a small model whose sources generate quickly
    from ipgen.model.system import System

    return System("rotary", 1)


def test_a_run_and_a_sweeps_run_build_in_their_cache(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """`run_scene(cache=)` (ipgen run --cache-dir) and a sweep's run (its --cache-dir, on any worker)
    run inside their cache folder."""
    seen: list[Path] = []
    monkeypatch.setattr(run_module, "_run_scene", lambda *_: seen.append(cache_root()))
    monkeypatch.setattr(execute, "_run_one", lambda *_: seen.append(cache_root()))
    run_module.run_scene(tmp_path / "s.toml", tmp_path / "out", cache=tmp_path / "a")
    execute.run_one(execute.SceneSource("s", "", str(tmp_path / "b")), None, None)  # type: ignore[arg-type]
    assert seen == [tmp_path / "a", tmp_path / "b"]


def test_no_home_folder_is_one_line(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """No $IPGEN_CACHE_DIR, no $XDG_CACHE_HOME and no home folder (a container's user without an
    entry in the password database): `ipgen run` says to pass --cache-dir, no traceback."""
    monkeypatch.delenv("IPGEN_CACHE_DIR", raising=False)
    monkeypatch.delenv("XDG_CACHE_HOME", raising=False)

    def no_home() -> Path:
        raise RuntimeError("Could not determine home directory.")

    monkeypatch.setattr(Path, "home", staticmethod(no_home))
    with pytest.raises(CacheError, match="--cache-dir"):
        cache_root()
    err = io.StringIO()
    with redirect_stdout(io.StringIO()), redirect_stderr(err):
        status = run(["run", str(preset_path("rsip_pulse")), "-o", str(tmp_path / "out"), "--no-plot"])
    lines = err.getvalue().strip().splitlines()
    assert status != 0 and len(lines) == 1 and "--cache-dir" in lines[0] and "Traceback" not in lines[0]


@pytest.mark.skipif(not Path("/sys").is_dir() or (os.access("/sys", os.W_OK) and os.geteuid() != 0),
                    reason="needs a folder nobody may write into (/sys)")  # fmt: skip
def test_a_cache_that_cannot_be_written_is_one_line() -> None:
    """A shared or read-only cache without the entry wanted: the recipe's error, naming the folder
    and --cache-dir (before: a PermissionError traceback from the lock file)."""
    recipe = Recipe({}, lambda entry, out: ["true"], simulator.BuildError, str, "a test file")
    with pytest.raises(simulator.BuildError, match=r"cannot write to the cache folder /sys .*--cache-dir"):
        cached_build(Path("/sys"), "ipgen-test-key", "target", recipe)


@given(flags=st.sampled_from(["-O2", "-Wall", "--version"]), wrapper=st.sampled_from(["", "env ", "ccache "]))
def test_a_compiler_variable_that_is_no_program_says_so(flags: str, wrapper: str) -> None:
    """$CC with flags or a wrapper is no program on PATH: the message names $CC and its value
    (it said "no C compiler found ... apt-get install gcc", gcc being installed)."""
    before = os.environ.get("CC")
    os.environ["CC"] = f"{wrapper}gcc {flags}"
    try:
        with pytest.raises(simulator.BuildError) as error:
            build_cache.c_compiler(simulator.BuildError)
    finally:
        if before is None:
            del os.environ["CC"]
        else:
            os.environ["CC"] = before
    message = str(error.value)
    assert "$CC = " in message and flags in message and "\n" not in message and "apt-get" not in message


@given(stem=st.sampled_from(sorted(HEADER_STEMS)))
def test_a_model_named_as_a_c_header_is_refused(stem: str) -> None:
    """NAME.h would hide the C library's header of that name from every compiler given the
    folder (CMake's include directories); ipgen's own build includes NAME.h by -iquote only."""
    assert name_problem(stem) is not None  # float, assert, errno...: a keyword's or a macro's message
    assert "<math.h>" in (name_problem("math") or "") and name_problem("mathematics") is None
    command = simulator.compile_command("cc", Path("/entry"), "pendulum", Path("/out.so"))
    assert "-I/entry" not in command and command[command.index("-iquote") + 1] == "/entry"
