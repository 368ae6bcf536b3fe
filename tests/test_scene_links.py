"""Scenes with the links as built: `[parameters]` arrays com, J, J_axial, tip (each optional,
the paper's rods when absent), written to the simulator's .cfg, folded into specialised headers,
used for a scene's LQR controller, and refused with one line when no body has them."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import ipgen
from ipgen.errors import SceneError
from ipgen.experiment.config import resolved_config
from ipgen.experiment.scene import load_scene
from ipgen.experiment.specialisation import from_scene

SCENE = """\
[system]
type = "rotary"
links = 2
inertia = "full"
specialise = true

[parameters]
m = [0.2, 0.1, 0.15]
l = [0.3, 0.5, 0.4]
delta = [0.01, 0.001, 0.002]
{links}

[simulation]
t_end = 1.0
"""


def scene(tmp_path: Path, links: str) -> Path:
    path = tmp_path / "built.toml"
    path.write_text(SCENE.format(links=links))
    return path


def test_links_reach_cfg_and_specialisation(tmp_path: Path) -> None:
    loaded = load_scene(
        scene(tmp_path, "com = [0, 0.2, -0.05]\nJ = [0.004, 0.002, 0.001]\ntip = [0, 0.141, 0]")
    )
    config = resolved_config(loaded)
    assert "com = 0 0.2 -0.05" in config and "J = 0.004 0.002 0.001" in config and "tip = 0 0.141 0" in config
    assert "J_axial" not in config  # not given: the simulator keeps its default (0)
    fixed = dict(from_scene(loaded).fixed)
    assert fixed["com1"] == pytest.approx(0.2) and fixed["com2"] == pytest.approx(-0.05)
    assert fixed["J0"] == pytest.approx(0.004) and fixed["tip1"] == pytest.approx(0.141)
    assert fixed["J_axial1"] == 0  # absent: the rods' value


def test_rods_by_default(tmp_path: Path) -> None:
    loaded = load_scene(scene(tmp_path, ""))
    assert "com" not in resolved_config(loaded)
    fixed = dict(from_scene(loaded).fixed)
    assert fixed["com1"] == pytest.approx(0.25) and fixed["J1"] == pytest.approx(0.1 * 0.25 / 12)
    assert fixed["J0"] == pytest.approx(0.2 * 0.09 / 3)


@pytest.mark.parametrize(
    ("links", "message"),
    [
        ("J = [0.004, -0.002, 0.001]", "J[1]"),
        ("tip = [0, 0.1, -1]", "tip[2]"),
        ("J = [0.004, 0.002, 0.001]\nJ_axial = [0, 0.0041, 0]", "J_axial[1]"),
        ("com = [0, 0.1]", "com"),
        ("com = [0, 0.2, 0]\nJ = [0.004, 0.002, 0]", "link 2 has no inertia"),
    ],
)
def test_bad_links_are_refused(tmp_path: Path, links: str, message: str) -> None:
    with pytest.raises(SceneError) as refused:
        load_scene(scene(tmp_path, links))
    text = str(refused.value)
    assert "\n" not in text and message in text, text


def test_controller_uses_the_links(tmp_path: Path) -> None:
    """A scene's LQR gain is computed on the links as built it gives."""
    links = 'J = [0.004, 0.002, 0.001]\ntip = [0, 0.05, 0]\n\n[controller]\nkind = "lqr"'
    loaded = load_scene(scene(tmp_path, links))
    expected = ipgen.lqr(
        "rotary", 2, [0.2, 0.1, 0.15], [0.3, 0.5, 0.4], [0.01, 0.001, 0.002], Q=np.ones(6), R=1,
        inertia="full", J=[0.004, 0.002, 0.001], tip=[0, 0.05, 0],
    )  # fmt: skip
    assert loaded.controller is not None
    assert np.allclose(loaded.controller.gain, expected, rtol=1e-9)
