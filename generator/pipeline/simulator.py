"""A scene's simulator: ipsim compiled once, and the model as a small library (`ipgen run`).

ipsim's simulator (cpp/src/simulate.cpp with -DIPSIM_RUNTIME_MODEL, linked with SUNDIALS and
LAPACK) is compiled once per installation, compiler and flags: `<cache>/ipsim/<key>/ipsim-simulate`,
keyed by the compiler (its path and `--version`), the flags and every ipsim source; its
model-independent functions (cpp/src/ipsim_core.cpp) are compiled into `<cache>/ipsim-core/<key>/`
and linked into it, as into a program of one's own (`compiled_core`). A model is its C header and
the adapter to the C model interface (`--emit library`, cpp/include/ipgen_model.h), compiled by the
C compiler into `<cache>/models/<key>/libipgen_<name>.so` in about a second; the simulator loads it
at run time (named on its command line). `<cache>/simulators/<key>/simulate_<name>` is a two-line
launcher that runs the one with the other: the executable a caller runs as the model's simulator.

The flags are the Release build's (-O2 -DNDEBUG); $IPGEN_SIM_OPT (one of -O0, -O1, -O2, -O3, -Os,
-Og) replaces -O2, e.g. -Og in the test suite, where compile time matters and the run time of a
simulation does not. `<cache>` is `--cache-dir`, else $IPGEN_CACHE_DIR, else $XDG_CACHE_HOME/ipgen,
else ~/.cache/ipgen. Every entry is built under an exclusive lock per key, to a temporary name
renamed into place, with its SHA-256 recorded beside it; an entry found corrupt before use is
reported, removed and rebuilt (common/build_cache.py). Anchors for the design: acados and
CppADCodeGen (generated functions compiled into a small library, plugged into a core compiled
once), cmdstanpy's compiled-model cache.
"""

from __future__ import annotations

import functools
import hashlib
import os
import re
import shlex
import shutil
import subprocess
from collections.abc import Callable, Mapping
from pathlib import Path

from ipgen.common.build_cache import (
    Built,
    Recipe,
    cache_root,
    cached_build,
    last_error_line,
    required_compiler,
)
from ipgen.common.build_cache import c_compiler as build_cache_c_compiler
from ipgen.common.install import REINSTALL
from ipgen.common.locations import cmake_dir
from ipgen.common.safetext import shown_path
from ipgen.errors import Error

# The files of a model library job (`--emit library`), after the model's name.
LIBRARY_SUFFIXES = (".h", "_model.c")

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
# ipsim-core/ and linked into the simulator (cpp/include/ipsim/linkage.hpp).
CORE_SOURCE = "ipsim_core.cpp"
SEPARATE = "-DIPSIM_SEPARATE_COMPILATION"
CORE_OBJECT = "ipsim_core.o"
# The simulator compiled once: simulate.cpp over the model interface, loading a model at run time.
RUNTIME = "-DIPSIM_RUNTIME_MODEL"
PROGRAM = "ipsim-simulate"
MODEL_OPTION = "--model"  # the simulator's option naming the model library to load
# An ipsim-simulate built elsewhere (CMake's target ipsim_simulate, e.g. at -O3 -march=native), used
# instead of the cache's when set; it must be built from this installation's ipsim sources, which
# it tells by its DIGEST_OPTION (`sources_digest`, computed by cmake/ipgen.cmake alike).
SIMULATOR_VARIABLE = "IPGEN_SIMULATOR"
DIGEST_OPTION = "--sources-digest"
# The model library: C99, position-independent, only the model's symbol exported.
C_FLAGS = ("-std=c99", "-O2", "-shared", "-fPIC", "-fvisibility=hidden")
INTERFACE = "ipgen_model.h"
LOOP = "ipgen_loop.h"  # the loop runtime ipsim includes (sensors, swing-up)
MPC = "ipgen_mpc.h"  # the MPC step ipsim includes (ipsim/mpc.hpp): part of the simulator's key
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
    present = (source, source.with_name(CORE_SOURCE), include / "ipsim" / "ipsim.hpp", include / INTERFACE)
    if not all(path.is_file() for path in present):
        raise BuildError(f"the simulator's sources are missing from {shown_path(root)}: {REINSTALL}")
    return source, include


def compiler() -> str:
    """The C++ compiler: $CXX, else g++, else c++."""
    return required_compiler("CXX", ("g++", "c++"), "C++", "g++", BuildError)


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


def c_compiler() -> str:
    """The C compiler of the model libraries (build_cache.c_compiler: $CC, else cc, else gcc)."""
    return build_cache_c_compiler(BuildError)


def c_optimisation() -> tuple[str, ...]:
    """C_FLAGS with $IPGEN_SIM_OPT's level in place of -O2 (as `optimisation` for C++)."""
    level = optimisation()[1]
    return tuple(level if flag == "-O2" else flag for flag in C_FLAGS)


def compile_command(cc: str, entry: Path, name: str, library: Path) -> list[str]:
    """The C compiler call that builds the model library of `name` from the sources in `entry`
    (NAME.h and NAME_model.c, `--emit library`)."""
    _, include = simulator_sources()
    return [
        cc,
        *c_optimisation(),
        f"-I{include}",
        "-iquote",  # NAME.h for #include "NAME.h" only: a model named math or string hides no <math.h>
        str(entry),
        str(entry / f"{name}_model.c"),
        "-o",
        str(library),
        "-lm",
    ]


def program_command(cxx: str, output: Path, core: Path) -> list[str]:
    """The compiler call that builds ipsim's simulator, compiled once for every model, linking
    ipsim's compiled `core` (`core_command`)."""
    source, include = simulator_sources()
    flags = [*optimisation(), SEPARATE, RUNTIME, f"-I{include}", *_eigen_flags()]
    return [cxx, *flags, str(source), str(core), "-o", str(output), *LIBRARIES, "-ldl"]


def launcher_command(program: Path, library: Path, output: Path) -> list[str]:
    """A shell call that writes the launcher `output`, a script that runs `program` on the model
    `library` with the launcher's own arguments."""
    run = shlex.join([str(program), MODEL_OPTION, str(library)])
    text = f'#!/bin/sh\nexec {run} "$@"\n'
    return ["/bin/sh", "-c", 'printf "%s" "$1" > "$2" && chmod 755 "$2"', "sh", text, str(output)]


def core_command(cxx: str, output: Path) -> list[str]:
    """The compiler call that builds ipsim's model-independent functions into the object `output`."""
    source, include = simulator_sources()
    core = source.with_name(CORE_SOURCE)
    flags = [*optimisation(), SEPARATE, f"-I{include}", *_eigen_flags()]
    return [cxx, *flags, "-c", str(core), "-o", str(output)]


def ipsim_source_files() -> list[Path]:
    """Every file ipsim's compiled core and simulator are compiled from (besides Eigen, SUNDIALS,
    LAPACK): the order of `cache_key` and `sources_digest` (and of cmake/ipgen.cmake's digest)."""
    source, include = simulator_sources()
    return [
        source,
        source.with_name(CORE_SOURCE),
        include / INTERFACE,
        include / LOOP,
        include / MPC,
        *sorted((include / "ipsim").glob("*.hpp")),
    ]


def sources_digest() -> str:
    """SHA-256 (hex) of ipsim's sources as ipsim-simulate prints it (DIGEST_OPTION): of the
    text "NAME\nSHA256\n" per file of `ipsim_source_files` (cmake/ipgen.cmake computes the same
    at configure time and compiles it in)."""
    text = "".join(
        f"{path.name}\n{hashlib.sha256(path.read_bytes()).hexdigest()}\n" for path in ipsim_source_files()
    )
    return hashlib.sha256(text.encode()).hexdigest()


def external_program() -> Built | None:
    """The simulator $IPGEN_SIMULATOR names, checked to be an executable built from this
    installation's ipsim sources; None when the variable is unset or empty."""
    value = os.environ.get(SIMULATOR_VARIABLE, "").strip()
    if not value:
        return None
    path = Path(value)
    shown = f"{SIMULATOR_VARIABLE}={shown_path(path)}"
    unset = f"or unset {SIMULATOR_VARIABLE} (ipgen then compiles its own)"
    if not path.is_file() or not os.access(path, os.X_OK):
        raise BuildError(f"{shown} is not an executable file: build it (CMake target ipsim_simulate) {unset}")
    stat = path.stat()
    if _reported_digest(str(path.resolve()), stat.st_mtime_ns, stat.st_size) != sources_digest():
        raise BuildError(
            f"{shown} was not built from this ipgen's ipsim sources: rebuild it (CMake target "
            f"ipsim_simulate of this checkout or installation) {unset}"
        )
    return Built(path.resolve(), built=False, seconds=0.0)


@functools.lru_cache(maxsize=8)
def _reported_digest(program: str, mtime_ns: int, size: int) -> str | None:
    """What `program` prints for DIGEST_OPTION (None if it fails): asked once per process for a
    program file as it is (its time and size in the key), not at every run of a sweep."""
    try:
        done = subprocess.run([program, DIGEST_OPTION], capture_output=True, text=True, timeout=60)
    except (OSError, subprocess.TimeoutExpired, UnicodeDecodeError):
        return None
    return done.stdout.strip() if done.returncode == 0 else None


def cache_key(cxx: str, header_text: str, version: str | None = None) -> str:
    """SHA-256 (hex, 24 digits) of everything ipsim's compiled core and simulator depend on, for
    the compiler `cxx` (`version`: its `--version` output, asked here unless given) and these
    flags; with `header_text`, of that too (what a program built on the core also compiles)."""
    digest = hashlib.sha256()
    if version is None:
        version = compiler_version(cxx)
    for part in (shutil.which(cxx) or cxx, version, " ".join(optimisation() + LIBRARIES), header_text):
        digest.update(part.encode() + b"\0")
    for path in ipsim_source_files():
        digest.update(path.name.encode() + b"\0" + path.read_bytes() + b"\0")
    return digest.hexdigest()[:24]


def library_key(cc: str, sources: Mapping[str, str], version: str) -> str:
    """SHA-256 (hex, 24 digits) of a model library's sources, the interface, the C compiler and flags."""
    _, include = simulator_sources()
    digest = hashlib.sha256()
    for part in (
        shutil.which(cc) or cc,
        version,
        " ".join(c_optimisation()),
        (include / INTERFACE).read_text(),
    ):
        digest.update(part.encode() + b"\0")
    for name in sorted(sources):
        digest.update(name.encode() + b"\0" + sources[name].encode() + b"\0")
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


def model_sources(folder: Path, name: str) -> dict[str, str]:
    """The model library's sources that a `library` job wrote into `folder`: NAME.h, NAME_model.c."""
    return {f"{name}{suffix}": (folder / f"{name}{suffix}").read_text() for suffix in LIBRARY_SUFFIXES}


def build(
    sources: Mapping[str, str],
    name: str,
    cache: Path | None = None,
    announce: Callable[[str], None] = lambda message: None,
) -> Simulator:
    """The simulator of the model `name` whose library sources are `sources` (`model_sources`):
    ipsim's simulator (compiled once), the model's library and their launcher, from the cache or
    built into it (calling `announce` with a progress line first). `built` and `seconds` tell
    whether and how long this call compiled the model's library (or the simulator, once)."""
    program = external_program()
    if program is None:
        cxx = compiler()
        program = compiled_program(cache, announce, cxx, compiler_version(cxx))
    cc = c_compiler()
    recipe = Recipe(
        sources=dict(sources),
        command=lambda entry, output: compile_command(cc, entry, name, output),
        error=BuildError,
        failed=_failed,
        what=f"the model library of {name}",
        noun="model library",
    )
    library = cached_build(
        cache_root(cache) / "models",
        library_key(cc, sources, compiler_version(cc)),
        f"libipgen_{name}.so",
        recipe,
        announce,
    )
    launcher = Recipe(
        sources={},
        command=lambda entry, output: launcher_command(program.path, library.path, output),
        error=BuildError,
        failed=_failed,
        what=f"the simulator of {name}",
        noun="simulator",
    )
    digest = hashlib.sha256(f"{program.path}\0{library.path}".encode()).hexdigest()[:24]
    ran = cached_build(cache_root(cache) / "simulators", digest, f"simulate_{name}", launcher)
    seconds = program.seconds + library.seconds
    return Built(ran.path, built=program.built or library.built, seconds=seconds)


def compiled_core(cache: Path | None = None, announce: Callable[[str], None] = lambda message: None) -> Path:
    """The object file of ipsim's model-independent code for this compiler and
    `optimisation()`'s flags, from the cache or compiled into it: a program of one's own that
    includes ipsim with `-DIPSIM_SEPARATE_COMPILATION` and these flags links it instead of
    compiling that code again."""
    cxx = compiler()
    return _core(cxx, compiler_version(cxx), cache, announce).path


def compiled_program(
    cache: Path | None = None,
    announce: Callable[[str], None] = lambda message: None,
    cxx: str | None = None,
    version: str | None = None,
) -> Built:
    """ipsim's simulator compiled once for every model (it loads the model library its command
    line names),
    for this compiler and `optimisation()`'s flags: from the cache, or compiled into it."""
    cxx = cxx or compiler()
    version = version if version is not None else compiler_version(cxx)
    core = _core(cxx, version, cache, announce)
    recipe = Recipe(
        sources={},
        command=lambda entry, output: program_command(cxx, output, core.path),
        error=BuildError,
        failed=_failed,
        what="ipsim's simulator (once for every model)",
        noun="simulator",
        legacy_whole=_answers_help,
    )
    built = cached_build(
        cache_root(cache) / "ipsim", cache_key(cxx, RUNTIME, version), PROGRAM, recipe, announce
    )
    if core.built:
        return Built(built.path, built=True, seconds=built.seconds + core.seconds)
    return built


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
