"""What the pictures show: a run about hanging keeps its own angle range, a sampled input is drawn
as steps, a link upright after a full turn reads 0, the identify plot names its coordinates, the
GIFs are larger than 420 × 216 and a cart's figure is mostly its side view, `ipgen plot` names u's
unit from the resolved scene beside the CSV (volts with a dc_motor)."""

from __future__ import annotations

import math
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from ipgen.model.coordinates import Coordinates
from ipgen.plots.run import (
    Run,
    display_turns,
    draw_run,
    input_unit_beside,
    plot_run,
    read_run,
    sampled_beside,
)  # fmt: skip


def run_of(t: np.ndarray, theta: list[np.ndarray], u: np.ndarray | None = None) -> Run:
    columns = {"t": list(t)}
    for i, values in enumerate(theta):
        columns[f"theta{i}"] = list(values)
    for i, values in enumerate(theta):
        columns[f"dtheta{i}"] = list(np.gradient(values, t))
    if u is not None:
        columns["u"] = list(u)
    return Run(columns, links=len(theta) - 1)


T = np.linspace(0.0, 5.0, 501)


def links_axes(fig):
    return fig.axes[1]


def test_a_run_about_hanging_keeps_its_own_range() -> None:
    """θ1 swings ±0.05 rad about π: the axis shows the swing, not −π..π (before: the dotted ±π
    lines forced the axis from below −π to above π, the swing a flat line)."""
    fig = draw_run(run_of(T, [0.1 * np.sin(T), math.pi + 0.05 * np.sin(3 * T)]), "hanging", "rotary")
    low, high = links_axes(fig).get_ylim()
    assert low > 2.5 and high < 3.8, (low, high)
    assert high - low < 1.0
    dotted = [line for line in links_axes(fig).lines if line.get_linestyle() == ":"]
    assert [line.get_ydata()[0] for line in dotted] == [math.pi]  # hanging is marked, −π is not
    assert fig.axes[0].get_title().endswith("dotted lines: hanging down (π)")


def test_a_run_through_both_hanging_levels_shows_both() -> None:
    fig = draw_run(run_of(T, [0 * T, 3.5 * np.sin(T)]), "swinging", "rotary")
    levels = sorted(line.get_ydata()[0] for line in links_axes(fig).lines if line.get_linestyle() == ":")
    assert levels == [-math.pi, math.pi]
    assert fig.axes[0].get_title().endswith("dotted lines: hanging down (−π, π)")


def test_a_sampled_input_is_drawn_as_steps(tmp_path: Path) -> None:
    u = np.floor(T / 0.5)  # held for 0.5 s at a time
    fig = draw_run(run_of(T, [0 * T, 0.1 * np.sin(T)], u), "sampled", "rotary", sampled=True)
    line = fig.axes[2].lines[0]
    assert line.get_drawstyle() == "steps-post"
    path = line.get_path().vertices  # steps: two vertices per sample, the value held to the next
    assert len(path) == 2 * len(T) - 1
    continuous = draw_run(run_of(T, [0 * T, 0.1 * np.sin(T)], u), "continuous", "rotary")
    assert continuous.axes[2].lines[0].get_drawstyle() == "default"
    cfg = tmp_path / "x.cfg"
    cfg.write_text("type = rotary\ncontroller = lqr\ncontroller.period = 0.01\n")
    assert sampled_beside(tmp_path / "x.csv")
    cfg.write_text("type = rotary\ncontroller = lqr\n")
    assert not sampled_beside(tmp_path / "x.csv")
    cfg.write_text("type = rotary\nswingup = energy\nswingup.period = 0.01\n")
    assert sampled_beside(tmp_path / "x.csv")


def test_a_link_upright_after_a_full_turn_reads_zero() -> None:
    """A swing-up from hanging (π) to the upright one turn on (2π) ends at 0 on the plot, the
    legend saying θ1 − 2π; a link that ends hanging is not shifted."""
    theta1 = math.pi + math.pi * (1 - np.exp(-T))  # π → 2π
    theta1[-1] = 2 * math.pi + 0.01
    fig = draw_run(run_of(T, [0 * T, theta1]), "swing-up", "rotary")
    line = links_axes(fig).lines[0]
    assert line.get_ydata()[-1] == pytest.approx(0.01)
    assert "θ1 − 2π" in line.get_label()
    hanging = draw_run(run_of(T, [0 * T, math.pi + 0.05 * np.sin(T)]), "hanging", "rotary")
    assert links_axes(hanging).lines[0].get_ydata()[0] == pytest.approx(math.pi)
    assert display_turns([-4 * math.pi + 0.1], 0.0) == -2
    # the rig's coordinates, zero hanging: upright is π there, three turns on it is 7π
    assert display_turns([7 * math.pi], math.pi) == 3
    rig = Coordinates(zero="hanging", positive="counterclockwise")
    fig = draw_run(run_of(T, [0 * T, np.full_like(T, 7 * math.pi)]), "rig", "rotary", coordinates=rig)
    assert links_axes(fig).lines[0].get_ydata()[-1] == pytest.approx(math.pi)  # upright there: π
    assert "θ1 − 6π" in links_axes(fig).lines[0].get_label()


def test_plot_run_writes_the_picture(tmp_path: Path) -> None:
    csv = tmp_path / "r.csv"
    lines = ["t,theta0,theta1,dtheta0,dtheta1,u"]
    lines += [f"{t:.2f},0,{math.pi + 0.05 * math.sin(3 * t)},0,0,{math.floor(t / 0.5)}" for t in T]
    csv.write_text("\n".join(lines) + "\n")
    (tmp_path / "r.cfg").write_text("type = rotary\ncontroller.period = 0.5\n")
    png = tmp_path / "r.png"
    plot_run(read_run(csv), png, "r", "rotary", sampled=sampled_beside(csv))
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def fake_fit(dof: int) -> SimpleNamespace:
    t = np.linspace(0, 2, 201)
    measured = np.stack([0.1 * np.sin(t)] + [0.05 * np.cos(t) * (i + 1) for i in range(1, dof)], axis=1)
    return SimpleNamespace(t=t, measured=measured, simulated=measured + 0.001, simulated_start=measured * 1.1)


def test_the_identify_plot_says_its_coordinates() -> None:
    """The fit's angles are ipgen's (upright 0, clockwise); with a rig's convention (zero hanging,
    counterclockwise) the plot draws them back in the CSV's coordinates and says so (before: ipgen's,
    unnamed, so a rig's hanging pendulum at 0 showed at ±π)."""
    from ipgen.plots.identify import identify_figure

    rig = Coordinates(zero="hanging", positive="counterclockwise")
    fit = fake_fit(2)
    fit.measured[:, 1] += math.pi  # hanging in ipgen's coordinates
    fig = identify_figure(fit, "rotary", "t", coordinates=rig)
    title = fig._suptitle.get_text()
    assert "the CSV's coordinates" in title and "0 hanging" in title and "counterclockwise" in title
    measured = fig.axes[2].lines[0].get_ydata()  # link 1: θ_rig = −(θ − π) = −0.05 cos t · 2 + ...
    assert np.allclose(measured, -(fit.measured[:, 1] - math.pi)[:: max(1, len(fit.t) // 4000)])
    own = identify_figure(fake_fit(2), "rotary", "t")
    assert "ipgen's coordinates" in own._suptitle.get_text()


@pytest.mark.parametrize("kind", ["classical", "rotary"])
def test_gifs_are_larger_and_a_carts_figure_is_its_side_view(tmp_path: Path, kind: str) -> None:
    pytest.importorskip("PIL")
    from PIL import Image

    from ipgen.plots.animation import RunData, animate_run, figure, geometry

    t = np.linspace(0, 1, 101)
    theta = np.stack([0.3 * np.sin(t), 0.4 * np.sin(2 * t), 0.2 * np.cos(3 * t)], axis=1)
    run = RunData(t=t, theta=theta, dtheta=np.gradient(theta, t, axis=0), u=None, phase=None)
    lengths = [0.0 if kind == "classical" else 0.6, 0.5, 0.5]
    gif = animate_run(run, tmp_path / "a.gif", kind, lengths, fps=4)
    width, height = Image.open(gif).size
    assert width > 420 and height > 216, (width, height)
    if kind == "classical":
        fig, top, side = figure(kind, np.array(lengths), geometry(kind, lengths, theta))
        fig.canvas.draw()
        box = {name: ax.get_window_extent() for name, ax in (("top", top), ("side", side))}
        area = fig.bbox.width * fig.bbox.height
        # before: two equal panels side by side, the view from above a band in a square of white
        assert box["side"].width * box["side"].height > 0.4 * area
        assert box["top"].height < 0.15 * fig.bbox.height
        assert box["top"].width > 0.8 * fig.bbox.width


@pytest.mark.parametrize(
    ("lines", "unit", "label"),
    [
        ("type = rotary\nactuator = dc_motor\n", "V", "input u [V]"),
        ("type = rotary\nactuator = acceleration\n", "rad/s²", "input u [rad/s²]"),
        ("type = classical\nactuator = acceleration\n", "m/s²", "input u [m/s²]"),
        ("type = rotary\n", None, "input u [N m]"),
        ("type = classical\n", None, "input u [N]"),
    ],
)
def test_ipgen_plot_names_the_unit_of_u(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, lines: str, unit: str | None, label: str
) -> None:
    """The unit of u `ipgen plot` draws with (`input_unit_beside`: the resolved scene's .cfg beside
    the CSV): volts for a dc_motor, an acceleration for an acceleration-driven base, else the force
    or torque of the base (`ipgen plot` called u of a motor's run "N m" before)."""
    from ipgen.command.cli import run as cli

    csv = tmp_path / "scene.csv"
    csv.write_text("t,theta0,theta1,dtheta0,dtheta1,u\n0,0,0.1,0,0,1\n0.01,0,0.1,0,0,-1\n")
    (tmp_path / "scene.cfg").write_text(lines + "l = 0.1 0.2\n")
    assert input_unit_beside(csv) == unit
    drawn = []
    original = draw_run

    def recording(*args, **kwargs):
        fig = original(*args, **kwargs)
        drawn.append([line.get_label() for ax in fig.axes for line in ax.get_lines()])
        return fig

    import ipgen.plots.run

    monkeypatch.setattr(ipgen.plots.run, "draw_run", recording)
    assert cli(["plot", str(csv), "-o", str(tmp_path / "plot.png")]) == 0
    assert any(label == name for name in drawn[0]), drawn


@pytest.mark.parametrize(
    ("frame", "ylabel", "second"),
    [
        (Coordinates(), "(0 upright, cw)", "link 2 angle"),
        (Coordinates("relative", "hanging", "counterclockwise"), "(0 hanging, ccw)",
         "link 2 angle from link 1"),
    ],
)
def test_a_fixed_chains_picture_says_what_its_angles_count_from(
    tmp_path: Path, frame: Coordinates, ylabel: str, second: str
) -> None:
    """A fixed chain's picture labels its angles in the run's coordinates (DFKI's: from hanging,
    counterclockwise, link 2 from link 1); it said "link angle [rad]" whatever they were."""
    csv = tmp_path / "chain.csv"
    rows = ["t,theta0,theta1,dtheta0,dtheta1", *(f"{k * 0.01},{0.1 * k},{-0.05 * k},0,0" for k in range(20))]
    csv.write_text("\n".join(rows) + "\n")
    figure = draw_run(read_run(csv, fixed=True), "chain", "fixed", coordinates=frame)
    links = figure.axes[0]
    assert links.get_ylabel().endswith(ylabel)
    assert [line.get_label() for line in links.get_lines()][1] == second
