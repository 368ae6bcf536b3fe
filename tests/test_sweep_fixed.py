"""`ipgen sweep` of fixed-pivot chains (issue 46): the pendubot's swing-up over a link's mass,
the nominal design kept, the torque bound, and what fixed scenes do not take yet, in one line.

The runs are the preset pendubot_swingup's (its simulator is built by tests/test_fixed_swingup.py
too, through the shared cache); its plan is read from the shipped CSV, not planned."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import pytest
from cxx import require_toolchain

import ipgen
from ipgen.common.presets import preset_path
from ipgen.errors import Error
from ipgen.sweeps import fixed
from ipgen.sweeps.spec import SweepError
from ipgen.sweeps.success import Success

NOMINAL_M2 = 0.6255677234174437  # the preset's second link [kg]


def test_a_fixed_sweep_runs_scores_and_plots(tmp_path: Path) -> None:
    """The nominal mass swings up and holds (the leaderboard's tolerance over the last second,
    |u| <= 6 N m); a second link of 0.4 kg loses the plan (the simulator's tracking check)."""
    require_toolchain()
    outcome = ipgen.sweep(
        preset_path("pendubot_swingup"), tmp_path / "out", vary=[f"parameters.m[1]=0.4,{NOMINAL_M2}"], jobs=1
    )
    rows = list(csv.DictReader((tmp_path / "out" / "runs.csv").open()))
    assert [(row["outcome"], row["reason"]) for row in rows] == [("fail", "lost the plan"), ("pass", "")]
    assert float(rows[1]["angle_error"]) < 1e-6 and float(rows[1]["max_travel"]) == 0.0
    assert outcome.score == 0.5
    names = {path.name for path in outcome.files}
    assert {"runs.csv", "scores.md", "criterion_grid.png", "scores.png"} <= names
    assert "a run also fails when a torque exceeds its bound" in (tmp_path / "out" / "scores.md").read_text()


def test_a_run_keeps_the_nominal_design_and_the_plain_run_is_ipgen_runs(tmp_path: Path) -> None:
    """Without overrides a run's config is `ipgen run`'s, line for line; with a plant override
    only the chain changes, the swing-up's lines (plan, TVLQR gains, hold) stay the nominal's."""
    scene = fixed.prepare(fixed.load_fixed(preset_path("pendubot_swingup")))
    path = scene.path
    assert fixed.run_config(scene, path, ()) == scene.plan.cfg
    heavier = fixed.run_config(scene, path, (("parameters.m[1]", 0.7),))
    assert "m = 0.5234602302310271 0.7" in heavier.splitlines()
    assert [line for line in heavier.splitlines() if fixed._is_design(line)] == list(scene.design)
    assert any(line.startswith("swingup.gains = ") for line in scene.design)
    assert fixed.designs((("swingup.u_max", 5.0),)) and not fixed.designs((("parameters.m[1]", 0.7),))


def test_a_torque_beyond_its_bound_fails_the_run(tmp_path: Path) -> None:
    """A trajectory on the goal throughout, one torque sample 6.5 N m against a bound of 6 N m."""
    t = np.linspace(0.0, 2.0, 201)
    u = np.where(t == t[50], 6.5, 1.0)
    table = np.column_stack(
        [t, np.full_like(t, np.pi), np.zeros_like(t), np.zeros_like(t), np.zeros_like(t), u]
    )
    path = tmp_path / "run.csv"
    np.savetxt(path, table, delimiter=",", header="t,theta0,theta1,dtheta0,dtheta1,u", comments="")
    cfg = "swingup.u_max = 6\nswingup.target = 3.141592653589793 0 0 0\n"
    verdict = fixed.judge_run(Success(), path, cfg, 2, 0)
    assert not verdict.passed and verdict.reason == "exceeded the torque bound (6.5 > 6 N m)"
    verdict = fixed.judge_run(Success(), path, cfg.replace("= 6\n", "= 7\n"), 2, 0)
    assert verdict.passed and verdict.angle_error == 0.0


def test_each_torque_is_held_to_its_own_saturation(tmp_path: Path) -> None:
    """An LQR with saturations 4 and 6 N m (one per joint): 5 N m on the first input fails the run
    though it is below the larger bound; within both bounds it passes."""
    t = np.linspace(0.0, 2.0, 201)
    u1 = np.where(t == t[50], 5.0, 1.0)
    states = np.zeros((len(t), 4))
    path = tmp_path / "run.csv"
    header = "t,theta0,theta1,dtheta0,dtheta1,u1,u2"
    np.savetxt(path, np.column_stack([t, states, u1, u1]), delimiter=",", header=header, comments="")
    cfg = "controller.equilibrium = 0 0 0 0\ncontroller.saturation = 4 6\n"
    verdict = fixed.judge_run(Success(), path, cfg, 2, 0)
    assert not verdict.passed and verdict.reason == "exceeded the torque bound (5 > 4 N m)"
    assert fixed.judge_run(Success(), path, cfg.replace("= 4 6", "= 5.5 6"), 2, 0).passed


@pytest.mark.parametrize(
    ("options", "message"),
    [
        ({"scorecard": ["delay"]}, "'delay' is not yet supported for fixed-pivot chains"),
        ({"vary": ["sensors.noise=0:0.01:3"]}, r"takes keys of \[parameters\], .*, not \[sensors\]"),
        ({"vary": ["actuator.joints=1,2"]}, r"\[actuator\] of a fixed-pivot scene's sweep has Ir, gr"),
        ({"vary": ["parameters.m[2]=0.5,0.6"]}, r"parameters.m has 2 entries \(indices 0..1\)"),
        ({"vary": ["parameters.m[0]=0.5,0.6"]}, "or .swingup.: a sweep judges a closed loop"),
        (
            {"vary": ["controller.saturation=3,4"]},
            r"controller.saturation: the scene has no \[controller\] \(its loop is its \[swingup\]",
        ),
    ],
)
def test_what_a_fixed_sweep_does_not_take_is_one_line(tmp_path: Path, options: dict, message: str) -> None:
    scene = preset_path("dfki_c1" if "closed loop" in message else "acrobot_swingup")
    with pytest.raises(Error, match=message) as caught:
        ipgen.sweep(scene, tmp_path / "out", **options)
    assert "\n" not in str(caught.value)
    assert not (tmp_path / "out").exists()


def test_the_fixed_scorecard_runs_the_model_criteria_and_refuses_the_others_by_name() -> None:
    scene = fixed.load_fixed(preset_path("acrobot_swingup"))
    found = {c.name: c for c in fixed.fixed_criteria(scene, levels={"mass": "0.9,1.1"})}
    assert [name for name, c in found.items() if not c.refused] == list(fixed.SUPPORTED)
    assert found["delay"].refused.startswith("not yet supported for fixed-pivot chains")
    assert found["mass"].levels[1].overrides == (
        ("parameters.m", [0.5234602302310271 * 1.1, NOMINAL_M2 * 1.1]),
    )
    assert found["period"].levels[0].overrides == (("swingup.period", 0.0005),)
    with pytest.raises(SweepError, match="needs a scene with a"):
        fixed.fixed_criteria(fixed.load_fixed(preset_path("dfki_c1")))
