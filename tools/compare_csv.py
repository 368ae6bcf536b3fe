"""Compare two simulator CSV files column by column to an absolute tolerance.

    .venv/bin/python tools/compare_csv.py ACTUAL.csv EXPECTED.csv --tol 1e-6

Both files must have the same header and the same number of rows. Prints the largest difference
(column, row, time, both values); exits 0 if it is <= tol, 1 if not, 2 if the files cannot be
compared. ctest's paper.<model>.golden tests run it against tests/data/<scene>.golden.csv.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np


def read(path: Path) -> tuple[list[str], np.ndarray]:
    try:
        with path.open() as f:
            header = f.readline().strip().split(",")
        return header, np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    except (OSError, ValueError) as e:
        print(f"compare_csv: error: {path}: {e}", file=sys.stderr)
        raise SystemExit(2) from e


def main() -> int:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("actual", type=Path)
    parser.add_argument("expected", type=Path)
    parser.add_argument("--tol", type=float, required=True, help="largest allowed absolute difference")
    args = parser.parse_args()
    header, actual = read(args.actual)
    expected_header, expected = read(args.expected)
    if header != expected_header:
        print(f"compare_csv: error: columns differ: {header} vs {expected_header}", file=sys.stderr)
        return 2
    if actual.shape != expected.shape:
        print(f"compare_csv: error: {len(actual)} rows vs {len(expected)} rows", file=sys.stderr)
        return 2
    difference = np.abs(actual - expected)
    if np.isnan(difference).any():
        row, column = np.argwhere(np.isnan(difference))[0]
    else:
        row, column = np.unravel_index(np.argmax(difference), difference.shape)
    worst = difference[row, column]
    where = (
        f"column {header[column]}, row {row + 1} (t = {actual[row, 0]:.17g}): "
        f"{actual[row, column]:.17g} vs {expected[row, column]:.17g}"
    )
    if not worst <= args.tol:
        print(f"compare_csv: FAILED: max |difference| {worst:.3e} > {args.tol:g} at {where}")
        return 1
    print(f"compare_csv: ok: max |difference| {worst:.3e} <= {args.tol:g} at {where}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
