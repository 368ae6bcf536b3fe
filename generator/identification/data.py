"""Measurements for identification: a CSV of t, the link coordinates and (optionally) rates and u.

The format is the simulator's own (`t,theta0..thetaN,dtheta0..dthetaN[,kinetic,...][,u]`): a
header line naming the columns, then one row of numbers per sample. Required: `t` and
`theta0..thetaN`; `dtheta*` may be missing (the rates are then differentiated from the angles),
`u` may be missing when the scene's [input] says what it was; other columns (the simulator's
energy columns) are ignored. Every problem is one `DataError` line naming the file and the fix.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ipgen.common.safetext import abbreviate, shown_path
from ipgen.identification.model import IdentifyError
from ipgen.model.coordinates import Coordinates

if TYPE_CHECKING:
    import numpy as np

__all__ = [
    "LARGEST_TIME",
    "LARGEST_VALUE",
    "MAX_DATA_BYTES",
    "MAX_GRID_FACTOR",
    "MAX_ROWS",
    "MIN_ROWS",
    "DataError",
    "Measurements",
    "check_columns",
    "check_measurements",
    "grid_points",
    "read_measurements",
]

# A 60 s recording at 1 kHz of a triple pendulum with rates and u is ~7 MB; 256 MB is a
# recording of hours: more is a wrong file (or one to decimate first), not an experiment.
MAX_DATA_BYTES = 1 << 28
MAX_ROWS = 5_000_000
# Fewer samples than this cannot carry a fit with its statistics (and smoothing windows).
MIN_ROWS = 50
# No measurement of a pendulum reaches these magnitudes (angles [rad], positions [m], rates, u
# [N, N m, V]; times [s]): larger values are a wrong column or a corrupt sample, and in the fit's
# squares they overflow.
LARGEST_VALUE = 1e6
LARGEST_TIME = 1e9
# Unevenly spaced samples are resampled onto a grid at their median step (identification/fit.py):
# that grid may have at most this many times more points than the samples (more is a recording
# whose steps are mostly far shorter than its rate, e.g. repeated time stamps 1 ns apart).
MAX_GRID_FACTOR = 4


class DataError(IdentifyError):
    """A data file that cannot be used; one line: `<file>: <problem>; <fix>`."""


@dataclass(frozen=True)
class Measurements:
    """Samples in ipgen's coordinates: t (N), theta (N × dof), dtheta (N × dof or None), u (N or None)."""

    t: np.ndarray
    theta: np.ndarray
    dtheta: np.ndarray | None
    u: np.ndarray | None
    source: str = "data"

    @property
    def dof(self) -> int:
        return int(self.theta.shape[1])

    @property
    def samples(self) -> int:
        return int(self.t.shape[0])

    def canonical(self, coordinates: Coordinates) -> Measurements:
        """These samples, measured in a rig's `coordinates`, in ipgen's: the convention undone
        as `Coordinates.to_canonical` does it, for every sample at once (the one place that
        converts measurements).

        Parameters
        ----------
        coordinates : Coordinates
            The rig's convention the samples are in.

        Returns
        -------
        Measurements
            In ipgen's coordinates (these if the convention is ipgen's).

        Examples
        --------
        >>> import numpy as np
        >>> data = Measurements(np.zeros(1), np.array([[0.0, 0.5]]), None, None)
        >>> data.canonical(Coordinates(positive="counterclockwise")).theta.tolist()
        [[0.0, -0.5]]
        """
        import numpy as np

        if coordinates.is_canonical:
            return self
        p, c = coordinates.matrices(self.dof - 1)
        rates = self.dtheta if self.dtheta is not None else np.zeros_like(self.theta)
        state = np.linalg.solve(p, (np.hstack([self.theta, rates]) - c).T).T
        return Measurements(
            t=self.t,
            theta=state[:, : self.dof],
            dtheta=state[:, self.dof :] if self.dtheta is not None else None,
            u=self.u,
            source=self.source,
        )


def read_measurements(path: str | Path, dof: int) -> Measurements:
    """The CSV at `path` for a system with `dof` coordinates, checked (module docstring)."""

    path = Path(path)
    where = shown_path(path)
    try:
        size = path.stat().st_size
    except OSError as e:
        raise DataError(f"{where}: cannot read the data file ({e.strerror}); check the path") from None
    if path.is_dir():
        raise DataError(f"{where} is a directory: pass the CSV file")
    if size > MAX_DATA_BYTES:
        raise DataError(
            f"{where}: {size / 2**20:.0f} MB is larger than {MAX_DATA_BYTES >> 20} MB: "
            "decimate or cut the recording first"
        )
    try:
        text = path.read_bytes().decode("utf-8")
    except UnicodeDecodeError:
        raise DataError(f"{where}: not a text (UTF-8) CSV file") from None
    except OSError as e:
        raise DataError(f"{where}: cannot read the data file ({e.strerror})") from None
    return parse_measurements(text, dof, where)


def parse_measurements(text: str, dof: int, where: str = "data") -> Measurements:
    """`read_measurements` on the file's text."""
    import numpy as np

    lines = text.splitlines()
    while lines and not lines[-1].strip():
        lines.pop()
    if not lines:
        raise DataError(f"{where}: empty file; expected a header line t,theta0,... and rows of numbers")
    header = [name.strip() for name in lines[0].split(",")]
    if len(lines) - 1 > MAX_ROWS:
        raise DataError(f"{where}: {len(lines) - 1} rows, more than {MAX_ROWS}: decimate the recording first")
    index: dict[str, int] = {}
    for k, name in enumerate(header):
        if name in index:
            raise DataError(f"{where}: column {abbreviate(name)!r} appears twice in the header")
        index[name] = k
    angles = [f"theta{i}" for i in range(dof)]
    missing = [name for name in ("t", *angles) if name not in index]
    if missing:
        raise DataError(
            f"{where}: missing column {missing[0]} (the header needs t,{','.join(angles)}"
            f"[,dtheta0..][,u]; it is {abbreviate(lines[0])!r})"
        )
    coordinate = re.compile(r"d?theta(\d+)")
    extra = [name for name in header if (m := coordinate.fullmatch(name)) and int(m.group(1)) >= dof]
    if extra:
        links = f"{dof - 1} link{'s' if dof > 2 else ''}"
        raise DataError(
            f"{where}: column {abbreviate(extra[0])} does not fit the scene's {links} "
            f"(theta0..theta{dof - 1}): a recording of another system; identify it with the scene of the rig "
            "that recorded it "
            "(--scene or --preset)"
        )
    rates = [f"dtheta{i}" for i in range(dof)]
    has_rates = all(name in index for name in rates)
    if any(name in index for name in rates) and not has_rates:
        absent = next(name for name in rates if name not in index)
        raise DataError(f"{where}: column {absent} is missing: give every dtheta column or none")
    rows = lines[1:]
    if len(rows) < MIN_ROWS:
        raise DataError(
            f"{where}: {len(rows)} samples are too few to identify anything: record at least {MIN_ROWS}"
        )
    width = len(header)
    table = np.empty((len(rows), width))
    for r, line in enumerate(rows):
        fields = line.split(",")
        if len(fields) != width:
            raise DataError(f"{where}: line {r + 2} has {len(fields)} fields, the header {width}")
        try:
            table[r] = [float(field) for field in fields]
        except ValueError:
            bad = next(f for f in fields if not _is_float(f))
            raise DataError(f"{where}: line {r + 2}: {abbreviate(bad.strip())!r} is not a number") from None
    used = ["t", *angles, *(rates if has_rates else []), *(["u"] if "u" in index else [])]
    for name in used:
        column = table[:, index[name]]
        if not np.all(np.isfinite(column)):
            line = int(np.flatnonzero(~np.isfinite(column))[0]) + 2
            raise DataError(
                f"{where}: line {line}: {name} is not finite (NaN or inf); remove or repair the sample"
            )
        largest = LARGEST_TIME if name == "t" else LARGEST_VALUE
        if np.any(np.abs(column) > largest):
            line = int(np.flatnonzero(np.abs(column) > largest)[0]) + 2
            raise DataError(
                f"{where}: line {line}: {name} = {column[line - 2]:.3g} is beyond ±{largest:g}, no "
                "measurement of a pendulum; remove or repair the sample (or check the column)"
            )
    t = table[:, index["t"]]
    steps = np.diff(t)
    if np.any(steps <= 0):
        line = int(np.flatnonzero(steps <= 0)[0]) + 3
        raise DataError(
            f"{where}: line {line}: t does not increase; sort the samples and drop repeated times"
        )
    _check_spacing(t, steps, where)
    return Measurements(
        t=t,
        theta=table[:, [index[n] for n in angles]],
        dtheta=table[:, [index[n] for n in rates]] if has_rates else None,
        u=table[:, index["u"]] if "u" in index else None,
        source=where,
    )


def grid_points(t: np.ndarray) -> int:
    """The points of the uniform grid the fit resamples `t` onto (its median step; `t` itself
    when the steps agree to 1e-3)."""
    import numpy as np

    steps = np.diff(t)
    dt = float(np.median(steps))
    if np.ptp(steps) <= 1e-3 * dt:
        return len(t)
    return int(min((t[-1] - t[0]) / dt, 2.0**62)) + 1


def check_measurements(data: Measurements, u: np.ndarray | None = None) -> None:
    """A DataError unless `data` (and the input `u`, if given) are what the fit can take: every
    value finite and within LARGEST_VALUE (t within LARGEST_TIME), t increasing, and a
    resampling grid of at most MAX_GRID_FACTOR times the samples. `read_measurements` checks a
    CSV so (naming its lines); the fit checks measurements made any other way."""
    columns = {"t": data.t, "theta": data.theta, "dtheta": data.dtheta, "u": u if u is not None else data.u}
    check_columns(data.source, columns)


def check_columns(where: str, columns: Mapping[str, Any]) -> None:
    """A DataError naming `where` unless the columns (name: values or None; "t" the time) are
    what a fit can take: every value finite and within LARGEST_VALUE (t within LARGEST_TIME), t
    increasing, and a resampling grid of at most MAX_GRID_FACTOR times the samples. The torque
    regression's recordings (identification/recording.py) are checked by it too."""
    import numpy as np

    for name, values in columns.items():
        if values is None:
            continue
        largest = LARGEST_TIME if name == "t" else LARGEST_VALUE
        if not np.all(np.abs(np.asarray(values, dtype=float)) <= largest):  # NaN fails too
            raise DataError(
                f"{where}: {name} holds a value that is not finite or beyond ±{largest:g}: "
                "remove or repair the sample"
            )
    t = np.asarray(columns["t"], dtype=float)
    steps = np.diff(t)
    if np.any(steps <= 0):
        raise DataError(f"{where}: t does not increase; sort the samples and drop repeated times")
    _check_spacing(t, steps, where)


def _check_spacing(t: np.ndarray, steps: np.ndarray, where: str) -> None:
    """A DataError when resampling `t` onto the fit's grid would make it more than
    MAX_GRID_FACTOR times larger (the grid's memory and time follow its points)."""
    import numpy as np

    points = grid_points(t)
    if points > MAX_GRID_FACTOR * len(t):
        raise DataError(
            f"{where}: the samples are unevenly spaced (median step {float(np.median(steps)):.3g} s, "
            f"{t[-1] - t[0]:.3g} s in all): resampling them would take {points:.3g} points, more than "
            f"{MAX_GRID_FACTOR} times the {len(t)} samples; record at a steady rate or resample first"
        )


def _is_float(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True
