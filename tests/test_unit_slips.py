"""Unit slips: millimetres for metres, grams for kilograms, degrees for radians run (the model is
valid) but get a warning naming the value and the unit probably meant."""

from __future__ import annotations

import math
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from test_scene import ROTARY, make

from ipgen.command.cli import run as cli
from ipgen.experiment.plausibility import HEAVIEST, LONGEST, unit_slips
from ipgen.experiment.scene import load_scene


def test_millimetres_degrees_and_grams_are_warned_about(tmp_path: Path) -> None:
    path = make(
        tmp_path,
        {
            **ROTARY,
            "parameters.l": "[600, 500]",  # millimetres
            "parameters.m": "[1500, 275]",  # grams (the arm)
            "initial.theta": "[0, 30]",  # degrees
        },
    )
    scene = load_scene(path)
    text = "\n".join(scene.warnings)
    assert len(scene.warnings) == 4, text
    assert all(w.startswith(f"{path.as_posix()}: warning: ") for w in scene.warnings)
    assert "parameters.l[0] = 600 m" in text and "parameters.l[1] = 500 m" in text and "0.5 m" in text
    assert "parameters.m[0] = 1500 kg" in text and "grams? 1.5 kg" in text
    assert "parameters.m[1]" not in text
    assert "initial.theta[1] = 30 rad" in text and "degrees?" in text


def test_a_cart_position_is_not_an_angle(tmp_path: Path) -> None:
    """θ0 of a cart is a position in metres: 7 m is no angle (nor longer than a rig's rail is
    checked here); on a rotary pendulum θ0 is the arm's angle and is checked."""
    assert load_scene(make(tmp_path, {"initial.theta": "[7, 0, 0]"})).warnings == ()
    rotary = load_scene(make(tmp_path, {**ROTARY, "initial.theta": "[7, 0]"}))
    assert len(rotary.warnings) == 1 and "initial.theta[0] = 7 rad" in rotary.warnings[0]


def test_the_command_warns_and_succeeds(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = make(tmp_path, {"parameters.l": "[0, 500, 500]"})
    assert cli(["--scene", str(path), "--describe"]) == 0
    captured = capsys.readouterr()
    assert "name=" in captured.out
    assert captured.err.count("warning: parameters.l[") == 2, captured.err


finite = st.floats(min_value=1e-6, max_value=1e6, allow_nan=False)


@settings(max_examples=200, deadline=None)
@given(
    m=st.lists(finite, min_size=2, max_size=4),
    l=st.lists(finite, min_size=2, max_size=4),
    theta=st.lists(st.floats(min_value=-100, max_value=100), min_size=2, max_size=4),
    kind=st.sampled_from(["classical", "rotary"]),
)
def test_one_warning_per_value_beyond_the_bounds(
    m: list[float], l: list[float], theta: list[float], kind: str  # noqa: E741
) -> None:
    first_angle = 0 if kind == "rotary" else 1
    expected = (
        sum(v > LONGEST for v in l)
        + sum(v > HEAVIEST for v in m)
        + sum(abs(v) > 2 * math.pi for v in theta[first_angle:])
    )
    assert len(unit_slips(kind, m, l, theta)) == expected
