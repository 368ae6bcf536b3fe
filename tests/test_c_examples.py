"""The C header's examples: examples/c/rk4.c (a fixed-step RK4 run, energy conserved) and the
README's C example, both compiled with the strict C99 flags and run."""

from __future__ import annotations

import re
import shlex
import subprocess
from pathlib import Path

from c_models import c_command, compile_c, require_cc

from ipgen.model.system import System
from ipgen.pipeline.generate import generate

ROOT = Path(__file__).resolve().parents[1]


def test_rk4_example_conserves_energy(tmp_path: Path) -> None:
    require_cc()
    generate(System("rotary", 1), "rsip", tmp_path, emit=("c",))
    binary = tmp_path / "rk4"
    error = compile_c(c_command(f"-I{tmp_path}", str(ROOT / "examples" / "c" / "rk4.c"), "-o", str(binary)))
    assert error is None, error
    run = subprocess.run([str(binary)], capture_output=True, text=True, check=False)
    assert run.returncode == 0, run.stdout
    drift = float(re.search(r"energy_drift (\S+)", run.stdout).group(1))  # type: ignore[union-attr]
    assert 0 <= drift < 1e-6, run.stdout


CHECK = r"""
#include <stdio.h>
int main(void) {
  const ipgen_rsip_params p = {{0.5f, 0.275f}, {0.6f, 0.5f}, {0.3f, 0.011458f}, 9.81f}; /* as in the README */
  float q[] = {0.0f, 0.3f}, qd[] = {1.0f, -0.5f}, qdd[IPGEN_RSIP_DOF];
  const float q1 = q[1], qd1 = qd[1];
  if (ipgen_rsip_forward_dynamics(q, qd, 0.5f, &p, qdd) != 0) return 2;
  if (observer_tick(q, qd, 0.5f, 0.001f) != 0) return 3;
  if (q[1] != q1 + 0.001f * qd1 || qd[1] != qd1 + 0.001f * qdd[1]) return 4;
  printf("ok\n");
  return 0;
}
"""


def without_main(example: str) -> str:
    """The README's program with its own main renamed (tests/test_readme_verbatim.py runs that
    one as it is), so that CHECK's main checks observer_tick."""
    return "#define main readme_main\n" + example + "#undef main\n"


def test_readme_c_example(tmp_path: Path) -> None:
    require_cc()
    readme = (ROOT / "README.md").read_text()
    blocks = re.findall(r"```c\n(.*?)```", readme, flags=re.S)
    example = next(b for b in blocks if "observer_tick" in b)
    assert len(example.strip().splitlines()) <= 24, "the README's C example should stay short"
    generate(System("rotary", 1), "rsip", tmp_path / "out", emit=("c",))
    source = tmp_path / "example.c"
    source.write_text(without_main(example) + CHECK)
    binary = tmp_path / "example"
    error = compile_c(c_command(f"-I{tmp_path}", str(source), "-o", str(binary), scalar="float"))
    assert error is None, error
    run = subprocess.run([str(binary)], capture_output=True, text=True, check=False)
    assert run.returncode == 0 and run.stdout == "ok\n", f"exit {run.returncode}: {run.stdout}"


def test_emit_c_from_the_command_line(tmp_path: Path) -> None:
    """`ipgen --type rotary --links 1 --emit c -o out/` writes out/rotary1.h only, byte-identical on a
    second run; with a scene, `emit = ["c"]` and --fix it is specialised like the C++ header."""
    from ipgen.command.cli import run

    out = tmp_path / "out"
    assert run(["--type", "rotary", "--links", "1", "--emit", "c", "-o", str(out)]) == 0
    assert sorted(p.name for p in out.iterdir()) == ["rotary1.h"]
    first = (out / "rotary1.h").read_bytes()
    assert b"--emit c -o <dir>" in first and b"#ifndef IPGEN_rotary1_H_INCLUDED" in first
    assert run(["--type", "rotary", "--links", "1", "--emit", "c", "-o", str(out)]) == 0
    assert (out / "rotary1.h").read_bytes() == first
    assert run(["--type", "classical", "--links", "2", "--name", "cdip", "--fix", "m0=0.3,delta2=0",
                "--emit", "cpp,c", "-o", str(out)]) == 0  # fmt: skip
    header = (out / "cdip.h").read_text()
    assert (out / "cdip.hpp").is_file() and "SPECIALISED" in header and "m0 = p->m[0];" not in header
    scene = tmp_path / "cdip.toml"
    scene.write_text(
        (ROOT / "scenes" / "cdip_pulse.toml")
        .read_text()
        .replace('name = "cdip"', 'name = "cdip"\nemit = ["c"]\nspecialise = true', 1)
    )
    assert run(["--scene", str(scene), "-o", str(tmp_path / "scene")]) == 0
    written = sorted(p.name for p in (tmp_path / "scene").iterdir())
    assert written == ["cdip.cfg", "cdip.h"], written
    assert "SPECIALISED for scene" in (tmp_path / "scene" / "cdip.h").read_text()


def test_readme_c_compile_line_builds_the_example(tmp_path: Path) -> None:
    """The README's gcc line, verbatim, is complete (-lm: the header calls sinf and cosf)."""
    require_cc()
    readme = (ROOT / "README.md").read_text()
    lines = [
        body.strip()
        for language, body in re.findall(r"^```(\w*)\n(.*?)^```$", readme, flags=re.S | re.M)
        if not language and body.startswith("gcc ")
    ]
    assert len(lines) == 1, "expected one gcc line in README.md"
    command = shlex.split(lines[0])
    assert command[-1] == "-lm"
    example = next(b for b in re.findall(r"```c\n(.*?)```", readme, flags=re.S) if "observer_tick" in b)
    generate(System("rotary", 1), "rsip", tmp_path / "out", emit=("c",))
    (tmp_path / command[command.index("-o") - 1]).write_text(without_main(example) + CHECK)
    build = subprocess.run(command, cwd=tmp_path, capture_output=True, text=True)
    assert build.returncode == 0, build.stderr
    run = subprocess.run([str(tmp_path / command[command.index("-o") + 1])], capture_output=True, text=True)
    assert run.returncode == 0 and run.stdout == "ok\n", run.stdout
