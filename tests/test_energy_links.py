"""The energy swing-up on links as built (docs/links.md): its link energy
E = ½ J θ̇1² + w (cos θ1 − 1) takes the link's inertia about its pivot and its gravity moment from
com, J and tip (control/energy.link_constants), checked against the derived model's mass matrix
and gravity term; with them a link with a tip mass is caught at the energy of upright and held
(with the rod's constants it was caught far above it and fell)."""

from __future__ import annotations

import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from cxx import require_toolchain
from hypothesis import given, settings
from hypothesis import strategies as st

from ipgen.control.casadi_model import plant
from ipgen.control.energy import energy_swingup, link_constants, link_energy, mass_and_bias
from ipgen.control.trajectory import PlanError

ROOT = Path(__file__).resolve().parents[1]
M, L, DELTA = [0.5, 0.275], [0.6, 0.5], [0.3, 0.011458]


@settings(max_examples=25, deadline=None)
@given(
    kind=st.sampled_from([("classical", "pivot"), ("rotary", "pivot"), ("rotary", "full")]),
    com=st.floats(0.05, 0.6),
    inertia=st.floats(1e-4, 0.05),
    tip=st.floats(0.0, 0.5),
    angle=st.floats(-math.pi, math.pi),
)
def test_the_constants_are_the_derived_models_inertia_and_gravity_moment(
    kind: tuple[str, str], com: float, inertia: float, tip: float, angle: float
) -> None:
    """J is M11 of the derived model (at any angle); w is minus the gravity term of the link's row
    at rest with the link horizontal (∂V/∂θ1 = −w sin θ1)."""
    system, model = kind
    p = plant(system, 1, M, L, DELTA, inertia=model, com=[0.3, com], J=[0.01, inertia], tip=[0.0, tip])
    j, w = link_constants(p)
    mass, _ = mass_and_bias(p, np.array([0.2, angle]), np.zeros(2))
    assert j == pytest.approx(mass[1, 1], rel=1e-12)
    _, bias = mass_and_bias(p, np.array([0.0, math.pi / 2]), np.zeros(2))
    assert w == pytest.approx(-bias[1], rel=1e-12)
    assert link_energy(p, np.array([0.0, math.pi, 0.0, 0.0])) == pytest.approx(-2 * w, rel=1e-12)


def test_the_rods_constants_are_the_rods_expressions_to_the_bit() -> None:
    """Unset links as built: the paper's rod, m1 l1²/3 and ½ m1 g l1 exactly (scenes keep their
    .cfg numbers)."""
    rods = (M[1] * L[1] ** 2 / 3, 0.5 * M[1] * 9.81 * L[1])
    assert link_constants(plant("rotary", 1, M, L, DELTA)) == rods
    written = float(f"{M[1] * L[1] ** 2 / 12 * (1 + 3e-16):.17g}")  # a rod's J as a decimal in a scene
    assert link_constants(plant("rotary", 1, M, L, DELTA, J=[0.01, written], com=[0.3, 0.25])) == rods
    assert link_constants(plant("rotary", 1, M, L, DELTA, J=[0.01, written * (1 + 1e-9)])) != rods


@pytest.mark.parametrize("com", [-0.2, 0.0])
def test_a_centre_of_mass_at_or_beyond_the_pivot_is_refused(com: float) -> None:
    """A link whose centre of mass is at or beyond its pivot has no energy to pump: its own
    message (at the pivot it said "m1 g l1 underflows", naming g, m and l)."""
    p = plant("rotary", 1, M, L, DELTA, com=[0.3, com])
    with pytest.raises(PlanError, match=r"gravity moment .* is not positive: .*check com\[1\] and tip\[1\]"):
        energy_swingup(p, u_max=5.0)


def test_a_link_with_a_tip_mass_is_swung_up_and_held(tmp_path: Path) -> None:
    """The paper's arm with a 0.5 kg tip on its link, 20 N m: the run ends upright and at rest
    (exit 0); the .cfg's constants are the link's as built."""
    require_toolchain()
    text = (ROOT / "scenes" / "rsip_swingup.toml").read_text(encoding="utf-8")
    text = text.replace("delta = [0.3, 0.011458]", "delta = [0.3, 0.011458]\ntip = [0, 0.5]")
    text = text.replace("u_max = 5.0 ", "u_max = 20.0 ").replace("hold = 8.0 ", "hold = 2.0 ")
    assert "tip = [0, 0.5]" in text and "u_max = 20.0" in text and "hold = 2.0" in text
    scene = tmp_path / "tip.toml"
    scene.write_text(text, encoding="utf-8")
    done = subprocess.run(
        [sys.executable, "-m", "ipgen", "run", str(scene), "-o", str(tmp_path / "out"), "--no-plot"],
        capture_output=True, text=True, env=os.environ.copy(), timeout=300,
    )  # fmt: skip
    assert done.returncode == 0, done.stdout + done.stderr
    cfg = (tmp_path / "out" / "tip.cfg").read_text(encoding="utf-8")
    m1, l1 = M[1], L[1]
    inertia = m1 * l1**2 / 12 + m1 * (l1 / 2) ** 2 + 0.5 * l1**2
    assert math.isclose(float(cfg.split("swingup.energy_inertia = ")[1].split()[0]), inertia)
    assert math.isclose(
        float(cfg.split("swingup.energy_weight = ")[1].split()[0]), 9.81 * (m1 * l1 / 2 + 0.5 * l1)
    )
    final = (tmp_path / "out" / "tip.csv").read_text(encoding="utf-8").strip().splitlines()[-1].split(",")
    theta1, rate1 = float(final[2]), float(final[4])
    assert abs(math.remainder(theta1, 2 * math.pi)) < 0.05 and abs(rate1) < 0.1
