"""Property (issue 31): a corrupted cache entry is detected, reported and rebuilt, never a
traceback. The entry corrupted is a model library (issue 45: what each new model compiles).
Corruptions: a truncated or altered file, an entry that is a file, a file that is a folder, a
checksum that is missing (a library has no legacy entries: rebuilt) or garbage, a lock that is a
folder. The compilers are replaced by a copy of a small executable script that answers --help
like a simulator, so nothing is compiled here; what is tested is the cache's handling
(pipeline/simulator.py, common/build_cache.py), not the compiler."""

from __future__ import annotations

import os
import shlex
import shutil
import stat
import subprocess
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from ipgen.common import build_cache
from ipgen.pipeline import simulator
from ipgen.pipeline.simulator import build

FAKE = (
    "#!/bin/sh\necho 'usage: simulate SCENE.cfg (a stand-in for the compiled simulator)'\n" + "# pad\n" * 200
)
NAME = "fake"
HEADER = {f"{NAME}.h": "/* a stand-in header for the cache test */\n", f"{NAME}_model.c": "/* adapter */\n"}


def _whole(binary: Path) -> bool:
    done = subprocess.run([str(binary), "--help"], capture_output=True, text=True)
    return done.returncode == 0 and "usage: simulate" in done.stdout


@pytest.fixture
def fake_compiler(monkeypatch: pytest.MonkeyPatch, tmp_path_factory: pytest.TempPathFactory) -> list[int]:
    """compile_command -> a copy of the stand-in script; returns the list counting the builds."""
    script = tmp_path_factory.mktemp("fake") / "simulate"
    script.write_text(FAKE)
    script.chmod(script.stat().st_mode | stat.S_IXUSR)
    builds: list[int] = []

    def command(cc: str, entry: Path, name: str, library: Path) -> list[str]:  # the model library
        builds.append(1)
        return ["cp", str(script), str(library)]

    def core_command(cxx: str, output: Path) -> list[str]:  # ipsim's compiled core: not counted
        return ["cp", str(script), str(output)]

    def program_command(cxx: str, output: Path, core: Path) -> list[str]:  # the simulator: not counted
        return ["cp", str(script), str(output)]

    monkeypatch.setattr(simulator, "compile_command", command)
    monkeypatch.delenv(simulator.SIMULATOR_VARIABLE, raising=False)  # the cache's own simulator
    monkeypatch.setattr(simulator, "core_command", core_command)
    monkeypatch.setattr(simulator, "program_command", program_command)
    return builds


CORRUPTIONS = (
    "none",
    "truncated",
    "altered",
    "empty",
    "entry_is_file",
    "binary_is_folder",
    "no_checksum",
    "no_checksum_truncated",
    "checksum_garbage",
    "checksum_is_folder",
    "lock_is_folder",
)


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(corruption=st.sampled_from(CORRUPTIONS), cut=st.integers(0, len(FAKE) - 1), flip=st.integers(0, 255))
def test_a_corrupt_cache_is_reported_and_rebuilt(
    fake_compiler: list[int], tmp_path_factory: pytest.TempPathFactory, corruption: str, cut: int, flip: int
) -> None:
    cache = tmp_path_factory.mktemp("cache")
    first = build(HEADER, NAME, cache)
    assert first.built and _whole(first.path)
    binary = Path(shlex.split(first.path.read_text().splitlines()[1])[3])  # exec P --model LIBRARY
    entry = binary.parent
    checksum = build_cache.checksum_path(binary)
    data = binary.read_bytes()
    if corruption in ("truncated", "no_checksum_truncated"):
        binary.write_bytes(data[: min(cut, 9)])  # not even the interpreter line is whole
    elif corruption == "altered":
        binary.write_bytes(data[:cut] + bytes([data[cut] ^ (flip or 1)]) + data[cut + 1 :])
    elif corruption == "empty":
        binary.write_bytes(b"")
    elif corruption == "entry_is_file":
        shutil.rmtree(entry)
        entry.write_text("not a folder")
    elif corruption == "binary_is_folder":
        binary.unlink()
        (binary / "inside").mkdir(parents=True)
    elif corruption == "checksum_garbage":
        checksum.write_text("0123 garbage")
    elif corruption == "checksum_is_folder":
        checksum.unlink()
        checksum.mkdir()
    elif corruption == "lock_is_folder":
        shutil.rmtree(entry)
        lock = entry.parent / f"{entry.name}.lock"
        lock.unlink()
        (lock / "x").mkdir(parents=True)
    if corruption.startswith("no_checksum"):
        checksum.unlink()
    said: list[str] = []
    builds_before = len(fake_compiler)
    again = build(HEADER, NAME, cache, announce=said.append)
    assert _whole(again.path), corruption  # whatever happened, the simulator runs
    corrupt = corruption != "none"
    if corruption == "lock_is_folder":  # the entry was removed too: rebuilt, and the lock reported
        assert again.built and any("corrupt" in line for line in said)
    elif corrupt:
        assert again.built and len(fake_compiler) > builds_before, corruption
        assert any("is corrupt" in line and "rebuilding" in line for line in said), said
    else:  # whole: taken from the cache, nothing said (a legacy entry gains its checksum)
        assert not again.built and not [line for line in said if "corrupt" in line]
        assert checksum.is_file()
    assert all("\n" not in line for line in said)
    third = build(HEADER, NAME, cache)  # and the next run takes it from the cache
    assert not third.built and third.path == again.path
    assert os.access(third.path, os.X_OK)
