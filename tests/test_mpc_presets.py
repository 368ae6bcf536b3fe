"""The MPC presets (issue 47): scenes/rigs/qube_servo2_mpc.toml (the QUBE-Servo 2 in volts, ±10 V,
encoders + Kalman filter, the identified damping) and scenes/cdip_mpc.toml (the cart double
pendulum, ±20 N, rail ±1 m) balance from their tilted, moving starts within their constraints:
|u| within its bound and the base within its travel at every sample, every step's status ok,
upright and nearly at rest at the end; scenes/rigs/qube_servo2_mpc_swingup.toml swings the QUBE up
from hanging by energy control and catches and holds it by MPC within ±10 V and the arm's travel."""

from __future__ import annotations

import io
from contextlib import redirect_stderr, redirect_stdout
from pathlib import Path

import numpy as np
import pytest

from ipgen.command.cli import run

ROOT = Path(__file__).resolve().parent.parent


@pytest.mark.parametrize(
    ("scene", "u_max", "travel", "tilt"),
    [("rigs/qube_servo2_mpc", 10.0, 1.0, 0.3), ("cdip_mpc", 20.0, 1.0, 0.02)],
    ids=["qube_servo2_mpc", "cdip_mpc"],
)
def test_preset_balances_within_its_constraints(
    tmp_path: Path, scene: str, u_max: float, travel: float, tilt: float
) -> None:
    with redirect_stdout(io.StringIO()) as out, redirect_stderr(io.StringIO()) as err:
        assert run(["run", str(ROOT / "scenes" / f"{scene}.toml"), "-o", str(tmp_path), "--no-plot"]) == 0, (
            err.getvalue()
        )
    assert "every status ok" in out.getvalue()
    header, *rows = next(tmp_path.glob("*.csv")).read_text().splitlines()
    names = header.split(",")
    data = np.array([[float(v) for v in row.split(",")] for row in rows])
    column = {name: data[:, i] for i, name in enumerate(names)}
    links = [name for name in names if name.startswith("theta") and name != "theta0"]
    assert np.max(np.abs(column["u"])) <= u_max * (1 + 1e-12) and np.max(np.abs(column["u"])) > 0.9 * u_max
    assert np.max(np.abs(column["theta0"])) <= travel and np.max(np.abs(column["theta0"])) > 0.7 * travel
    assert max(abs(column[name][0]) for name in links) >= tilt
    assert all(abs(column[name][-1]) < 0.01 for name in links)
    assert abs(column["theta0"][-1]) < 0.05 and abs(column["dtheta0"][-1]) < 0.1


def test_qube_swing_up_caught_by_mpc_within_its_constraints(tmp_path: Path) -> None:
    scene = ROOT / "scenes" / "rigs" / "qube_servo2_mpc_swingup.toml"
    with redirect_stdout(io.StringIO()) as out, redirect_stderr(io.StringIO()) as err:
        assert run(["run", str(scene), "-o", str(tmp_path), "--no-plot"]) == 0, err.getvalue()
    summary = out.getvalue()
    assert "every status ok" in summary and "hold (MPC) from t = " in summary
    header, *rows = next(tmp_path.glob("*.csv")).read_text().splitlines()
    names = header.split(",")
    phase = np.array([row.rsplit(",", 1)[1] for row in rows])
    data = np.array([[float(v) for v in row.split(",")[:-1]] for row in rows])
    column = {name: data[:, i] for i, name in enumerate(names[:-1])}
    t, arm, link, u = column["t"], column["theta0"], column["theta1"], column["u"]
    assert link[0] == pytest.approx(np.pi) and column["dtheta1"][0] == 0.0  # hanging at rest
    # |u| <= 10 V at every sample (on its bound in the swing), the arm within its ±1 rad travel
    assert np.max(np.abs(u)) <= 10.0 * (1 + 1e-12) and np.max(np.abs(u)) > 9.9
    assert np.max(np.abs(arm)) <= 1.0
    # caught by the MPC, then held upright (θ1 = 2πk) for the scene's 5 s: the run ends there
    hold = phase == "hold"
    assert hold.any() and hold[np.argmax(hold) :].all()
    caught = t[np.argmax(hold)]
    assert caught < 3.0 and t[-1] == pytest.approx(caught + 5.0, abs=1e-9)
    upright = link - 2 * np.pi * np.round(link[-1] / (2 * np.pi))
    last = t >= t[-1] - 1.0
    assert np.max(np.abs(upright[last])) < 0.02 and abs(upright[-1]) < 0.01
    assert np.max(np.abs(arm[last])) < 0.05
