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

from ipgen.common import files
from ipgen.common.safetext import shown_path
from ipgen.control.coordinates import ANGLES, POSITIVE, ZEROS, Coordinates
from ipgen.plots.animation import PlotError  # one error class for every picture of a run

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


def read_run(path: Path) -> Run:
    """The CSV a simulator wrote, or a PlotError naming what is wrong with it. A run of more than
    POINTS rows is thinned evenly (every k-th row, and the last) for the picture."""
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
    if header[:1] != ["t"] or len(angles) < 2 or angles != [f"theta{i}" for i in range(len(angles))]:
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
    return Run(columns, links=len(angles) - 1, phases=phases)


def scene_beside(csv_path: Path) -> tuple[str, list[float]] | None:
    """(type, lengths l0..ln) from the resolved scene `<stem>.cfg` next to the CSV (what `ipgen run`
    writes there), or None when there is none or it does not say."""
    cfg = csv_path.with_suffix(".cfg")
    found: dict[str, str] = {}
    with contextlib.suppress(OSError, UnicodeDecodeError):
        for line in cfg.read_text().splitlines()[:64]:
            match = re.fullmatch(r"(type|l) = ([^=]{1,400})", line.strip())
            if match:
                found.setdefault(match.group(1), match.group(2))
    if found.get("type") not in ("classical", "rotary") or "l" not in found:
        return None
    try:
        lengths = [float(value) for value in found["l"].split()]
    except ValueError:
        return None
    return found["type"], lengths


def coordinates_beside(csv_path: Path) -> Coordinates:
    """The convention of the CSV's angles from the resolved scene `<stem>.cfg` next to it (its
    `angles`, `zero`, `positive` lines, which a scene in the rig's coordinates has), else ipgen's."""
    cfg = csv_path.with_suffix(".cfg")
    found: dict[str, str] = {}
    with contextlib.suppress(OSError, UnicodeDecodeError):
        for line in cfg.read_text().splitlines()[:64]:
            match = re.fullmatch(r"(angles|zero|positive) = (\w{1,20})", line.strip())
            if match:
                found.setdefault(match.group(1), match.group(2))
    allowed = {"angles": ANGLES, "zero": ZEROS, "positive": POSITIVE}
    return Coordinates(**{key: value for key, value in found.items() if value in allowed[key]})


def system_type_beside(csv_path: Path) -> str | None:
    """`classical` or `rotary` from the resolved scene `<stem>.cfg` next to the CSV, if there."""
    scene = scene_beside(csv_path)
    return scene[0] if scene else None


def check_replaceable(png: Path, force: bool) -> None:
    """The OutputError writing the PNG `png` would meet (`common.files`: a directory, a path the
    system refuses, a file ipgen did not write or of another kind, without force), if any."""
    files.check_replaceable(png, force, PNG)


def plot_run(
    run: Run,
    png: Path,
    title: str,
    system_type: str | None = None,
    force: bool = False,
    coordinates: Coordinates | None = None,
    input_unit: str | None = None,
) -> None:
    """Draw `run` into `png` (temporary file, then rename); `coordinates` (default ipgen's) names
    the convention of the run's angles in the labels; `input_unit` labels u (default: N on a
    cart, N m on an arm; "V" with a dc_motor)."""
    frame = coordinates if coordinates is not None else Coordinates()
    check_replaceable(png, force)
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
    for i in range(1, run.links + 1):
        relative = not frame.is_canonical and frame.angles == "relative" and i >= 2
        links.plot(
            t,
            run.columns[f"theta{i}"],
            label=f"link {i} angle θ{i}" + (f" from link {i - 1}" if relative else ""),
        )
    # ±π: hanging down in ipgen's coordinates; in a rig's, whatever its convention puts there.
    meaning = "hanging down (±π)" if frame.is_canonical else "±π"
    largest = max((abs(v) for i in range(1, run.links + 1) for v in run.columns[f"theta{i}"]), default=0.0)
    hanging = largest > math.pi / 2  # mark ±π only when a link gets near it (else it flattens the plot)
    for level in (-math.pi, math.pi) if hanging else ():
        links.axhline(level, color="grey", linestyle=":", linewidth=0.8)
    links.set_ylabel(
        "link angle from upright [rad]"
        if frame.is_canonical
        else f"link angle [rad] (0 {frame.zero}, {'ccw' if frame.positive == 'counterclockwise' else 'cw'})"
    )
    if has_input:
        unit = input_unit or {"classical": "N", "rotary": "N m", None: "N or N m"}[system_type]
        axes[2].plot(t, run.columns["u"], color="tab:red", label=f"input u [{unit}]")
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
    base.set_title(f"{title}\ndotted lines: {meaning}" if hanging else title)
    for ax in axes:
        ax.grid(True, alpha=0.3)
        ax.legend(loc="best", fontsize="small")
    picture = io.BytesIO()
    fig.savefig(picture, dpi=110, format="png", metadata={"Software": f"{files.MARKER} (ipgen plot)"})
    files.prepare_directory(png.parent)
    files.write_file(png, picture.getvalue(), force)
