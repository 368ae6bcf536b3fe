"""`ipgen sweep` / `ipgen.sweep`: robustness scorecards and grids of scene keys.

The runs use the paper's rotary single pendulum under a sampled LQR (one simulator compile, shared
with every other test of model rsip through ipgen's cache), integrated with rk4 for short runs so
that the whole file takes seconds. Checked independently: the plant a sweep simulates (a scaled
mass, the nominal controller) against Kane's equations (tests/independent_model.py) integrated by
scipy with the same zero-order hold; the success test on trajectories written by hand; the scores
recomputed from the table; a Dask LocalCluster's table against the local pool's.
"""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import numpy as np
import pytest
from cxx import require_toolchain
from hypothesis import event, example, given, settings
from hypothesis import strategies as st

import ipgen
from ipgen.command.cli import run
from ipgen.experiment.scene import load_scene
from ipgen.sweeps import spec
from ipgen.sweeps.spec import SweepError, parse_key, parse_levels, parse_vary
from ipgen.sweeps.success import Success, judge
from ipgen.sweeps.table import RESULT

ROOT = Path(__file__).resolve().parents[1]
SCENE = """\
[system]
type = "rotary"
links = 1
name = "rsip"

[parameters]
m = [0.5, 0.275]
l = [0.6, 0.5]
delta = [0.3, 0.011458]

[initial]
theta = [0, 0.1]

[controller]
kind = "lqr"
q = [1, 1, 1, 1]
r = 1
saturation = 5.0
period = 0.01

[simulation]
t_end = 2.0
sample = 0.01
method = "rk4"
step = 0.001
"""


@pytest.fixture
def scene(tmp_path: Path) -> Path:
    require_toolchain()
    path = tmp_path / "rsip_sweep.toml"
    path.write_text(SCENE)
    return path


def _rows(folder: Path) -> list[dict[str, str]]:
    with (folder / "runs.csv").open(newline="") as f:
        return list(csv.DictReader(f))


def _results(rows: list[dict[str, str]]) -> list[tuple[str, ...]]:
    """What a run gave (not its wall time)."""
    return [tuple(row[column] for column in RESULT) for row in rows]


# ---------------------------------------------------------------------------- the success test


def test_the_success_test_on_trajectories_written_by_hand() -> None:
    t = np.linspace(0.0, 3.0, 301)
    settled = np.zeros((t.size, 4))
    settled[:, 1] = 0.5 * np.exp(-3 * t)  # the link's angle decays to 0.05 at 0.77 s
    test = Success()
    assert judge(test, t, settled, (0, 0, 0, 0), rotary=True, status=0, travel=None).passed
    turned = settled.copy()
    turned[:, 1] += 2 * math.pi  # a link that turned over once is upright again
    verdict = judge(test, t, turned, (0, 0, 0, 0), rotary=True, status=0, travel=None)
    assert verdict.passed and verdict.angle_error < 1e-3
    late = settled.copy()
    late[t > 2.5, 1] = 0.4  # leaves the 0.35 rad band in the last second, then...
    late[-1, 1] = 0.0  # ...ends on the goal: still a failure
    verdict = judge(test, t, late, (0, 0, 0, 0), rotary=True, status=0, travel=None)
    assert not verdict.passed and verdict.reason == "left the tolerance in the hold time"
    assert judge(Success(hold=0.4), t, late, (0, 0, 0, 0), rotary=True, status=0, travel=None).passed is False
    spinning = settled.copy()
    spinning[:, 3] = 1.5  # the rate tolerance (1 rad/s) counts too
    assert judge(test, t, spinning, (0, 0, 0, 0), rotary=True, status=0, travel=None).reason == (
        "not within the tolerance"
    )
    assert judge(test, t, settled, (0, 0, 0, 0), rotary=True, status=3, travel=None).reason == "diverged"
    wide = settled.copy()
    wide[:, 0] = np.sin(t)  # the base swings to |θ0| = 1 (rad)
    assert judge(test, t, wide, (0, 0, 0, 0), rotary=True, status=0, travel=0.9).reason == "left the travel"
    assert judge(test, t, wide, (0, 0, 0, 0), rotary=True, status=0, travel=1.1).passed
    assert not judge(Success(base=0.1), t, wide, (0, 0, 0, 0), rotary=True, status=0, travel=None).passed
    hanging_goal = (0.0, math.pi, 0.0, 0.0)
    near_pi = settled.copy()
    near_pi[:, 1] = -math.pi + 0.01  # 0.01 rad from π the other way round
    assert judge(test, t, near_pi, hanging_goal, rotary=True, status=0, travel=None).passed


def test_a_balance_run_must_converge_a_swingup_only_reach_the_tolerance() -> None:
    """Issue 49: a link that stays where it started (0.1 rad, inside the leaderboard's 0.35 rad)
    passes the tolerance alone but not as a balance run; a link that settles to a quarter of its
    initial error does; a run that starts on the goal is judged by the tolerance alone."""
    t = np.linspace(0.0, 3.0, 301)
    frozen = np.zeros((t.size, 4))
    frozen[:, 1] = 0.1  # held by friction where it started
    goal = (0.0, 0.0, 0.0, 0.0)
    test = Success()
    assert judge(test, t, frozen, goal, rotary=True, status=0, travel=None).passed  # the tolerance alone
    verdict = judge(test, t, frozen, goal, rotary=True, status=0, travel=None, balance=True)
    assert not verdict.passed and verdict.reason.startswith("did not converge"), verdict
    settling = frozen.copy()
    settling[:, 1] = 0.1 * np.exp(-2 * t)  # 0.1 · e^-4 = 0.0018 rad from t = 2 s on: converged
    assert judge(test, t, settling, goal, rotary=True, status=0, travel=None, balance=True).passed
    halfway = frozen.copy()
    halfway[:, 1] = 0.1 * (0.3 + 0.7 * np.exp(-5 * t))  # settles at 0.03 rad: 0.3 of the start
    assert not judge(test, t, halfway, goal, rotary=True, status=0, travel=None, balance=True).passed
    looser = Success(converge=0.5)
    assert judge(looser, t, halfway, goal, rotary=True, status=0, travel=None, balance=True).passed
    assert "converge" in test.text()
    at_goal = np.zeros((t.size, 4))
    at_goal[t > 1, 1] = 0.01  # starts on the goal: only the tolerance applies
    assert judge(test, t, at_goal, goal, rotary=True, status=0, travel=None, balance=True).passed


def test_scores_md_shows_levels_that_are_not_a_range_as_they_are() -> None:
    """Issue 49: the resolution's levels exact, 8192, …, 64 were shown as "0 … 64"."""
    from ipgen.sweeps import scorecard, scores

    nominal = load_scene(ROOT / "scenes" / "rigs" / "qube_servo2_sensors.toml")
    found = scorecard.criteria(nominal, ("resolution", "mass"), estimator="kalman")
    rows = [
        {"criterion": c.name, "level": str(i), "reason": "diverged" if i == 0 else "",
         "outcome": "fail" if c.name == "resolution" and i == 0 else "pass"}
        for c in found for i in range(len(c.levels))
    ]  # fmt: skip
    text = scores.as_markdown("qube", Success(), scores.score(found, rows), len(rows))
    resolution = next(line for line in text.splitlines() if line.startswith("| resolution"))
    assert "exact, 8192, 4096, 2048, 1024, 512, 256, 128, 64 (9 levels)" in resolution, resolution
    assert "0 … 64" not in resolution and "| exact: diverged |" in resolution
    mass = next(line for line in text.splitlines() if line.startswith("| mass"))
    assert "0.75 … 1.25 (21 levels)" in mass


# A do-nothing controller (K = 0) on the QUBE-Servo 2 as its encoders measure it, with Coulomb
# friction on both joints (5 mN m, more than gravity's 1.5 mN m on the link at 0.1 rad).
ZERO_CONTROLLER = (ROOT / "scenes" / "rigs" / "qube_servo2_sensors.toml").read_text()
ZERO_CONTROLLER = ZERO_CONTROLLER.replace('kind = "lqr"', 'kind = "gain"\ngain = [0, 0, 0, 0]')
ZERO_CONTROLLER = ZERO_CONTROLLER.replace("q = [5, 1, 1, 1]", "").replace("r = 1 ", "# r = 1 ")
ZERO_CONTROLLER = ZERO_CONTROLLER.replace(
    "delta = [0.0015, 0.0005]", "coulomb = [0.005, 0.005]\ndelta = [0.0015, 0.0005]"
)
ZERO_CONTROLLER = ZERO_CONTROLLER.replace("t_end = 5.0", "t_end = 3.0")
# Every criterion at its two ends and one level between (the defaults' 633 runs take minutes).
ENDS = {
    "mass": "0.75,1,1.25", "com": "0.75,1,1.25", "inertia": "0.75,1,1.25", "damping": "0,1,2",
    "coulomb": "0,0.05,0.1", "period": "0.0005,0.001,0.05", "resolution": "0,2048,64",
    "sensor_noise": "0,0.01,0.02", "delay": "0,0.01,0.04", "drive_noise": "0,0.1,0.2",
    "lag": "0,0.025,0.05", "pulses": "0,0.25,0.5",
}  # fmt: skip


def test_a_zero_controller_fails_every_level_of_every_criterion(tmp_path: Path) -> None:
    """Issue 49: on main 1302ddc the Coulomb criterion passed from 0.015 N m on, the link frozen at
    its initial 0.1 rad inside the 0.35 rad tolerance; a balance run must now converge."""
    require_toolchain()
    path = tmp_path / "zero_controller.toml"
    path.write_text(ZERO_CONTROLLER)
    assert "gain = [0, 0, 0, 0]" in ZERO_CONTROLLER and "coulomb = [0.005, 0.005]" in ZERO_CONTROLLER
    out = tmp_path / "card"
    outcome = ipgen.sweep(path, out, scorecard=True, levels=ENDS, repeat=1, jobs=2, plots=False)
    rows = _rows(out)
    assert {row["criterion"] for row in rows} == set(ENDS)  # every criterion ran (an estimator: all)
    passed = [(row["criterion"], row["values"], row["reason"]) for row in rows if row["outcome"] != "fail"]
    assert not passed, passed
    assert outcome.score == 0.0
    frozen = [row for row in rows if row["criterion"] == "coulomb" and row["values"] == "[0.1]"]
    assert float(frozen[0]["angle_error"]) < 0.35  # inside the leaderboard's tolerance, yet failed
    assert frozen[0]["reason"].startswith("did not converge")


# ---------------------------------------------------------------------------- specifications


def test_keys_levels_and_one_line_errors() -> None:
    assert parse_key("parameters.m[1]") == spec.Key("parameters", "m", 1)
    assert parse_key("controller.period").designs
    assert not parse_key("initial.theta[1]").designs
    assert parse_levels("0:1:5", "x") == (0.0, 0.25, 0.5, 0.75, 1.0)
    assert parse_levels("0.1,0.3", "x") == (0.1, 0.3)
    assert parse_levels("2:2:1", "x") == (2.0,)
    for bad, needle in (
        ("parameters.mass=0:1:3", "has no key 'mass'"),
        ("nosuch.m=0:1:3", "unknown table"),
        ("system.links=1,2", "cannot be swept"),
        ("parameters.m[1]=1:2:0", "the range is empty"),
        ("parameters.m[1]=", "no values"),
        ("parameters.m[1]=1,,2", "an empty value"),
        ("parameters.m[1]=1:nan:3", "not a finite number"),
        ("parameters.m[1]", "expected KEY=LO:HI:N"),
        ("m1=0:1:3", "not a scene key"),
    ):
        with pytest.raises(SweepError, match=needle.replace("[", r"\[")) as caught:
            parse_vary(bad)
        assert "\n" not in str(caught.value)


@settings(max_examples=150, deadline=None)
@given(st.text(max_size=60))
def test_any_vary_text_parses_or_is_refused_in_one_line(text: str) -> None:
    try:
        key, levels = parse_vary(text)
    except SweepError as error:
        assert "\n" not in str(error) and len(str(error)) < 400
        return
    assert levels and all(math.isfinite(value) for value in levels)
    assert key.table in spec.schema.TABLES


# Keys a sweep takes (parse_key accepts them), and keys it refuses: the ranges' check must be
# reached (an audit found a random table name refused in 94 % of the draws).
SWEPT_KEYS = (
    "parameters.m[1]", "parameters.delta[0]", "initial.theta[1]", "controller.period", "sensors.delay",
)  # fmt: skip


@settings(max_examples=120, deadline=None)
@example("parameters.m[1]", 1.0, 1.1754943508222875e-38, 2)  # the last level rounded to 0.0
@example("parameters.m[1]", 0.0, 1e308, 4)  # span · i overflowed to inf
@example("parameters.m[1]", -1e308, 1e308, 3)  # span itself overflowed
@given(
    st.one_of(
        st.sampled_from(SWEPT_KEYS),
        st.from_regex(r"[a-z_]{1,12}\.[A-Za-z_]{1,12}(\[[0-9]{1,2}\])?", fullmatch=True),
    ),
    st.one_of(st.floats(-1e3, 1e3), st.floats(allow_nan=True, allow_infinity=True)),
    st.one_of(st.floats(-1e3, 1e3), st.floats(allow_nan=True, allow_infinity=True)),
    st.integers(-3, 30),
)
def test_ranges_over_any_key(key: str, low: float, high: float, count: int) -> None:
    """KEY=LO:HI:N parses exactly when the key is sweepable, LO and HI finite and 1 <= N (N = 1
    only for LO = HI), to N finite levels from LO to HI; else a one-line refusal."""
    valid = (
        key in SWEPT_KEYS
        and math.isfinite(low)
        and math.isfinite(high)
        and (count > 1 or (count == 1 and low == high))
    )
    text = f"{key}={low!r}:{high!r}:{count}"
    try:
        _, levels = parse_vary(text)
    except SweepError as error:
        event("refused")
        assert "\n" not in str(error)
        assert not valid, (text, str(error))
        return
    event("parsed")
    assert valid, text
    assert len(levels) == count and levels[0] == low and math.isclose(levels[-1], high, rel_tol=1e-12)
    assert all(math.isfinite(level) for level in levels), levels


def test_bad_specifications_from_the_command_write_nothing(scene: Path, tmp_path: Path, capsys) -> None:
    out = tmp_path / "out"
    for arguments, needle in (
        (["--vary", "parameters.nope=1:2:3"], "has no key 'nope'"),
        (["--vary", "parameters.m[1]=1:2:0"], "the range is empty"),
        ([], "nothing to sweep"),
        (["--scorecard", "--only", "mass,wind"], "criterion 'wind' is unknown"),
        (["--scorecard", "--criterion", "mass=1:1.2:2", "--criterion", "mass=0.5,0.6"], "given twice"),
        (["--scorecard", "--only", "mass", "--criterion", "damping=0,1"], "damping is not among --only mass"),
        (["--vary", "initial.theta[1]=0,1", "--repeat", "0"], "--repeat 0"),
        (["--vary", "initial.theta[1]=0,1", "--jobs", "0"], "--jobs 0"),
    ):
        status = run(["sweep", str(scene), "-o", str(out), *arguments])
        err = capsys.readouterr().err
        assert status == 2, err
        assert needle in err and err.count("\n") == 1 and "Traceback" not in err
        assert not out.exists()


def test_progress_off_a_terminal_is_plain_lines_with_count_rate_and_time_left() -> None:
    """Issue 49: not on a terminal (a log, CI) click's bar printed only "runs" until the end; now
    a line at most every 10 s and at the end, from a clock stepped by hand (1.8 runs/s)."""
    import io

    from ipgen.command.sweep import _Progress

    now = [0.0]
    out = io.StringIO()
    progress = _Progress(out, every=10.0, clock=lambda: now[0])
    for done in range(634):
        now[0] = done / 1.8
        progress(done, 633)
    lines = out.getvalue().splitlines()
    assert lines[0] == "ipgen: runs 0/633 (0 %)"
    assert lines[1] == "ipgen: runs 18/633 (2 %), 1.8 runs/s, about 5 min 42 s left"  # (633 - 18) / 1.8 s
    assert lines[-1] == "ipgen: runs 633/633 (100 %), 1.8 runs/s, 5 min 52 s"
    assert 30 <= len(lines) <= 37  # one per 10 s of 352 s, and the last


def test_the_command_off_a_terminal_reports_its_runs(scene: Path, tmp_path: Path, capsys) -> None:
    vary = ["--vary", "initial.theta[1]=0.05,0.1", "--jobs", "1"]
    status = run(["sweep", str(scene), "-o", str(tmp_path / "o"), *vary])
    err = capsys.readouterr().err
    assert status == 0, err
    assert "ipgen: runs 0/2 (0 %)" in err and "ipgen: runs 2/2 (100 %), " in err and " runs/s, " in err, err


# ---------------------------------------------------------------------------- runs


def test_a_small_scorecard_scored_as_its_table_says(scene: Path, tmp_path: Path) -> None:
    out = tmp_path / "card"
    outcome = ipgen.sweep(
        scene,
        out,
        scorecard=("mass", "damping", "period", "sensor_noise"),
        levels={"mass": "0.75:1.25:3", "damping": "0,1,2", "period": "0.01,0.05,0.5"},
        jobs=2,
    )
    rows = _rows(out)
    assert len(rows) == 9 == outcome.runs  # sensor_noise: not run on the exact state
    assert {p.name for p in outcome.files} >= {"runs.csv", "scores.json", "scores.md", "scores.png"}
    assert (out / "criterion_mass.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    seeds = [int(row["seed"]) for row in rows]
    assert len(set(seeds)) == len(seeds)  # one explicit seed per run
    by_level: dict[tuple[str, str], list[str]] = {}
    for row in rows:
        by_level.setdefault((row["criterion"], row["level"]), []).append(row["outcome"])
    scores = json.loads((out / "scores.json").read_text())
    for criterion in scores["criteria"]:
        if criterion["refused"]:
            continue
        passes = [
            sum(o == "pass" for o in by_level[criterion["name"], str(i)]) * 2
            > len(by_level[criterion["name"], str(i)])
            for i in range(len(criterion["levels"]))
        ]
        assert [level["passes"] for level in criterion["levels"]] == passes
        assert math.isclose(criterion["score"], sum(passes) / len(passes))
    counted = [c["score"] for c in scores["criteria"] if c["score"] is not None]
    assert math.isclose(scores["score"], sum(counted) / len(counted))
    # the nominal levels pass; a 0.5 s sample period (poles at -26/s) cannot hold the link
    outcomes = {(row["criterion"], row["values"]): row for row in rows}
    assert outcomes["mass", "[1.0]"]["outcome"] == "pass"
    assert outcomes["damping", "[1.0]"]["outcome"] == "pass"
    assert outcomes["period", "[0.5]"]["outcome"] == "fail"
    noise = next(c for c in scores["criteria"] if c["name"] == "sensor_noise")
    assert noise["refused"].startswith("the controller sees the exact state")  # the scene has no estimator
    assert "give the scene an estimator to score it" in (out / "scores.md").read_text()


def test_the_plant_changes_and_the_controller_stays_nominal(scene: Path, tmp_path: Path) -> None:
    """A sweep's run with the masses × 1.25 against Kane's equations under the nominal gain with the
    same zero-order hold (scipy); the gain designed on the heavier model gives another end state."""
    from independent_model import reference
    from scipy.integrate import solve_ivp

    out = tmp_path / "mass"
    ipgen.sweep(scene, out, scorecard=("mass",), levels={"mass": "1.25"}, jobs=1, plots=False)
    (row,) = _rows(out)
    nominal = load_scene(scene)
    model = reference("rotary", 1, "pivot")
    m = [1.25 * value for value in nominal.m]
    params = (m, list(nominal.l), list(nominal.delta), 9.81)

    def end_state(gain: np.ndarray) -> np.ndarray:
        x = np.array([0.0, 0.1, 0.0, 0.0])
        for k in range(200):  # 2 s at 10 ms, u held
            u = float(np.clip(-gain @ x, -5, 5))

            def f(t: float, state: np.ndarray, u: float = u) -> np.ndarray:
                mass = np.asarray(model.mass_matrix(state[:2], state[2:], u, params), float)
                forcing = np.asarray(model.forcing(state[:2], state[2:], u, params), float).reshape(-1)
                return np.concatenate([state[2:], np.linalg.solve(mass, forcing)])

            x = solve_ivp(f, (0.01 * k, 0.01 * (k + 1)), x, method="DOP853", rtol=1e-10, atol=1e-12).y[:, -1]
        return x

    expected = end_state(np.asarray(nominal.controller.gain))
    got = (float(row["base_error"]), float(row["angle_error"]), float(row["rate_error"]))
    assert np.allclose(got, np.abs([expected[0], expected[1], expected[3]]), rtol=1e-5, atol=1e-9), (
        got,
        expected,
    )
    redesigned = np.asarray(ipgen.lqr("rotary", 1, m, list(nominal.l), list(nominal.delta), np.eye(4), 1.0))
    redesigned = redesigned.reshape(-1)
    other = end_state(redesigned)
    assert not np.allclose(got, np.abs([other[0], other[1], other[3]]), rtol=1e-3, atol=1e-9)


def test_refused_levels_are_recorded_and_the_sweep_goes_on(scene: Path, tmp_path: Path) -> None:
    out = tmp_path / "period"
    outcome = ipgen.sweep(scene, out, vary=["controller.period=0.01,0.003,-1,0.02"], jobs=2, plots=False)
    rows = _rows(out)
    assert [row["outcome"] for row in rows] == ["pass", "refused", "refused", "pass"]
    assert "whole multiple or a whole fraction of simulation.sample" in rows[1]["reason"]
    assert "\n" not in rows[2]["reason"] and rows[2]["reason"].startswith("controller.period")
    assert outcome.score == 1.0  # refused levels are not counted
    text = (out / "scores.md").read_text()
    assert "2/2" in text


def test_an_interrupted_sweep_resumes_from_its_table(scene: Path, tmp_path: Path) -> None:
    out = tmp_path / "basin"
    grid = ["initial.theta[1]=-0.9:0.9:4", "initial.dtheta[1]=-1,1"]
    whole = ipgen.sweep(scene, out, vary=grid, jobs=2)
    assert whole.ran == 8 and (out / "grid.png").is_file()
    complete = _rows(out)
    assert {row["outcome"] for row in complete} == {"pass", "fail"}  # ±0.9 rad is outside the basin
    lines = (out / "runs.csv").read_text().splitlines(keepends=True)
    (out / "runs.csv").write_text("".join(lines[:4]) + lines[4][:20])  # 3 runs, then a cut line
    resumed = ipgen.sweep(scene, out, vary=grid, jobs=2, plots=False)
    assert resumed.ran == 5 and resumed.runs == 8
    assert _results(_rows(out)) == _results(complete)
    with pytest.raises(SweepError, match="from another sweep"):
        ipgen.sweep(scene, out, vary=["initial.theta[1]=0,0.1"], jobs=1)
    assert ipgen.sweep(scene, out, vary=["initial.theta[1]=0,0.1"], jobs=1, force=True, plots=False).ran == 2


def test_sensor_keys_by_name(scene: Path, tmp_path: Path) -> None:
    """The sensor and drive keys sweep by name; a noisy run gets its own seed."""
    outcome = ipgen.sweep(
        scene, tmp_path / "noise", vary=["sensors.noise=0,0.001"], repeat=2, jobs=2, plots=False
    )
    rows = _rows(tmp_path / "noise")
    assert outcome.runs == 4 and rows[0]["outcome"] == "pass"
    assert len({row["seed"] for row in rows}) == 4


def test_a_dask_local_cluster_gives_the_local_table(scene: Path, tmp_path: Path) -> None:
    distributed = pytest.importorskip("distributed")
    grid = ["initial.theta[1]=-0.8:0.8:3", "parameters.m[1]=0.2,0.35"]
    local = ipgen.sweep(scene, tmp_path / "local", vary=grid, jobs=2, plots=False)
    with (
        distributed.LocalCluster(
            n_workers=1,
            threads_per_worker=2,
            processes=False,
            protocol="tcp",
            host="127.0.0.1",
            dashboard_address=None,
        ) as cluster,
    ):
        remote = ipgen.sweep(scene, tmp_path / "dask", vary=grid, dask=cluster.scheduler_address, plots=False)
    assert remote.workers == 2 and local.runs == remote.runs == 6
    assert _results(_rows(tmp_path / "dask")) == _results(_rows(tmp_path / "local"))
    assert (tmp_path / "dask" / "scores.json").read_text() == (tmp_path / "local" / "scores.json").read_text()


def test_no_scheduler_at_the_address_is_one_line(scene: Path, tmp_path: Path, capsys) -> None:
    """Nothing listening (the connection refused): the one line at once, not after Dask's 5 s."""
    import time

    pytest.importorskip("distributed")
    status = run(["sweep", str(scene), "-o", str(tmp_path / "o"), "--vary", "initial.theta[1]=0", "--dask",
                  "tcp://127.0.0.1:9"])  # fmt: skip
    err = capsys.readouterr().err
    assert status == 2 and "cannot reach a Dask scheduler" in err and err.count("\n") == 1
    assert "refused" in err.lower()
    # the probe alone (the command builds the scene's simulator first): well within Dask's 5 s
    from ipgen.sweeps.engine import probe

    started = time.monotonic()
    with pytest.raises(SweepError, match="refused"):
        probe("tcp://127.0.0.1:9")
    assert time.monotonic() - started < 2.0


def test_delay_levels_are_whole_multiples_of_the_period() -> None:
    from ipgen.sweeps.scorecard import delay_levels

    kilohertz = [float(v) for v in delay_levels(load_scene(ROOT / "scenes" / "rsip_lqr.toml")).split(",")]
    assert len(kilohertz) == 21 and kilohertz[0] == 0 and math.isclose(kilohertz[-1], 0.04)
    assert all(math.isclose(v / 0.001, round(v / 0.001), abs_tol=1e-9) for v in kilohertz)
    hundred = delay_levels(load_scene(ROOT / "scenes" / "rsip_swingup.toml"))
    assert [float(v) for v in hundred.split(",")] == [0.0, 0.01, 0.02, 0.03, 0.04]


def test_the_package_does_not_shadow_the_function() -> None:
    """The library is the package ipgen.sweeps; ipgen.sweep stays the function after importing it."""
    import ipgen.sweeps.runner

    assert callable(ipgen.sweep) and ipgen.sweep.__module__ == "ipgen"


def test_the_estimator_stays_the_nominal_design() -> None:
    """With issue 32's measured loop: a run on a heavier plant keeps the Kalman filter designed on the
    nominal scene (its A, gain), and gets its own seed; an [estimator] key designs it anew."""
    path = ROOT / "scenes" / "rigs" / "qube_servo2_sensors.toml"
    from ipgen.experiment.scene import read_document, scene_from_document
    from ipgen.sweeps import overrides
    from ipgen.sweeps.execute import nominal_estimator

    nominal, document = load_scene(path), read_document(path)
    heavier = (("parameters.m", [1.2 * m for m in nominal.m]), ("sensors.seed", 7))
    changed = scene_from_document(path, overrides.apply(document, nominal, heavier), designed=nominal)
    # the scene format designs on the changed parameters...
    assert changed.loop.estimator.A != nominal.loop.estimator.A
    kept = nominal_estimator(changed, nominal, heavier)
    assert kept.loop.estimator == nominal.loop.estimator  # ...the sweep keeps it
    assert kept.loop.seed == 7 and kept.m == changed.m
    retuned = (*heavier, ("estimator.kind", "kalman"))
    anew = scene_from_document(path, overrides.apply(document, nominal, retuned), designed=nominal)
    assert nominal_estimator(anew, nominal, retuned).loop.estimator.A == changed.loop.estimator.A


@pytest.mark.parametrize(
    ("loop", "stated"),
    [
        ("controller = mpc\n", True),
        ("swingup = energy\n", True),
        ("estimator = ekf\n", True),
        ("estimator = exact\nestimator.predict = 1\n", True),
        ("controller = lqr\nestimator = kalman\n", False),
        ("swingup = trajectory\n", False),
    ],
)
def test_a_sweeps_runs_keep_the_model_a_loop_runs(loop: str, stated: bool) -> None:
    """`model_lines`: the nominal plant stated as controller.model.* (the simulator's Scene::design)
    for a loop that runs a model (an MPC, the energy law, an EKF, the prediction over a delay),
    none for one that runs numbers (gains, a plan, a Kalman gain); none where already stated."""
    from ipgen.sweeps.design_model import model_lines

    cfg = "m = 0.5 0.3\nl = 0.6 0.5\ndelta = 0.3 0.01\ng = 9.81\nactuator.gain = 0.005\n" + loop
    lines = model_lines(cfg)
    keys = {line.split(" = ")[0] for line in lines}
    plant = {"controller.model.m", "controller.model.l", "controller.model.delta", "controller.model.g"}
    assert keys == ({*plant, "controller.model.gain"} if stated else set())
    assert model_lines(cfg + "".join(f"{line}\n" for line in lines)) == []


@pytest.mark.parametrize(
    ("path", "kept"),
    [
        (ROOT / "scenes" / "rsip_swingup.toml", True),  # the energy law runs the model
        (ROOT / "bench" / "scenes" / "rsip_swingup_ekf.toml", True),  # and its EKF
        (ROOT / "bench" / "scenes" / "rsip_lqr_kalman.toml", False),  # gains and a Kalman gain: numbers
    ],
    ids=["energy", "energy+ekf", "lqr+kalman"],
)
def test_a_sweeps_run_keeps_the_energy_laws_and_the_ekfs_nominal_model(
    tmp_path: Path, path: Path, kept: bool
) -> None:
    """A run of a sweep with the links twice as heavy: the plant's masses change, the model the
    energy law and the EKF run (controller.model.*) stays the nominal scene's; a loop that runs
    no model gets none."""
    import re

    from ipgen.experiment.config import resolved_config
    from ipgen.experiment.scene import load_scene, read_document, scene_from_document
    from ipgen.sweeps import execute, overrides
    from ipgen.sweeps.design_model import model_lines

    def numbers(cfg: str, key: str) -> list[float]:
        found = re.search(rf"^{re.escape(key)} = (.*)$", cfg, re.MULTILINE)
        assert found is not None, key
        return [float(v) for v in found.group(1).split()]

    scene = load_scene(path)
    lines = tuple(model_lines(resolved_config(scene, model="rotary1")))
    prepared = execute.Prepared(path, scene, {}, Path("unused"), tmp_path, "rotary1", (), None, lines)
    changes = (("parameters.m[1]", 2 * scene.m[1]),)
    heavier = scene_from_document(path, overrides.apply(read_document(path), scene, changes), designed=scene)
    text = execute.run_config(prepared, heavier, nominal_design=True)
    assert numbers(text, "m")[1] == 2 * scene.m[1]
    if kept:
        assert numbers(text, "controller.model.m") == [float(v) for v in scene.m]
    else:
        assert "controller.model." not in text


def test_a_swing_up_counting_from_hanging_is_judged_at_its_upright() -> None:
    """qube_servo2_swingup (the energy law and its LQR hold, no [controller]) as shipped and with
    its angles counted from hanging: both runs pass the success test, held within 0.01 rad of
    upright (the two differ by the rounding of the coordinates' map on quantised encoders). The
    hold's target is in ipgen's coordinates (the upright at 0), the run's states in the scene's,
    where counting from hanging puts the upright half a turn away (it was judged π off before)."""
    require_toolchain()
    from ipgen.sweeps import execute

    source = (ROOT / "scenes" / "rigs" / "qube_servo2_swingup.toml").read_text()
    sense = 'positive = "counterclockwise"'
    hanging = source.replace(sense, f'{sense}\nzero = "hanging"', 1)
    assert 'zero = "hanging"' in hanging
    task = execute.Task(0, "nominal", 0, 0, 0, ())
    results = [
        execute.run_one(execute.SceneSource(f"qube_{name}", text), task, Success())
        for name, text in (("upright", source), ("hanging", hanging))
    ]
    assert [r.outcome for r in results] == ["pass", "pass"], [r.reason for r in results]
    assert max(r.angle_error for r in results) < 0.01


@given(values=st.lists(st.integers(-10**6, 10**6), min_size=1, max_size=12, unique=True).map(
    lambda whole: sorted(v / 1000 for v in whole)))  # fmt: skip
def test_a_grids_cells_hold_their_values_however_spaced(values: list[float]) -> None:
    """grid.png draws each point of a 2-D sweep in a cell of its own around its value (a list such
    as 0.05, 0.1, 1.5 is not evenly spaced: the cells spread evenly put 0.1's result up to 1.1)."""
    from ipgen.sweeps.plots import cell_edges

    edges = cell_edges(values)
    assert len(edges) == len(values) + 1
    assert all(lo < value < hi for lo, value, hi in zip(edges, values, edges[1:], strict=False))
    assert cell_edges([0.05, 0.1, 1.5]) == pytest.approx([0.025, 0.075, 0.8, 2.2])


def test_a_scenes_own_drive_noise_differs_between_repeats(scene: Path, tmp_path: Path) -> None:
    """A scene with [actuator] noise but no [sensors]: each repeat runs on its own seed (sensors.seed
    = the run's seed), so the repeats differ; before, every repeat ran on seed 0 and came out the
    same, whatever runs.csv's seed column said."""
    noisy = SCENE.replace("[simulation]\n", "[actuator]\nnoise = 0.5\n\n[simulation]\n", 1)
    scene.write_text(noisy)
    vary = ["--vary", "initial.theta[1]=0.1", "--repeat", "3", "--jobs", "1"]
    status = run(["sweep", str(scene), "-o", str(tmp_path / "o"), *vary])
    assert status == 0
    rows = _rows(tmp_path / "o")
    assert len(rows) == 3 and len({row["seed"] for row in rows}) == 3
    assert len({row["angle_error"] for row in rows}) == 3, rows


@pytest.mark.parametrize("count", ["100001", "1000000000"])
def test_too_many_random_starts_are_refused_before_they_are_drawn(
    scene: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str], count: str
) -> None:
    """--random beyond the sweep's 100,000 runs: one line at once (a billion starts were drawn
    first, filling the memory; 200,000 were refused after 13 s), and no output folder."""
    import time

    started = time.process_time()
    status = run(["sweep", str(scene), "-o", str(tmp_path / "o"), "--random", count])
    err = capsys.readouterr().err
    assert status == 2 and err.count("\n") == 1 and "at most 100,000 runs" in err, err
    assert time.process_time() - started < 5 and not (tmp_path / "o").exists()


def test_force_removes_only_what_a_sweep_wrote(scene: Path, tmp_path: Path) -> None:
    """--force over an earlier sweep removes its scores and pictures, not a user's files beside
    them that look alike (criterion_holiday.png was deleted by a glob)."""
    out = tmp_path / "o"
    vary = ["--vary", "initial.theta[1]=0.05,0.1", "--jobs", "1"]
    assert run(["sweep", str(scene), "-o", str(out), *vary]) == 0
    pictures = sorted(path.name for path in out.glob("criterion_*.png"))
    assert pictures, sorted(path.name for path in out.iterdir())
    (out / "criterion_holiday.png").write_bytes(b"\x89PNG\r\n\x1a\n a photograph")
    (out / "notes.txt").write_text("mine\n")
    assert run(["sweep", str(scene), "-o", str(out), *vary, "--force"]) == 0
    assert (out / "criterion_holiday.png").read_bytes().endswith(b"a photograph")
    assert (out / "notes.txt").read_text() == "mine\n"
    after = sorted(path.name for path in out.glob("criterion_*.png"))
    assert after == sorted([*pictures, "criterion_holiday.png"])
