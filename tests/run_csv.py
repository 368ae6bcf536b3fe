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


def read_run_csv(path: Path, *, phase: bool) -> RunCsv:
    """The CSV at `path`: a header line, then rows of numbers, with the text column `phase` last
    when `phase` (a swing-up's run), without it otherwise (asserted either way)."""
    header, *rows = Path(path).read_text().splitlines()
    names = header.split(",")
    assert (names[-1] == PHASE) == phase, f"{path}: phase column expected {phase}, header {header}"
    cells = [row.split(",") for row in rows]
    phases: list[str] = []
    if phase:
        names = names[:-1]
        phases = [row[-1] for row in cells]
        cells = [row[:-1] for row in cells]
    data = np.array([[float(value) for value in row] for row in cells]).reshape(len(cells), len(names))
    return RunCsv(names, data, phases)
