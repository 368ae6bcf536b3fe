"""Generated C headers (`--emit c`) compiled into tests/c/eval_model.c, and how to run them.

Every header is compiled twice with `gcc -std=c99 -Wall -Wextra -Wpedantic -Werror`: in double
precision, and with `-DIPGEN_SCALAR=float -Wdouble-promotion -Wconversion` (float mode must
not promote to double or convert silently). The builds run in the background, one program per
header and precision; a test waits only for the one it needs.
"""

from __future__ import annotations

import os
import shlex
import shutil
import subprocess
from collections.abc import Sequence
from concurrent.futures import Future, ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pytest
from conftest import model_name

from ipgen.model.system import System
from ipgen.pipeline.generate import generate

CC = os.environ.get("CC", "gcc")
C_DIR = Path(__file__).resolve().parent / "c"
DRIVER = C_DIR / "eval_model.c"
WARNINGS = ("-Wall", "-Wextra", "-Wpedantic", "-Werror")
FLOAT_WARNINGS = ("-DIPGEN_SCALAR=float", "-Wdouble-promotion", "-Wconversion")
STDERR_LINES = 40
# A C header's MPC step as a program: a state per line in (ipgen's coordinates), u of
# ipgen_NAME_mpc_step and its status out (NAME: the header's model name, replaced by the caller).
MPC_STEP_PROGRAM = """\
#include <stdio.h>
#include "NAME.h"
static ipgen_NAME_mpc_state s;
int main(void) {
  double x[4];
  IPGEN_SCALAR xs[4];
  int i;
  ipgen_NAME_mpc_init(&s);
  while (scanf("%lf %lf %lf %lf", &x[0], &x[1], &x[2], &x[3]) == 4) {
    double u;
    for (i = 0; i < 4; ++i) xs[i] = (IPGEN_SCALAR)x[i];
    u = (double)ipgen_NAME_mpc_step(&s, xs);
    printf("%.17g %d\\n", u, s.info.status);
  }
  return 0;
}
"""


def c_command(*arguments: str, scalar: str = "double", optimisation: str = "-O1") -> tuple[str, ...]:
    """The C compiler, C99, all warnings as errors (and the float-mode ones), then `arguments`."""
    extra = FLOAT_WARNINGS if scalar == "float" else ()
    return (CC, "-std=c99", optimisation, *WARNINGS, *extra, *arguments, "-lm")


def require_cc() -> None:
    """Fail (or skip, with IPGEN_ALLOW_NO_CXX=1) when there is no C compiler."""
    if shutil.which(CC) is not None:
        return
    if os.environ.get("IPGEN_ALLOW_NO_CXX") == "1":
        pytest.skip(f"no C compiler {CC!r}; skipped because IPGEN_ALLOW_NO_CXX=1")
    pytest.fail(f"no C compiler {CC!r} on PATH (set CC)", pytrace=False)


def compile_c(command: Sequence[str]) -> str | None:
    """Run a compile command; None, or the failure with the compiler's first lines."""
    result = subprocess.run(list(command), capture_output=True, text=True, check=False)
    if result.returncode == 0:
        return None
    lines = (result.stderr or result.stdout).splitlines()
    return f"$ {shlex.join(command)}\nexit status {result.returncode}\n" + "\n".join(lines[:STDERR_LINES])


class CModels:
    """C headers of the models and their evaluation programs (double and float)."""

    def __init__(self, workdir: Path, jobs: int) -> None:
        self.workdir = workdir
        self.headers = workdir / "include"
        self.pool = ThreadPoolExecutor(max_workers=jobs)
        self.builds: dict[tuple[System, str], Future[str | None]] = {}

    def submit(self, systems: Sequence[System]) -> None:
        for system in systems:
            if (system, "double") in self.builds:
                continue
            name = model_name(system)
            generate(system, name, self.headers, force=True, emit=("c",))
            for scalar in ("double", "float"):
                self.builds[system, scalar] = self.pool.submit(self._build, system, scalar)

    def _build(self, system: System, scalar: str) -> str | None:
        name = model_name(system)
        return compile_c(
            c_command(
                f"-I{self.headers}",
                f'-DIPGEN_C_HEADER="{name}.h"',
                f"-DIPGEN_C_NAME={name}",
                f"-DIPGEN_C_NAMEU={name.upper()}",
                str(DRIVER),
                "-o",
                str(self.executable(system, scalar)),
                scalar=scalar,
            )
        )

    def executable(self, system: System, scalar: str) -> Path:
        return self.workdir / f"{model_name(system)}_{scalar}"

    def program(self, system: System, scalar: str) -> Path:
        """The built program; fails the test with the compiler's message if it did not build."""
        self.submit([system])
        error = self.builds[system, scalar].result()
        if error is not None:
            pytest.fail(
                f"{model_name(system)}.h ({scalar}) does not compile cleanly:\n{error}", pytrace=False
            )
        return self.executable(system, scalar)

    def close(self) -> None:
        self.pool.shutdown(wait=True, cancel_futures=True)


def run_c(
    executable: Path,
    params: tuple[np.ndarray, np.ndarray, np.ndarray, float],
    states: Sequence[tuple[np.ndarray, np.ndarray, float]],
) -> list[dict[str, np.ndarray]]:
    """Evaluate at `states`; per state {quantity: flat array} (matrices row by row)."""
    m, lengths, delta, g = params
    numbers: list[float | int] = [*m, *lengths, *delta, g, len(states)]
    for q, qd, u in states:
        numbers += [*q, *qd, u]
    text = " ".join(str(x) if isinstance(x, int) else repr(float(x)) for x in numbers)
    result = subprocess.run([str(executable)], input=text, capture_output=True, text=True, check=False)
    assert result.returncode == 0, f"{executable.name} failed ({result.returncode}): {result.stderr}"
    blocks: list[dict[str, np.ndarray]] = []
    for line in result.stdout.splitlines()[1:]:
        key, *values = line.split()
        if key == "M":
            blocks.append({})
        blocks[-1][key] = np.array([float(v) for v in values])
    assert len(blocks) == len(states), result.stdout
    return blocks
