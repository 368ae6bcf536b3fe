"""runs.csv: one row per run, appended as runs finish (an interrupted sweep keeps every finished
run) and read back to resume; rewritten in run order when the sweep completes.

Columns: run (its number in the sweep's order), criterion, level (index), values (the level's
values, JSON), repeat, seed, overrides (JSON [[key, value], ...]), outcome (pass, fail, refused),
reason (why it failed or was refused), status (the simulator's exit status), angle_error,
rate_error, base_error (the end state's errors from the goal: rad, rad/s, m or rad), max_travel
(the largest |θ0|), t_final (s) and seconds (the run's wall time, not part of the result).
"""

from __future__ import annotations

import csv
import json
import math
import os
from pathlib import Path

from ipgen.common.safetext import shown_path
from ipgen.sweeps.execute import Result, Task
from ipgen.sweeps.spec import SweepError

COLUMNS: tuple[str, ...] = (
    "run",
    "criterion",
    "level",
    "values",
    "repeat",
    "seed",
    "overrides",
    "outcome",
    "reason",
    "status",
    "angle_error",
    "rate_error",
    "base_error",
    "max_travel",
    "t_final",
    "seconds",
)
OUTCOMES: tuple[str, ...] = ("pass", "fail", "refused")
# Columns that say what the run was (checked on resume) and what it gave (compared across engines).
IDENTITY: tuple[str, ...] = ("run", "criterion", "level", "repeat", "seed", "overrides")
RESULT: tuple[str, ...] = COLUMNS[:-1]


def _number(value: float | None) -> str:
    if value is None:
        return ""
    return "nan" if math.isnan(value) else repr(float(value))


def overrides_text(overrides: tuple[tuple[str, object], ...]) -> str:
    """The overrides as JSON (floats by their shortest repr: exact)."""
    return json.dumps([[key, value] for key, value in overrides], separators=(",", ":"))


def row(result: Result, values: tuple[float, ...]) -> dict[str, str]:
    """The CSV row of a run."""
    task = result.task
    return {
        "run": str(task.index),
        "criterion": task.criterion,
        "level": str(task.level),
        "values": json.dumps(list(values)),
        "repeat": str(task.repeat),
        "seed": str(task.seed),
        "overrides": overrides_text(task.overrides),
        "outcome": result.outcome,
        "reason": result.reason,
        "status": "" if result.status is None else str(result.status),
        "angle_error": _number(result.angle_error),
        "rate_error": _number(result.rate_error),
        "base_error": _number(result.base_error),
        "max_travel": _number(result.max_travel),
        "t_final": _number(result.t_final),
        "seconds": f"{result.seconds:.4f}",
    }


def identity(task: Task) -> dict[str, str]:
    """The identity columns of a planned run."""
    return {
        "run": str(task.index),
        "criterion": task.criterion,
        "level": str(task.level),
        "repeat": str(task.repeat),
        "seed": str(task.seed),
        "overrides": overrides_text(task.overrides),
    }


def read(path: Path) -> list[dict[str, str]]:
    """The complete rows of a runs.csv (a last line cut off by an interruption is dropped)."""
    try:
        with path.open(newline="") as f:
            lines = f.read().splitlines(keepends=True)
    except OSError as error:
        raise SweepError(f"cannot read {shown_path(path)}: {error.strerror}") from None
    if not lines:
        return []
    if lines[0].rstrip("\r\n").split(",") != list(COLUMNS):
        raise SweepError(
            f"{shown_path(path)} is not a sweep's runs.csv: pass another -o, or --force to replace it"
        )
    rows = []
    body = lines[1:]
    for number, parsed in enumerate(csv.DictReader(body, fieldnames=COLUMNS)):
        whole = body[number].endswith("\n") and parsed.get("outcome") in OUTCOMES and None not in parsed
        if not whole:
            if number == len(body) - 1:
                break  # cut off mid-line by an interruption: that run is run again
            raise SweepError(f"{shown_path(path)}: line {number + 2} is damaged; pass --force to start over")
        rows.append(parsed)
    return rows


def resumable(path: Path, tasks: list[Task], force: bool) -> dict[int, dict[str, str]]:
    """The finished runs of an earlier, interrupted run of the same sweep, by run number."""
    if not path.exists() or force:
        return {}
    planned = {task.index: identity(task) for task in tasks}
    done = {}
    for found in read(path):
        index = int(found["run"]) if found["run"].isdigit() else -1
        want = planned.get(index)
        if want is None or any(found[column] != want[column] for column in IDENTITY):
            raise SweepError(
                f"{shown_path(path)} is from another sweep (run {found['run']} differs): pass another -o, "
                "or --force to start over"
            )
        done[index] = found
    return done


class Appender:
    """Appends rows to runs.csv as runs finish (header first when the file is new)."""

    def __init__(self, path: Path, rows: list[dict[str, str]]) -> None:
        self.path = path
        write_all(path, rows)
        self.handle = path.open("a", newline="")
        self.writer = csv.DictWriter(self.handle, fieldnames=COLUMNS, lineterminator="\n")

    def add(self, rows: list[dict[str, str]]) -> None:
        """Append and flush (an interruption keeps these)."""
        self.writer.writerows(rows)
        self.handle.flush()

    def close(self) -> None:
        """Close the file."""
        self.handle.close()


def write_all(path: Path, rows: list[dict[str, str]]) -> None:
    """Write runs.csv with `rows` (a temporary file renamed into place)."""
    partial = path.with_name(f".{path.name}.partial")
    with partial.open("w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=COLUMNS, lineterminator="\n")
        writer.writeheader()
        writer.writerows(rows)
    os.replace(partial, path)
