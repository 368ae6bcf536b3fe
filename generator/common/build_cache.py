"""A content-keyed cache of compiled files: `ipgen run`'s simulators and ipgen.gym's kernels.

An entry is `<folder>/<key>/<target>`, the key a hash of everything the file depends on (the
caller's). An exclusive lock file per key (`<folder>/<key>.lock`) serialises concurrent builds
of one entry; the file is compiled to a temporary name and renamed, so no process sees half of
one, and its SHA-256 is recorded beside it (`.<target>.sha256`). An entry is checked before use:
it is corrupt when it is a file, its target is not a regular file, or the target's SHA-256
differs from the one recorded (a truncated or altered file); a corrupt entry is reported, removed
and rebuilt. The time of the last build is kept in `<folder>/last_build_seconds.txt` (a
courtesy shown before the next one). Anchors for the design: cmdstanpy's compiled-model cache
and PyTorch's `torch.utils.cpp_extension.load` (a content hash naming a build folder, guarded by
a lock).
"""

from __future__ import annotations

import contextlib
import contextvars
import fcntl
import hashlib
import os
import shlex
import shutil
import subprocess
import tempfile
import time
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path

from ipgen.common.safetext import shown_path
from ipgen.errors import Error

MISSING = "missing"
LAST_BUILD = "last_build_seconds.txt"
NO_CACHE_HINT = "pass --cache-dir or set IPGEN_CACHE_DIR"

# The cache folder a command was given (`--cache-dir`, `run_scene(cache=)`) while it runs: what it
# builds on the way (the MPC's and the loop's runtime libraries, the model library) goes there too.
_COMMAND_CACHE: contextvars.ContextVar[Path | None] = contextvars.ContextVar("ipgen_cache", default=None)


class CacheError(Error):
    """ipgen's cache folder cannot be found or written (one line naming --cache-dir)."""


@dataclass(frozen=True)
class Built:
    """A compiled file of the cache, and whether this call built it (and how long it took)."""

    path: Path
    built: bool
    seconds: float = 0.0


@dataclass(frozen=True)
class Recipe:
    """How to build one entry: its sources (file name → text, written into the entry), the
    compiler call that writes the target to a given path, and the messages of a failure."""

    sources: Mapping[str, str]
    command: Callable[[Path, Path], list[str]]  # (entry folder, output path) -> argv
    error: type[Exception]  # raised with a one-line message
    failed: Callable[[str], str]  # the compiler's output -> the one-line message
    what: str  # "the simulator for model rotary1": in the progress line
    noun: str = "file"  # "simulator": in the messages about a corrupt entry
    legacy_whole: Callable[[Path], bool] | None = None  # a target without a checksum: usable?


def chosen_compiler(variable: str, candidates: tuple[str, ...]) -> str | None:
    """The compiler a build uses: $`variable` if set, else the first of `candidates` on PATH;
    None when that is not on PATH (the caller says what to install)."""
    wanted = os.environ.get(variable) or next((c for c in candidates if shutil.which(c)), None)
    return wanted if wanted is not None and shutil.which(wanted) is not None else None


def required_compiler(
    variable: str, candidates: tuple[str, ...], language: str, package: str, error: type[Exception]
) -> str:
    """`chosen_compiler`, or `error` with one line naming what was tried and the Debian package."""
    found = chosen_compiler(variable, candidates)
    given = os.environ.get(variable)
    if found is None and given and len(given.split()) > 1:  # "gcc -O2", "ccache gcc"
        raise error(
            f"${variable} = {given!r} is not a program on PATH: set {variable} to the compiler alone "
            f"(e.g. {variable}={candidates[0]}; its flags are ipgen's), or unset it"
        )
    if found is None and given:
        raise error(
            f"no {language} compiler found: ${variable} = {given!r} is not on PATH; install one (Debian: "
            f"apt-get install {package}) or unset {variable}"
        )
    if found is None:
        tried = ", ".join((f"${variable}", *candidates))
        raise error(
            f"no {language} compiler found (tried {tried}): install one (Debian: apt-get install {package})"
        )
    return found


def c_compiler(error: type[Exception]) -> str:
    """The C compiler of what ipgen compiles in C (model libraries, ipgen.gym's kernels): $CC,
    else cc, else gcc; `error` when there is none."""
    return required_compiler("CC", ("cc", "gcc"), "C", "gcc", error)


def compiler_key(compiler: str, *parts: str) -> str:
    """SHA-256 (hex, 24 digits) of a C compiler (its path and `--version`) and `parts` (the flags,
    the sources): the cache key of what it compiles (the loop library, ipgen.gym's kernels)."""
    version = subprocess.run([compiler, "--version"], capture_output=True, text=True).stdout
    digest = hashlib.sha256()
    for part in (shutil.which(compiler) or compiler, version, *parts):
        digest.update(part.encode() + b"\0")
    return digest.hexdigest()[:24]


def cache_root(override: Path | None = None) -> Path:
    """The cache folder, absolute (a launcher that names it runs from any folder): `override`, the
    running command's (`cache_folder`), $IPGEN_CACHE_DIR, $XDG_CACHE_HOME/ipgen or ~/.cache/ipgen.
    `CacheError` when none is set and there is no home folder (a user without one)."""
    chosen = override if override is not None else _COMMAND_CACHE.get()
    if chosen is not None:
        return Path(chosen).absolute()
    if os.environ.get("IPGEN_CACHE_DIR"):
        return Path(os.environ["IPGEN_CACHE_DIR"]).absolute()
    xdg = os.environ.get("XDG_CACHE_HOME")
    if xdg:
        return (Path(xdg) / "ipgen").absolute()
    try:
        return Path.home() / ".cache" / "ipgen"
    except RuntimeError:  # no $HOME and no entry in the password database
        raise CacheError(f"no home folder for ipgen's cache of compiled files: {NO_CACHE_HINT}") from None


@contextlib.contextmanager
def cache_folder(folder: Path | None) -> Iterator[None]:
    """While the block runs, `cache_root()` is `folder` (None: unchanged): a command's cache for
    everything built on its way, not only its simulator."""
    token = _COMMAND_CACHE.set(_COMMAND_CACHE.get() if folder is None else Path(folder).absolute())
    try:
        yield
    finally:
        _COMMAND_CACHE.reset(token)


@contextlib.contextmanager
def locked(path: Path) -> Iterator[None]:
    """An exclusive lock on the file `path` (created) while the block runs: one build per entry."""
    with path.open("a") as handle:
        fcntl.flock(handle, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(handle, fcntl.LOCK_UN)


def checksum_path(target: Path) -> Path:
    """Where the target's SHA-256 is recorded: a hidden file beside it."""
    return target.with_name(f".{target.name}.sha256")


def _sha256(path: Path) -> str:
    digest = hashlib.sha256()
    with path.open("rb") as handle:
        for block in iter(lambda: handle.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def _write_checksum(target: Path, record: Path) -> None:
    """The SHA-256 of `target` into `record` (temporary file, then rename)."""
    partial = record.with_name(f".{record.name}.{os.getpid()}")
    partial.write_text(_sha256(target) + "\n")
    os.replace(partial, record)


def cache_problem(
    entry: Path, target: Path, legacy_whole: Callable[[Path], bool] | None = None, noun: str = "file"
) -> str | None:
    """What is wrong with the entry (module comment): None if its target is whole, MISSING if
    there is none yet, else the corruption in words. A target without a recorded checksum (built
    before checksums were) is whole when `legacy_whole` says so, and then gets its checksum."""
    try:
        if not entry.exists() and not entry.is_symlink():
            return MISSING
        if not entry.is_dir():
            return "the entry is a file, not a folder"
        if not target.exists():
            return MISSING
        if not target.is_file():
            return f"the {noun} is not a regular file"
        checksum = checksum_path(target)
        if checksum.exists():
            recorded = checksum.read_text().strip() if checksum.is_file() else ""
            if recorded != _sha256(target):
                return f"the {noun}'s checksum does not match: a truncated or altered file"
            return None
    except (OSError, UnicodeDecodeError) as e:
        return f"unreadable: {e.strerror if isinstance(e, OSError) else e}"
    if legacy_whole is None or not legacy_whole(target):
        return f"the {noun} does not run"
    with contextlib.suppress(OSError):
        _write_checksum(target, checksum_path(target))
    return None


def _remove_corrupt(
    path: Path, problem: str, announce: Callable[[str], None], recipe: Recipe, fine: Callable[[Path], bool]
) -> None:
    """Remove the corrupt cache `path` (unless it does not exist or `fine(path)`), saying so."""
    if not (path.exists() or path.is_symlink()) or fine(path):
        return
    shown = shown_path(path)
    announce(f"the cached {recipe.noun} {shown} is corrupt ({problem}): removing it and rebuilding")
    try:
        if path.is_dir() and not path.is_symlink():
            shutil.rmtree(path)
        else:
            path.unlink()
    except OSError as e:
        raise recipe.error(
            f"the cache entry {shown_path(path)} is corrupt ({problem}) and cannot be removed "
            f"({e.strerror}): delete it, or pass --cache-dir"
        ) from e


def cached_build(
    folder: Path, key: str, target: str, recipe: Recipe, announce: Callable[[str], None] = lambda _: None
) -> Built:
    """`<folder>/<key>/<target>`: from the cache, or built into it by `recipe` (calling
    `announce` with a progress line first)."""
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise recipe.error(
            f"cannot create the cache folder {shown_path(folder)}: {e.strerror}; pass --cache-dir "
            "or set IPGEN_CACHE_DIR"
        ) from e
    entry = folder / key
    path = entry / target
    if cache_problem(entry, path, recipe.legacy_whole, recipe.noun) is None:  # the common case: no lock
        return Built(path, built=False)
    lock = folder / f"{key}.lock"
    _remove_corrupt(lock, "its lock is a folder", announce, recipe, lambda p: not p.is_dir())
    try:
        return _build_locked(folder, entry, path, lock, recipe, announce)
    except OSError as e:  # a shared or read-only cache without this entry, a full disk
        raise recipe.error(
            f"cannot write to the cache folder {shown_path(folder)} ({e.strerror}), which has no "
            f"{recipe.noun} for this yet: {NO_CACHE_HINT} (a folder of your own)"
        ) from e


def _build_locked(
    folder: Path, entry: Path, path: Path, lock: Path, recipe: Recipe, announce: Callable[[str], None]
) -> Built:
    """`cached_build`'s build under the entry's lock (another process may have built it meanwhile)."""
    target = path.name
    with locked(lock):
        problem = cache_problem(entry, path, recipe.legacy_whole, recipe.noun)
        if problem is None:  # built by a concurrent process while we waited
            return Built(path, built=False)
        if problem != MISSING:
            _remove_corrupt(entry, problem, announce, recipe, lambda p: False)
        entry.mkdir(exist_ok=True)
        for name, text in recipe.sources.items():
            (entry / name).write_text(text)
        last = last_build(folder)
        history = f" (the last build in this cache took {last:.0f} s)" if last is not None else ""
        announce(f"building {recipe.what}{history}…")
        start = time.perf_counter()
        with tempfile.TemporaryDirectory(dir=entry, prefix=".build.") as scratch:
            partial = Path(scratch) / target
            done = subprocess.run(recipe.command(entry, partial), capture_output=True, text=True)
            if done.returncode != 0:
                raise recipe.error(recipe.failed(done.stdout + done.stderr))
            _write_checksum(partial, checksum_path(path))
            os.replace(partial, path)
        (entry / "command.txt").write_text(shlex.join(recipe.command(entry, path)) + "\n")
        seconds = time.perf_counter() - start
        _record_build(folder, seconds)
        return Built(path, built=True, seconds=seconds)


def last_error_line(output: str) -> str:
    """The compiler's last line that mentions an error (or ""), shortened for a message."""
    return next((line for line in reversed(output.splitlines()) if "error" in line), "").strip()[:300]


def runtime_library(
    folder: str, sources: Mapping[str, str], glue: str, flags: tuple[str, ...], target: str,
    error: type[Exception], what: str, noun: str,
) -> Path:  # fmt: skip
    """A shared library of the C runtime (the loop's, the MPC's): `glue`, one of `sources` (name →
    text, which it includes), compiled with `flags` by the C compiler, from the cache
    `<cache>/<folder>/<key>/<target>` or compiled into it; the key is the compiler's, the flags'
    and every source's (`compiler_key`). `what` names it in messages ("the loop library
    (ipgen_loop.h)"), `noun` in the build announcement."""
    cc = c_compiler(error)
    recipe = Recipe(
        sources=dict(sources),
        command=lambda entry, out: [cc, *flags, f"-I{entry}", str(entry / glue), "-o", str(out), "-lm"],
        error=error,
        failed=lambda output: f"compiling {what} failed: {last_error_line(output)}",
        what=what,
        noun=noun,
    )
    key = compiler_key(cc, " ".join(flags), *(sources[name] for name in sorted(sources)))
    return cached_build(cache_root() / folder, key, target, recipe).path


def last_build(folder: Path) -> float | None:
    """How long the last build in the cache folder `folder` took [s] (this machine's own history,
    shown before the next build), or None when there is none or it is unreadable."""
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
