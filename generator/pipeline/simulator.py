"""A scene's simulator, compiled once per model content and cached (`ipgen run`).

The simulator is cpp/src/simulate.cpp built against the model's generated header and the
ipsim library (cpp/include, installed with the package), linked with SUNDIALS and LAPACK: the
same sources and libraries CMake's `ipgen_add_simulator` uses, compiled here by direct compiler
calls (no CMake project to configure, which takes longer than the compile's link step). ipsim's
model-independent functions are compiled once per compiler and flags (cpp/src/ipsim_core.cpp,
cached in `<cache>/ipsim-core/<key>/ipsim_core.o`, keyed like a simulator without a header) and
linked into every simulator (`-DIPSIM_SEPARATE_COMPILATION`, cpp/include/ipsim/linkage.hpp).
The flags are the Release build's (-O2 -DNDEBUG); $IPGEN_SIM_OPT (one of -O0, -O1,
-O2, -O3, -Os, -Og) replaces -O2, e.g. -O1 in the test suite, where compile time matters and the
run time of a simulation does not (docs/testing.md has the compile times measured).

Cache: `<cache>/simulators/<key>/simulate_<name>`, where the key is a SHA-256 over the generated
header, simulate.cpp, ipsim_core.cpp and every ipsim header, the compiler (its path and `--version`) and the
flags, so a run with other initial conditions, inputs, settings or (unless the scene is
specialised) parameters reuses the binary, and any change of the model or the simulator's
sources builds a new one. `<cache>` is `--cache-dir`, else $IPGEN_CACHE_DIR, else
$XDG_CACHE_HOME/ipgen, else ~/.cache/ipgen. An exclusive lock file per key serialises concurrent
builds of one model; the binary is compiled to a temporary name and renamed, so a run never sees
half a binary, and its SHA-256 is recorded beside it (`.simulate_<name>.sha256`): an entry that is
checked corrupt before use (a truncated binary, an entry that is a file, a binary that is a
folder) is reported, removed and rebuilt. Anchors for the design: cmdstanpy's compiled-model
cache and PyTorch's `torch.utils.cpp_extension.load` (a content hash naming a build folder,
guarded by a lock).
"""

from __future__ import annotations

import hashlib
import os
import re
import shutil
import subprocess
from collections.abc import Callable
from pathlib import Path

from ipgen.common.build_cache import Built, Recipe, cache_root, cached_build, chosen_compiler, last_error_line
from ipgen.common.install import REINSTALL
from ipgen.common.locations import cmake_dir
from ipgen.common.safetext import shown_path
from ipgen.errors import Error

OPTIMISATION = ("-std=c++17", "-O2", "-DNDEBUG")
# $IPGEN_SIM_OPT: another optimisation level in place of OPTIMISATION's -O2 (part of the cache key).
OPT_VARIABLE = "IPGEN_SIM_OPT"
OPT_LEVELS = ("-O0", "-O1", "-O2", "-O3", "-Os", "-Og")
# The libraries of cmake/ipgen.cmake's ipgen::ipsim: SUNDIALS 6 (CVODE, ARKODE) and LAPACK.
LIBRARIES = (
    "-lsundials_cvode",
    "-lsundials_arkode",
    "-lsundials_nvecserial",
    "-lsundials_sunmatrixdense",
    "-lsundials_sunlinsoldense",
    "-lsundials_sunnonlinsolfixedpoint",
    "-llapack",
)
# ipsim's model-independent functions, compiled once per compiler and flags into the cache's
# ipsim-core/ and linked into every simulator (cpp/include/ipsim/linkage.hpp).
CORE_SOURCE = "ipsim_core.cpp"
SEPARATE = "-DIPSIM_SEPARATE_COMPILATION"
CORE_OBJECT = "ipsim_core.o"
EIGEN_INCLUDE = Path("/usr/include/eigen3")  # Debian's libeigen3-dev (else pkg-config eigen3)
# What a failed compile most likely lacks: (pattern in the compiler's output, Debian package).
MISSING_PACKAGES = (
    (re.compile(r"Eigen/\w+: No such file"), "libeigen3-dev"),
    (re.compile(r"(cvode|arkode|sundials|nvector|sunmatrix|sunlinsol|sunnonlinsol)/\S+: No such file"),
     "libsundials-dev"),
    (re.compile(r"cannot find -lsundials"), "libsundials-dev"),
    (re.compile(r"cannot find -llapack"), "liblapack-dev"),
)  # fmt: skip


class BuildError(Error):
    """The simulator could not be compiled; the message names the missing piece."""


# A compiled simulator: its executable and whether this call built it (and how long it took).
Simulator = Built


def simulator_sources() -> tuple[Path, Path]:
    """(cpp/src/simulate.cpp, cpp/include) of this installation (package or checkout)."""
    root = cmake_dir().parent  # the installed package's folder ipgen/, or the checkout
    source, include = root / "cpp" / "src" / "simulate.cpp", root / "cpp" / "include"
    present = (source, source.with_name(CORE_SOURCE), include / "ipsim" / "ipsim.hpp")
    if not all(path.is_file() for path in present):
        raise BuildError(f"the simulator's sources are missing from {shown_path(root)}: {REINSTALL}")
    return source, include


def compiler() -> str:
    """The C++ compiler: $CXX, else g++, else c++."""
    found = chosen_compiler("CXX", ("g++", "c++"))
    if found is None:
        raise BuildError(
            "no C++ compiler found (tried $CXX, g++, c++): install one (Debian: apt-get install g++)"
        )
    return found


def _eigen_flags() -> list[str]:
    if (EIGEN_INCLUDE / "Eigen" / "Core").is_file():
        return ["-isystem", str(EIGEN_INCLUDE)]
    if shutil.which("pkg-config"):
        found = subprocess.run(["pkg-config", "--cflags", "eigen3"], capture_output=True, text=True)
        if found.returncode == 0:
            return found.stdout.split()
    raise BuildError("Eigen 3 headers not found: install them (Debian: apt-get install libeigen3-dev)")


def optimisation() -> tuple[str, ...]:
    """OPTIMISATION with $IPGEN_SIM_OPT's level in place of -O2 when it is set (and not empty)."""
    level = os.environ.get(OPT_VARIABLE, "").strip()
    if not level:
        return OPTIMISATION
    if level not in OPT_LEVELS:
        raise BuildError(
            f"{OPT_VARIABLE}={level[:40]!r} is not an optimisation level: set it to one of "
            f"{', '.join(OPT_LEVELS)} or unset it (default -O2)"
        )
    return tuple(level if flag == "-O2" else flag for flag in OPTIMISATION)


def compile_command(cxx: str, header: Path, name: str, binary: Path, core: Path) -> list[str]:
    """The compiler call that builds simulate.cpp for the model `name` in `header`, linking
    ipsim's compiled `core` (`core_command`)."""
    source, include = simulator_sources()
    return [
        cxx,
        *optimisation(),
        SEPARATE,
        f"-I{include}",
        f"-I{header.parent}",
        *_eigen_flags(),
        f'-DIPGEN_MODEL_HEADER="{header.name}"',
        f"-DIPGEN_MODEL=ipgen::{name}::Model",
        str(source),
        str(core),
        "-o",
        str(binary),
        *LIBRARIES,
    ]


def core_command(cxx: str, output: Path) -> list[str]:
    """The compiler call that builds ipsim's model-independent functions into the object `output`."""
    source, include = simulator_sources()
    core = source.with_name(CORE_SOURCE)
    flags = [*optimisation(), SEPARATE, f"-I{include}", *_eigen_flags()]
    return [cxx, *flags, "-c", str(core), "-o", str(output)]


def cache_key(cxx: str, header_text: str, version: str | None = None) -> str:
    """SHA-256 (hex, 24 digits) of everything the binary depends on (with `header_text` empty:
    everything ipsim's compiled core depends on); `version`: `cxx --version`'s output, asked
    here unless given."""
    source, include = simulator_sources()
    digest = hashlib.sha256()
    if version is None:
        version = compiler_version(cxx)
    for part in (shutil.which(cxx) or cxx, version, " ".join(optimisation() + LIBRARIES), header_text):
        digest.update(part.encode() + b"\0")
    for path in [source, source.with_name(CORE_SOURCE), *sorted((include / "ipsim").glob("*.hpp"))]:
        digest.update(path.name.encode() + b"\0" + path.read_bytes() + b"\0")
    return digest.hexdigest()[:24]


def compiler_version(cxx: str) -> str:
    """`cxx --version`'s output: part of every cache key (another compiler, another binary)."""
    return subprocess.run([cxx, "--version"], capture_output=True, text=True).stdout


def _missing_package(output: str) -> str | None:
    for pattern, package in MISSING_PACKAGES:
        if pattern.search(output):
            return package
    return None


def _failed(output: str) -> str:
    """The one-line message of a failed compile: the missing Debian package, else the error."""
    package = _missing_package(output)
    if package is not None:
        missing = f"compiling the simulator failed: {package} is missing"
        return f"{missing}; install it (Debian: apt-get install {package})"
    return f"compiling the simulator failed: {last_error_line(output)}"


def _answers_help(binary: Path) -> bool:
    """Whether `binary` runs as a simulator (an entry from before the checksums were recorded)."""
    try:
        done = subprocess.run([str(binary), "--help"], capture_output=True, text=True, timeout=60)
    except (OSError, subprocess.TimeoutExpired, UnicodeDecodeError):
        return False
    return done.returncode == 0 and "usage: simulate" in done.stdout


def build(
    header_text: str,
    name: str,
    cache: Path | None = None,
    announce: Callable[[str], None] = lambda message: None,
) -> Simulator:
    """The simulator for the model `name` whose generated header is `header_text`: from the
    cache, or compiled into it (calling `announce` with a progress line first)."""
    cxx = compiler()
    version = compiler_version(cxx)  # asked once for both keys
    core = _core(cxx, version, cache, announce).path
    recipe = Recipe(
        sources={f"{name}.hpp": header_text},
        command=lambda entry, binary: compile_command(cxx, entry / f"{name}.hpp", name, binary, core),
        error=BuildError,
        failed=_failed,
        what=f"the simulator for model {name}",
        noun="simulator",
        legacy_whole=_answers_help,
    )
    folder = cache_root(cache) / "simulators"
    return cached_build(folder, cache_key(cxx, header_text, version), f"simulate_{name}", recipe, announce)


def compiled_core(cache: Path | None = None, announce: Callable[[str], None] = lambda message: None) -> Path:
    """The object file of ipsim's model-independent code for this compiler and
    `optimisation()`'s flags, from the cache or compiled into it: a program of one's own that
    includes ipsim with `-DIPSIM_SEPARATE_COMPILATION` and these flags links it instead of
    compiling that code again."""
    cxx = compiler()
    return _core(cxx, compiler_version(cxx), cache, announce).path


def _core(cxx: str, version: str, cache: Path | None, announce: Callable[[str], None]) -> Built:
    """ipsim's compiled core for this compiler and these flags: from the cache, or compiled into it."""
    recipe = Recipe(
        sources={},
        command=lambda entry, output: core_command(cxx, output),
        error=BuildError,
        failed=_failed,
        what="ipsim's model-independent code (once for all models)",
        noun="compiled core",
    )
    folder = cache_root(cache) / "ipsim-core"
    return cached_build(folder, cache_key(cxx, "", version), CORE_OBJECT, recipe, announce)
