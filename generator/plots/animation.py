"""Pictures of a run: an animated GIF drawn to scale, and a PNG of a plan against a run.

A run is a CSV as the simulator writes it: a header `t,theta0..thetan,dtheta0..dthetan` and
optionally more columns (`u`, `phase`, `energy`, …), one row per sample. The drawing needs the
system's type and lengths (l0 the arm [m] of a rotary pendulum, unused for a cart; l1..ln the
links [m]); angles are absolute from upright, clockwise positive (docs/model.md):

- classical: from the side (x, z) the cart at x = θ0 on its rail and the links in their plane;
  from above (x, y) the rail, the cart and the links' shadow on the rail's line;
- rotary: from above (x, y) the arm from the axis to its tip at l0 (sin θ0, cos θ0) and the links'
  shadow, which swings perpendicular to the arm; from the side, the links' own vertical plane
  (r, z) at the arm's tip, r along (cos θ0, −sin θ0) (the view of an observer riding the arm).

Both views trace the last link's tip over the last `trace` seconds. Frames are subsampled to
`fps` (default 15 per second of the run: a frame every 1 / fps s of it, each shown so that k
frames play k / fps s to a hundredth, the GIF's unit) and written as a GIF by pillow; every file is
written to a temporary name and renamed, and an existing file is kept unless `force`.
"""

from __future__ import annotations

import csv
import dataclasses
import io
import itertools
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ipgen.common import files
from ipgen.errors import Error
from ipgen.model.coordinates import Coordinates

if TYPE_CHECKING:
    import numpy as np

__all__ = ["PlotError", "RunData", "animate_run", "check_fps", "frame_plan", "plot_plan_and_run", "read_run"]


class PlotError(Error):
    """A run or picture that cannot be drawn (unreadable CSV, wrong lengths, existing file)."""


@dataclass(frozen=True)
class RunData:
    """A run read from a CSV: times (K), angles and rates (K × dof), the input (K, or None) and
    the phase names (or None)."""

    t: np.ndarray
    theta: np.ndarray
    dtheta: np.ndarray
    u: np.ndarray | None
    phase: tuple[str, ...] | None

    @property
    def links(self) -> int:
        return self.theta.shape[1] - 1


def read_run(path: str | Path) -> RunData:
    """The run in the simulator's CSV at `path` (PlotError naming the problem if unreadable)."""
    import numpy as np

    path = Path(path)
    try:  # a long run is thinned evenly to MAX_ROWS rows (and its last), read streaming
        with path.open(newline="") as handle:
            count = sum(1 for _ in handle)
        stride = max(1, (count - 1) // MAX_ROWS)
        with path.open(newline="") as handle:
            rows = [
                row
                for i, row in enumerate(csv.reader(handle))
                if i == 0 or (i - 1) % stride == 0 or i == count - 1
            ]
    except csv.Error as exc:
        raise PlotError(f"{path}: not a CSV the simulator wrote ({exc})") from None
    except OSError as exc:
        raise PlotError(f"{path}: cannot read the run ({exc.strerror or exc})") from None
    except UnicodeDecodeError:
        raise PlotError(f"{path}: not a text CSV file") from None
    if len(rows) < 2:
        raise PlotError(f"{path}: expected a header and at least one row (a CSV the simulator wrote)")
    header = [name.strip() for name in rows[0]]
    dof = 0
    while f"theta{dof}" in header:
        dof += 1
    wanted = ["t", *(f"theta{i}" for i in range(dof)), *(f"dtheta{i}" for i in range(dof))]
    missing = [name for name in wanted if name not in header]
    if dof < 2 or missing:
        raise PlotError(
            f"{path}: expected columns t, theta0..thetan, dtheta0..dthetan (n >= 1); "
            f"missing {', '.join(missing) or 'theta1'}"
        )
    columns = {name: header.index(name) for name in header}
    numeric = [*wanted, *(["u"] if "u" in columns else [])]
    data = np.empty((len(rows) - 1, len(numeric)))
    for r, row in enumerate(rows[1:], start=2):
        try:
            data[r - 2] = [float(row[columns[name]]) for name in numeric]
        except (ValueError, IndexError):
            raise PlotError(f"{path}: line {r} is not a row of numbers in the header's columns") from None
    if not np.all(np.isfinite(data)):
        raise PlotError(f"{path}: the run holds non-finite values (a run that failed?)")
    t = data[:, 0]
    if np.any(np.diff(t) <= 0):
        raise PlotError(f"{path}: the times in column t must increase")
    phase = tuple(row[columns["phase"]] for row in rows[1:]) if "phase" in columns else None
    return RunData(
        t=t,
        theta=data[:, 1 : 1 + dof],
        dtheta=data[:, 1 + dof : 1 + 2 * dof],
        u=data[:, -1] if "u" in columns else None,
        phase=phase,
    )


def canonical_angles(data: RunData, coordinates: Coordinates | None) -> np.ndarray:
    """The run's angle rows (K × dof) in ipgen's coordinates (absolute, from upright, clockwise),
    from the rig's `coordinates` the CSV is in (None: already ipgen's)."""
    import numpy as np

    if coordinates is None or coordinates.is_canonical:
        return data.theta
    states = np.hstack([data.theta, data.dtheta])
    p, c = coordinates.matrices(data.links)
    return np.linalg.solve(p, (states - c).T).T[:, : data.links + 1]


# Bounds of an animation: frames (each kept in memory until the GIF is written: 400 frames of
# 420 × 216 pixels are about 36 MB; drawing one takes ~70 ms of CPU; 400 frames are a 26 s run
# at the default 15 per second, longer than every shipped swing-up), frames per
# second of the run (a GIF frame lasts at most 655 s; below 0.1 nothing moves), and the
# distances drawn to scale [m].
MAX_FRAMES = 400
MAX_ROWS = 200_000  # rows of a CSV read (more are thinned evenly): a few MB, more than frames need
FPS_RANGE = (0.1, 50.0)
LARGEST_DRAWN = 1e9
GIF = "GIF animation"  # the kind of file an animation is (common.files)


def check_fps(fps: float) -> None:
    """A PlotError unless `fps` is in FPS_RANGE."""
    low, high = FPS_RANGE
    if not (math.isfinite(fps) and low <= fps <= high):
        raise PlotError(f"fps = {fps:g}: expected {low:g} <= fps <= {high:g} frames per second of the run")


def frame_plan(duration: float, fps: float) -> tuple[int, float]:
    """(frames, speed-up) of an animation of a run lasting `duration` s at `fps` frames per second
    of the run: at most MAX_FRAMES frames; a longer run plays faster than real time (speed-up > 1)."""
    if not (math.isfinite(duration) and duration >= 0):
        raise PlotError(f"the run lasts {duration:g} s: its times must be finite and increase")
    wanted = duration * fps + 1
    if wanted <= MAX_FRAMES:
        return max(2, int(wanted)), 1.0
    return MAX_FRAMES, (duration * fps) / (MAX_FRAMES - 1)


def frame_delays(count: int, fps: float) -> list[int]:
    """Each frame's delay [ms] for `count` frames at `fps`: a GIF counts whole hundredths of a
    second, so frame k ends at round(100 k / fps) cs and the GIF plays k / fps s in k frames to a
    hundredth (one delay of round(1000 / fps) ms, truncated to cs, played 15 fps 10 % fast)."""
    ends = [round(100 * k / fps) for k in range(count + 1)]
    return [10 * max(1, b - a) for a, b in itertools.pairwise(ends)]


def _on_a_still_base(data: RunData) -> RunData:
    """A fixed chain's run (theta0..theta(n-1): links 1..n) with a base coordinate 0 in front:
    the same chain on a cart that never moves, whose coordinates (`Coordinates`: index 0 the base,
    1 the first link) and geometry are the cart's."""
    import numpy as np

    zero = np.zeros((data.theta.shape[0], 1))
    theta, dtheta = np.hstack([zero, data.theta]), np.hstack([zero, data.dtheta])
    return dataclasses.replace(data, theta=theta, dtheta=dtheta)


def _lengths(type: str, links: int, l: Sequence[float]) -> list[float]:  # noqa: E741
    if type not in ("classical", "rotary"):
        raise PlotError(f"type {type!r}: expected 'classical' or 'rotary'")
    values = [float(v) for v in l]
    if len(values) != links + 1:
        raise PlotError(f"l has {len(values)} entries, expected {links + 1} (l0 and one per link of the run)")
    if not all(abs(v) <= LARGEST_DRAWN for v in values) or any(v <= 0 for v in values[1:]):
        raise PlotError(f"lengths l must be at most {LARGEST_DRAWN:g} m, the links' l1..ln > 0")
    if sum(values) > LARGEST_DRAWN:
        raise PlotError(f"the lengths add up to {sum(values):.3g} m: at most {LARGEST_DRAWN:g} m are drawn")
    if type == "rotary" and values[0] <= 0:
        raise PlotError("a rotary pendulum needs its arm length l0 > 0")
    return values


def geometry(type: str, l: Sequence[float], theta: np.ndarray) -> dict[str, np.ndarray]:  # noqa: E741
    """Points to draw for angle rows `theta` (K × dof): `top` (K × (links+2) × 2: axis or cart,
    arm tip or cart, then each link's tip, seen from above) and `side` (K × (links+1) × 2:
    the pivot then each link's tip, in the side view's (horizontal, up) coordinates)."""
    import numpy as np

    theta = np.atleast_2d(theta)
    l = np.asarray(l, dtype=float)  # noqa: E741
    links = theta.shape[1] - 1
    radial = np.cumsum(l[1:] * np.sin(theta[:, 1:]), axis=1)  # horizontal offsets of the tips
    up = np.cumsum(l[1:] * np.cos(theta[:, 1:]), axis=1)
    side = np.zeros((theta.shape[0], links + 1, 2))
    top = np.zeros((theta.shape[0], links + 2, 2))
    if type == "classical":
        x0 = theta[:, 0]
        side[:, 0, 0] = x0
        side[:, 1:, 0] = x0[:, None] + radial
        side[:, 1:, 1] = up
        top[:, 0, 0] = top[:, 1, 0] = x0
        top[:, 2:, 0] = x0[:, None] + radial
    else:
        a = theta[:, 0]
        tip = np.stack([l[0] * np.sin(a), l[0] * np.cos(a)], axis=1)
        direction = np.stack([np.cos(a), -np.sin(a)], axis=1)
        side[:, 1:, 0] = radial
        side[:, 1:, 1] = up
        top[:, 1] = tip
        top[:, 2:] = tip[:, None, :] + radial[:, :, None] * direction[:, None, :]
    return {"top": top, "side": side}


def _check_output(path: Path, force: bool, kind: str) -> None:
    """The output-path policy (common.files) as a PlotError, before any drawing."""
    try:
        files.check_replaceable(path, force, kind)
    except files.OutputError as exc:
        raise PlotError(str(exc)) from None


def _write_atomically(path: Path, force: bool, write: Any) -> Path:
    """`write(buffer)` renders the file in memory; it is then written by the output-path policy
    (common.files: temporary file and rename, never over a file ipgen did not write or of
    another kind without force)."""
    buffer = io.BytesIO()
    write(buffer)
    try:
        with files.removed_if_left_empty():
            files.prepare_directory(path.parent)
            files.write_file(path, buffer.getvalue(), force)
    except files.OutputError as exc:
        raise PlotError(str(exc)) from None
    return path


FIGURE_SIZE = (7.0, 3.6)  # inches (rotary): 700 × 360 pixels at the default 100 dpi
CART_HEIGHT = 4.4  # inches (classical; the width follows the side view's shape)
AXES_WIDTH, SIDE_SHARE, STRIP_SHARE = 0.84, 0.60, 0.10  # fractions of the cart's figure


def figure(type: str, lengths: np.ndarray, points: dict[str, np.ndarray]) -> tuple[Any, Any, Any]:
    """(figure, top view, side view) of an animation, laid out and scaled.

    Rotary: the view from above (the arm's circle) and the links' plane side by side, both to
    scale. Classical: everything seen from above lies on the rail's line, so the side view
    (x, z) takes the figure's width and most of its height, and the view from above is a strip
    under it on the same x scale (the cart and the links' shadow on the rail)."""
    import matplotlib.pyplot as plt
    import numpy as np

    reach = float(np.sum(lengths[1:]))
    if type == "classical":
        x_lo = min(float(points["side"][:, :, 0].min()), -reach) - 0.2
        x_hi = max(float(points["side"][:, :, 0].max()), reach) + 0.2
        z_half = reach + 0.2
        # The figure takes the shape of what it shows (the side view to scale), 4.4 in high and
        # 5 to 10 in wide; what is left over widens the shorter range.
        height = CART_HEIGHT
        side_height = SIDE_SHARE * height
        width = min(max((x_hi - x_lo) / (2 * z_half) * side_height / AXES_WIDTH, 5.0), 10.0)
        fig = plt.figure(figsize=(width, height))
        # [left, bottom, width, height] as fractions: the title above, the strip at the bottom
        ax_side = fig.add_axes((0.13, 0.30, AXES_WIDTH, SIDE_SHARE))
        ax_top = fig.add_axes((0.13, 0.10, AXES_WIDTH, STRIP_SHARE))
        width_in = AXES_WIDTH * width
        if (x_hi - x_lo) / (2 * z_half) < width_in / side_height:
            middle, half = 0.5 * (x_lo + x_hi), z_half * width_in / side_height
            x_lo, x_hi = middle - half, middle + half
        else:
            z_half = 0.5 * (x_hi - x_lo) * side_height / width_in
        ax_side.set_xlim(x_lo, x_hi)
        ax_side.set_ylim(-z_half, z_half)
        strip = 0.5 * (x_hi - x_lo) * (STRIP_SHARE * height) / width_in
        ax_top.set_xlim(x_lo, x_hi)
        ax_top.set_ylim(-strip, strip)
        for ax in (ax_top, ax_side):
            ax.set_aspect("equal", adjustable="box")
        ax_top.tick_params(labelleft=False, left=False)
        ax_side.tick_params(labelbottom=False)
        ax_side.set_ylabel("side: z [m]")
        ax_top.set_ylabel("above", fontsize=8)
        ax_top.set_xlabel("x [m] (the rail; below: seen from above)", fontsize=8)
        ax_top.axhline(0.0, color="0.6", lw=2)  # the rail
        ax_side.axhline(0.0, color="0.6", lw=2)
    else:
        fig, (ax_top, ax_side) = plt.subplots(1, 2, figsize=FIGURE_SIZE)
        span = lengths[0] + reach + 0.1
        ax_top.set_xlim(-span, span)
        ax_top.set_ylim(-span, span)
        ax_side.set_xlim(-reach - 0.1, reach + 0.1)
        ax_side.set_ylim(-reach - 0.1, reach + 0.1)
        ax_top.set_title("from above (x, y) [m]")
        ax_side.set_title("side: the links' plane (r, z) [m]")
        ax_top.add_patch(plt.Circle((0, 0), lengths[0], fill=False, ls=":", color="0.6"))
        for ax in (ax_top, ax_side):
            ax.set_aspect("equal")
        fig.tight_layout(rect=(0.0, 0.0, 1.0, 0.93))
    for ax in (ax_top, ax_side):
        ax.grid(True, lw=0.3)
    return fig, ax_top, ax_side


def animate_run(
    run: RunData | str | Path,
    output: str | Path,
    type: str,
    l: Sequence[float],  # noqa: E741
    *,
    fps: float = 15.0,
    trace: float = 1.0,
    dpi: int = 100,
    force: bool = False,
    coordinates: Coordinates | None = None,
    announce: Callable[[str], None] | None = None,
) -> Path:
    """Write an animated GIF of `run` (a RunData or the path of a simulator CSV) to `output`,
    drawn to scale (module docstring) at `fps` frames per second of the run, `dpi` dots per inch
    (a rotary pendulum's GIF is 700 × 360 pixels at the default 100, a cart's 440 high and as
    wide as its side view needs, 500 to 1000). `coordinates`: the convention of the
    run's angles (a scene's [system] angles, zero, positive; default ipgen's). A run longer than
    MAX_FRAMES frames plays time-lapsed; `announce` is told so in one line."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np
    from PIL import Image

    check_fps(fps)
    _check_output(Path(output), force, GIF)  # before the drawing
    data = run if isinstance(run, RunData) else read_run(run)
    fixed = type == "fixed"
    if fixed:  # a chain on a fixed pivot: drawn as a cart's chain whose cart stays at the pivot
        data, type, l = _on_a_still_base(data), "classical", [0.0, *l]  # noqa: E741
    lengths = np.asarray(_lengths(type, data.links, l))
    duration = float(data.t[-1] - data.t[0])
    count, speedup = frame_plan(duration, fps)
    if speedup > 1 and announce is not None:
        announce(
            f"the run lasts {duration:.6g} s: at {fps:g} frames per second of the run that is more than "
            f"{MAX_FRAMES} frames, so the GIF plays it {speedup:.3g} times faster (lower --fps for fewer)"
        )
    # a frame every speedup / fps s of the run (1 / fps in real time: none left over at the end)
    times = np.minimum(data.t[0] + np.arange(count) * (speedup / fps), data.t[-1])
    frames = np.searchsorted(data.t, times).clip(0, len(data.t) - 1)
    points = geometry(type, lengths, canonical_angles(data, coordinates))
    reach_drawn = max(float(np.max(np.abs(points["side"]))), float(np.max(np.abs(points["top"]))))
    if not reach_drawn <= LARGEST_DRAWN:
        raise PlotError(
            f"the run reaches {reach_drawn:.3g} m from the origin, beyond what can be drawn to scale "
            f"(at most {LARGEST_DRAWN:g} m): check the CSV's θ0 column and the lengths"
        )
    fig, ax_top, ax_side = figure(type, lengths, points)
    if fixed:
        ax_top.set_xlabel("x [m] (below: seen from above)", fontsize=8)
    (top_arm,) = ax_top.plot([], [], "-", color="tab:blue", lw=4, solid_capstyle="round")
    (top_links,) = ax_top.plot([], [], "-o", color="tab:red", lw=2, ms=3)
    (top_trace,) = ax_top.plot([], [], "-", color="tab:orange", lw=0.8, alpha=0.7)
    (side_links,) = ax_side.plot([], [], "-o", color="tab:red", lw=2, ms=3)
    (side_trace,) = ax_side.plot([], [], "-", color="tab:orange", lw=0.8, alpha=0.7)
    (side_base,) = ax_side.plot([], [], "s", color="tab:blue", ms=12)
    label = fig.suptitle("")
    steps = np.diff(data.t)  # empty for a run of one row
    window = max(1, round(trace / max(float(np.median(steps)) if steps.size else 1.0, 1e-12)))

    def draw(i: int) -> list[Any]:
        k = frames[i]
        top, side = points["top"][k], points["side"][k]
        if fixed:
            top_arm.set_data([], [])  # no base: the pivot is the square of the side view
        elif type == "classical":
            top_arm.set_data([top[0, 0] - 0.1, top[0, 0] + 0.1], [0.0, 0.0])  # the cart
        else:
            top_arm.set_data(top[:2, 0], top[:2, 1])
        top_links.set_data(top[1:, 0], top[1:, 1])
        side_links.set_data(side[:, 0], side[:, 1])
        side_base.set_data([side[0, 0]], [side[0, 1]])
        start = max(0, k - window)
        top_trace.set_data(points["top"][start : k + 1, -1, 0], points["top"][start : k + 1, -1, 1])
        side_trace.set_data(points["side"][start : k + 1, -1, 0], points["side"][start : k + 1, -1, 1])
        time = f"{data.t[k]:5.2f}" if abs(data.t[k]) < 1e6 else f"{data.t[k]:.6g}"
        text = f"{'fixed' if fixed else type}, n = {data.links}   t = {time} s"
        if speedup > 1:  # a long run, time-lapsed to MAX_FRAMES frames
            text += f" (×{speedup:.3g})"
        if data.phase is not None:
            text += f"   {data.phase[k]}"
        if data.u is not None:
            text += f"   u = {data.u[k]:+6.2f}"
        label.set_text(text)
        return [top_arm, top_links, top_trace, side_links, side_trace, side_base, label]

    fig.set_dpi(dpi)

    # Frames rendered straight from the Agg canvas and quantised to one shared 64-colour palette
    # (lines on white need no more), then written by pillow as one looping GIF.
    def render(i: int) -> Any:
        draw(i)
        fig.canvas.draw()
        size = fig.canvas.get_width_height()
        return Image.frombuffer("RGBA", size, fig.canvas.buffer_rgba()).convert("RGB")

    palette = render(count // 2).quantize(colors=64, method=Image.Quantize.MEDIANCUT)  # every artist shown
    images = [render(i).quantize(palette=palette, dither=Image.Dither.NONE) for i in range(count)]

    def write(tmp: io.BytesIO) -> None:
        images[0].save(
            tmp,
            format="GIF",
            comment=f"{files.MARKER} (ipgen animate)".encode(),  # a GIF ipgen may replace
            save_all=True,
            append_images=images[1:],
            duration=frame_delays(count, fps),
            loop=0,
            optimize=False,
        )

    try:
        return _write_atomically(Path(output), force, write)
    finally:
        plt.close(fig)


def plot_plan_and_run(
    output: str | Path,
    run: RunData | str | Path,
    *,
    plan_t: np.ndarray | None = None,
    plan_x: np.ndarray | None = None,
    plan_u: np.ndarray | None = None,
    u_max: float | None = None,
    force: bool = False,
    input_unit: str | None = None,
) -> Path:
    """Write a PNG: the run's angles (solid) against the plan's (dashed, when given), the base
    coordinate, and u(t) of both with the limit ±u_max. `input_unit` labels u (default "N or N m";
    `plots.run.input_unit_beside` reads it from the resolved scene next to a CSV)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    data = run if isinstance(run, RunData) else read_run(run)
    fig, axes = plt.subplots(3, 1, figsize=(8.0, 7.0), sharex=True)
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for i in range(1, data.links + 1):
        colour = colours[(i - 1) % len(colours)]
        axes[0].plot(data.t, data.theta[:, i], color=colour, label=f"θ{i} run")
        if plan_t is not None and plan_x is not None:
            axes[0].plot(plan_t, plan_x[:, i], "--", color=colour, label=f"θ{i} plan")
    axes[0].set_ylabel("link angle [rad]")
    axes[0].legend(ncol=2, fontsize=8)
    axes[1].plot(data.t, data.theta[:, 0], color="k", label="θ0 run")
    if plan_t is not None and plan_x is not None:
        axes[1].plot(plan_t, plan_x[:, 0], "--", color="k", label="θ0 plan")
    axes[1].set_ylabel("θ0 [m or rad]")
    axes[1].legend(fontsize=8)
    if data.u is not None:
        axes[2].step(data.t, data.u, where="post", color="tab:blue", label="u run (held)")
    if plan_t is not None and plan_u is not None:
        axes[2].plot(plan_t, plan_u, "--", color="tab:orange", label="u plan")
    if u_max is not None:
        for sign in (1, -1):
            axes[2].axhline(sign * u_max, color="tab:red", lw=0.8, ls=":")
        axes[2].plot([], [], color="tab:red", lw=0.8, ls=":", label=f"±u_max = {u_max:g}")
    axes[2].set_ylabel(f"u [{input_unit or 'N or N m'}]")
    axes[2].set_xlabel("t [s]")
    if axes[2].get_legend_handles_labels()[0]:
        axes[2].legend(fontsize=8)
    else:
        axes[2].text(0.5, 0.5, "no input column u in the run", ha="center", transform=axes[2].transAxes)
    for ax in axes:
        ax.grid(True, lw=0.3)
    if data.phase is not None:
        changes = [k for k in range(1, len(data.phase)) if data.phase[k] != data.phase[k - 1]]
        for k in [0, *changes]:
            if k:
                for ax in axes:
                    ax.axvline(data.t[k], color="0.5", lw=0.8)
            axes[0].text(data.t[k], axes[0].get_ylim()[1], f" {data.phase[k]}", va="top", fontsize=8)
    fig.tight_layout()
    try:
        return _write_atomically(
            Path(output),
            force,
            lambda tmp: fig.savefig(tmp, dpi=100, format="png", metadata={"Software": files.MARKER}),
        )
    finally:
        plt.close(fig)
