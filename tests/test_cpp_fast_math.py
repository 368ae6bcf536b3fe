"""The C++ header under -ffast-math: a com or J left unset means the paper's rod (a NaN marks it),
and the test of that mark must survive -ffinite-math-only, which folds isnan to false (the
header's q̈ was NaN under -ffast-math, -Ofast or -ffinite-math-only before)."""

from __future__ import annotations

import subprocess
from pathlib import Path

import numpy as np
import pytest
from c_models import compile_c
from cxx import cxx_command, require_toolchain

import ipgen
from ipgen.estimation import as_model

PROGRAM = """\
#include <cstdio>
#include "c1.hpp"
int main() {
  ipgen::c1::Params<double> p{{0.3, 0.275}, {0, 0.5}, {0.3, 0.1}};  // com and J unset: rods
  ipgen::c1::Vector<double> q, qd;
  q << 0.1, 0.2;
  qd << 0.0, 0.3;
  const auto qdd = ipgen::c1::forward_dynamics(q, qd, 1.0, p);
  ipgen::c1::Params<float> pf{{0.3f, 0.275f}, {0, 0.5f}, {0.3f, 0.1f}};
  ipgen::c1::Vector<float> qf, qdf;
  qf << 0.1f, 0.2f;
  qdf << 0.0f, 0.3f;
  const auto qddf = ipgen::c1::forward_dynamics(qf, qdf, 1.0f, pf);
  std::printf("%.17g %.17g %.9g %.9g\\n", qdd(0), qdd(1), (double)qddf(0), (double)qddf(1));
}
"""


@pytest.mark.parametrize("flag", ["-ffast-math", "-ffinite-math-only"])
def test_unset_rod_values_survive_fast_math(tmp_path: Path, flag: str) -> None:
    """A cart pendulum with com and J unset, compiled with `flag` (-O2): q̈ in double and float is
    the Python model's (ipgen.estimation's, the same rods), not NaN."""
    require_toolchain()
    ipgen.write_header(tmp_path, "classical", 1, name="c1")
    (tmp_path / "fast.cpp").write_text(PROGRAM)
    program = tmp_path / "fast"
    # no precompiled Eigen: a .gch built without the flag is not for this build
    command = cxx_command(flag, f"-I{tmp_path}", str(tmp_path / "fast.cpp"), "-o", str(program),
                          optimisation="-O2", precompiled=False)  # fmt: skip
    problem = compile_c(command)
    assert problem is None, problem
    out = subprocess.run([str(program)], capture_output=True, text=True, check=True).stdout
    values = np.array([float(v) for v in out.split()])
    pendulum = ipgen.Pendulum("classical", 1, [0.3, 0.275], [0.0, 0.5], [0.3, 0.1], 9.81)
    expected = as_model(pendulum).f(np.array([0.1, 0.2, 0.0, 0.3]), 1.0)[2:]
    assert np.all(np.isfinite(values))
    np.testing.assert_allclose(values[:2], expected, rtol=1e-12)
    np.testing.assert_allclose(values[2:], expected, rtol=1e-5)
