"""Shared fixtures: generated model headers compiled into the C++ test driver, once per session;
one simulator cache for the whole test run.

The simulators `ipgen run` compiles go into one cache for every test and every xdist worker:
$IPGEN_CACHE_DIR if it is set, else build/test-cache/ in the checkout (kept between runs, so a
second `make test` compiles none of them; `make clean` removes it). The cache is keyed by the
model's content and locks each key, so two workers that need one model compile it once. They are
compiled at -Og ($IPGEN_SIM_OPT, unless set): no test measures a simulator's speed, and the
compile takes a fifth to a third less than at -O1 and less still than at the users' -O2
(docs/testing.md).

`cpp_models` (session scope) generates each requested model's header with
`generate_header` into a temporary folder and compiles it into `tests/cpp/eval_model.cpp`.
Models with the same number of degrees of freedom are compiled together into one program
(Eigen is parsed and instantiated once for them), and the groups are built in parallel in
the background: a test waits only for the program it needs. The programs are kept in the run's
cache (<cache>/test-programs/<key>/, keyed by the flags, the compiler and the sources' text, one
lock per key): the xdist workers, which each have their own session, compile each program once.
The compiler, flags and Eigen come from tests/cxx.py: without them the fixture fails, unless
IPGEN_ALLOW_NO_CXX=1.
"""

from __future__ import annotations

import fcntl
import functools
import hashlib
import os
import shlex
import subprocess
from collections.abc import Iterable, Iterator
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import pytest
from cxx import CXX, cxx_command, require_toolchain

from ipgen.model.system import System
from ipgen.pipeline.generate import generate_header

CPP_DIR = Path(__file__).resolve().parent / "cpp"
ROOT = CPP_DIR.parents[1]
TEST_CACHE = ROOT / "build" / "test-cache"  # `ipgen run`'s simulators for every test (IPGEN_CACHE_DIR)
TEST_OPTIMISATION = "-Og"  # the simulators' optimisation level in the tests (IPGEN_SIM_OPT)


@functools.cache
def compiler_version() -> str:
    """`$CXX --version`: part of the key of the test programs cached across runs."""
    return subprocess.run([CXX, "--version"], capture_output=True, text=True).stdout


def shared_cache() -> Path:
    """The run's cache folder (set by pytest_configure)."""
    return Path(os.environ.get("IPGEN_CACHE_DIR") or TEST_CACHE)


def pytest_configure(config: pytest.Config) -> None:
    """One simulator cache and one optimisation level for the whole run, set before any test (and
    before xdist starts its workers, which inherit the environment). Set by the caller, they stay."""
    os.environ.setdefault("IPGEN_CACHE_DIR", str(TEST_CACHE))
    os.environ.setdefault("IPGEN_SIM_OPT", TEST_OPTIMISATION)
DRIVER = CPP_DIR / "eval_model.cpp"
STDERR_LINES = 40  # compiler output quoted in a failure message


def model_name(system: System) -> str:
    """The header's file and namespace name: classical3, rotary2_pivot, rotary2_full."""
    name = f"{system.type}{system.links}"
    return f"{name}_{system.inertia}" if system.is_rotary else name


@dataclass(frozen=True)
class Program:
    """A compiled driver holding one or more models, or why it failed to build."""

    executable: Path
    command: tuple[str, ...]
    error: str | None = None


def check_built(system: System, program: Program) -> None:
    if program.error is not None:
        pytest.fail(
            f"{model_name(system)}: the generated header does not compile into the test driver\n"
            f"$ {shlex.join(program.command)}\n{program.error}",
            pytrace=False,
        )


class CppModels:
    """Generated headers compiled into the test driver, built in the background."""

    def __init__(self, workdir: Path, jobs: int) -> None:
        self.workdir = workdir
        self.headers = workdir / "include"
        self.pool = ThreadPoolExecutor(max_workers=jobs)
        self.programs: dict[System, Future[dict[System, Program]]] = {}

    def submit(self, systems: Iterable[System]) -> None:
        """Generate and start compiling every model not requested before (grouped by dof)."""
        groups: dict[int, list[System]] = {}
        for system in systems:
            if system not in self.programs and system not in groups.get(system.dof, []):
                groups.setdefault(system.dof, []).append(system)
        for dof in sorted(groups):  # small programs first: their tests can start early
            members = groups[dof]
            for system in members:
                generate_header(system, model_name(system), self.headers, force=True)
            future = self.pool.submit(self._compile, f"dof{dof}_{len(self.programs)}", members)
            for system in members:
                self.programs[system] = future

    def program(self, system: System) -> Path:
        """The executable holding `system` (as `model_name(system)`); fails if it did not build."""
        if system not in self.programs:
            self.submit([system])
        program = self.programs[system].result()[system]
        check_built(system, program)
        return program.executable

    def _compile(self, label: str, members: list[System]) -> dict[System, Program]:
        """One program for all `members`; if that fails, each alone, to tell which header fails."""
        names = [model_name(system) for system in members]
        umbrella = self.workdir / f"{label}.hpp"
        umbrella.write_text("".join(f'#include "{name}.hpp"\n' for name in names))
        models = "-DIPGEN_MODELS=" + " ".join(f"X({name})" for name in names)
        headers = [umbrella, *(self.headers / f"{name}.hpp" for name in names)]
        program = self._build(self.workdir / label, f"{umbrella.name}", models, headers)
        if program.error is None or len(members) == 1:
            return dict.fromkeys(members, program)
        return {system: self.build_alone(system) for system in members}

    def build_alone(self, system: System) -> Program:
        """A program with `system` only, built with the driver's IPGEN_NAMESPACE macro."""
        name = model_name(system)
        if not (self.headers / f"{name}.hpp").is_file():
            generate_header(system, name, self.headers, force=True)
        header = self.headers / f"{name}.hpp"
        return self._build(self.workdir / f"{name}_alone", header.name, f"-DIPGEN_NAMESPACE={name}", [header])

    def _build(self, executable: Path, header: str, models: str, sources: list[Path]) -> Program:
        """Compile the driver with `header` (which includes `sources`), or take the program from the
        run's cache (another xdist worker may have built it): keyed by the command, the driver and
        the headers' contents, compiled under a lock, so the workers build each program once."""
        command = cxx_command(
            f"-I{self.workdir}",
            f"-I{self.headers}",
            f'-DIPGEN_HEADER="{header}"',
            models,
            str(DRIVER),
            "-o",
            str(executable),
            optimisation="-O2",
        )
        # The key: the flags (not the folders, the umbrella's name or the output), the compiler's
        # version, the driver and every header's text.
        flags = [part for part in command[:-3] if not part.startswith(("-I", "-DIPGEN_HEADER="))]
        digest = hashlib.sha256()
        for part in (*flags, compiler_version(), DRIVER.read_text(), *(path.read_text() for path in sources)):
            digest.update(part.encode() + b"\0")
        entry = shared_cache() / "test-programs" / digest.hexdigest()[:24]
        cached = entry / "program"
        entry.mkdir(parents=True, exist_ok=True)
        with (entry / "lock").open("a") as lock:
            fcntl.flock(lock, fcntl.LOCK_EX)  # released when the file closes
            if cached.is_file():  # built before, or by the other worker while this one waited
                return Program(cached, command)
            partial = entry / f".program.{os.getpid()}"
            result = subprocess.run([*command[:-1], str(partial)], capture_output=True, text=True)
            if result.returncode == 0:
                os.replace(partial, cached)
                return Program(cached, command)
            partial.unlink(missing_ok=True)
        lines = (result.stderr or result.stdout).splitlines()
        shown = "\n".join(lines[:STDERR_LINES])
        if len(lines) > STDERR_LINES:
            shown += f"\n... ({len(lines) - STDERR_LINES} more lines)"
        return Program(executable, command, f"exit status {result.returncode}\n{shown}")

    def close(self) -> None:
        self.pool.shutdown(wait=True, cancel_futures=True)


@pytest.fixture(scope="session")
def cpp_models(tmp_path_factory: pytest.TempPathFactory) -> Iterator[CppModels]:
    require_toolchain()
    models = CppModels(tmp_path_factory.mktemp("cpp_models"), jobs=max(1, os.cpu_count() or 1))
    yield models
    models.close()
