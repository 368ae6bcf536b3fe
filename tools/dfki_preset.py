"""Write a fixed-pivot preset scene from one of DFKI's model_parameters.yml files.

    python tools/dfki_preset.py tests/data/dfki/design_C.0_model_3.0.yml C.0 3.0 > scenes/rigs/dfki_c0.toml

The values are DFKI's (github:dfki-ric-underactuated-lab/double_pendulum, BSD-3-Clause,
Copyright (c) 2022 DFKI RIC Underactuated Robotics Lab) mapped by `ipgen.model.dfki.dfki_pendulum`:
J = I − m r² (their I about the joint axes), gr → −gr (their closed form's −gr Ir), the atan
Coulomb law with k = 100, their coordinates. tests/test_fixed_scene.py checks that each preset
equals the mapping of the file it came from.
"""

from __future__ import annotations

import sys
from pathlib import Path

from ipgen.model.dfki import dfki_pendulum, read_model_parameters

ROOT = Path(__file__).resolve().parent.parent


def _array(values: tuple[float, ...]) -> str:
    return "[" + ", ".join(repr(float(v)) for v in values) + "]"


def preset_text(path: Path, design: str, model: str) -> str:
    """The preset scene's TOML for DFKI's parameter file `path` of `design`, `model`."""
    p = dfki_pendulum(read_model_parameters(path))
    source = (
        "github.com/dfki-ric-underactuated-lab/double_pendulum at commit 1e8544e, "
        f"data/system_identification/identified_parameters/design_{design}/model_{model}/"
        "model_parameters.yml (BSD-3-Clause, Copyright (c) 2022 DFKI RIC Underactuated Robotics Lab)."
    )
    return f"""# The DFKI double pendulum, hardware design {design}, with DFKI's parameters model_{model}.
# Values from: {source}
# Written by tools/dfki_preset.py from tests/data/dfki/{path.name}: J = I - m r^2 (DFKI's I1, I2
# are about the joint axes; J may be negative for identified values), gr = -6 (DFKI's closed
# form has M12 = ... - gr Ir: the rotor turns against its joint), Coulomb friction cf atan(100 w),
# DFKI's coordinates (q1 from hanging, q2 relative, counterclockwise). Both joints driven by
# AK80-6 motors (torque limit 10 N m each, not modelled here).
[system]
type = "fixed"
links = 2
angles = "{p.angles}"
zero = "{p.zero}"
positive = "{p.positive}"

[parameters]
m = {_array(p.m)}
l = {_array(p.l)}
com = {_array(p.resolved("com"))}
J = {_array(p.resolved("J"))}
delta = {_array(p.delta)}
coulomb = {_array(p.coulomb or ())}
coulomb_law = "{p.coulomb_law}"
coulomb_gain = {p.coulomb_gain!r}
g = {p.g!r}

[actuator]
joints = [{", ".join(str(j) for j in p.joints)}]
Ir = {_array(p.motor("Ir"))}
gr = {_array(p.motor("gr"))}

# ipgen run: a free swing from 0.5 rad (DFKI's coordinates: q1 from hanging), both motors idle.
[initial]
theta = [0.5, 0.0]
dtheta = [0.0, 0.0]

[[input]]                 # joint 1: torque [N m], counterclockwise positive
kind = "zero"

[[input]]                 # joint 2
kind = "zero"

[simulation]
t_end = 5.0
sample = 0.01

[outputs]
energy = true
"""


if __name__ == "__main__":
    sys.stdout.write(preset_text(Path(sys.argv[1]), sys.argv[2], sys.argv[3]))
