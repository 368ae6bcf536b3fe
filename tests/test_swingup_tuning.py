"""The energy swing-up a rig owner can tune (issue 33): every constant a [swingup] key, Quanser's
proportional law as an option, a_max at a design speed, the rig's coordinates, volts in messages.

References are independent of ipgen's law: Quanser's formula written out here from its lab
(a_tip = sat(μ (E_r − E_Q) sign(α̇ cos α)), E_Q measured from hanging), the damping's share of
the input at a speed (force balance), and the coordinate map α = −θ1 by hand."""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest
from test_scene import ROTARY, config_dict, expect_error, make

from ipgen.control import energy
from ipgen.control.casadi_model import plant
from ipgen.control.energy import energy_swingup
from ipgen.control.trajectory import PlanError
from ipgen.experiment.config import resolved_config
from ipgen.experiment.scene import load_scene
from ipgen.scene import swingup as swing

ROOT = Path(__file__).resolve().parents[1]
QUBE = ROOT / "scenes" / "rigs" / "qube_servo2_swingup.toml"
ENERGY = {
    **ROTARY,
    "input.kind": None,
    "input.amplitude": None,
    "input.duration": None,
    "swingup.method": '"energy"',
    "swingup.u_max": "5",
}


def _qube_plant():  # the QUBE's mechanics (direct drive in N m), ipgen's coordinates
    return plant("rotary", 1, [0.095, 0.024], [0.085, 0.129], [5e-6, 1e-6])


def test_the_scene_layer_and_the_law_agree_on_the_laws() -> None:
    import inspect

    assert swing.LAWS == energy.LAWS
    # the default catch angle the scene's release_angle rule compares with
    default = inspect.signature(energy.energy_swingup).parameters["catch_angle"].default
    assert default == swing.DEFAULT_CATCH_ANGLE


def test_proportional_law_is_quansers_formula_at_the_arm_tip() -> None:
    """Acceleration drive, no centring: the law's u is its a [rad/s²]; r·a must be Quanser's
    a_tip for states all around the circle (E_Q from hanging, α = −θ1 in Quanser's convention)."""
    p = _qube_plant()
    mu, a_max, e_r = 50.0, 6.0, 0.030
    law = energy_swingup(
        p, u_max=1e9, period=0.001, law="proportional", gain_energy=mu, accel_max=a_max,
        energy_target=e_r, gain_position=0.0, gain_velocity=0.0, acceleration=True, catch_angle=1e-9,
    )  # fmt: skip
    mp, lp, r, g = 0.024, 0.129, 0.085, 9.81
    jp = mp * lp**2 / 3  # the rod about its pivot
    rng = np.random.default_rng(33)
    for _ in range(200):
        theta1 = rng.uniform(0.2, 2 * math.pi - 0.2)
        rate = rng.uniform(-15, 15)
        alpha, alpha_dot = -theta1, -rate  # Quanser's α: counter-clockwise from upright
        e_q = 0.5 * jp * alpha_dot**2 + 0.5 * mp * g * lp * (1 + math.cos(alpha))  # 0 hanging at rest
        tip = float(np.clip(mu * (e_r - e_q) * np.sign(alpha_dot * math.cos(alpha)), -a_max, a_max))
        law.reset()
        u, phase = law.control(0, np.array([0.0, theta1, 0.0, rate]))
        assert phase == "swing"
        # ipgen's arm angle θ0 and Quanser's θ are both counter-clockwise seen from above: same sign
        assert abs(u * r - tip) <= 1e-9 * max(1.0, abs(tip)), (theta1, rate, u * r, tip)


def test_design_speed_takes_the_damping_off_the_stall_acceleration() -> None:
    p = _qube_plant()
    u_max = 0.05  # N m: 10 V on the QUBE
    stall = energy_swingup(p, u_max=u_max, period=0.001).accel_max
    for speed in (10.0, 100.0, 5000.0):
        a = energy_swingup(p, u_max=u_max, period=0.001, design_speed=speed).accel_max
        assert a == pytest.approx(stall * (1 - 5e-6 * speed / u_max), rel=1e-12)
    with pytest.raises(PlanError, match="design_speed"):
        energy_swingup(p, u_max=u_max, period=0.001, design_speed=u_max / 5e-6)


def test_every_constant_is_a_scene_key_and_reaches_the_config(tmp_path: Path) -> None:
    changes = {
        "swingup.gain_energy": "7.5",
        "swingup.accel_max": "12",
        "swingup.energy_target": "-0.01",
        "swingup.catch_angle": "0.2",
        "swingup.catch_rate": "2.5",
        "swingup.gain_position": "4",
        "swingup.gain_velocity": "3",
    }
    config = config_dict(resolved_config(load_scene(make(tmp_path, {**ENERGY, **changes}))))
    for key, value in changes.items():
        assert float(config[key]) == pytest.approx(float(value), rel=1e-15), key


def test_absent_keys_keep_todays_config(tmp_path: Path) -> None:
    """The defaults spelled out give the same .cfg as no keys (backward compatibility)."""
    plain = resolved_config(load_scene(make(tmp_path, ENERGY)))
    config = config_dict(plain)
    spelled = {
        "swingup.law": '"energy"',
        "swingup.design_speed": "0",
        "swingup.catch_angle": "0.3",
        "swingup.catch_rate": "3",
        "swingup.energy_target": "0",
        "swingup.gain_energy": config["swingup.gain_energy"],
    }
    assert resolved_config(load_scene(make(tmp_path, {**ENERGY, **spelled}))) == plain


@pytest.mark.parametrize(
    ("changes", "key", "expected"),
    [
        ({"swingup.law": '"bang"'}, "law", "energy"),
        ({"swingup.accel_max": "0"}, "accel_max", "> 0"),
        ({"swingup.gain_energy": "-1"}, "gain_energy", ">= 0"),
        ({"swingup.catch_angle": "-0.1"}, "catch_angle", "> 0"),
        # a catch that wide took the hanging link: "the hold diverged at t = 0 s"
        ({"swingup.catch_angle": "1.5708"}, "catch_angle", "< π/2"),
        ({"swingup.catch_angle": "4"}, "catch_angle", "< π/2"),
        # design_speed sets a_max only when it is computed: it was silently dropped
        ({"swingup.design_speed": "1e6", "swingup.accel_max": "10"}, "design_speed", "accel_max is given"),
        ({"swingup.design_speed": "5", "swingup.law": '"proportional"'}, "design_speed", "own a_max"),
        ({"swingup.method": '"trajectory"', "swingup.duration": "2", "swingup.catch_rate": "1"},
         "catch_rate", 'method = "energy" only'),
    ],
)  # fmt: skip
def test_bad_energy_key_is_one_line(tmp_path: Path, changes: dict, key: str, expected: str) -> None:
    expect_error(make(tmp_path, {**ENERGY, **changes}), key, expected)


def test_qube_preset_in_quansers_coordinates(tmp_path: Path) -> None:
    """The preset loads in α (counter-clockwise) coordinates and starts hanging (α = ±π); its
    a_max is what 10 V buys at the 50 rad/s design speed, by hand: (b·10 − (Dr + kt km/Rm)·50) /
    (Jr + Mp Lr²); switched to law = "proportional" its constants are Quanser's mapped to the
    arm (μ / r, a_max / r, E_r − Mp g Lp), with u_max in volts."""
    scene = load_scene(QUBE)
    assert not scene.coordinates.is_canonical
    assert abs(abs(scene.theta[1]) - math.pi) < 1e-15 and scene.theta[0] == 0.0
    config = config_dict(resolved_config(scene))
    r, mp, lp, b = 0.085, 0.024, 0.129, 0.042 / 8.4
    damping = 5e-6 + 0.042 * 0.042 / 8.4
    inertia = 5.7197916666666667e-05 + mp * r**2  # arm about the vertical, pendulum hanging at its tip
    assert float(config["swingup.accel_max"]) == pytest.approx((b * 10 - damping * 50) / inertia, rel=1e-9)
    assert float(config["swingup.u_max"]) == 10.0  # volts
    text = QUBE.read_text().replace('law = "energy"', 'law = "proportional"')
    text = text.replace("design_speed = 50", "gain_energy = 50\naccel_max = 6\nenergy_target = 0.030")
    (tmp_path / "qube.toml").write_text(text)
    config = config_dict(resolved_config(load_scene(tmp_path / "qube.toml")))
    assert float(config["swingup.gain_energy"]) == pytest.approx(50 / r, rel=1e-12)
    assert float(config["swingup.accel_max"]) == pytest.approx(6 / r, rel=1e-12)
    assert float(config["swingup.energy_target"]) == pytest.approx(0.030 - mp * 9.81 * lp, rel=1e-12)


def _hold_gain(tmp_path: Path, changes: dict[str, str]) -> np.ndarray:
    config = config_dict(resolved_config(load_scene(make(tmp_path, {**ENERGY, **changes}))))
    return np.array([float(v) for v in config["swingup.hold_gain"].split()])


def test_hold_weights_are_keys(tmp_path: Path) -> None:
    """An LQR gain is unchanged when Q and R scale together, and changes when only R does."""
    plain = _hold_gain(tmp_path, {})
    scaled = _hold_gain(tmp_path, {"swingup.q": "[4, 4, 4, 4]", "swingup.r": "4"})
    np.testing.assert_allclose(scaled, plain, rtol=1e-9)
    cheap = _hold_gain(tmp_path, {"swingup.r": "0.01"})
    assert np.linalg.norm(cheap) > 2 * np.linalg.norm(plain)


def test_demo_fails_a_swingup_beyond_its_voltage(tmp_path: Path) -> None:
    import sys

    sys.path.insert(0, str(ROOT / "tools"))
    from demo import swingup_problems

    path = tmp_path / "run.csv"
    path.write_text("t,theta0,theta1,dtheta0,dtheta1,u,phase\n0,0,3.1,0,0,-10.5,swing\n1,0,0,0,0,0,hold\n")
    assert swingup_problems(path) == []
    assert swingup_problems(path, 10.0) == ["|u| reached 10.5 > 10"]
    assert swingup_problems(path, 11.0) == []


def test_margin_is_trajectory_only_and_a_fraction(tmp_path: Path) -> None:
    expect_error(make(tmp_path, {**ENERGY, "swingup.margin": "0.9"}), "margin", 'method = "trajectory" only')
    trajectory = {**ENERGY, "swingup.method": '"trajectory"', "swingup.duration": "2"}
    expect_error(make(tmp_path, {**trajectory, "swingup.margin": "1.5"}), "margin", "(0, 1]")


def test_no_plan_message_states_the_limit_in_volts() -> None:
    """A dc_motor rig (b = 0.005 N m/V) that cannot swing up in 0.2 s: the limit in V, not N m."""
    from ipgen.control.swingup import trajectory_swingup

    with pytest.raises(PlanError, match=r"\|u\| ≤ 9 V"):
        trajectory_swingup(
            _qube_plant(), duration=0.2, u_max=0.05, margin=0.9, period=0.01, input_gain=0.005, intervals=20
        )


RSIP = ("rotary", 1, [0.5, 0.275], [0.6, 0.5], [0.3, 0.011458])


@pytest.mark.parametrize(
    ("arguments", "expected"),
    [
        ({"catch_angle": 2.0}, "catch_angle = 2.0: expected less than π/2"),
        ({"accel_max": 0}, "accel_max = 0: expected a finite number > 0"),
        (
            {"design_speed": 1e6, "accel_max": 10},
            "design_speed = 1000000.0 sets a_max only when it is computed",
        ),
        ({"design_speed": 1.0, "law": "proportional"}, 'law = "proportional" has its own a_max'),
        ({"design_speed": 1.0, "acceleration": True}, "u is the base's acceleration"),
    ],
)
def test_energy_arguments_that_do_nothing_or_harm_are_refused(arguments: dict, expected: str) -> None:
    """Each of these was taken: a catch below the horizontal, a law that never pumps, or a
    design speed that was silently dropped."""
    with pytest.raises(PlanError, match=re.escape(expected)):
        energy_swingup(plant(*RSIP), u_max=5.0, **arguments)


def test_a_plan_of_a_duration_not_a_whole_number_of_periods_is_refused_before_planning(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """trajectory_swingup refuses duration = 3.005 s at period = 0.01 s before IPOPT plans (it
    was refused by track after seconds of planning); input_gain = 0 is one line (a
    ZeroDivisionError in the failure message)."""
    from ipgen.control import swingup
    from ipgen.control.trajectory import plan_swingup

    def planned(*args: object, **kwargs: object) -> None:
        raise AssertionError("planned before the duration was checked")

    with monkeypatch.context() as patch:
        patch.setattr(swingup, "plan_swingup", planned)
        with pytest.raises(PlanError, match=r"duration 3\.005 s is not a whole multiple of period = 0\.01 s"):
            swingup.trajectory_swingup(plant(*RSIP), duration=3.005, u_max=5.0, period=0.01)
    with pytest.raises(PlanError, match=r"input_gain = 0: expected a finite number > 0"):
        plan_swingup(plant(*RSIP), duration=0.2, u_max=0.01, input_gain=0)


def test_a_refusal_under_a_margin_names_the_margin() -> None:
    """x_max = 1 with margin = 0.8: the refusal's "x_max = 0.8" is the planning limit, and the
    message says so (it read as if the user had set 0.8)."""
    from ipgen.control.swingup import trajectory_swingup

    cart = plant("classical", 2, [0.3, 0.275, 0.275], [0.0, 0.5, 0.5], [0.3, 0.1, 0.1])
    start = [0.9, math.pi, math.pi, 0.0, 0.0, 0.0]
    with pytest.raises(PlanError, match=r"x_max = 0\.8 \(planned within margin = 0\.8 of u_max and x_max\)"):
        trajectory_swingup(cart, duration=3.0, u_max=50.0, x_max=1.0, margin=0.8, start=start)
