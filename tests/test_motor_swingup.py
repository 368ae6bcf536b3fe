"""A swing-up driven by a DC motor ([swingup] with [actuator] dc_motor): designed on the
motor-folded model and run in volts. Reference: the same scene written by hand as the direct
model the motor folds into (δ0 + b K_g k_m, u_max b N m) must give the same trajectory, with
u_volts · b = u_torque at every sample (the motor is an exact rewrite of the mechanics)."""

from __future__ import annotations

import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from c_models import c_command, require_cc
from cxx import require_toolchain
from run_csv import read_run_csv

import ipgen
from ipgen.experiment.scene import load_scene

SCENE = """
[system]
type = "rotary"
links = 1
name = "NAME"
emit = ["cpp", "c"]

[parameters]
m = [0.5, 0.275]
l = [0.6, 0.5]
delta = [DELTA0, 0.011458]
ACTUATOR
[simulation]
t_end = 6.0

[swingup]
method = "energy"
u_max = UMAX
period = 0.01
hold = 2.0
"""
MOTOR = '\n[actuator]\nkind = "dc_motor"\nRm = 2.0\nkt = 0.1\nkm = 0.1\nKg = 10\n'
GAIN = 10 * 0.1 / 2.0  # b = Kg kt / Rm [N m/V]; back-EMF c = b Kg km = 0.5 N m s


def _scene(tmp_path: Path, name: str, motor: bool, model: str | None = None) -> Path:
    """`name`.toml; its model is called `model` (default: `name`)."""
    text = SCENE.replace("NAME", model or name).replace("ACTUATOR", MOTOR if motor else "")
    text = text.replace("DELTA0", "0.3" if motor else "0.8").replace("UMAX", "10.0" if motor else "5.0")
    path = tmp_path / f"{name}.toml"
    path.write_text(text)
    return path


def _run(scene: Path, out: Path, env: dict[str, str]) -> np.ndarray:
    done = subprocess.run(
        [sys.executable, "-m", "ipgen", "run", str(scene), "-o", str(out), "--no-plot"],
        capture_output=True,
        text=True,
        env=env,
    )
    assert done.returncode == 0, done.stderr
    return read_run_csv(out / f"{scene.stem}.csv", phase=True).data


def test_motor_swingup_is_the_folded_direct_swingup(tmp_path: Path) -> None:
    require_toolchain()
    env = dict(os.environ)  # the run's shared simulator cache (tests/conftest.py)
    # One model name for both: the motor is folded in the .cfg, the headers are the same, so the
    # simulator is compiled once.
    motor = _run(_scene(tmp_path, "rsip_motor", True, model="rsip_swing"), tmp_path / "motor", env)
    direct = _run(_scene(tmp_path, "rsip_direct", False, model="rsip_swing"), tmp_path / "direct", env)
    assert motor.shape == direct.shape
    np.testing.assert_allclose(motor[:, 1:5], direct[:, 1:5], atol=1e-7)
    np.testing.assert_allclose(motor[:, 5] * GAIN, direct[:, 5], atol=1e-7)
    assert np.max(np.abs(motor[:, 5])) == pytest.approx(10.0)  # the voltage limit is reached
    assert abs(math.remainder(motor[-1, 2], 2 * math.pi)) < 0.1  # held upright (after whole turns)
    summary = (tmp_path / "motor" / "rsip_motor.txt").read_text()
    assert "|u| <= 10 V; hold (LQR) from" in summary and "largest |u| 10 V." in summary


def test_motor_swingup_law_is_in_volts(tmp_path: Path) -> None:
    """The law in volts is the direct law divided by b; the C header divides the energy law's
    torque by b (the loop runtime's input_gain) and compiles warning-free."""
    motor = load_scene(_scene(tmp_path, "m", True)).swingup
    direct = load_scene(_scene(tmp_path, "d", False)).swingup
    assert motor is not None and direct is not None
    assert motor.input_gain == GAIN and motor.u_max == pytest.approx(10.0)
    np.testing.assert_allclose(np.array(motor.hold_gain) * GAIN, direct.hold_gain, rtol=1e-9)
    assert dict(motor.energy) == pytest.approx(dict(direct.energy), rel=1e-12)
    require_cc()
    ipgen.write_header(tmp_path / "gen", scene=_scene(tmp_path, "mc", True))
    header = (tmp_path / "gen" / "mc.h").read_text()
    # ipgen_loop_energy_input divides the law's torque by the energy law's input_gain, b
    assert "(IPGEN_SCALAR)0.5, /* input_gain: the law's torque or force in volts" in header
    (tmp_path / "main.c").write_text('#include "mc.h"\nint main(void) { return 0; }\n')
    subprocess.run(
        c_command(f"-I{tmp_path / 'gen'}", str(tmp_path / "main.c"), "-o", str(tmp_path / "a")), check=True
    )
