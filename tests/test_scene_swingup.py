"""The [swingup] table of scenes: what the resolved config carries, and every bad key as one line."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from test_scene import ROTARY, config_dict, expect_error, make

from ipgen.command.cli import run
from ipgen.control.casadi_model import plant
from ipgen.control.tvlqr import discrete_lqr
from ipgen.errors import SceneError

# The paper's rotary single pendulum swung up by energy control: no [input], no [initial].
from ipgen.experiment.config import resolved_config
from ipgen.experiment.scene import load_scene

ENERGY = {
    **ROTARY,
    "input.kind": None,
    "input.amplitude": None,
    "input.duration": None,
    "swingup.method": '"energy"',
    "swingup.u_max": "5",
}
TRAJECTORY = {**ENERGY, "swingup.method": '"trajectory"', "swingup.duration": "2.0"}
# An MPC that catches and holds the swing-up (its period a whole multiple of the swing-up's).
MPC = {"controller.kind": '"mpc"', "controller.u_max": "5", "controller.period": "0.01"}


def swingup(tmp_path: Path, changes: dict[str, str | None] | None = None, base: dict | None = None) -> Path:
    return make(tmp_path, {**(base or ENERGY), **(changes or {})})


def test_energy_scene_starts_hanging_and_carries_the_law(tmp_path: Path) -> None:
    scene = load_scene(swingup(tmp_path, {"swingup.hold": "0.5"}))
    assert scene.theta == (0.0, math.pi) and scene.dtheta == (0.0, 0.0)
    config = config_dict(resolved_config(scene))
    assert config["swingup"] == "energy" and config["input"] == "zero"
    assert (
        config["swingup.u_max"] == "5"
        and config["swingup.period"] == "0.01"
        and config["swingup.hold"] == "0.5"
    )
    # The hold gain is the discrete LQR of the exact model at the period (scipy's DARE), Q = I, R = 1.
    p = plant("rotary", 1, scene.m, scene.l, scene.delta)
    gain, *_ = discrete_lqr(p, 0.01, np.eye(4), np.eye(1), np.zeros(4))
    written = [float(v) for v in config["swingup.hold_gain"].split()]
    np.testing.assert_allclose(written, np.ravel(gain), rtol=1e-12)
    m1, l1 = scene.m[1], scene.l[1]
    assert float(config["swingup.energy_inertia"]) == pytest.approx(m1 * l1**2 / 3, rel=1e-15)
    assert float(config["swingup.energy_weight"]) == pytest.approx(0.5 * m1 * 9.81 * l1, rel=1e-15)
    assert "swingup.gains" not in config


def test_an_mpc_controller_catches_the_swing_up(tmp_path: Path) -> None:
    # [controller] kind = "mpc" with [swingup]: both written, the loop at the swing-up's period.
    changes = {**MPC, "controller.period": "0.02", "swingup.period": "0.005", "sensors.measured": "[0, 1]",
               "sensors.resolution": "2048", "estimator.kind": '"filter"'}  # fmt: skip
    scene = load_scene(swingup(tmp_path, changes))
    config = config_dict(resolved_config(scene))
    assert config["controller"] == "mpc" and config["controller.period"] == "0.02"
    assert config["swingup"] == "energy" and config["swingup.period"] == "0.005"
    assert scene.loop is not None and config["estimator"] == "filter"


def test_release_angle_reaches_the_config_only_when_set(tmp_path: Path) -> None:
    """`release_angle` is written to the resolved config (swingup.release_angle) when the scene
    sets it; a scene without it writes the config it wrote before (no such key)."""
    released = load_scene(swingup(tmp_path, {"swingup.release_angle": "1.2"}))
    assert released.swingup is not None and released.swingup.release_angle == 1.2
    assert "swingup.release_angle = 1.2\n" in resolved_config(released)
    (tmp_path / "plain").mkdir()
    plain = load_scene(swingup(tmp_path / "plain"))
    assert plain.swingup is not None and plain.swingup.release_angle == 0.0
    assert "swingup.release_angle" not in resolved_config(plain)


def test_energy_step_reaches_the_config_only_when_set(tmp_path: Path) -> None:
    """`energy_step` > 0 is written to the resolved config (swingup.energy_step); 0 or absent
    writes the config a scene without it wrote before (no such key)."""
    learnt = load_scene(swingup(tmp_path, {"swingup.energy_step": "0.002"}))
    assert "swingup.energy_step = 0.002\n" in resolved_config(learnt)
    for value in ("0", None):
        (tmp_path / f"plain{value}").mkdir()
        plain = load_scene(swingup(tmp_path / f"plain{value}", {"swingup.energy_step": value}))
        assert "swingup.energy_step" not in resolved_config(plain)


@pytest.mark.parametrize(("key", "value"), [("catch_deficit", "0.0006"), ("catch_base", "0.45")])
def test_a_catch_condition_reaches_the_config_only_when_set(tmp_path: Path, key: str, value: str) -> None:
    """`catch_deficit` and `catch_base` > 0 are written to the resolved config; 0 or absent
    writes the config a scene without them wrote before (no such key)."""
    gated = load_scene(swingup(tmp_path, {f"swingup.{key}": value}))
    assert f"swingup.{key} = {value}\n" in resolved_config(gated)
    for off in ("0", None):
        (tmp_path / f"plain{off}").mkdir()
        plain = load_scene(swingup(tmp_path / f"plain{off}", {f"swingup.{key}": off}))
        assert f"swingup.{key}" not in resolved_config(plain)


def test_tracking_reaches_the_config_only_when_the_mpc_tracks(tmp_path: Path) -> None:
    """`tracking = "mpc"` is written to the resolved config (swingup.tracking = mpc); "lqr" or
    absent writes nothing (the config of a scene without it unchanged)."""
    changes = {**MPC, "controller.period": "0.02"}
    tracked = load_scene(swingup(tmp_path, {**changes, "swingup.tracking": '"mpc"'}, base=TRAJECTORY))
    assert tracked.swingup is not None and tracked.swingup.tracking == "mpc"
    assert "swingup.tracking = mpc\n" in resolved_config(tracked)
    for value in ('"lqr"', None):
        plain = load_scene(swingup(tmp_path, {**changes, "swingup.tracking": value}, base=TRAJECTORY))
        assert plain.swingup is not None and plain.swingup.tracking == "lqr"
        assert "swingup.tracking" not in resolved_config(plain)


def test_trajectory_scene_carries_plan_and_schedule(tmp_path: Path) -> None:
    scene = load_scene(swingup(tmp_path, base=TRAJECTORY))
    config = config_dict(resolved_config(scene))
    steps = int(config["swingup.steps"])
    assert steps == 200  # duration / period
    inputs = np.array(config["swingup.inputs"].split(), dtype=float)
    states = np.array(config["swingup.states"].split(), dtype=float).reshape(steps + 1, 4)
    gains = np.array(config["swingup.gains"].split(), dtype=float).reshape(steps, 4)
    assert inputs.shape == (steps,) and np.all(np.abs(inputs) <= 5 + 1e-9)
    np.testing.assert_allclose(states[0], [0, math.pi, 0, 0], atol=1e-9)  # from hanging ...
    np.testing.assert_allclose(states[-1], [0, 0, 0, 0], atol=1e-9)  # ... to upright at rest
    # The schedule ends in the hold gain (the recursion starts from the DARE solution).
    hold = np.array(config["swingup.hold_gain"].split(), dtype=float)
    np.testing.assert_allclose(gains[-1], hold, rtol=0.05)


def test_the_initial_table_sets_the_start(tmp_path: Path) -> None:
    scene = load_scene(swingup(tmp_path, {"initial.theta": "[0, 3.0]"}))
    assert scene.theta == (0.0, 3.0)


BAD = [
    ({"swingup.method": '"pump"'}, "swingup.method", '"energy" or "trajectory"'),
    ({"swingup.u_max": None}, "swingup.u_max", "missing"),
    ({"swingup.u_max": "0"}, "swingup.u_max = 0", "> 0"),
    ({"swingup.u_max": "-1"}, "swingup.u_max = -1", "> 0"),
    ({"swingup.u_max": '"5"'}, "swingup.u_max", "expected a number"),
    ({"swingup.period": "0"}, "swingup.period = 0", "> 0 s"),
    ({"swingup.period": "20"}, "swingup.period = 20", "<= t_end"),
    ({"swingup.period": "0.015"}, "swingup.period = 0.015", "whole multiple or a whole fraction"),
    ({"swingup.hold": "-1"}, "swingup.hold = -1", ">= 0"),
    ({"swingup.duration": "2"}, "swingup.duration = 2", 'method = "trajectory" only'),
    ({"swingup.x_max": "1"}, "swingup.x_max = 1", 'method = "trajectory" only'),
    ({"swingup.release_angle": "0.3"}, "swingup.release_angle = 0.3", "more than catch_angle (0.3 rad)"),
    ({"swingup.release_angle": "0.5", "swingup.catch_angle": "0.6"}, "swingup.release_angle = 0.5",
     "more than catch_angle (0.6 rad)"),
    ({"swingup.release_angle": "2"}, "swingup.release_angle = 2", "< π/2"),
    ({"swingup.release_angle": "1.5707963267948966"}, "swingup.release_angle = 1.5707963267948966", "< π/2"),
    ({"swingup.release_angle": "0"}, "swingup.release_angle = 0", "> 0"),
    ({"swingup.method": '"trajectory"', "swingup.duration": "2", "swingup.release_angle": "1"},
     "swingup.release_angle = 1", 'method = "energy" only'),
    ({"swingup.energy_step": "-0.001"}, "swingup.energy_step = -0.001", "J >= 0"),
    ({"swingup.energy_step": '"1"'}, "swingup.energy_step", "expected a number"),
    ({"swingup.method": '"trajectory"', "swingup.duration": "2", "swingup.energy_step": "0.001"},
     "swingup.energy_step = 0.001", 'method = "energy" only'),
    ({"swingup.catch_deficit": "-0.001"}, "swingup.catch_deficit = -0.001", "J >= 0"),
    ({"swingup.catch_deficit": '"1"'}, "swingup.catch_deficit", "expected a number"),
    ({"swingup.catch_base": "-0.5"}, "swingup.catch_base = -0.5", "rad or m >= 0"),
    ({"swingup.method": '"trajectory"', "swingup.duration": "2", "swingup.catch_base": "0.5"},
     "swingup.catch_base = 0.5", 'method = "energy" only'),
    ({"swingup.tracking": '"mpc"'}, "swingup.tracking", 'method = "trajectory" only'),
    ({"swingup.method": '"trajectory"', "swingup.duration": "2", "swingup.tracking": '"mpc"'},
     "swingup.tracking", 'needs a [controller] with kind = "mpc"'),
    ({"swingup.method": '"trajectory"', "swingup.duration": "2", "swingup.tracking": '"tvlqr"'},
     "swingup.tracking", '"lqr" or "mpc"'),
    ({"swingup.speed": "1"}, "swingup.speed", "unknown key"),
    ({"controller.kind": '"lqr"'}, "swingup.method", "remove the [controller] table"),
    ({**MPC, "swingup.period": "0.02"}, "swingup.period = 0.02", "a whole number of times"),
    ({"input.kind": '"constant"', "input.amplitude": "1"}, "swingup.method", "remove [input]"),
    ({"swingup.method": '"trajectory"'}, "swingup.method", "needs duration"),
    ({"swingup.method": '"trajectory"', "swingup.duration": "20"}, "swingup.duration = 20", "t_end"),
    ({"swingup.method": '"trajectory"', "swingup.duration": "0"}, "swingup.duration = 0", "> 0 s"),
    ({"swingup.method": '"trajectory"', "swingup.duration": "2", "swingup.x_max": "0"},
     "swingup.x_max = 0", "> 0"),
    ({"system.links": "2", "parameters.m": "[0.5, 0.2, 0.2]", "parameters.l": "[0.6, 0.3, 0.3]",
      "parameters.delta": "[0.3, 0.01, 0.01]"}, "swingup.method", 'use method = "trajectory"'),
]  # fmt: skip


@pytest.mark.parametrize(("changes", "key", "expected"), BAD, ids=[f"{c}" for c, _, _ in BAD])
def test_bad_swingup_key_is_one_line(tmp_path: Path, changes: dict, key: str, expected: str) -> None:
    expect_error(swingup(tmp_path, changes), key, expected)


def test_a_plan_that_cannot_be_found_names_what_to_relax(tmp_path: Path) -> None:
    # 0.05 N m cannot swing the link up in 0.5 s (the homotopy fallback fails too).
    path = swingup(tmp_path, {"swingup.u_max": "0.05", "swingup.duration": "0.5"}, base=TRAJECTORY)
    expect_error(path, "swingup: no swing-up plan found", "relax u_max")


def test_command_exits_2_and_writes_nothing(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "out"
    assert run(["--scene", str(swingup(tmp_path, {"swingup.u_max": "0"})), "-o", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("ipgen: error: ") and "swingup.u_max = 0" in err[0]
    assert not out.exists()


# Any [swingup] table: a swing-up scene or one clean SceneError line naming the table.
VALUES = st.one_of(
    st.integers(-3, 3).map(str),
    st.sampled_from(
        [
            "0.5",
            "1e-3",
            "0.01",
            "0.02",
            "-0.0",
            "nan",
            "inf",
            "1e400",
            '"energy"',
            '"trajectory"',
            '"mpc"',
            '"lqr"',
            "true",
            "[1]",
        ]
    ),
)
KEYS = st.sampled_from(
    [
        "method",
        "u_max",
        "x_max",
        "duration",
        "period",
        "hold",
        "gain",
        "release_angle",
        "energy_step",
        "catch_deficit",
        "catch_base",
        "tracking",
    ]
)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.dictionaries(KEYS, VALUES, max_size=4))
def test_any_swingup_table_loads_or_fails_in_one_line(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, table: dict[str, str]
) -> None:
    import ipgen.control.swingup as swing
    from ipgen.control.trajectory import PlanError

    def no_plan(*_args: object, **_kwargs: object) -> None:  # planning is tested above; keep this fast
        raise PlanError("no swing-up plan found (planning skipped in this test)")

    monkeypatch.setattr(swing, "trajectory_swingup", no_plan)
    path = swingup(tmp_path, {f"swingup.{key}": value for key, value in table.items()})
    try:
        scene = load_scene(path)
    except SceneError as exc:
        message = str(exc)
        assert "\n" not in message and message.startswith(f"{path.as_posix()}: "), message
        assert "swingup" in message, message
        return
    law = scene.swingup
    assert law is not None and law.method == "energy"
    assert law.u_max > 0 and law.period > 0 and law.hold >= 0
    assert all(math.isfinite(k) for k in law.hold_gain)


def test_specialised_energy_scene_keeps_what_the_law_needs(tmp_path: Path) -> None:
    """`specialise = true`: the header keeps the input path, and for the energy law the mass
    matrix and bias (the simulator and the C header evaluate them at the state)."""
    from ipgen.experiment.specialisation import from_scene

    spec = from_scene(load_scene(swingup(tmp_path, {"system.specialise": "true"})))
    assert not spec.zero_input
    assert {"mass_matrix", "bias", "forward_dynamics"} <= set(spec.outputs)
