"""The C++ toolchain every compiling test uses: one compiler, one set of flags, one Eigen.

CXX (default g++) and EIGEN3_INCLUDE_DIR (default /usr/include/eigen3) choose them. A missing
compiler or Eigen fails the tests that compile; set IPGEN_ALLOW_NO_CXX=1 to skip them instead
(for a machine that only works on the Python side).
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import pytest

CXX = os.environ.get("CXX", "g++")
EIGEN_INCLUDE = Path(os.environ.get("EIGEN3_INCLUDE_DIR", "/usr/include/eigen3"))
WARNINGS = ("-Wall", "-Wextra", "-Wpedantic", "-Werror")
ALLOW_NO_CXX = "IPGEN_ALLOW_NO_CXX"


def cxx_command(*arguments: str, optimisation: str = "-Og") -> tuple[str, ...]:
    """The compiler, C++17, all warnings as errors, Eigen on the include path, then `arguments`."""
    return (CXX, "-std=c++17", optimisation, *WARNINGS, f"-I{EIGEN_INCLUDE}", *arguments)


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
