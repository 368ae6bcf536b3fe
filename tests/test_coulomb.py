"""Coulomb friction (`[parameters] coulomb`, `coulomb_speed`): the simulator's smooth law
f = c tanh(w / v_s) on the rates the viscous damping acts on (θ̇0, θ̇1, θ̇i − θ̇(i−1)).

Checked against Kane's equations (sympy.physics.mechanics, tests/independent_model.py) with the
friction torques applied by hand (a joint's torque on link i and its reaction on link i − 1),
integrated by scipy; the dissipated energy the summary reports against the independent integral
of Σ c w tanh(w/v_s); the energy balance; and that the friction is excluded from linearisation.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from cxx import require_toolchain
from independent_model import reference
from scipy.integrate import solve_ivp

from ipgen.errors import SceneError
from ipgen.experiment.config import resolved_config
from ipgen.experiment.scene import load_scene

SCENE = """\
[system]
type = "classical"
links = 2
name = "fric2"

[parameters]
m = [0.5, 0.2, 0.15]
l = [0, 0.4, 0.3]
delta = [0.1, 0.001, 0.001]
coulomb = [0.3, 0.004, 0.002]
coulomb_speed = 0.02

[initial]
theta = [0, 2.5, 2.0]
dtheta = [0.5, 0, 1]

[outputs]
energy = true

[simulation]
t_end = 2
"""
C, VS = np.array([0.3, 0.004, 0.002]), 0.02


def friction(qd: np.ndarray) -> tuple[np.ndarray, float]:
    """(Q, dissipated power) of the tanh law, written out joint by joint."""
    w = np.array([qd[0], qd[1], qd[2] - qd[1]])
    f = C * np.tanh(w / VS)
    q = np.array([-f[0], -f[1] + f[2], -f[2]])  # joint 2 acts on link 2, reacts on link 1
    return q, float(np.dot(f, w))


def independent() -> tuple[np.ndarray, float]:
    model = reference("classical", 2, "pivot")
    params = ([0.5, 0.2, 0.15], [0.0, 0.4, 0.3], [0.1, 0.001, 0.001], 9.81)

    def f(_: float, y: np.ndarray) -> np.ndarray:
        x = y[:6]
        mass = np.asarray(model.mass_matrix(x[:3], x[3:], 0.0, params), float)
        forcing = np.asarray(model.forcing(x[:3], x[3:], 0.0, params), float).reshape(-1)
        q, power = friction(x[3:])
        return np.concatenate([x[3:], np.linalg.solve(mass, forcing + q), [power]])

    y0 = np.array([0.0, 2.5, 2.0, 0.5, 0.0, 1.0, 0.0])
    sol = solve_ivp(f, (0.0, 2.0), y0, method="LSODA", rtol=1e-11, atol=1e-12)
    return sol.y[:6, -1], float(sol.y[6, -1])


def test_coulomb_run_against_kane_and_its_energy(tmp_path: Path) -> None:
    require_toolchain()
    scene = tmp_path / "fric.toml"
    scene.write_text(SCENE)
    env = dict(os.environ)  # the run's shared simulator cache (tests/conftest.py)
    result = subprocess.run(
        [sys.executable, "-m", "ipgen", "run", str(scene), "-o", str(tmp_path / "out"), "--no-plot"],
        capture_output=True,
        text=True,
        env=env,
    )
    assert result.returncode == 0, result.stderr
    last = (tmp_path / "out" / "fric.csv").read_text().splitlines()[-1].split(",")
    state = np.array([float(v) for v in last[1:7]])
    expected, dissipated = independent()
    assert np.allclose(state, expected, atol=1e-6), (state, expected)
    summary = (tmp_path / "out" / "fric.txt").read_text()
    reported = float(re.search(r"Coulomb friction .*?dissipated ([0-9.e+-]+) J", summary).group(1))
    assert dissipated > 0.05  # the friction did something
    assert reported == pytest.approx(dissipated, rel=1e-6)
    error = float(re.search(r"balance error ([0-9.e+-]+) J", summary).group(1))
    assert abs(error) < 1e-7


def test_coulomb_is_not_linearised_and_goes_to_the_config(tmp_path: Path) -> None:
    with_friction = tmp_path / "a.toml"
    without = tmp_path / "b.toml"
    base = SCENE.replace("coulomb = [0.3, 0.004, 0.002]\ncoulomb_speed = 0.02\n", "")
    controller = '[controller]\nkind = "lqr"\n'
    without.write_text(base.replace("[outputs]\nenergy = true\n", "") + controller)
    with_friction.write_text(SCENE.replace("[outputs]\nenergy = true\n", "") + controller)
    a, b = load_scene(with_friction), load_scene(without)
    assert a.controller is not None and b.controller is not None
    assert a.controller.gain == b.controller.gain
    config = resolved_config(a)
    assert "coulomb = 0.3 0.004 0.002\n" in config and "coulomb_speed = 0.02\n" in config
    assert "\ncoulomb" not in resolved_config(b)


@pytest.mark.parametrize(
    ("line", "message"),
    [
        ("coulomb = [0.3, -0.1, 0]", "parameters.coulomb[1] = -0.1: friction must be >= 0"),
        ("coulomb = [0.3, 0.1]", "parameters.coulomb has 2 entries, expected 3"),
        ("coulomb_speed = 0", "parameters.coulomb_speed = 0: must be > 0"),
    ],
)
def test_bad_coulomb_is_one_line(tmp_path: Path, line: str, message: str) -> None:
    scene = tmp_path / "bad.toml"
    text = SCENE.replace("coulomb = [0.3, 0.004, 0.002]\ncoulomb_speed = 0.02\n", line + "\n")
    scene.write_text(text)
    with pytest.raises(SceneError, match=re.escape(message)) as caught:
        load_scene(scene)
    assert "\n" not in str(caught.value)
