"""Recordings of a fixed-pivot rig: joint angles and measured joint torques over time, read from
a CSV as the rig wrote it, and the filtered signals the torque regression uses.

Columns recognised (docs/identify.md, "Fixed-pivot rigs: joint torques"): the time `time` or
`t` [s]; the angles `pos_meas1..n` (DFKI's header) or `q1..qn` [rad], in the scene's
coordinates; the measured torques `tau_measJ` (DFKI: by joint J) or `tau1..taum` / `u1..um` [N m], one per
actuated joint in the order of `[actuator] joints`. Other columns (DFKI's vel_meas, pos_filt,
vel_filt, tau_con, tau_fric) are ignored. A `.gz` file is read decompressed.

Filtering (`filtered`): the samples are interpolated onto a uniform grid at their median step;
the angles and the torques pass the same zero-phase Butterworth low-pass (order 4, `cutoff` Hz,
scipy.signal.butter + filtfilt, so that the regressor and the torque it must explain are delayed
and attenuated alike: none of each); the rates and accelerations are central differences of the
filtered angles (numpy.gradient); `edge` seconds at both ends are dropped (filtfilt's start-up).
"""

from __future__ import annotations

import gzip
import io
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ipgen.errors import Error
from ipgen.identification.data import MAX_DATA_BYTES, DataError, check_columns

DEFAULT_CUTOFF = 6.0  # Hz: above the pendulum's swing (≈ 1–2 Hz) and DFKI's excitation, below the noise
DEFAULT_EDGE = 0.1  # s dropped at each end after filtering
FILTER_ORDER = 4
MIN_SAMPLES = 50


class RecordingError(Error, ValueError):
    """A recording that cannot be used; one line naming the file and the problem."""


@dataclass(frozen=True)
class Recording:
    """One recording: `t` (N), `q` (N × n) angles, `tau` (N × m) measured torques."""

    name: str
    t: np.ndarray
    q: np.ndarray
    tau: np.ndarray


@dataclass(frozen=True)
class Filtered:
    """A recording on a uniform grid, filtered (module docstring): q, q̇, q̈ (N × n), τ (N × m)
    and the unfiltered measured τ on the same grid."""

    name: str
    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    tau: np.ndarray
    tau_raw: np.ndarray


def _columns(header: list[str], prefixes: tuple[str, ...], count: int, path: Path, what: str) -> list[int]:
    for prefix in prefixes:
        names = [f"{prefix}{i}" for i in range(1, count + 1)]
        if all(name in header for name in names):
            return [header.index(name) for name in names]
    expected = " or ".join(f"{p}1..{p}{count}" for p in prefixes)
    raise RecordingError(f"{path.name}: no {what} columns: expected {expected} in the header")


def read_recording(
    path: str | Path, links: int, inputs: int, joints: tuple[int, ...] | None = None
) -> Recording:
    """The recording at `path` (CSV, or CSV.gz) for a chain of `links` links and `inputs` torques
    at `joints` (1-based, the scene's `[actuator] joints`; default 1..inputs). DFKI's header names
    a torque by its joint (`tau_measJ`, every joint's, 0 where passive): those of `joints` are
    read; `tau1..`/`u1..` are the driven joints' in the order of `joints`.

    Raises
    ------
    RecordingError
        One line: a missing column, a non-number, a time that does not increase, too few rows.
    """
    path = Path(path)
    try:  # at most MAX_DATA_BYTES, decompressed: a small .gz can hold gigabytes
        with (gzip.open(path, "rb") if path.suffix == ".gz" else path.open("rb")) as stream:
            raw = stream.read(MAX_DATA_BYTES + 1)
        if len(raw) > MAX_DATA_BYTES:
            raise RecordingError(
                f"{path.name}: more than {MAX_DATA_BYTES // 2**20} MB (decompressed): cut it into parts"
            )
        text = raw.decode("utf-8-sig")  # a byte-order mark (spreadsheets' "CSV UTF-8") is not a name
    except (OSError, EOFError, gzip.BadGzipFile, UnicodeDecodeError) as exc:
        raise RecordingError(f"{path.name}: cannot read it ({exc})") from None
    header = [name.strip() for name in text.split("\n", 1)[0].split(",")]
    time_column = next((header.index(n) for n in ("time", "t") if n in header), None)
    if time_column is None:
        raise RecordingError(f"{path.name}: no time column: expected 'time' (DFKI) or 't' in the header")
    angles = _columns(header, ("pos_meas", "q"), links, path, "angle")
    joints = tuple(joints) if joints is not None else tuple(range(1, inputs + 1))
    dfki = [f"tau_meas{j}" for j in joints]
    if all(name in header for name in dfki):  # DFKI's: by joint number
        torques = [header.index(name) for name in dfki]
    elif any(name.startswith("tau_meas") for name in header):
        missing = ", ".join(name for name in dfki if name not in header)
        raise RecordingError(f"{path.name}: no {missing} in the header: DFKI's tau_measJ is joint J's torque")
    else:
        torques = _columns(header, ("tau", "u"), inputs, path, "torque")
    rows = (line.strip() for line in text.splitlines()[1:])
    if not any(row and not row.startswith("#") for row in rows):  # (numpy would warn, read none)
        raise RecordingError(f"{path.name}: needs at least {MIN_SAMPLES} rows of finite numbers")
    try:
        data = np.loadtxt(io.StringIO(text), delimiter=",", skiprows=1, ndmin=2)
    except ValueError as exc:
        raise RecordingError(f"{path.name}: not a table of numbers ({str(exc)[:80]})") from None
    if data.shape[0] < MIN_SAMPLES or not np.all(np.isfinite(data[:, [time_column, *angles, *torques]])):
        raise RecordingError(f"{path.name}: needs at least {MIN_SAMPLES} rows of finite numbers")
    t = data[:, time_column]
    if np.any(np.diff(t) <= 0):
        raise RecordingError(f"{path.name}: the time does not increase from row to row")
    q, tau = data[:, angles], data[:, torques]
    try:  # the classical fit's rules: magnitudes no pendulum measures, a bounded resampling grid
        check_columns(path.name, {"t": t, "angles": q, "torques": tau})
    except DataError as error:
        raise RecordingError(str(error)) from None
    return Recording(path.name.removesuffix(".gz").removesuffix(".csv"), t, q, tau)


def filtered(recording: Recording, cutoff: float = DEFAULT_CUTOFF, edge: float = DEFAULT_EDGE) -> Filtered:
    """`recording` resampled, low-passed and differentiated (module docstring)."""
    from scipy.signal import butter, filtfilt

    t0 = recording.t
    step = float(np.median(np.diff(t0)))
    t = np.arange(t0[0], t0[-1], step)

    def resampled(values: np.ndarray) -> np.ndarray:
        return np.column_stack([np.interp(t, t0, column) for column in values.T])

    nyquist = 0.5 / step
    if not 0 < cutoff < nyquist:
        unit = " (is its time in ms? it must be in s)" if step >= 0.5 else ""
        raise RecordingError(
            f"{recording.name}: sampled every {step:g} s{unit}: the cutoff {cutoff:g} Hz must be between 0 "
            f"and its Nyquist frequency {nyquist:g} Hz; give a lower --cutoff"
        )
    b, a = butter(FILTER_ORDER, cutoff / nyquist)
    q_raw, tau_raw = resampled(recording.q), resampled(recording.tau)
    if len(t) <= 3 * (FILTER_ORDER + 1) * 2 + 2 * int(edge / step):
        raise RecordingError(f"{recording.name}: too short to filter")
    q = filtfilt(b, a, q_raw, axis=0)
    tau = filtfilt(b, a, tau_raw, axis=0)
    qd = np.gradient(q, step, axis=0)
    qdd = np.gradient(qd, step, axis=0)
    keep = slice(round(edge / step), len(t) - round(edge / step))
    return Filtered(recording.name, t[keep], q[keep], qd[keep], qdd[keep], tau[keep], tau_raw[keep])
