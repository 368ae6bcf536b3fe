"""Properties (issue 31): `ipgen plot` and `ipgen animate` over generated CSVs and options. Any
times (spanning up to 1e20 s), any values (up to ±1.8e308), any --fps and --lengths: the command
writes its picture, or exits with status 2 and one line `ipgen: error: ...`; the animation has
at most MAX_FRAMES frames (a longer run is time-lapsed, said in one line), so time and memory
stay bounded. To keep the suite fast, MAX_FRAMES is lowered here (the bound's logic is the same;
its value's cost is measured in docs/generator.md)."""

from __future__ import annotations

import contextlib
import io
import math
import time
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from PIL import Image

from ipgen.command.cli import run
from ipgen.plots import animation

FRAMES = 12  # MAX_FRAMES in these tests

VALUES = st.one_of(
    st.floats(-10, 10),
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from([1e308, -1.8e308, 1e100, 1e101, 0.0]),
)


FPS = st.one_of(
    st.sampled_from([0.001, 0.1, 1.0, 15.0, 50.0, 1e308, math.nan, -1.0]),
    st.floats(0.05, 60),
    st.floats(allow_nan=True),
)


@st.composite
def runs(draw: st.DrawFn) -> tuple[list[float], list[list[float]]]:
    rows = draw(st.integers(1, 40))
    span = draw(st.sampled_from([0.5, 10.0, 1e6, 1e20, 1e300]))
    times = sorted({span * k / max(rows - 1, 1) for k in range(rows)})
    if draw(st.booleans()):  # jitter, possibly out of order
        times = [t + draw(st.floats(-0.01, 0.01)) * span / max(rows, 1) for t in times]
    values = [
        [draw(VALUES) if draw(st.integers(0, 9)) == 0 else 0.1 * k for _ in range(4)] for k in range(rows)
    ]
    return times, values


def _call(argv: list[str]) -> tuple[int, str]:
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        status = run(argv)
    return status, err.getvalue()


def _write(folder: Path, run_: tuple[list[float], list[list[float]]]) -> Path:
    times, values = run_
    path = folder / "run.csv"
    lines = ["t,theta0,theta1,dtheta0,dtheta1"] + [
        ",".join(repr(float(x)) for x in (t, *row)) for t, row in zip(times, values, strict=True)
    ]
    path.write_text("\n".join(lines) + "\n")
    return path


def _one_line_error(status: int, err: str) -> None:
    assert status == 2, err
    errors = [line for line in err.splitlines() if line.startswith("ipgen: error: ")]
    assert len(errors) == 1 and "Traceback" not in err, err


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(
    run_=runs(),
    fps=FPS,
    lengths=st.one_of(st.none(), st.lists(st.floats(allow_nan=True), min_size=1, max_size=3)),
)
def test_animate_over_generated_runs_and_options(
    monkeypatch: pytest.MonkeyPatch, tmp_path_factory: pytest.TempPathFactory, run_, fps: float, lengths
) -> None:
    monkeypatch.setattr(animation, "MAX_FRAMES", FRAMES)
    folder = tmp_path_factory.mktemp("a")
    csv = _write(folder, run_)
    gif = folder / "run.gif"
    words = "0,0.5" if lengths is None else ",".join(repr(v) for v in lengths)
    clock = time.perf_counter()
    status, err = _call(["animate", str(csv), "-o", str(gif), "--type", "classical", "--lengths", words,
                         "--fps", repr(fps)])  # fmt: skip
    assert time.perf_counter() - clock < 120  # bounded: at most FRAMES frames are drawn
    if status != 0:
        _one_line_error(status, err)
        assert not gif.exists()
        return
    with Image.open(gif) as image:
        # a still run's identical frames are one GIF frame (Pillow merges them, summing durations)
        assert image.format == "GIF" and 1 <= image.n_frames <= FRAMES
    low, high = animation.FPS_RANGE
    assert low <= fps <= high
    duration = run_[0][-1] - run_[0][0]
    if duration * fps + 1 > FRAMES:  # time-lapsed, and said so in one line
        assert "times faster" in err


@settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(run_=runs())
def test_plot_over_generated_runs(tmp_path_factory: pytest.TempPathFactory, run_) -> None:
    folder = tmp_path_factory.mktemp("p")
    csv = _write(folder, run_)
    png = folder / "run.png"
    status, err = _call(["plot", str(csv), "-o", str(png)])
    if status != 0:
        _one_line_error(status, err)
        assert not png.exists()
        return
    with Image.open(png) as image:
        assert image.format == "PNG"
    finite = all(math.isfinite(v) and abs(v) <= 1e100 for row in run_[1] for v in row)
    assert finite and all(abs(t) <= 1e100 for t in run_[0])


def test_frame_plan_bounds_every_run() -> None:
    for duration in (0.0, 1.0, 40.0, 1e6, 1e20, 1e300):
        for fps in (0.1, 15.0, 50.0):
            count, speedup = animation.frame_plan(duration, fps)
            assert 2 <= count <= animation.MAX_FRAMES
            assert speedup == 1.0 or math.isclose((count - 1) * speedup, duration * fps)
    with pytest.raises(animation.PlotError):
        animation.frame_plan(math.inf, 15.0)


@given(fps=st.floats(0.1, 50.0), count=st.integers(2, 400))
def test_a_gif_plays_its_frames_at_fps_to_a_hundredth(fps: float, count: int) -> None:
    """A GIF counts its delays in hundredths of a second: after k frames it has played k / fps s
    to within 5 ms (one delay of round(1000 / fps) ms, which pillow truncates to hundredths, played
    a run at 15 fps 10 % fast and at 40 fps 25 % fast), and no delay is below 20 ms (what viewers
    show as 100 ms)."""
    from ipgen.plots.animation import frame_delays

    delays = frame_delays(count, fps)
    assert len(delays) == count and all(d % 10 == 0 and d >= 20 for d in delays)
    played = 0
    for k, delay in enumerate(delays, start=1):
        played += delay
        assert abs(played / 1000 - k / fps) <= 0.005 + 1e-9
