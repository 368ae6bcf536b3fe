"""Run an estimator over a recording: a CSV of the simulator or a rig with measured columns.

The CSV has a time column `t`, one column `y_<coordinate>` per measured coordinate (y_theta0,
y_theta1, …: the samples the controller saw) and, for the estimators with a model, the input
column (default `u`: the input held over [t, next sample)). Rows at the estimator's sampling
instants t_k = k T are used (the simulator may write rows more often); the estimator's step k
gets y_k and the input of row k − 1.
"""

from __future__ import annotations

import csv
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from ipgen.estimation.pendulum import EstimationError

if TYPE_CHECKING:
    import numpy as np

    from ipgen.estimation.estimators import Estimator

SAMPLE_TOLERANCE = 1e-9  # relative: a row is at a sampling instant when |t / T − k| ≤ this


@dataclass(frozen=True)
class Replay:
    """The samples used (`t`, `y`, `u`) and the estimates x̂_{k|k} (one row per sample)."""

    t: np.ndarray
    y: np.ndarray
    u: np.ndarray
    estimate: np.ndarray


def read_columns(path: str | Path) -> dict[str, np.ndarray]:
    """Every column of a CSV with a header row, as float arrays."""
    import numpy as np

    try:
        with open(path, newline="") as handle:
            rows = list(csv.reader(handle))
    except OSError as exc:
        raise EstimationError(f"{path}: cannot read ({exc.strerror})") from None
    if not rows:
        raise EstimationError(f"{path}: empty file; expected a CSV with a header row")
    header, body = rows[0], rows[1:]
    try:
        values = [[float(v) for v in row] for row in body]
        data = np.array(values, dtype=float).reshape(len(body), len(header))
    except ValueError:
        raise EstimationError(f"{path}: every row must have {len(header)} numbers") from None
    return {name.strip(): data[:, i] for i, name in enumerate(header)}


def replay(
    estimator: Estimator,
    path: str | Path,
    *,
    measured: list[str] | None = None,
    input_column: str | None = "u",
) -> Replay:
    """Run `estimator` (reset first) over the CSV at `path` (module docstring).

    `measured`: the y columns in the estimator's order (default y_theta<i> for its measured
    coordinates); `input_column`: None for no input (zeros)."""
    import numpy as np

    columns = read_columns(path)
    names = measured or [f"y_theta{i}" for i in estimator.measured]
    missing = [name for name in ["t", *names] if name not in columns]
    if input_column is not None and input_column not in columns:
        missing.append(input_column)
    if missing:
        raise EstimationError(f"{path}: no column {missing[0]!r} (columns: {', '.join(columns)})")
    t = columns["t"]
    ratio = t / estimator.period
    at_sample = np.abs(ratio - np.round(ratio)) <= SAMPLE_TOLERANCE * np.maximum(1.0, np.abs(ratio))
    rows = np.flatnonzero(at_sample)
    if rows.size == 0:
        raise EstimationError(f"{path}: no row at a multiple of the period {estimator.period:g} s")
    steps = np.round(ratio[rows]).astype(int)
    if steps[0] != 0 or np.any(np.diff(steps) != 1):
        raise EstimationError(
            f"{path}: the rows do not cover every sample k·{estimator.period:g} s from t = 0"
        )
    y = np.column_stack([columns[name][rows] for name in names])
    u = columns[input_column][rows] if input_column is not None else np.zeros(rows.size)
    if not (np.all(np.isfinite(y)) and np.all(np.isfinite(u))):
        raise EstimationError(f"{path}: the measured and input columns must be finite")
    estimator.reset()
    estimates = [estimator.step(y[0], 0.0)]
    estimates += [estimator.step(y[k], float(u[k - 1])) for k in range(1, rows.size)]
    return Replay(t=t[rows], y=y, u=u, estimate=np.asarray(estimates))
