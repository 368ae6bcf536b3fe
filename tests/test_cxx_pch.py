"""tests/cxx.py's precompiled Eigen: its cache key follows the Eigen it was built from (gcc does
not check a .gch's headers, so a stale one would be used silently)."""

from __future__ import annotations

import subprocess
from pathlib import Path

import pytest
from cxx import CXX, EIGEN_VERSION_FILE, cxx_command, eigen_pch, pch_key, require_toolchain

from ipgen.command.cli import run


def _eigen(root: Path, minor: int) -> Path:
    macros = root / EIGEN_VERSION_FILE
    macros.parent.mkdir(parents=True, exist_ok=True)
    macros.write_text(f"#define EIGEN_WORLD_VERSION 3\n#define EIGEN_MAJOR_VERSION {minor}\n")
    return root


def test_another_eigen_at_the_same_path_is_another_key(tmp_path: Path) -> None:
    flags = (CXX, "-std=c++17", "-Og", "-isystem", str(tmp_path / "eigen"))
    _eigen(tmp_path / "eigen", 3)
    old = pch_key(flags)
    assert pch_key(flags) == old  # deterministic
    _eigen(tmp_path / "eigen", 4)
    assert pch_key(flags) != old
    assert pch_key((*flags[:2], "-O2", *flags[3:])) != pch_key(flags)


def test_no_cache_folder_or_pch_off_compiles_without_it(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("IPGEN_CACHE_DIR", raising=False)
    assert eigen_pch.__wrapped__((CXX, "-std=c++17")) is None
    monkeypatch.setenv("IPGEN_CACHE_DIR", "/nonexistent-never-created")
    monkeypatch.setenv("IPGEN_TEST_PCH", "0")
    assert eigen_pch.__wrapped__((CXX, "-std=c++17")) is None


def test_a_missing_compiler_builds_no_pch(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    """cxx_command of a compiler that is not there returns its command (the compile then says so),
    rather than raising while it keys the precompiled header."""
    monkeypatch.setenv("IPGEN_CACHE_DIR", str(tmp_path))
    monkeypatch.delenv("IPGEN_TEST_PCH", raising=False)
    assert eigen_pch.__wrapped__(("no-such-compiler-ipgen", "-std=c++17")) is None
    assert not (tmp_path / "eigen-pch").exists()


@pytest.mark.parametrize("system", [("rotary", 2), ("fixed", 2)])
def test_generated_headers_include_what_they_use_without_the_pch(
    tmp_path: Path, system: tuple[str, int]
) -> None:
    """The precompiled Eigen is force-included into the tests' programs, so it would hide a
    generated C++ header that forgot `#include <Eigen/Dense>`: each kind of header compiled alone,
    without it."""
    require_toolchain()
    kind, links = system
    name = f"{kind}{links}"
    assert run(["--type", kind, "--links", str(links), "--name", name, "-o", str(tmp_path)]) == 0
    source = tmp_path / "alone.cpp"
    source.write_text(f'#include "{name}.hpp"\nint main() {{ return 0; }}\n')
    command = cxx_command(f"-I{tmp_path}", "-fsyntax-only", str(source), precompiled=False)
    assert "-include" not in command
    done = subprocess.run(command, capture_output=True, text=True)
    assert done.returncode == 0, done.stderr[-2000:]
