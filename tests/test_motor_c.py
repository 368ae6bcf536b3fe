"""The C99 header's DC motor (`ipgen_NAME_dc_motor`, `_motor_gain`, `_with_motor`): driven by a
voltage, the folded model's accelerations equal those of the mechanics with the manufacturer's
motor torque (or force) and the rotor's inertia added by hand (as tests/test_actuator.py checks
the C++ header's DcMotor), in double and in float."""

from __future__ import annotations

import subprocess
from pathlib import Path

import numpy as np
import pytest
from c_models import c_command, require_cc
from motor_by_hand import MOTOR, R, accelerations_by_hand, rig

from ipgen.codegen.c_header import render_c_header
from ipgen.codegen.header import HeaderRequest
from ipgen.model.derivation import derive
from ipgen.model.system import System

PROGRAM = """
#include <stdio.h>
#include "m.h"
int main(void) {
  ipgen_m_params p = {{M}, {L}, {D}, (IPGEN_SCALAR)9.81};
  ipgen_m_links links;
  ipgen_m_dc_motor motor = {MOTOR};
  const IPGEN_SCALAR q[2] = {(IPGEN_SCALAR)0.3, (IPGEN_SCALAR)-0.2};
  const IPGEN_SCALAR qd[2] = {(IPGEN_SCALAR)1.5, (IPGEN_SCALAR)-2.0};
  IPGEN_SCALAR qdd[2];
  ipgen_m_rod_links(&p, &links);
  links.J[0] = (IPGEN_SCALAR)J0;
  links.J[1] = (IPGEN_SCALAR)J1;
  ipgen_m_with_motor(&motor, &p, &links);
  const IPGEN_SCALAR u = ipgen_m_motor_gain(&motor) * (IPGEN_SCALAR)4.0;
  if (ipgen_m_forward_dynamics_built(q, qd, u, &p, &links, qdd)) return 1;
  printf("%.17g %.17g\\n", (double)qdd[0], (double)qdd[1]);
  return 0;
}
"""


@pytest.mark.parametrize("scalar", ["double", "float"])
@pytest.mark.parametrize("kind", ["rotary", "classical"])
def test_c_header_dc_motor(kind: str, scalar: str, tmp_path: Path) -> None:
    require_cc()
    system = System(kind, 1)  # type: ignore[arg-type]
    m, l, delta, j = rig(kind)  # noqa: E741
    constants = [*MOTOR] + ([R] if kind == "classical" else [])

    def c_list(values: list[float]) -> str:
        return ", ".join(f"(IPGEN_SCALAR){v!r}" for v in values)

    program = PROGRAM.replace("{M}", "{" + c_list(m) + "}").replace("{L}", "{" + c_list(l) + "}")
    program = program.replace("{D}", "{" + c_list(delta) + "}").replace(
        "{MOTOR}", "{" + c_list(constants) + "}"
    )
    program = program.replace("J0;", f"{j[0]!r};").replace("J1;", f"{j[1]!r};")
    (tmp_path / "m.h").write_text(render_c_header(derive(system), HeaderRequest("m", "test")))
    (tmp_path / "main.c").write_text(program)
    subprocess.run(
        c_command(f"-I{tmp_path}", str(tmp_path / "main.c"), "-o", str(tmp_path / "main"), scalar=scalar),
        check=True,
    )
    out = subprocess.run([str(tmp_path / "main")], capture_output=True, text=True, check=True).stdout
    qdd_c = np.array([float(x) for x in out.split()])

    qdd_hand = accelerations_by_hand(kind)
    tolerance = 1e-12 if scalar == "double" else 2e-4
    np.testing.assert_allclose(qdd_c, qdd_hand, rtol=tolerance, atol=tolerance)
