"""A run's CSV read back for the tests (`ipgen run`, ipsim's simulator, the CMake scenes): one
reader instead of one per test file.

The CSV's columns are t, the states, the energies and u as the scene has them, all numbers, and
a swing-up's text column `phase` last (swing, track, hold).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

PHASE = "phase"


@dataclass(frozen=True)
class RunCsv:
    """The numeric columns' names and values (rows × columns) and, for a swing-up, the phase of
    each row."""

    names: list[str]
    data: np.ndarray
    phase: list[str]

    def __getitem__(self, name: str) -> np.ndarray:
        """The column `name`, every row."""
        return self.data[:, self.names.index(name)]

    def columns(self, rows: slice = slice(None)) -> dict[str, np.ndarray]:
        """Every numeric column by name, the rows `rows` (`slice(-1)`: the sampling instants,
        without the last row at t_end)."""
        return {name: self.data[rows, i] for i, name in enumerate(self.names)}


def read_run_csv(path: Path) -> RunCsv:
    """The CSV at `path` (a header line, then rows of numbers; `phase` text when it is a column)."""
    header, *rows = Path(path).read_text().splitlines()
    names = header.split(",")
    cells = [row.split(",") for row in rows]
    phase: list[str] = []
    if names[-1] == PHASE:
        names = names[:-1]
        phase = [row[-1] for row in cells]
        cells = [row[:-1] for row in cells]
    data = np.array([[float(value) for value in row] for row in cells]).reshape(len(cells), len(names))
    return RunCsv(names, data, phase)
