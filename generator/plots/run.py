"""A PNG of a simulator run (`ipgen plot`, `ipgen run`): the base, the link angles and, for a
closed loop, the input, against time. Reads any CSV a `simulate_<model>` wrote, streaming (a long
run is thinned for the picture), and the resolved scene next to it (`scene_beside`).

The CSV's columns are `t, theta0..thetaN, dtheta0..dthetaN`, then optionally the energy columns
(`T, V, W_in, E_diss`) and a controller's input `u`. The CSV does not say whether θ0 is a cart
position [m] or an arm angle [rad]: the resolved scene next to it (`<stem>.cfg`, its `type =`
line), or the caller, does.
"""

from __future__ import annotations

import contextlib
import csv
import io
import math
import re
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from ipgen.common import files
from ipgen.common.safetext import shown_path
from ipgen.model.coordinates import ANGLES, POSITIVE, ZEROS, Coordinates
from ipgen.plots.animation import PlotError  # one error class for every picture of a run

if TYPE_CHECKING:
    from matplotlib.figure import Figure

LARGEST = 1e100  # the largest magnitude plotted
POINTS = 20_000  # rows drawn at most
PNG = "PNG image"  # the kind of file a plot is (common.files)


@dataclass(frozen=True)
class Run:
    """The columns of a simulator CSV, by name."""

    columns: dict[str, list[float]]
    links: int
    phases: list[str] | None = None  # a swing-up's phase column (swing, track, hold), if any

    @property
    def time(self) -> list[float]:
        return self.columns["t"]


def read_run(path: Path, fixed: bool = False) -> Run:
    """The CSV a simulator wrote, or a PlotError naming what is wrong with it. A run of more than
    POINTS rows is thinned evenly (every k-th row, and the last) for the picture. `fixed`: a chain
    on a fixed pivot (no base: theta0..theta(n-1) are links 1..n; `Run.links` is n)."""
    try:
        with path.open(newline="") as f:
            count = sum(1 for _ in f)
        with path.open(newline="") as f:
            stride = max(1, (count - 1) // POINTS)
            rows = [
                row
                for i, row in enumerate(csv.reader(f))
                if i == 0 or (i - 1) % stride == 0 or i == count - 1
            ]
    except OSError as e:
        raise PlotError(f"cannot read {shown_path(path)}: {e.strerror}") from e
    except (UnicodeDecodeError, csv.Error) as e:
        raise PlotError(f"{shown_path(path)} is not a CSV the simulator wrote ({e})") from e
    header = rows[0] if rows else []
    angles = [name for name in header if re.fullmatch(r"theta\d+", name)]
    least = 1 if fixed else 2
    if header[:1] != ["t"] or len(angles) < least or angles != [f"theta{i}" for i in range(len(angles))]:
        raise PlotError(
            f"{shown_path(path)} is not a CSV the simulator wrote: its first line should be "
            "t,theta0,...,dtheta0,..."
        )
    phases = None
    if header[-1:] == ["phase"]:  # a swing-up: the last column names the controller's phase
        header = header[:-1]
        phases = [row[-1] for row in rows[1:] if row]
        rows = [rows[0]] + [row[:-1] for row in rows[1:] if row]
    try:
        data = [[float(value) for value in row] for row in rows[1:] if row]
    except ValueError as e:
        raise PlotError(f"{shown_path(path)}: a value is not a number ({e})") from e
    if not data or any(len(row) != len(header) for row in data):
        raise PlotError(f"{shown_path(path)} has no rows, or a row of the wrong length")
    # The simulator writes finite values only; beyond LARGEST matplotlib's axis ticks overflow.
    bad = next((value for row in data for value in row if not abs(value) <= LARGEST), None)
    if bad is not None:
        raise PlotError(
            f"{shown_path(path)}: the value {bad:g} cannot be plotted "
            f"(values must be finite, |x| <= {LARGEST:g})"
        )
    columns = {name: [row[i] for row in data] for i, name in enumerate(header)}
    return Run(columns, links=len(angles) - (0 if fixed else 1), phases=phases)


def _cfg_beside(csv_path: Path, line_pattern: str) -> dict[str, str]:
    """{key: value} of the first 64 lines of the resolved scene `<stem>.cfg` next to the CSV that
    match `line_pattern` (groups: key, value; the first of each key kept); {} without one."""
    found: dict[str, str] = {}
    with contextlib.suppress(OSError, UnicodeDecodeError):
        for line in csv_path.with_suffix(".cfg").read_text().splitlines()[:64]:
            match = re.fullmatch(line_pattern, line.strip())
            if match:
                found.setdefault(match.group(1), match.group(2))
    return found


def scene_beside(csv_path: Path) -> tuple[str, list[float]] | None:
    """(type, lengths) from the resolved scene `<stem>.cfg` next to the CSV (what `ipgen run`
    writes there), or None when there is none or it does not say: l0..ln for a cart or an arm,
    the links' l1..ln for a chain on a fixed pivot (type "fixed")."""
    found = _cfg_beside(csv_path, r"(type|l) = ([^=]{1,400})")
    if found.get("type") not in ("classical", "rotary", "fixed") or "l" not in found:
        return None
    try:
        lengths = [float(value) for value in found["l"].split()]
    except ValueError:
        return None
    return found["type"], lengths


def coordinates_beside(csv_path: Path) -> Coordinates:
    """The convention of the CSV's angles from the resolved scene `<stem>.cfg` next to it (its
    `angles`, `zero`, `positive` lines, which a scene in the rig's coordinates has), else ipgen's."""
    found = _cfg_beside(csv_path, r"(angles|zero|positive) = (\w{1,20})")
    allowed = {"angles": ANGLES, "zero": ZEROS, "positive": POSITIVE}
    return Coordinates(**{key: value for key, value in found.items() if value in allowed[key]})


def input_unit_beside(csv_path: Path) -> str | None:
    """u's unit from the resolved scene `<stem>.cfg` next to the CSV when it is not a force or a
    torque: V with `actuator = dc_motor`, m/s² or rad/s² with `acceleration`; else None."""
    found = _cfg_beside(csv_path, r"(type|actuator) = (\w{1,20})")
    if found.get("actuator") == "dc_motor":
        return "V"
    if found.get("actuator") == "acceleration":
        return "rad/s²" if found.get("type") == "rotary" else "m/s²"
    return None


def system_type_beside(csv_path: Path) -> str | None:
    """`classical`, `rotary` or `fixed` from the resolved scene `<stem>.cfg` next to the CSV, if there."""
    scene = scene_beside(csv_path)
    return scene[0] if scene else None


def check_replaceable(png: Path, force: bool) -> None:
    """The OutputError writing the PNG `png` would meet (`common.files`: a directory, a path the
    system refuses, a file ipgen did not write or of another kind, without force), if any."""
    files.check_replaceable(png, force, PNG)


def sampled_beside(csv_path: Path) -> bool:
    """Whether the resolved scene `<stem>.cfg` next to the CSV has a sampled-data input (a
    `controller.period` or a swing-up's `swingup.period`): u is then held between samples."""
    cfg = csv_path.with_suffix(".cfg")
    with contextlib.suppress(OSError, UnicodeDecodeError):
        for line in cfg.read_text().splitlines()[:400]:
            if re.fullmatch(r"(controller|swingup)\.period = \S{1,40}", line.strip()):
                return True
    return False


def display_turns(values: list[float], upright: float) -> int:
    """The whole turns k to take off a link's angles for display when the link ends near an
    upright (within π/2 of `upright` + 2πk): the trace shifted by −2πk ends near `upright` (a link
    upright after a full turn reads 0, not 2π); a link that ends elsewhere is not shifted."""
    if not values:
        return 0
    k = round((values[-1] - upright) / (2 * math.pi))
    return k if abs(values[-1] - upright - 2 * math.pi * k) < math.pi / 2 else 0


def _turns_label(k: int) -> str:
    if k == 0:
        return ""
    sign = "−" if k > 0 else "+"
    return f" {sign} {2 * abs(k) if abs(k) > 1 else 2}π"


def _multiple_of_pi(level: float) -> str:
    k = round(level / math.pi)
    return f"{'−' if k < 0 else ''}{abs(k) if abs(k) != 1 else ''}π"


def _reference_levels(low: float, high: float, levels: tuple[float, ...]) -> list[float]:
    """The levels (±π, ...) within reach of the data [low, high]: a run about one of them is not
    stretched to show the other."""
    reach = max(0.25 * (high - low), 0.2)
    return [level for level in levels if low - reach <= level <= high + reach]


def draw_run(
    run: Run,
    title: str,
    system_type: str | None = None,
    coordinates: Coordinates | None = None,
    input_unit: str | None = None,
    sampled: bool = False,
) -> Figure:
    """The figure of `run` (plot_run's picture): the base, the link angles (each shifted by whole
    turns so that it ends within π of its upright, the legend says by how much; dotted lines at
    ±π where the links come near them) and, for a closed loop, the input u (as steps when
    `sampled`: u held between the controller's samples)."""
    if system_type == "fixed":
        return _draw_fixed(run, title, coordinates if coordinates is not None else Coordinates())
    frame = coordinates if coordinates is not None else Coordinates()
    # The object-oriented API without pyplot: no GUI backend, no global state, a faster import.
    from matplotlib.figure import Figure

    t = run.time
    has_input = "u" in run.columns
    height = 8.5 if has_input else 6.5
    fig = Figure(figsize=(8, height))
    axes = fig.subplots(3 if has_input else 2, 1, sharex=True)
    # Fixed margins (in inches, as fractions): matplotlib's constrained layout would cost a third
    # of the drawing time, and every plot here has the same labels.
    fig.subplots_adjust(left=0.11, right=0.98, bottom=0.6 / height, top=1 - 0.75 / height, hspace=0.08)
    base, links = axes[0], axes[1]
    base_label = {
        "classical": "cart position θ0 [m]",
        "rotary": "arm angle θ0 [rad]",
        None: "base θ0 (cart [m] or arm [rad])",
    }[system_type]
    base.plot(t, run.columns["theta0"], color="black", label=base_label)
    base.set_ylabel(base_label)
    _, offsets = frame.matrices(run.links)  # a link's upright in the run's coordinates: c_i
    shown: list[list[float]] = []
    for i in range(1, run.links + 1):
        relative = not frame.is_canonical and frame.angles == "relative" and i >= 2
        values = run.columns[f"theta{i}"]
        k = display_turns(values, float(offsets[i]))
        values = [v - 2 * math.pi * k for v in values] if k else values
        shown.append(values)
        links.plot(
            t,
            values,
            label=f"link {i} angle θ{i}{_turns_label(k)}" + (f" from link {i - 1}" if relative else ""),
        )
    # ±π: hanging down in ipgen's coordinates; in a rig's, whatever its convention puts there.
    low = min((min(v) for v in shown if v), default=0.0)
    high = max((max(v) for v in shown if v), default=0.0)
    levels = _reference_levels(low, high, (-3 * math.pi, -math.pi, math.pi, 3 * math.pi))
    named = ", ".join(_multiple_of_pi(level) for level in levels)
    meaning = f"hanging down ({named})" if frame.is_canonical else named
    for level in levels:
        links.axhline(level, color="grey", linestyle=":", linewidth=0.8)
    links.set_ylabel(
        "link angle from upright [rad]"
        if frame.is_canonical
        else f"link angle [rad] (0 {frame.zero}, {'ccw' if frame.positive == 'counterclockwise' else 'cw'})"
    )
    if has_input:
        unit = input_unit or {"classical": "N", "rotary": "N m", None: "N or N m"}[system_type]
        axes[2].plot(
            t,
            run.columns["u"],
            color="tab:red",
            label=f"input u [{unit}]" + (", held between samples" if sampled else ""),
            drawstyle="steps-post" if sampled else "default",
        )
        axes[2].set_ylabel(f"u [{unit}]")
    if run.phases:  # a swing-up: a dashed line where the controller changes phase, named inside
        for k in range(1, len(run.phases)):  # the top panel (above it, the title's second line)
            if run.phases[k] != run.phases[k - 1]:
                for ax in axes:
                    ax.axvline(t[k], color="grey", linestyle="--", linewidth=0.8)
                base.annotate(
                    f" {run.phases[k]}",
                    (t[k], 0.97),
                    xycoords=("data", "axes fraction"),
                    fontsize=8,
                    va="top",
                    color="grey",
                )
    axes[-1].set_xlabel("time t [s]")
    base.set_title(f"{title}\ndotted lines: {meaning}" if levels else title)
    for ax in axes:
        ax.grid(True, alpha=0.3)
        ax.legend(loc="best", fontsize="small")
    return fig


def _draw_fixed(run: Run, title: str, frame: Coordinates) -> Figure:
    """A fixed-pivot chain's figure in the scene's coordinates `frame`: the link angles
    (theta0..theta(n-1) of the CSV are links 1..n; the labels say what they count from) and the
    joints' torques (u, or u1..um)."""
    from matplotlib.figure import Figure

    t = run.time
    inputs = [name for name in run.columns if re.fullmatch(r"u\d*", name)]
    height = 8.5 if inputs else 6.5
    fig = Figure(figsize=(8, height))
    axes = fig.subplots(2 if inputs else 1, 1, sharex=True, squeeze=False)[:, 0]
    fig.subplots_adjust(left=0.11, right=0.98, bottom=0.6 / height, top=1 - 0.75 / height, hspace=0.08)
    links = axes[0]
    for i in range(run.links):
        values = run.columns[f"theta{i}"]
        k = display_turns(values, 0.0)
        values = [v - 2 * math.pi * k for v in values] if k else values
        relative = f" from link {i}" if frame.angles == "relative" and i >= 1 else ""
        links.plot(t, values, label=f"link {i + 1} angle{_turns_label(k)}{relative}")
    sense = "ccw" if frame.positive == "counterclockwise" else "cw"
    links.set_ylabel(f"link angle [rad] (0 {frame.zero}, {sense})")
    for name in inputs:
        axes[1].plot(t, run.columns[name], label=f"torque {name} [N m]")
    if inputs:
        axes[1].set_ylabel("joint torque [N m]")
    axes[-1].set_xlabel("time t [s]")
    links.set_title(title)
    for ax in axes:
        ax.grid(True, alpha=0.3)
        ax.legend(loc="best", fontsize="small")
    return fig


def plot_run(
    run: Run,
    png: Path,
    title: str,
    system_type: str | None = None,
    force: bool = False,
    coordinates: Coordinates | None = None,
    input_unit: str | None = None,
    sampled: bool = False,
) -> None:
    """Draw `run` into `png` (temporary file, then rename); `coordinates` (default ipgen's) names
    the convention of the run's angles in the labels; `input_unit` labels u (default: N on a
    cart, N m on an arm; "V" with a dc_motor); `sampled`: u is drawn as steps (`draw_run`)."""
    check_replaceable(png, force)
    fig = draw_run(run, title, system_type, coordinates, input_unit, sampled)
    picture = io.BytesIO()
    fig.savefig(picture, dpi=110, format="png", metadata={"Software": f"{files.MARKER} (ipgen plot)"})
    with files.removed_if_left_empty():
        files.prepare_directory(png.parent)
        files.write_file(png, picture.getvalue(), force)
