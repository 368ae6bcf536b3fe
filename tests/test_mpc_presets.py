"""The MPC presets (issue 47): scenes/rigs/qube_servo2_mpc.toml (the QUBE-Servo 2 in volts, ±10 V,
encoders + Kalman filter, the identified damping) and scenes/cdip_mpc.toml (the cart double
pendulum, ±20 N, rail ±1 m) balance from their tilted, moving starts within their constraints:
|u| within its bound and the base within its travel at every sample, every step's status ok,
upright and nearly at rest at the end; scenes/rigs/qube_servo2_mpc_swingup.toml (and its
_ekf and _fast variants) swings the QUBE up from hanging by energy control and catches and holds it
by MPC within ±10 V and the arm's travel;
scenes/cdip_mpc_track.toml swings the cart double pendulum up by MPC along a plan within its rail
(and the same plan tracked by time-varying LQR leaves it)."""

from __future__ import annotations

import io
import math
import re
import tomllib
from collections.abc import Callable
from contextlib import redirect_stderr, redirect_stdout
from pathlib import Path

import numpy as np
import pytest
from run_csv import read_run_csv

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
    run_ = read_run_csv(next(tmp_path.glob("*.csv")), phase=False)
    names, column = run_.names, run_.columns()
    links = [name for name in names if name.startswith("theta") and name != "theta0"]
    assert np.max(np.abs(column["u"])) <= u_max * (1 + 1e-12) and np.max(np.abs(column["u"])) > 0.9 * u_max
    assert np.max(np.abs(column["theta0"])) <= travel and np.max(np.abs(column["theta0"])) > 0.7 * travel
    assert max(abs(column[name][0]) for name in links) >= tilt
    assert all(abs(column[name][-1]) < 0.01 for name in links)
    # held over the last second: the base near its centre and its rate small in RMS, not at the last
    # sample alone (the QUBE's encoders, 3.07 mrad a count, keep its hold in a limit cycle whose rate
    # at one sample differs between machines: 0.16 rad/s on one, below 0.1 on another, same commit)
    last = column["t"] > column["t"][-1] - 1.0
    assert np.max(np.abs(column["theta0"][last])) < 0.05
    assert np.sqrt(np.mean(column["dtheta0"][last] ** 2)) < 0.15


SWINGUP = ROOT / "scenes" / "rigs" / "qube_servo2_mpc_swingup.toml"


def _swing_up(scene: Path, folder: Path) -> tuple[str, dict[str, np.ndarray], np.ndarray]:
    """(the summary, the CSV's numeric columns, its phase column) of `ipgen run` of `scene`."""
    with redirect_stdout(io.StringIO()) as out, redirect_stderr(io.StringIO()) as err:
        assert run(["run", str(scene), "-o", str(folder), "--no-plot"]) == 0, err.getvalue()
    run_ = read_run_csv(next(folder.glob("*.csv")), phase=True)
    return out.getvalue(), run_.columns(), np.array(run_.phase)


Run = tuple[str, dict[str, np.ndarray], np.ndarray]


@pytest.fixture(scope="module")
def rti_swing_up(tmp_path_factory: pytest.TempPathFactory) -> Callable[[str], Run]:
    """Each QUBE swing-up preset's run (real-time iteration), made once and shared by the tests below."""
    runs: dict[str, Run] = {}

    def of(preset: str) -> Run:
        if preset not in runs:
            runs[preset] = _swing_up(SWINGUP.with_name(f"{preset}.toml"), tmp_path_factory.mktemp(preset))
        return runs[preset]

    return of


@pytest.mark.parametrize(
    "preset",
    [
        "qube_servo2_mpc_swingup",
        "qube_servo2_mpc_swingup_ekf",
        "qube_servo2_mpc_swingup_fast",
        "qube_servo2_mpc_swingup_m4f",
        "qube_servo2_mpc_swingup_delay",  # 20 ms of delay, the laws on the predicted estimate
    ],
)
def test_qube_swing_up_caught_by_mpc_within_its_constraints(
    preset: str, rti_swing_up: Callable[[str], Run]
) -> None:
    """Each QUBE swing-up preset from hanging at rest: |u| within 10 V (on it in the swing), the arm
    within its travel, caught by the MPC before 3 s and held upright for the scene's 5 s."""
    summary, column, phase = rti_swing_up(preset)
    assert "every status ok" in summary and "hold (MPC) from t = " in summary
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


def _hold_cost(
    column: dict[str, np.ndarray], phase: np.ndarray, q: list[float], r: float, period: float
) -> float:
    """The closed loop's cost from the catch on: x'Qx + r u² at each MPC sample (every `period`
    s), the pendulum's angle taken from the upright it was caught at (θ1 − 2πk)."""
    t = column["t"]
    first = int(np.argmax(phase == "hold"))
    samples = np.arange(first, len(t), round(period / (t[1] - t[0])))
    x = np.column_stack([column[name][samples] for name in ("theta0", "theta1", "dtheta0", "dtheta1")])
    x[:, 1] -= 2 * np.pi * np.round(x[:, 1] / (2 * np.pi))
    u = column["u"][samples]
    return float(np.sum(x**2 @ np.asarray(q)) + r * np.sum(u**2))


def _converged(scene: Path, folder: Path) -> tuple[dict, Run]:
    """(the [controller] table, the run) of `scene` with its MPC iterated to convergence at every
    sample (mode = "converged"), run into folder/out; every step ok."""
    text = scene.read_text()
    converged = folder / f"{scene.stem}_converged.toml"
    converged.write_text(re.sub(r"\nhorizon = ", '\nmode = "converged"\nhorizon = ', text, count=1))
    run = _swing_up(converged, folder / "out")
    assert "converged" in run[0] and "every status ok" in run[0]
    return tomllib.loads(text)["controller"], run


@pytest.mark.parametrize("preset", ["qube_servo2_mpc_swingup", "qube_servo2_mpc_swingup_ekf"])
def test_qube_swing_up_rti_costs_what_the_converged_mode_costs(
    preset: str, rti_swing_up: Callable[[str], Run], tmp_path: Path
) -> None:
    """Issue 47's bound: the real-time iteration's closed-loop cost over the swing-up (from the
    catch, which the energy law makes the same in both) within 5 % of the same scene's with the
    MPC iterated to convergence (mode = "converged") at every sample; for both QUBE presets."""
    rti_run = rti_swing_up(preset)
    controller, (_, column, phase) = _converged(SWINGUP.with_name(f"{preset}.toml"), tmp_path)
    weights = (controller["q"], controller["r"], controller["period"])
    rti, full = _hold_cost(*rti_run[1:], *weights), _hold_cost(column, phase, *weights)
    catch = rti_run[1]["t"][int(np.argmax(rti_run[2] == "hold"))]
    assert column["t"][int(np.argmax(phase == "hold"))] == catch  # the same swing
    assert abs(rti / full - 1) <= 0.05, (rti, full)


def test_the_cart_swung_up_along_its_plan_is_caught_by_mpc_within_its_rail(tmp_path: Path) -> None:
    """scenes/cdip_mpc_swingup.toml: the plan (cart within ±0.9 m) tracked from hanging, the MPC
    catching at the plan's end: |F| <= 50 N and the cart inside its ±1 m rail at every sample
    (the run would stop at the rail), every MPC step ok, both links upright and at rest at the end."""
    summary, column, phase = _swing_up(ROOT / "scenes" / "cdip_mpc_swingup.toml", tmp_path)
    assert "every status ok" in summary and "hold (MPC) from t = " in summary
    assert column["theta1"][0] == pytest.approx(np.pi) and column["theta2"][0] == pytest.approx(np.pi)
    assert np.max(np.abs(column["u"])) <= 50.0 * (1 + 1e-12) and np.max(np.abs(column["u"])) > 40
    assert np.max(np.abs(column["theta0"])) <= 1.0 and np.max(np.abs(column["theta0"])) > 0.85
    assert "track" in phase and phase[-1] == "hold"
    for link in ("theta1", "theta2"):
        assert abs(math.remainder(column[link][-1], 2 * math.pi)) < 1e-3
        assert abs(column["d" + link][-1]) < 1e-2
    assert abs(column["theta0"][-1]) < 1e-2


TRACK = ROOT / "scenes" / "cdip_mpc_track.toml"


@pytest.fixture(scope="module")
def tracked(tmp_path_factory: pytest.TempPathFactory) -> tuple[Run, Path]:
    """scenes/cdip_mpc_track.toml's run (real-time iteration) and its folder, made once."""
    folder = tmp_path_factory.mktemp("cdip_mpc_track")
    return _swing_up(TRACK, folder), folder


def _plan(folder: Path) -> tuple[np.ndarray, np.ndarray]:
    """(states (K+1) × 6, inputs K) of the plan the run's resolved .cfg holds."""
    values = {}
    for line in next(folder.glob("*.cfg")).read_text().splitlines():
        key, _, value = line.partition("=")
        if key.strip() in ("swingup.states", "swingup.inputs"):
            values[key.strip()] = np.array([float(v) for v in value.split()])
    return values["swingup.states"].reshape(-1, 6), values["swingup.inputs"]


def _tracking_cost(
    column: dict[str, np.ndarray], folder: Path, q: list[float], r: float, every: int
) -> float:
    """The closed loop's cost about the plan, at each MPC sample (every `every` plan samples from
    t = 0): (x − x̄)'Q(x − x̄) + r (u − ū)², x̄ the plan's state there (its target after its end), ū
    the plan's mean input over the sample (0 after its end): what the MPC's stage cost weighs."""
    states, inputs = _plan(folder)
    steps = len(inputs)
    names = ("theta0", "theta1", "theta2", "dtheta0", "dtheta1", "dtheta2")
    x = np.column_stack([column[n] for n in names])
    cost = 0.0
    for k in range(0, len(column["t"]) - 1, every):
        reference = states[min(k, steps)]
        u_ref = sum(inputs[m] for m in range(k, k + every) if m < steps) / every
        e = x[k] - reference
        cost += float(e**2 @ np.asarray(q)) + r * (column["u"][k] - u_ref) ** 2
    return cost


def test_the_cart_is_swung_up_by_the_mpc_tracking_its_plan_within_the_rail(tracked: tuple[Run, Path]) -> None:
    """scenes/cdip_mpc_track.toml: the plan uses the whole ±1 m rail and the MPC tracks it from
    hanging (its reference per stage), then holds: |F| <= 50 N and the cart inside its soft ±0.98 m
    (+ 1 mm) at every sample, every MPC step ok, both links upright and at rest at the end."""
    (summary, column, phase), folder = tracked
    assert "every status ok" in summary and "planned trajectory tracked by the MPC" in summary
    assert "hold (MPC) from t = 3 s" in summary
    assert column["theta1"][0] == pytest.approx(np.pi) and column["theta2"][0] == pytest.approx(np.pi)
    assert np.max(np.abs(column["u"])) <= 50.0 * (1 + 1e-12) and np.max(np.abs(column["u"])) > 45
    assert np.max(np.abs(_plan(folder)[0][:, 0])) > 0.99  # the plan reaches the rail's end
    assert 0.95 < np.max(np.abs(column["theta0"])) <= 0.981  # the MPC keeps the cart inside
    assert phase[0] == "track" and phase[-1] == "hold"
    assert all(abs(column[name][-1]) < 1e-3 for name in ("theta0", "theta1", "theta2", "dtheta1", "dtheta2"))


def test_the_same_plan_tracked_by_time_varying_lqr_leaves_the_rail(tmp_path: Path) -> None:
    """Without `tracking = "mpc"` the plan's gains track it, knowing nothing of the rail: the
    cart passes the rail's end and the simulator stops the run (why the MPC tracks here)."""
    scene = tmp_path / "lqr.toml"
    scene.write_text(TRACK.read_text().replace('tracking = "mpc"', ""))
    with redirect_stdout(io.StringIO()), redirect_stderr(io.StringIO()) as err:
        assert run(["run", str(scene), "-o", str(tmp_path / "out"), "--no-plot"]) != 0
    assert "travel" in err.getvalue(), err.getvalue()


def test_the_tracking_rti_costs_what_the_converged_mode_costs(
    tracked: tuple[Run, Path], tmp_path: Path
) -> None:
    """Issue 47's bound on the cart's swing-up: the real-time iteration's closed-loop cost about
    the plan (from hanging, the whole run) within 5 % of the same scene's with the MPC iterated to
    convergence at every sample."""
    (_, column, _), folder = tracked
    controller, (_, full_column, _) = _converged(TRACK, tmp_path)
    every = round(controller["period"] / 0.01)
    rti = _tracking_cost(column, folder, controller["q"], controller["r"], every)
    full = _tracking_cost(full_column, tmp_path / "out", controller["q"], controller["r"], every)
    assert abs(rti / full - 1) <= 0.05, (rti, full)
