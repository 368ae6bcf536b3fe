"""A `--vary` grid's plots name each key with its unit (sweeps/units.py): the cart's coordinate in
metres, an arm's or a link's in radians, u in the scene's unit."""

from __future__ import annotations

from pathlib import Path

import pytest

from ipgen.common.presets import preset_path
from ipgen.experiment.scene import load_scene
from ipgen.sweeps import plots
from ipgen.sweeps.runner import _criteria
from ipgen.sweeps.scores import CriterionScore, LevelScore
from ipgen.sweeps.spec import Key, grid, split_key
from ipgen.sweeps.units import axis_label, key_unit

# (key, system, u's unit or None, the unit), written out from the scene format's docs
CASES = [
    ("initial.theta[0]", "classical", None, "m"),
    ("initial.theta[0]", "rotary", None, "rad"),
    ("initial.theta[1]", "classical", None, "rad"),
    ("initial.dtheta[0]", "classical", None, "m/s"),
    ("initial.dtheta[2]", "rotary", None, "rad/s"),
    ("initial.theta[0]", "fixed", None, "rad"),
    ("initial.theta", "classical", None, ""),  # metres and radians at once: no one unit
    ("parameters.delta[0]", "classical", None, "N s/m"),
    ("parameters.delta[0]", "rotary", None, "N m s/rad"),
    ("parameters.coulomb[0]", "classical", None, "N"),
    ("parameters.coulomb[1]", "rotary", None, "N m"),
    ("parameters.m[1]", "classical", None, "kg"),
    ("parameters.J[1]", "rotary", None, "kg m²"),
    ("parameters.g", "rotary", None, "m/s²"),
    ("limits.travel", "classical", None, "m"),
    ("limits.travel", "rotary", None, "rad"),
    ("controller.period", "rotary", "V", "s"),
    ("controller.u_max", "rotary", "V", "V"),
    ("controller.u_max", "classical", None, "N"),
    ("swingup.u_max", "classical", "m/s²", "m/s²"),
    ("actuator.noise", "rotary", None, "N m"),
    ("actuator.Rm", "rotary", "V", "Ω"),
    ("swingup.catch_rate", "rotary", "V", "rad/s"),
    ("controller.q", "rotary", None, ""),  # weights have no plain unit
    ("sensors.resolution", "rotary", None, ""),  # counts
]


@pytest.mark.parametrize(("text", "system", "input_unit", "unit"), CASES)
def test_each_key_has_its_unit(text: str, system: str, input_unit: str | None, unit: str) -> None:
    key = split_key(text)
    assert key_unit(key, system, input_unit) == unit
    assert axis_label(key, system, input_unit) == (f"{text} [{unit}]" if unit else text)


def test_a_motor_scenes_grid_is_labelled_in_its_units() -> None:
    """The QUBE preset (an arm on a dc motor): its grid's axes in rad, rad/s and volts."""
    path = preset_path("qube_servo2_mpc_swingup_m4f")
    vary = ("initial.theta[1]=0:0.1:2", "initial.dtheta[0]=0:1:2", "controller.u_max=8:10:2")
    (criterion,) = _criteria(path, load_scene(path), False, vary, None, None)
    assert criterion.labels == (
        "initial.theta[1] [rad]",
        "initial.dtheta[0] [rad/s]",
        "controller.u_max [V]",
    )
    assert criterion.axes == ("initial.theta[1]", "initial.dtheta[0]", "controller.u_max")


def test_the_heatmap_shows_the_labels(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """grid.png's axes are the criterion's labels (the keys' text before: no unit)."""
    keys = [(Key("initial", "theta", 0), (0.0, 0.1)), (Key("initial", "dtheta", 0), (0.0, 1.0))]
    criterion = grid(keys, 1, ("initial.theta[0] [m]", "initial.dtheta[0] [m/s]"))
    levels = tuple(LevelScore(level.values, 1, 0, 0, ()) for level in criterion.levels)
    seen: list[tuple[str, str]] = []
    saved = plots._save

    def save(figure: object, path: Path) -> Path:
        axis = figure.axes[0]
        seen.append((axis.get_xlabel(), axis.get_ylabel()))
        return saved(figure, path)

    monkeypatch.setattr(plots, "_save", save)
    assert plots.heatmap(CriterionScore(criterion, levels), tmp_path / "grid.png").is_file()
    assert seen == [("initial.theta[0] [m]", "initial.dtheta[0] [m/s]")]
