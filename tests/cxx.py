"""The C++ toolchain every compiling test uses: one compiler, one set of flags, one Eigen.

CXX (default g++) and EIGEN3_INCLUDE_DIR (default /usr/include/eigen3) choose them. A missing
compiler or Eigen fails the tests that compile; set IPGEN_ALLOW_NO_CXX=1 to skip them instead
(for a machine that only works on the Python side).
"""

from __future__ import annotations

import fcntl
import functools
import hashlib
import os
import shutil
import subprocess
from pathlib import Path

import pytest

CXX = os.environ.get("CXX", "g++")
EIGEN_INCLUDE = Path(os.environ.get("EIGEN3_INCLUDE_DIR", "/usr/include/eigen3"))
WARNINGS = ("-Wall", "-Wextra", "-Wpedantic", "-Werror")
ALLOW_NO_CXX = "IPGEN_ALLOW_NO_CXX"


def cxx_command(*arguments: str, optimisation: str = "-Og", precompiled: bool = True) -> tuple[str, ...]:
    """The compiler, C++17, all warnings as errors, Eigen on the (system) include path, Eigen
    precompiled (`eigen_pch`; `precompiled=False`: not, e.g. to check that a header includes what
    it uses), then `arguments`."""
    flags = (CXX, "-std=c++17", optimisation, *WARNINGS, "-isystem", str(EIGEN_INCLUDE))
    pch = eigen_pch(flags) if precompiled else None
    return (*flags, *(("-include", str(pch)) if pch is not None else ()), *arguments)


# What the precompiled header holds: what every generated C++ header includes first. A program
# that includes Eigen itself is the same program with it (the header is include-guarded); one that
# does not gets Eigen's declarations it never uses.
PCH_TEXT = "#include <Eigen/Dense>\n"


# Eigen's version macros: gcc does not check that a .gch's headers are unchanged, so another Eigen
# at the same path must give another key (else the tests compile against the old one's .gch).
EIGEN_VERSION_FILE = Path("Eigen", "src", "Core", "util", "Macros.h")


def pch_key(flags: tuple[str, ...]) -> str:
    """The precompiled header's cache key: `flags`, the compiler's version, Eigen's version
    header (`EIGEN_VERSION_FILE` under the include path of `flags`, absent: empty) and `PCH_TEXT`."""
    version = subprocess.run([CXX, "--version"], capture_output=True, text=True).stdout
    include = Path(flags[flags.index("-isystem") + 1]) if "-isystem" in flags else EIGEN_INCLUDE
    try:
        eigen = (include / EIGEN_VERSION_FILE).read_text(errors="replace")
    except OSError:
        eigen = ""
    return hashlib.sha256("\0".join((*flags, version, eigen, PCH_TEXT)).encode()).hexdigest()[:24]


@functools.cache
def eigen_pch(flags: tuple[str, ...]) -> Path | None:
    """`<cache>/eigen-pch/<key>/eigen.hpp`, with `eigen.hpp.gch` beside it compiled by `flags`
    (`pch_key`: them, the compiler's and Eigen's versions; once per run for both xdist workers,
    under a lock), or None where it cannot be built (the compile then parses Eigen as before).

    Parsing Eigen is about 0.9 s of each test program's 1.3-3 s of compiler time (2026-11-29).
    gcc takes the .gch only for a compile with the same -O level and no macro that Eigen reads
    defined differently (e.g. -DNDEBUG); any other compile reads eigen.hpp as text: the same
    program, without the saving."""
    cache = os.environ.get("IPGEN_CACHE_DIR")
    if not cache or os.environ.get("IPGEN_TEST_PCH") == "0":
        return None
    if shutil.which(flags[0]) is None:  # no compiler: the compile reports it (or require_toolchain)
        return None
    entry = Path(cache) / "eigen-pch" / pch_key(flags)
    header, compiled = entry / "eigen.hpp", entry / "eigen.hpp.gch"
    entry.mkdir(parents=True, exist_ok=True)
    with (entry / "lock").open("a") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)  # released when the file closes
        if not compiled.is_file():
            header.write_text(PCH_TEXT)
            partial = entry / f".eigen.hpp.gch.{os.getpid()}"
            command = [*flags, "-x", "c++-header", str(header), "-o", str(partial)]
            done = subprocess.run(command, capture_output=True)
            if done.returncode != 0:
                partial.unlink(missing_ok=True)
                return None
            os.replace(partial, compiled)
    return header


def missing_toolchain() -> str | None:
    """Why the C++ checks cannot run here, or None."""
    if shutil.which(CXX) is None:
        return f"no C++ compiler {CXX!r} on PATH (set CXX)"
    if not (EIGEN_INCLUDE / "Eigen" / "Dense").is_file():
        return f"Eigen not found in {EIGEN_INCLUDE} (set EIGEN3_INCLUDE_DIR)"
    return None


def require_toolchain() -> None:
    """Fail (or skip, with IPGEN_ALLOW_NO_CXX=1) when the compiler or Eigen is missing."""
    problem = missing_toolchain()
    if problem is None:
        return
    if os.environ.get(ALLOW_NO_CXX) == "1":
        pytest.skip(f"{problem}; skipped because {ALLOW_NO_CXX}=1")
    pytest.fail(f"{problem}; set {ALLOW_NO_CXX}=1 to skip the C++ checks instead", pytrace=False)


IPSIM_CORE = "IPGEN_TEST_IPSIM_CORE"


def ipsim_core() -> Path:
    """ipsim's compiled core for a test's own ipsim program: the one $IPGEN_TEST_IPSIM_CORE names
    (the Makefile's: the CMake build's libipgen_ipsim_core.a, built from the same sources with the
    tests' -Og -DNDEBUG), else the run's simulator cache's (compiled there on first use)."""
    from ipgen.pipeline.simulator import compiled_core

    named = os.environ.get(IPSIM_CORE, "").strip()
    if named:
        if not Path(named).is_file():
            pytest.fail(f"{IPSIM_CORE}={named} is not a file: build it (CMake target ipgen_ipsim_core)")
        return Path(named)
    return compiled_core()
