"""Pictures of runs: the geometry is to scale, a GIF and a PNG come out of a simulator CSV, and
bad input (unreadable CSV, wrong lengths, an existing file) is a one-line PlotError."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from ipgen import Error
from ipgen.plots.animation import PlotError, animate_run, geometry, plot_plan_and_run, read_run

DATA = Path(__file__).resolve().parent / "data"


def test_geometry_classical_is_to_scale() -> None:
    # cart at 0.2 m, link 1 horizontal to the right (π/2 clockwise from upright), link 2 upright
    points = geometry("classical", [0.0, 0.5, 0.4], np.array([[0.2, math.pi / 2, 0.0]]))
    np.testing.assert_allclose(points["side"][0], [[0.2, 0.0], [0.7, 0.0], [0.7, 0.4]], atol=1e-12)
    np.testing.assert_allclose(points["top"][0, :, 1], 0.0, atol=1e-12)


def test_geometry_rotary_follows_the_model_coordinates() -> None:
    """Tips seen from above: l0 (sin θ0, cos θ0) + r (cos θ0, −sin θ0), r = Σ l_k sin θk
    (docs/model.md, eq. 25); the side view is the links' own (r, z) plane."""
    theta0, theta1 = 0.3, 1.1
    points = geometry("rotary", [0.6, 0.5], np.array([[theta0, theta1]]))
    arm = 0.6 * np.array([math.sin(theta0), math.cos(theta0)])
    r = 0.5 * math.sin(theta1)
    np.testing.assert_allclose(points["top"][0, 1], arm, atol=1e-12)
    np.testing.assert_allclose(points["top"][0, 2], arm + r * np.array([math.cos(theta0), -math.sin(theta0)]))
    np.testing.assert_allclose(points["side"][0, 1], [r, 0.5 * math.cos(theta1)], atol=1e-12)
    # every tip is a link length from the one before it (3-D: top offset and height)
    assert math.isclose(math.hypot(np.linalg.norm(points["top"][0, 2] - arm), points["side"][0, 1, 1]), 0.5)


def _short_csv(tmp_path: Path, seconds: float = 1.0) -> Path:
    lines = (DATA / "rsip_pulse.golden.csv").read_text().splitlines()
    path = tmp_path / "rsip.csv"
    path.write_text("\n".join(lines[: int(seconds / 0.01) + 2]) + "\n")
    return path


def test_gif_and_png_from_a_simulator_csv(tmp_path: Path) -> None:
    csv_path = _short_csv(tmp_path)
    run = read_run(csv_path)
    assert run.links == 1 and run.u is None and run.theta.shape == (101, 2)
    gif = animate_run(csv_path, tmp_path / "rsip.gif", "rotary", [0.6, 0.5], fps=10)
    with Image.open(gif) as image:
        assert image.format == "GIF" and image.n_frames == 11
    png = plot_plan_and_run(tmp_path / "rsip.png", run, u_max=0.4)
    with Image.open(png) as image:
        assert image.format == "PNG"
    assert not list(tmp_path.glob(".ipgen.*"))  # no temporary left behind
    plain = tmp_path / "plain"
    plain.write_text("")
    assert gif.stat().st_mode & 0o777 == plain.stat().st_mode & 0o777  # the umask's mode, not 0600


def test_an_existing_picture_is_kept_without_force(tmp_path: Path) -> None:
    csv_path = _short_csv(tmp_path, 0.2)
    target = tmp_path / "run.png"
    target.write_text("keep me")
    with pytest.raises(PlotError, match="force"):
        plot_plan_and_run(target, csv_path)
    assert target.read_text() == "keep me"
    plot_plan_and_run(target, csv_path, force=True)
    assert target.read_bytes()[:4] == b"\x89PNG"


@pytest.mark.parametrize(
    ("text", "words"),
    [
        ("", "header"),
        ("t,x\n0,1\n", "theta0"),
        ("t,theta0,theta1,dtheta0,dtheta1\n0,0,0,0\n", "line 2"),
        ("t,theta0,theta1,dtheta0,dtheta1\n0,0,nan,0,0\n", "non-finite"),
        ("t,theta0,theta1,dtheta0,dtheta1\n0,0,0,0,0\n0,0,0,0,0\n", "increase"),
    ],
)
def test_bad_csv_is_a_one_line_error(tmp_path: Path, text: str, words: str) -> None:
    path = tmp_path / "bad.csv"
    path.write_text(text)
    with pytest.raises(Error) as caught:
        read_run(path)
    message = str(caught.value)
    assert words in message and "\n" not in message


def test_lengths_must_match_the_run(tmp_path: Path) -> None:
    csv_path = _short_csv(tmp_path, 0.2)
    with pytest.raises(PlotError, match="expected 2"):
        animate_run(csv_path, tmp_path / "x.gif", "rotary", [0.6, 0.5, 0.5])
    with pytest.raises(PlotError, match="arm length"):
        animate_run(csv_path, tmp_path / "x.gif", "rotary", [0.0, 0.5])
    assert not (tmp_path / "x.gif").exists()
