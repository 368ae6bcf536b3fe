"""The rig presets in scenes/rigs/: each loads, generates, has an LQR in volts that stabilises it
within its voltage limit, and reproduces the manufacturer's linear model where one is published.

Published numbers found wrong: the circulated QUBE-Servo 2 script's back-EMF column (200× too
small; tests/test_actuator.py). The IP02 + single pendulum is checked against the textbook
cart-pendulum equations Quanser's IP02 manual uses, derived here by hand with the motor's
F = ηg Kg ηm kt (V − Kg km ẋ/r)/(Rm r) and the rotor's mass ηg Kg² Jm/r² on the cart. No linear
model of the SRV02 + DBIP is published with its setup file (setup_dbip.m builds it from a Maple
worksheet); its test checks the motor's fold by hand and the closed loop.
"""

from __future__ import annotations

import math
import os
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from cxx import require_toolchain
from motor_by_hand import flat_parameters
from run_csv import read_run_csv
from run_summary import simulator_of
from scipy.integrate import solve_ivp
from test_actuator import by_hand

import ipgen
from ipgen.control.linear import dynamics
from ipgen.experiment.config import resolved_config
from ipgen.experiment.scene import load_scene

ROOT = Path(__file__).resolve().parents[1]
RIGS = ROOT / "scenes" / "rigs"
PRESETS = ("qube_servo2", "ip02_sip", "srv02_dbip")


def model(name: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(A, B, K) of a preset, through the scene reader (K: its controller's gain, volts), all in
    the rig's coordinates the preset declares ([system] angles, zero, positive)."""
    scene = load_scene(RIGS / f"{name}.toml")
    frame = scene.coordinates
    a, b = ipgen.linearize(
        scene.type, scene.links, scene.m, scene.l, scene.delta, scene.g, scene.inertia,
        actuator=scene.actuator, **scene.link_values(),
        angles=frame.angles, zero=frame.zero, positive=frame.positive,
    )  # fmt: skip
    assert scene.controller is not None
    return a, b, np.array(scene.controller.gain).reshape(1, -1)


@pytest.fixture(scope="module")
def generated(tmp_path_factory: pytest.TempPathFactory) -> Callable[[str], Path]:
    """The folder of `ipgen --scene scenes/rigs/<name>.toml -o <folder>`, run once per module and
    preset (two tests read qube_servo2's files); the command's exit status is checked on each call,
    and a failed run is not kept."""
    done: dict[str, Path] = {}

    def folder(name: str) -> Path:
        if name not in done:
            out = tmp_path_factory.mktemp(name)
            result = subprocess.run(
                [sys.executable, "-m", "ipgen", "--scene", str(RIGS / f"{name}.toml"), "-o", str(out)],
                capture_output=True,
                text=True,
            )
            assert result.returncode == 0, result.stderr
            done[name] = out
        return done[name]

    return folder


@pytest.mark.parametrize("name", PRESETS)
def test_preset_loads_and_its_lqr_in_volts_stabilises(name: str, generated: Callable[[str], Path]) -> None:
    scene = load_scene(RIGS / f"{name}.toml")
    assert scene.actuator.is_motor
    assert scene.controller is not None and scene.controller.saturation == 10.0
    a, b, k = model(name)
    assert np.max(np.linalg.eigvals(a - b @ k).real) < 0
    config = resolved_config(scene)
    assert "actuator = dc_motor" in config
    written = next(line for line in config.splitlines() if line.startswith("actuator.gain = "))
    assert float(written.split()[2]) == pytest.approx(scene.actuator.gain(), rel=1e-15)
    out = generated(name)
    assert (out / f"{scene.name}.hpp").is_file() and (out / f"{name}.cfg").is_file()


def test_qube_servo_2_preset_reproduces_quanser_in_volts() -> None:
    """The preset declares Quanser's counter-clockwise α: its A, B are Quanser's as published,
    and ipgen's own (clockwise) ones are S A S, S B with S = diag(1, −1, 1, −1)."""
    a, b, _ = model("qube_servo2")
    a_hand, b_hand = by_hand()
    assert load_scene(RIGS / "qube_servo2.toml").coordinates.positive == "counterclockwise"
    assert np.allclose(a, a_hand, rtol=1e-9, atol=1e-9)
    assert np.allclose(b, b_hand, rtol=1e-9, atol=1e-12)
    scene = load_scene(RIGS / "qube_servo2.toml")
    a_own, b_own = ipgen.linearize(
        "rotary", 1, scene.m, scene.l, scene.delta, actuator=scene.actuator, **scene.link_values()
    )
    s = np.diag([1.0, -1.0, 1.0, -1.0])
    assert np.allclose(s @ a_own @ s, a_hand, rtol=1e-9, atol=1e-9)
    assert np.allclose(s @ b_own, b_hand, rtol=1e-9, atol=1e-12)


def test_ip02_preset_matches_the_hand_derived_cart_pendulum() -> None:
    """(Mc + ηg Kg² Jm/r² + Mp) ẍ + Mp lp θ̈ + (Beq + b Kg km/r) ẋ = b V,
    Mp lp ẍ + (Jp + Mp lp²) θ̈ + Bp θ̇ − Mp g lp θ = 0 (θ clockwise from upright, x to the right),
    b = ηg Kg ηm kt/(Rm r), from config_ip02.m and config_sp.m's numbers; the preset is in
    Quanser's α = −θ (counter-clockwise), so its A, B are S A S, S B, S = diag(1, −1, 1, −1)."""
    rm, kt, km, kg, jm, r = 2.6, 0.00767, 0.00767, 3.71, 3.9e-7, 6.35e-3
    mc, beq, mp, lp_, lp, bp, g = 0.57, 4.3, 0.230, 0.6413, 0.3302, 0.0024, 9.81
    jp = mp * lp_**2 / 12
    gain = kg * kt / (rm * r)
    mass = np.array([[mc + kg**2 * jm / r**2 + mp, mp * lp], [mp * lp, jp + mp * lp**2]])
    stiffness = np.array([[0.0, 0.0], [0.0, -mp * g * lp]])
    damping = np.diag([beq + gain * kg * km / r, bp])
    inverse = np.linalg.inv(mass)
    a_hand = np.block([[np.zeros((2, 2)), np.eye(2)], [-inverse @ stiffness, -inverse @ damping]])
    b_hand = np.vstack([np.zeros((2, 1)), inverse @ np.array([[gain], [0.0]])])
    a, b, _ = model("ip02_sip")
    s = np.diag([1.0, -1.0, 1.0, -1.0])
    assert np.allclose(s @ a @ s, a_hand, rtol=1e-9, atol=1e-9), (a, a_hand)
    assert np.allclose(s @ b, b_hand, rtol=1e-9, atol=1e-12)


def test_srv02_dbip_motor_fold_by_hand() -> None:
    scene = load_scene(RIGS / "srv02_dbip.toml")
    motor = scene.actuator
    assert motor.gain() == pytest.approx(0.9 * 70 * 0.69 * 0.00767 / 2.6, rel=1e-12)
    assert motor.damping() == pytest.approx(0.9 * 70**2 * 0.69 * 0.00767**2 / 2.6, rel=1e-12)
    assert motor.inertia() == pytest.approx(0.9 * 70**2 * 3.9e-7, rel=1e-12)
    config = resolved_config(scene).splitlines()
    j0 = float(next(line for line in config if line.startswith("J = ")).split()[2])
    assert j0 == pytest.approx(1.983014784166667e-3 + 0.9 * 70**2 * 3.9e-7, rel=1e-12)


def test_ipgen_run_qube_servo_2(tmp_path: Path) -> None:
    """`ipgen run scenes/rigs/qube_servo2.toml` balances the pendulum; the CSV's u is volts,
    clipped at 10 V, and the trajectory is the one of an independent simulation in which the
    motor's torque is the manufacturer's kt (V − km θ̇0)/Rm on the unmodified arm. The CSV is
    in Quanser's coordinates (α = −θ1), the independent simulation in ipgen's."""
    require_toolchain()
    env = dict(os.environ)  # the run's shared simulator cache (tests/conftest.py)
    result = subprocess.run(
        [
            sys.executable,
            "-m",
            "ipgen",
            "run",
            str(RIGS / "qube_servo2.toml"),
            "-o",
            str(tmp_path / "out"),
            "--no-plot",
        ],
        capture_output=True,
        text=True,
        env=env,
    )
    assert result.returncode == 0, result.stderr
    run_ = read_run_csv(tmp_path / "out" / "qube_servo2.csv", phase=False)
    assert run_.names == ["t", "theta0", "theta1", "dtheta0", "dtheta1", "u"] and not run_.phase
    data = run_.data
    _, _, k = model("qube_servo2")
    volts = np.clip(-(data[:, 1:5] @ k.ravel()), -10.0, 10.0)
    assert np.allclose(data[:, 5], volts, rtol=1e-9, atol=1e-9)
    assert abs(data[-1, 2]) < 1e-3 and abs(data[-1, 1]) < 1e-3  # balanced, arm back at 0
    summary = (tmp_path / "out" / "qube_servo2.txt").read_text()
    assert "Actuator: dc motor, u in volts" in summary and "|u| <= 10;" in summary

    from ipgen.model.system import System

    system = System("rotary", 1)
    mech = flat_parameters(
        system,
        [0.095, 0.024],
        [0.085, 0.129],
        [0.0015, 0.0005],
        9.81,
        {"J": [5.7197916666666667e-05, 3.3282e-05]},
    )
    dyn = dynamics(system)

    s = np.diag([1.0, -1.0, 1.0, -1.0])  # Quanser's state = S (ipgen's state)

    def rhs(_: float, x: np.ndarray) -> np.ndarray:
        v = float(np.clip(-(k.ravel() @ (s @ x)), -10.0, 10.0))
        torque = 0.042 * (v - 0.042 * x[2]) / 8.4
        return np.concatenate([x[2:], dyn.forward_dynamics(x[:2], x[2:], torque, mech)])

    sol = solve_ivp(rhs, (0.0, 1.0), s @ data[0, 1:5], rtol=1e-10, atol=1e-12, dense_output=True)
    for row in data[data[:, 0] <= 1.0][::10]:
        assert np.allclose(row[1:5], s @ sol.sol(row[0]), atol=1e-6), row[0]
    assert sol.sol(0.0)[1] == pytest.approx(-0.1)  # [initial] 0.1 rad counter-clockwise
    assert not math.isclose(data[1, 1], 0.0)  # the arm moved


def test_the_c_header_carries_the_lqr_in_volts(generated: Callable[[str], Path]) -> None:
    header = (generated("qube_servo2") / "qube_servo2.h").read_text()
    assert "(motor voltage [V]), clipped to |u| <= 10.0 (a state that is not a number" in header


@pytest.mark.parametrize("extra", ['emit = ["fmu"]', 'emit = ["fmu3"]'])
def test_a_motor_scene_refuses_what_it_cannot_fold_yet(tmp_path: Path, extra: str) -> None:
    text = (RIGS / "qube_servo2.toml").read_text().replace('emit = ["cpp", "c"]', extra)
    scene = tmp_path / "motor.toml"
    scene.write_text(text)
    with pytest.raises(ipgen.Error, match=r"dc_motor with an FMU in emit is not supported yet") as caught:
        load_scene(scene)
    assert "\n" not in str(caught.value)


def test_the_simulator_refuses_a_bad_actuator_line(tmp_path: Path) -> None:
    """The resolved config's actuator lines as the simulator reads them: a wrong kind or gain
    is a one-line error naming the line, exit status 2."""
    require_toolchain()
    env = dict(os.environ)  # the run's shared simulator cache (tests/conftest.py)
    out = tmp_path / "out"
    first = subprocess.run(
        [sys.executable, "-m", "ipgen", "run", str(RIGS / "qube_servo2.toml"), "-o", str(out), "--no-plot"],
        capture_output=True,
        text=True,
        env=env,
    )
    assert first.returncode == 0, first.stderr
    simulator = simulator_of((out / "qube_servo2.txt").read_text())
    config = (out / "qube_servo2.cfg").read_text()
    for old, new, message in (
        ("actuator = dc_motor", "actuator = servo", "actuator must be `direct` or `dc_motor`"),
        ("actuator.gain = 0.005", "actuator.gain = -1", "actuator.gain must be a finite number > 0"),
    ):
        assert old in config
        bad = tmp_path / "bad.cfg"
        bad.write_text(config.replace(old, new))
        result = subprocess.run(
            [str(simulator), str(bad), "--csv", str(tmp_path / "bad.csv")], capture_output=True, text=True
        )
        assert result.returncode == 2, result.stderr
        assert message in result.stderr and result.stderr.count("\n") == 1, result.stderr


def test_the_ip02_swings_up_within_its_rail_and_10_volts(tmp_path: Path) -> None:
    """scenes/rigs/ip02_sip_swingup.toml (issue 33): from hanging at rest, caught and held
    upright; the cart stays within 70 % of its ±0.407 m rail (the simulator would stop the run
    at the rail, exit status 4), every |u| ≤ 10 V, the last row at rest upright and centred."""
    require_toolchain()
    result = subprocess.run(
        [
            sys.executable,
            "-m",
            "ipgen",
            "run",
            str(RIGS / "ip02_sip_swingup.toml"),
            "-o",
            str(tmp_path),
            "--no-plot",
        ],
        capture_output=True,
        text=True,
        env=dict(os.environ),  # the run's shared simulator cache (tests/conftest.py)
    )
    assert result.returncode == 0, result.stderr
    run_ = read_run_csv(tmp_path / "ip02_sip_swingup.csv", phase=True)
    phase, data = run_.phase, run_.data
    assert "hold" in phase and phase[-1] == "hold"
    caught = data[phase.index("hold"), 0]
    assert 0 < caught < 10 and data[-1, 0] == pytest.approx(caught + 5, abs=2e-3)
    assert np.max(np.abs(data[:, 1])) <= 0.7 * 0.407
    assert np.max(np.abs(run_["u"])) <= 10.0 + 1e-12
    upright = data[-1, 2] - 2 * math.pi * round(data[-1, 2] / (2 * math.pi))
    assert abs(upright) < 1e-3 and abs(data[-1, 1]) < 1e-2 and np.max(np.abs(data[-1, 3:5])) < 1e-2
