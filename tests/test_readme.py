"""The README's C++ example compiles cleanly and does what it says."""

from __future__ import annotations

import re
import subprocess
from pathlib import Path

from cxx import cxx_command, require_toolchain

from ipgen.generate import generate_header
from ipgen.model import System

ROOT = Path(__file__).resolve().parents[1]

CHECK = r"""
#include <cmath>
#include <cstdio>
int main() {
  const m::Params<double> p{{0.3, 0.275, 0.275}, {0.0, 0.5, 0.5}, {0.3, 0.1, 0.1}};
  m::Vector<double> q(0.1, 0.4, -0.7), qd(-0.3, 1.5, 2.0);
  for (double a : {-2.0, 0.0, 3.5}) {
    const double u = force_for_cart_acceleration(q, qd, a);
    const double achieved = m::forward_dynamics(q, qd, u, p)(0);
    if (std::abs(achieved - a) > 1e-9) { std::printf("a=%g achieved %.17g\n", a, achieved); return 1; }
  }
  return 0;
}
"""


def test_readme_controller_example(tmp_path: Path) -> None:
    require_toolchain()
    readme = (ROOT / "README.md").read_text()
    blocks = re.findall(r"```cpp\n(.*?)```", readme, flags=re.S)
    example = next(b for b in blocks if "force_for_cart_acceleration" in b)
    generate_header(System("classical", 2), "cdip", tmp_path / "out")
    source = tmp_path / "example.cpp"
    source.write_text(example + CHECK)
    binary = tmp_path / "example"
    build = subprocess.run(
        cxx_command(f"-I{tmp_path}", str(source), "-o", str(binary)), capture_output=True, text=True
    )
    assert build.returncode == 0, build.stderr
    run = subprocess.run([str(binary)], capture_output=True, text=True)
    assert run.returncode == 0, run.stdout
