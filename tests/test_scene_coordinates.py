"""The rig's own coordinates in scenes: `[system] angles, zero, positive`.

Independent checks: the scene's LQR gain against ipgen's canonical LQR with the weights carried
over by hand (Q = Pᵀ Q_user P, K_user = K P⁻¹); the simulator's CSV in the rig's coordinates
against the same physical run in ipgen's seen through the Python map (so the C++ map of
ipsim/coordinates.hpp is checked against model/coordinates.py), energies unchanged; the
animation's geometry from either CSV the same. Bad values: one line naming the key (hypothesis).
"""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from cxx import require_toolchain
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from run_csv import read_run_csv
from run_summary import simulator_of
from test_scene import ROTARY, config_dict, make

import ipgen
from ipgen.errors import SceneError
from ipgen.experiment.config import resolved_config
from ipgen.experiment.scene import load_scene
from ipgen.model.coordinates import ANGLES, POSITIVE, ZEROS, Coordinates
from ipgen.plots.animation import canonical_angles, geometry
from ipgen.plots.animation import read_run as read_run_data
from ipgen.plots.run import coordinates_beside

CONVENTIONS = [Coordinates(a, z, p) for a in ANGLES for z in ZEROS for p in POSITIVE]
RIG = Coordinates("relative", "hanging", "counterclockwise")

# A rotary double pendulum under LQR about upright.
DOUBLE = {
    **ROTARY,
    "system.links": "2",
    "parameters.m": "[0.5, 0.275, 0.2]",
    "parameters.l": "[0.6, 0.5, 0.4]",
    "parameters.delta": "[0.3, 0.011458, 0.01]",
    "input.kind": None,
    "input.amplitude": None,
    "input.duration": None,
    "controller.kind": '"lqr"',
    "controller.q": "[1, 2, 3, 0.5, 0.25, 0.125]",
}


def keys(frame: Coordinates) -> dict[str, str | None]:
    return {
        "system.angles": f'"{frame.angles}"',
        "system.zero": f'"{frame.zero}"',
        "system.positive": f'"{frame.positive}"',
    }


def test_the_default_is_ipgen_s_and_writes_nothing_new(tmp_path: Path) -> None:
    plain = load_scene(make(tmp_path, DOUBLE))
    explicit = load_scene(make(tmp_path, {**DOUBLE, **keys(Coordinates())}))
    assert plain.coordinates.is_canonical and explicit.coordinates == plain.coordinates
    assert resolved_config(explicit) == resolved_config(plain)
    assert "angles" not in config_dict(resolved_config(plain))


@pytest.mark.parametrize("frame", CONVENTIONS, ids=lambda f: f"{f.angles}-{f.zero}-{f.positive}")
def test_the_gain_is_the_canonical_one_carried_over(tmp_path: Path, frame: Coordinates) -> None:
    """K_user from the scene = K P⁻¹, K the canonical LQR with Q = Pᵀ Q_user P (the same cost)."""
    scene = load_scene(make(tmp_path, {**DOUBLE, **keys(frame)}))
    assert scene.coordinates == frame and scene.controller is not None
    p, c = frame.matrices(2)
    q_user = np.diag([1, 2, 3, 0.5, 0.25, 0.125])
    k = ipgen.lqr("rotary", 2, scene.m, scene.l, scene.delta, p.T @ q_user @ p, 1.0)
    assert np.allclose(np.array(scene.controller.gain), (k @ np.linalg.inv(p)).ravel(), rtol=1e-7, atol=1e-9)
    # "upright" is the physical state; in the rig's coordinates its angles are c
    assert np.allclose(scene.controller.equilibrium, c, atol=0)
    config = config_dict(resolved_config(scene))
    if frame.is_canonical:
        assert "angles" not in config
    else:
        assert (config["angles"], config["zero"], config["positive"]) == (
            frame.angles,
            frame.zero,
            frame.positive,
        )
        assert [float(v) for v in config["controller.gain"].split()] == list(scene.controller.gain)


@pytest.mark.parametrize("frame", CONVENTIONS, ids=lambda f: f"{f.angles}-{f.zero}-{f.positive}")
def test_without_initial_the_pendulum_starts_upright_in_any_coordinates(
    tmp_path: Path, frame: Coordinates
) -> None:
    """No [initial] theta (and no [swingup]): the pendulum starts upright at rest (docs/scenes.md),
    whatever the scene counts from: its theta is ipgen's upright (all angles 0) written in the
    scene's coordinates (counting from hanging: half a turn), and the LQR about upright holds it
    there. Before, it started at 0 in the scene's coordinates: hanging, when they count from it."""
    scene = load_scene(make(tmp_path, {**DOUBLE, **keys(frame), "initial.theta": None}))
    state = np.array(scene.theta + scene.dtheta)
    canonical = frame.to_canonical(state, 2)
    assert np.allclose(np.remainder(canonical[:3] + math.pi, 2 * math.pi) - math.pi, 0.0, atol=1e-12)
    assert np.allclose(scene.theta, np.array(scene.controller.equilibrium[:3]), atol=1e-12)
    if frame.zero == "hanging":
        assert abs(scene.theta[1]) == pytest.approx(math.pi)


def test_an_equilibrium_given_in_the_rig_s_angles(tmp_path: Path) -> None:
    """[controller] equilibrium = [0, 0, π] with relative angles from hanging: link 1 hanging,
    link 2 turned by π from it, i.e. upright: the gain about ipgen's [0, π, 0]."""
    frame = Coordinates("relative", "hanging", "clockwise")
    scene = load_scene(
        make(tmp_path, {**DOUBLE, **keys(frame), "controller.equilibrium": "[0, 0, 3.141592653589793]"})
    )
    assert scene.controller is not None
    assert scene.controller.equilibrium == (0.0, 0.0, math.pi, 0.0, 0.0, 0.0)
    p, _ = frame.matrices(2)
    q_user = np.diag([1, 2, 3, 0.5, 0.25, 0.125])
    k = ipgen.lqr(
        "rotary", 2, scene.m, scene.l, scene.delta, p.T @ q_user @ p, 1.0, equilibrium=[0, math.pi, 0]
    )
    assert np.allclose(np.array(scene.controller.gain), (k @ np.linalg.inv(p)).ravel(), rtol=1e-7, atol=1e-9)


def test_a_swingup_in_the_rig_s_coordinates_is_ipgen_s_law(tmp_path: Path) -> None:
    """[swingup] in the rig's coordinates: the same law (swingup.* are ipgen's) as the scene in
    ipgen's, starting hanging written in the rig's angles (by hand: α = −θ1, hanging-zero α = π − θ1)."""
    base = {
        **ROTARY,
        "input.kind": None,
        "input.amplitude": None,
        "input.duration": None,
        "swingup.method": '"energy"',
        "swingup.u_max": "2",
    }
    laws, starts = [], []
    for extra in ({}, {"system.positive": '"counterclockwise"'},
                  {"system.positive": '"counterclockwise"', "system.zero": '"hanging"'}):  # fmt: skip
        scene = load_scene(make(tmp_path, {**base, **extra}))
        config = config_dict(resolved_config(scene))
        laws.append({key: value for key, value in config.items() if key.startswith("swingup")})
        starts.append(scene.theta)
    assert laws[0] == laws[1] == laws[2]
    assert starts[0] == (0.0, math.pi) and starts[1] == (0.0, -math.pi)
    assert abs(starts[2][1]) < 1e-15 and starts[2][0] == 0.0


# Any value of the three keys: a scene in that convention, or one line naming the key.
VALUES = st.one_of(
    st.sampled_from([*ANGLES, *ZEROS, *POSITIVE, "Absolute", "ccw", "down", ""]).map(lambda v: f'"{v}"'),
    st.sampled_from(["1", "true", "[]", '["relative"]', "{}", "0.5"]),
    st.text(st.characters(exclude_categories=("Cc", "Cs")), max_size=12).map(
        lambda v: json.dumps(v, ensure_ascii=False)
    ),
)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.dictionaries(st.sampled_from(["angles", "zero", "positive"]), VALUES, max_size=3))
def test_any_convention_loads_or_fails_in_one_line(tmp_path: Path, table: dict[str, str]) -> None:
    path = make(tmp_path, {**DOUBLE, **{f"system.{key}": value for key, value in table.items()}})
    try:
        scene = load_scene(path)
    except SceneError as exc:
        message = str(exc)
        assert "\n" not in message and message.startswith(f"{path.as_posix()}: "), message
        assert any(f"system.{key}" in message for key in table), message
        assert "expected" in message, message
        return
    allowed = {"angles": ANGLES, "zero": ZEROS, "positive": POSITIVE}
    for key, value in table.items():
        assert value.strip('"') in allowed[key]
        assert getattr(scene.coordinates, key) == value.strip('"')
    assert scene.controller is not None and all(math.isfinite(k) for k in scene.controller.gain)


# ---------------------------------------------------------------------------- the simulator


def _run(scene: Path, out: Path) -> subprocess.CompletedProcess[str]:
    env = dict(os.environ)  # the run's shared simulator cache (tests/conftest.py)
    return subprocess.run(
        [sys.executable, "-m", "ipgen", "run", str(scene), "-o", str(out), "--no-plot"],
        capture_output=True,
        text=True,
        env=env,
    )


def test_the_csv_is_in_the_rig_s_coordinates(tmp_path: Path) -> None:
    """The same physical open-loop run, once in ipgen's coordinates and once in a rig's
    (relative, hanging, counter-clockwise): the rig's CSV is the Python map of ipgen's, the
    energy columns are the same, the summary and the .txt say the convention, the animation's
    geometry is the same, and a bad convention line in the .cfg is one line from the simulator."""
    require_toolchain()
    common = {
        **ROTARY,
        "system.links": "2",
        "system.name": '"rdip_frame"',
        "parameters.m": "[0.5, 0.275, 0.2]",
        "parameters.l": "[0.6, 0.5, 0.4]",
        "parameters.delta": "[0.3, 0.011458, 0.01]",
        "simulation.t_end": "1",
        "outputs.energy": "true",
    }
    x0 = np.array([0.1, 0.3, -0.2, 0.2, -0.5, 0.5])  # ipgen's
    user = RIG.to_user(x0, 2)

    def listed(values: np.ndarray) -> str:
        return "[" + ", ".join(repr(float(v)) for v in values) + "]"

    own = make(
        tmp_path,
        {**common, "initial.theta": listed(x0[:3]), "initial.dtheta": listed(x0[3:])},
    )
    own = own.rename(tmp_path / "own.toml")
    rig = make(
        tmp_path,
        {**common, **keys(RIG), "initial.theta": listed(user[:3]), "initial.dtheta": listed(user[3:])},
    ).rename(tmp_path / "rig.toml")
    for scene in (own, rig):
        result = _run(scene, tmp_path / "out")
        assert result.returncode == 0, result.stderr
    own = read_run_csv(tmp_path / "out" / "own.csv", phase=False)
    rig = read_run_csv(tmp_path / "out" / "rig.csv", phase=False)
    header_own, data_own, header_rig, data_rig = own.names, own.data, rig.names, rig.data
    assert header_rig == header_own  # the same columns: every CSV reader keeps working
    assert np.allclose(data_rig[0, 1:7], user, rtol=0, atol=1e-15)
    mapped = np.array([RIG.to_user(row, 2) for row in data_own[:, 1:7]])
    assert np.allclose(data_rig[:, 1:7], mapped, rtol=1e-7, atol=1e-7)
    assert not np.allclose(data_rig[:, 1:7], data_own[:, 1:7], atol=1e-3)  # it did map
    assert np.allclose(data_rig[:, 7:], data_own[:, 7:], rtol=1e-7, atol=1e-9)  # energies
    summary = (tmp_path / "out" / "rig.txt").read_text()
    assert "Coordinates: the rig's (angles relative, zero hanging, positive counterclockwise)" in summary
    assert "in the rig's coordinates: angles relative" in summary
    assert "Coordinates" not in (tmp_path / "out" / "own.txt").read_text()
    final = summary.split("Final state theta = [", 1)[1].split("]", 1)[0]
    assert np.allclose([float(v) for v in final.split(",")], data_rig[-1, 1:4], rtol=1e-5, atol=1e-6)

    # ipgen animate draws the same pendulum from either CSV (the .cfg beside says the convention)
    assert coordinates_beside(tmp_path / "out" / "rig.csv") == RIG
    assert coordinates_beside(tmp_path / "out" / "own.csv").is_canonical
    lengths = [0.6, 0.5, 0.4]
    drawn_own = geometry("rotary", lengths, read_run_data(tmp_path / "out" / "own.csv").theta)
    rig_run = read_run_data(tmp_path / "out" / "rig.csv")
    drawn_rig = geometry("rotary", lengths, canonical_angles(rig_run, RIG))
    for part in drawn_own:
        assert np.allclose(drawn_rig[part], drawn_own[part], atol=1e-7)

    # a CSV without its .cfg: the options say the convention (ipgen plot and ipgen animate share them)
    from ipgen.command.cli import _csv_coordinates, run

    alone = tmp_path / "alone" / "rig.csv"
    alone.parent.mkdir()
    alone.write_text((tmp_path / "out" / "rig.csv").read_text())
    assert _csv_coordinates(alone, None, None, None).is_canonical
    assert _csv_coordinates(alone, "relative", "hanging", "counterclockwise") == RIG
    assert _csv_coordinates(tmp_path / "out" / "rig.csv", None, None, None) == RIG
    # one option restated or changed: the .cfg's others stay (they were reset to ipgen's)
    assert _csv_coordinates(tmp_path / "out" / "rig.csv", None, RIG.zero, None) == RIG
    assert _csv_coordinates(tmp_path / "out" / "rig.csv", "absolute", None, None) == Coordinates(
        "absolute", RIG.zero, RIG.positive
    )
    assert run(["plot", str(alone), "--angles", "relative", "--zero", "hanging"]) == 0
    assert alone.with_suffix(".png").is_file()
    assert run(["plot", str(alone), "--zero", "sideways", "--force"]) == 2

    simulator = simulator_of(summary)
    config = (tmp_path / "out" / "rig.cfg").read_text()
    for old, new in (
        ("angles = relative", "angles = joint"),
        ("positive = counterclockwise", "positive = ccw"),
    ):
        bad = tmp_path / "bad.cfg"
        bad.write_text(config.replace(old, new))
        result = subprocess.run(
            [str(simulator), str(bad), "--csv", str(tmp_path / "bad.csv")], capture_output=True, text=True
        )
        key = old.split()[0]
        assert result.returncode == 2, result.stderr
        assert f"{key} must be" in result.stderr and result.stderr.count("\n") == 1, result.stderr
