"""`ipgen sweep --random N`: random starts with the parameters spread (issue 47's 1,000 starts).

Checked: every draw within its stated range and reproducible from the run's seed, the hanging and
near-upright starts alternating, the draws written in a rig's own coordinates when the scene uses
them; a run of the paper's RSIP under LQR, whose hanging starts it cannot swing up (fail) and whose
near-upright starts it catches (pass), so that the score is the fraction of runs that pass; bad
counts and spreads refused in one line before anything is written (hypothesis).
"""

from __future__ import annotations

import csv
import io
import json
import math
from contextlib import redirect_stderr, redirect_stdout
from pathlib import Path

import numpy as np
import pytest
from cxx import require_toolchain
from hypothesis import given, settings
from hypothesis import strategies as st
from test_sweep import SCENE

from ipgen.command.cli import run
from ipgen.experiment.scene import load_scene
from ipgen.sweeps import scorecard
from ipgen.sweeps.spec import SweepError

ROOT = Path(__file__).resolve().parents[1]
QUBE_SWINGUP = ROOT / "scenes" / "rigs" / "qube_servo2_mpc_swingup.toml"


def _overrides(level: object) -> dict[str, object]:
    return dict(level.overrides)  # type: ignore[attr-defined]


@pytest.mark.parametrize("positive", ["clockwise", "counterclockwise"])
def test_the_draws_are_in_their_ranges_and_reproducible(tmp_path: Path, positive: str) -> None:
    text = QUBE_SWINGUP.read_text()
    if positive == "counterclockwise":  # Quanser's α: the draws are written in the rig's angles
        text = text.replace('name = "qube_servo2_mpc_swingup"', 'name = "q"\npositive = "counterclockwise"')
    path = tmp_path / "q.toml"
    path.write_text(text)
    scene = load_scene(path)
    sign = -1.0 if positive == "counterclockwise" else 1.0
    first = scorecard.random_starts(scene, 40, 0.2, seed=7)
    again = scorecard.random_starts(scene, 40, 0.2, seed=7)
    other = scorecard.random_starts(scene, 40, 0.2, seed=8)
    assert first == again and first.levels != other.levels and len(first.levels) == 40
    nominal_m, nominal_delta = np.array([0.095, 0.024]), np.array([5e-6, 1e-6])
    for i, level in enumerate(first.levels):
        drawn = _overrides(level)
        for key, nominal in (("parameters.m", nominal_m), ("parameters.delta", nominal_delta)):
            ratio = np.array(drawn[key]) / nominal
            assert np.all(np.abs(ratio - 1.0) <= 0.2 + 1e-12), (key, ratio)
        assert abs(drawn["actuator.Rm"] / 8.4 - 1.0) <= 0.2 + 1e-12
        theta, dtheta = np.array(drawn["initial.theta"]), np.array(drawn["initial.dtheta"])
        assert abs(theta[0]) <= 0.1 and dtheta[0] == 0.0
        link = sign * theta[1]  # ipgen's angle of the link
        if i % 2 == 0:  # hanging, at rest
            assert abs(link - math.pi) <= 0.1 and dtheta[1] == 0.0
        else:  # near upright
            assert abs(link) <= 0.2 and abs(dtheta[1]) <= 0.5


def test_the_score_is_the_fraction_of_starts_that_end_upright(tmp_path: Path) -> None:
    """RSIP under a sampled LQR (no swing-up): every start near upright (a balance scene is not
    started hanging, where it fails by construction), the score the fraction of runs that pass,
    recomputed from the table; the draw replaces the scene's own start (a scene tilted to 1.2 rad,
    out of the LQR's reach, is caught from its drawn start)."""
    require_toolchain()
    scene = tmp_path / "rsip.toml"
    scene.write_text(SCENE)
    nominal = load_scene(scene)
    assert all(
        abs(_overrides(level)["initial.theta"][1]) <= 0.2
        for level in scorecard.random_starts(nominal, 9, 0.2, 3).levels
    )
    out = tmp_path / "out"
    with redirect_stdout(io.StringIO()) as printed, redirect_stderr(io.StringIO()) as err:
        assert run(["sweep", str(scene), "--random", "5", "--seed", "3", "-o", str(out)]) == 0, err.getvalue()
    rows = list(csv.DictReader((out / "runs.csv").open()))
    assert [row["criterion"] for row in rows] == ["random"] * 5
    passed = [row["outcome"] == "pass" for row in rows]
    scores = json.loads((out / "scores.json").read_text())
    assert scores["score"] == pytest.approx(sum(passed) / 5) and sum(passed) >= 4
    assert f"score {round(100 * sum(passed) / 5)} %" in printed.getvalue()
    far = scene.read_text().replace("theta = [0, 0.1]", "theta = [0, 1.2]")
    scene.write_text(far)
    with redirect_stdout(io.StringIO()), redirect_stderr(io.StringIO()):
        assert run(["sweep", str(scene), "--random", "1", "--spread", "0", "-o", str(tmp_path / "far")]) == 0
    row = next(csv.DictReader((tmp_path / "far" / "runs.csv").open()))
    assert row["outcome"] == "pass", "the draw replaces the scene's start (near upright again)"


def test_a_specialised_scene_refuses_random_starts(tmp_path: Path) -> None:
    scene = tmp_path / "rsip.toml"
    scene.write_text(SCENE.replace('name = "rsip"', 'name = "rsip"\nspecialise = true'))
    with pytest.raises(SweepError, match="specialised scene compiles in: set specialise = false"):
        scorecard.random_starts(load_scene(scene), 4, 0.2, 0)


@settings(max_examples=30, deadline=None)
@given(
    count=st.one_of(st.integers(max_value=0), st.integers(min_value=1, max_value=5)),
    spread=st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.sampled_from([-0.1, 1.0, 0.2])),
)
def test_bad_counts_and_spreads_are_one_line_errors(count: int, spread: float) -> None:
    scene = load_scene(QUBE_SWINGUP)
    good = count >= 1 and 0.0 <= spread < 1.0
    if good:
        assert len(scorecard.random_starts(scene, count, spread, seed=0).levels) == count
        return
    with pytest.raises(SweepError) as info:
        scorecard.random_starts(scene, count, spread, seed=0)
    message = str(info.value)
    assert "\n" not in message and ("--random" in message or "--spread" in message), message
