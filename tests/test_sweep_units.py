"""A `--vary` grid's plots name each key with its unit (sweeps/units.py): the cart's coordinate in
metres, an arm's or a link's in radians, u in the scene's unit."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import pytest

from ipgen.common.presets import preset_path
from ipgen.experiment.scene import load_scene
from ipgen.sweeps import plots, runner
from ipgen.sweeps.runner import _criteria
from ipgen.sweeps.scores import CriterionScore, LevelScore
from ipgen.sweeps.spec import Key, SweepError, grid, split_key
from ipgen.sweeps.success import Success
from ipgen.sweeps.units import axis_label, key_unit

if TYPE_CHECKING:
    from matplotlib.figure import Figure

# (key, system, u's unit, the unit), written out from the scene format's docs (docs/scenes.md,
# the schema's descriptions; a cart's damping there in kg/s, the same as N s/m)
CASES = [
    ("initial.theta[0]", "classical", "N", "m"),
    ("initial.theta[0]", "rotary", "N m", "rad"),
    ("initial.theta[1]", "classical", "N", "rad"),
    ("initial.dtheta[0]", "classical", "N", "m/s"),
    ("initial.dtheta[2]", "rotary", "N m", "rad/s"),
    ("initial.theta[0]", "fixed", "N m", "rad"),
    ("initial.theta", "classical", "N", ""),  # metres and radians at once: no one unit
    ("parameters.delta[0]", "classical", "N", "N s/m"),
    ("parameters.delta[0]", "rotary", "N m", "N m s/rad"),
    ("parameters.coulomb[0]", "classical", "N", "N"),
    ("parameters.coulomb[1]", "rotary", "N m", "N m"),
    ("parameters.m[1]", "classical", "N", "kg"),
    ("parameters.J[1]", "rotary", "N m", "kg m²"),
    ("parameters.g", "rotary", "N m", "m/s²"),
    ("limits.travel", "classical", "N", "m"),
    ("limits.travel", "rotary", "N m", "rad"),
    ("controller.period", "rotary", "V", "s"),
    ("controller.u_max", "rotary", "V", "V"),
    ("controller.u_max", "classical", "N", "N"),
    ("swingup.u_max", "classical", "m/s²", "m/s²"),
    ("actuator.noise", "rotary", "N m", "N m"),
    ("actuator.Rm", "rotary", "V", "Ω"),
    ("swingup.catch_rate", "rotary", "V", "rad/s"),
    ("swingup.catch_base", "classical", "N", "m"),  # it bounds |θ0|
    ("swingup.catch_base", "rotary", "V", "rad"),
    ("swingup.x_max", "classical", "N", "m"),
    ("swingup.accel_max", "rotary", "V", "rad/s²"),
    ("controller.travel", "classical", "N", "m"),
    ("parameters.coulomb_speed", "rotary", "N m", "rad/s"),
    ("parameters.coulomb_speed", "classical", "N", ""),  # the cart's m/s and the links' rad/s
    ("sensors.noise", "rotary", "V", "rad"),
    ("estimator.lag", "rotary", "V", "s"),
    ("estimator.cutoff", "rotary", "V", "rad/s"),
    ("parameters.delta[1]", "fixed", "N m", "N m s/rad"),
    ("actuator.Ir[0]", "fixed", "N m", "kg m²"),
    ("limits.travel", "fixed", "N m", ""),  # no base
    ("controller.q", "rotary", "N m", ""),  # weights have no plain unit
    ("sensors.resolution", "rotary", "N m", ""),  # counts
]


@pytest.mark.parametrize(("text", "system", "input_unit", "unit"), CASES)
def test_each_key_has_its_unit(text: str, system: str, input_unit: str, unit: str) -> None:
    key = split_key(text)
    assert key_unit(key, system, input_unit) == unit
    assert axis_label(key, system, input_unit) == (f"{text} [{unit}]" if unit else text)


def test_a_motor_scenes_grid_is_labelled_in_its_units() -> None:
    """The QUBE preset (an arm on a dc motor): its grid's axes in rad, rad/s and volts."""
    path = preset_path("qube_servo2_mpc_swingup_m4f")
    vary = ("initial.theta[1]=0:0.1:2", "initial.dtheta[0]=0:1:2", "controller.u_max=8:10:2")
    (criterion,) = _criteria(path, load_scene(path), False, vary, None, None)
    assert criterion.axis_titles == (
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

    def save(figure: Figure, path: Path) -> Path:
        axis = figure.axes[0]
        seen.append((axis.get_xlabel(), axis.get_ylabel()))
        return saved(figure, path)

    monkeypatch.setattr(plots, "_save", save)
    assert plots.heatmap(CriterionScore(criterion, levels), tmp_path / "grid.png").is_file()
    assert seen == [("initial.theta[0] [m]", "initial.dtheta[0] [m/s]")]


def test_a_cart_scenes_grid_of_one_key_is_labelled_on_its_plot(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A 1-D grid on a cart: the criterion's x axis is the key with the cart's unit."""
    path = preset_path("cdip_lqr_tilt")
    (criterion,) = _criteria(path, load_scene(path), False, ("initial.theta[0]=0:0.1:2",), None, None)
    assert criterion.axis_titles == ("initial.theta[0] [m]",)
    levels = tuple(LevelScore(level.values, 1, 0, 0, ()) for level in criterion.levels)
    seen: list[str] = []
    saved = plots._save

    def save(figure: Figure, path: Path) -> Path:
        seen.append(figure.axes[0].get_xlabel())
        return saved(figure, path)

    monkeypatch.setattr(plots, "_save", save)
    plots.criterion_plot(CriterionScore(criterion, levels), [], Success(), tmp_path / "c.png")
    assert seen == ["initial.theta[0] [m]"]


def test_a_fixed_chains_grid_is_labelled_in_radians(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A fixed chain (the acrobot preset): its links' angles in rad, a rotor's inertia in kg m²
    (the sweep stopped once its grid is made: no run)."""
    made: list[tuple[str, ...]] = []

    def stop(keys: list, repeat: int, labels: tuple[str, ...] = ()) -> None:
        made.append(labels)
        raise SweepError("stopped by the test")

    monkeypatch.setattr(runner, "grid", stop)
    vary = ("initial.theta[1]=0:0.1:2", "actuator.Ir[0]=0:1e-4:2")
    with pytest.raises(SweepError, match="stopped by the test"):
        runner.sweep(preset_path("acrobot_mpc"), tmp_path / "o", vary=vary)
    assert made == [("initial.theta[1] [rad]", "actuator.Ir[0] [kg m²]")]


def test_a_grid_takes_one_label_per_key() -> None:
    keys = [(Key("initial", "theta", 0), (0.0,)), (Key("initial", "dtheta", 0), (0.0,))]
    with pytest.raises(ValueError, match="1 labels for 2 keys"):
        grid(keys, 1, ("initial.theta[0] [m]",))
