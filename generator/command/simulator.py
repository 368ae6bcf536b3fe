"""A scene's simulator, compiled once per model content and cached (`ipgen run`).

The simulator is cpp/src/simulate.cpp built against the model's generated header and the
header-only ipsim library (cpp/include, installed with the package), linked with SUNDIALS and
LAPACK: the same sources and libraries CMake's `ipgen_add_simulator` uses, compiled here by one
direct compiler call (no CMake project to configure, which takes longer than the compile's
link step). The flags are the Release build's (-O2 -DNDEBUG); $IPGEN_SIM_OPT (one of -O0, -O1,
-O2, -O3, -Os, -Og) replaces -O2, e.g. -O1 in the test suite, where compile time matters and the
run time of a simulation does not (docs/testing.md has the compile times measured).

Cache: `<cache>/simulators/<key>/simulate_<name>`, where the key is a SHA-256 over the generated
header, simulate.cpp and every ipsim header, the compiler (its path and `--version`) and the
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

import contextlib
import fcntl
import hashlib
import os
import re
import shlex
import shutil
import subprocess
import tempfile
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path

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


@dataclass(frozen=True)
class Simulator:
    """A compiled simulator: its executable and whether this call built it (and how long it took)."""

    path: Path
    built: bool
    seconds: float = 0.0


def cache_root(override: Path | None = None) -> Path:
    """The cache folder: `override`, $IPGEN_CACHE_DIR, $XDG_CACHE_HOME/ipgen or ~/.cache/ipgen."""
    if override is not None:
        return override
    if os.environ.get("IPGEN_CACHE_DIR"):
        return Path(os.environ["IPGEN_CACHE_DIR"])
    xdg = os.environ.get("XDG_CACHE_HOME")
    return Path(xdg) / "ipgen" if xdg else Path.home() / ".cache" / "ipgen"


def simulator_sources() -> tuple[Path, Path]:
    """(cpp/src/simulate.cpp, cpp/include) of this installation (package or checkout)."""
    root = cmake_dir().parent  # the installed package's folder ipgen/, or the checkout
    source, include = root / "cpp" / "src" / "simulate.cpp", root / "cpp" / "include"
    if not source.is_file() or not (include / "ipsim" / "ipsim.hpp").is_file():
        raise BuildError(f"the simulator's sources are missing from {shown_path(root)}: reinstall ipgen")
    return source, include


def compiler() -> str:
    """The C++ compiler: $CXX, else g++, else c++."""
    wanted = os.environ.get("CXX") or next((c for c in ("g++", "c++") if shutil.which(c)), None)
    if wanted is None or shutil.which(wanted) is None:
        raise BuildError(
            "no C++ compiler found (tried $CXX, g++, c++): install one (Debian: apt-get install g++)"
        )
    return wanted


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


def compile_command(cxx: str, header: Path, name: str, binary: Path) -> list[str]:
    """The compiler call that builds simulate.cpp for the model `name` in `header`."""
    source, include = simulator_sources()
    return [
        cxx,
        *optimisation(),
        f"-I{include}",
        f"-I{header.parent}",
        *_eigen_flags(),
        f'-DIPGEN_MODEL_HEADER="{header.name}"',
        f"-DIPGEN_MODEL=ipgen::{name}::Model",
        str(source),
        "-o",
        str(binary),
        *LIBRARIES,
    ]


def cache_key(cxx: str, header_text: str) -> str:
    """SHA-256 (hex, 24 digits) of everything the binary depends on."""
    source, include = simulator_sources()
    digest = hashlib.sha256()
    version = subprocess.run([cxx, "--version"], capture_output=True, text=True).stdout
    for part in (shutil.which(cxx) or cxx, version, " ".join(optimisation() + LIBRARIES), header_text):
        digest.update(part.encode() + b"\0")
    for path in [source, *sorted((include / "ipsim").glob("*.hpp"))]:
        digest.update(path.name.encode() + b"\0" + path.read_bytes() + b"\0")
    return digest.hexdigest()[:24]


@contextlib.contextmanager
def locked(path: Path) -> Iterator[None]:
    """An exclusive lock on the file `path` (created) while the block runs: one build per cache entry."""
    with path.open("a") as handle:
        fcntl.flock(handle, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(handle, fcntl.LOCK_UN)


def _missing_package(output: str) -> str | None:
    for pattern, package in MISSING_PACKAGES:
        if pattern.search(output):
            return package
    return None


# A cache entry is checked before use: it is corrupt when it is a file, its simulator is not a
# regular file, or the simulator's SHA-256 differs from the one recorded beside it when it was
# built (a truncated or altered binary); an entry from before the checksums must answer --help.
MISSING = "missing"


def checksum_path(binary: Path) -> Path:
    """Where the binary's SHA-256 is recorded: a hidden file beside it (not a `simulate_*`)."""
    return binary.with_name(f".{binary.name}.sha256")


def _sha256(path: Path) -> str:
    digest = hashlib.sha256()
    with path.open("rb") as handle:
        for block in iter(lambda: handle.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def _write_checksum(binary: Path, target: Path) -> None:
    """The SHA-256 of `binary` into `target` (temporary file, then rename)."""
    partial = target.with_name(f".{target.name}.{os.getpid()}")
    partial.write_text(_sha256(binary) + "\n")
    os.replace(partial, target)


def _cache_problem(entry: Path, binary: Path) -> str | None:
    """What is wrong with the cache entry (module comment above): None if its simulator is whole,
    MISSING if there is none yet, else the corruption in words."""
    try:
        if not entry.exists() and not entry.is_symlink():
            return MISSING
        if not entry.is_dir():
            return "the entry is a file, not a folder"
        if not binary.exists():
            return MISSING
        if not binary.is_file():
            return "the simulator is not a regular file"
        checksum = checksum_path(binary)
        if checksum.exists():
            recorded = checksum.read_text().strip() if checksum.is_file() else ""
            if recorded != _sha256(binary):
                return "the simulator's checksum does not match: a truncated or altered file"
            return None
    except (OSError, UnicodeDecodeError) as e:
        return f"unreadable: {e.strerror if isinstance(e, OSError) else e}"
    try:  # an entry built before checksums were recorded: whole if it runs
        done = subprocess.run([str(binary), "--help"], capture_output=True, text=True, timeout=60)
    except (OSError, subprocess.TimeoutExpired, UnicodeDecodeError):
        return "the simulator does not run"
    if done.returncode != 0 or "usage: simulate" not in done.stdout:
        return "the simulator does not run"
    with contextlib.suppress(OSError):
        _write_checksum(binary, checksum_path(binary))
    return None


def _remove_corrupt(
    path: Path, problem: str, announce: Callable[[str], None], fine: Callable[[Path], bool]
) -> None:
    """Remove the corrupt cache `path` (unless it does not exist or `fine(path)`), saying so."""
    if not (path.exists() or path.is_symlink()) or fine(path):
        return
    announce(f"the cached simulator {shown_path(path)} is corrupt ({problem}): removing it and rebuilding")
    try:
        if path.is_dir() and not path.is_symlink():
            shutil.rmtree(path)
        else:
            path.unlink()
    except OSError as e:
        raise BuildError(
            f"the cache entry {shown_path(path)} is corrupt ({problem}) and cannot be removed "
            f"({e.strerror}): delete it, or pass --cache-dir"
        ) from e


def build(
    header_text: str,
    name: str,
    cache: Path | None = None,
    announce: Callable[[str], None] = lambda message: None,
) -> Simulator:
    """The simulator for the model `name` whose generated header is `header_text`: from the
    cache, or compiled into it (calling `announce` with a progress line first)."""
    import time

    cxx = compiler()
    key = cache_key(cxx, header_text)
    folder = cache_root(cache) / "simulators"
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise BuildError(
            f"cannot create the cache folder {shown_path(folder)}: {e.strerror}; pass --cache-dir"
        ) from e
    entry = folder / key
    binary = entry / f"simulate_{name}"
    if _cache_problem(entry, binary) is None:  # the common case, without taking the lock
        return Simulator(binary, built=False)
    lock = folder / f"{key}.lock"
    _remove_corrupt(lock, "its lock is a folder", announce, lambda path: not path.is_dir())
    with locked(lock):
        problem = _cache_problem(entry, binary)
        if problem is None:  # built by a concurrent run while we waited
            return Simulator(binary, built=False)
        if problem != MISSING:
            _remove_corrupt(entry, problem, announce, lambda path: False)
        entry.mkdir(exist_ok=True)
        header = entry / f"{name}.hpp"
        header.write_text(header_text)
        last = last_build(folder)
        history = f" (the last build in this cache took {last:.0f} s)" if last is not None else ""
        announce(f"building the simulator for model {name}{history}…")
        start = time.perf_counter()
        with tempfile.TemporaryDirectory(dir=entry, prefix=".build.") as scratch:
            partial = Path(scratch) / binary.name
            done = subprocess.run(compile_command(cxx, header, name, partial), capture_output=True, text=True)
            if done.returncode != 0:
                output = done.stdout + done.stderr
                package = _missing_package(output)
                if package is not None:
                    raise BuildError(
                        f"compiling the simulator failed: {package} is missing; install it "
                        f"(Debian: apt-get install {package})"
                    )
                last = next((line for line in reversed(output.splitlines()) if "error" in line), "")
                raise BuildError(f"compiling the simulator failed: {last.strip()[:300]}")
            _write_checksum(partial, checksum_path(binary))
            os.replace(partial, binary)
        (entry / "command.txt").write_text(shlex.join(compile_command(cxx, header, name, binary)) + "\n")
        seconds = time.perf_counter() - start
        _record_build(folder, seconds)
        return Simulator(binary, built=True, seconds=seconds)


LAST_BUILD = "last_build_seconds.txt"


def last_build(folder: Path) -> float | None:
    """How long the last simulator build in the cache folder `folder` took [s] (this machine's
    own history, shown before the next build), or None when there is none or it is unreadable."""
    try:
        seconds = float((folder / LAST_BUILD).read_text().split()[0])
    except (OSError, ValueError, IndexError):
        return None
    return seconds if seconds >= 0 and seconds < 1e6 else None


def _record_build(folder: Path, seconds: float) -> None:
    with contextlib.suppress(OSError):  # a history is a courtesy: never fail a build over it
        with tempfile.NamedTemporaryFile("w", dir=folder, prefix=".last_build.", delete=False) as handle:
            handle.write(f"{seconds:.3f}\n")
        os.replace(handle.name, folder / LAST_BUILD)
