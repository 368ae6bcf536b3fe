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
import hashlib
import json
import math
from pathlib import Path
from typing import TYPE_CHECKING

from ipgen.common import files
from ipgen.common.safetext import abbreviate, shown_path
from ipgen.sweeps.execute import Result, Task
from ipgen.sweeps.spec import SweepError

if TYPE_CHECKING:
    from ipgen.sweeps.success import Success

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
    "sweep",
)
# The columns of an older ipgen's table (no sweep digest): not resumed, as it cannot be checked.
OLD_COLUMNS: tuple[str, ...] = COLUMNS[:-1]
OUTCOMES: tuple[str, ...] = ("pass", "fail", "refused")
# Columns that say what the run was (checked on resume) and what it gave (compared across engines).
IDENTITY: tuple[str, ...] = ("run", "criterion", "level", "repeat", "seed", "overrides", "sweep")
RESULT: tuple[str, ...] = tuple(column for column in COLUMNS if column != "seconds")
NUMBERS: tuple[str, ...] = ("angle_error", "rate_error", "base_error", "max_travel", "t_final")
COUNTS: tuple[str, ...] = ("run", "level", "repeat", "seed")
DIGEST_CHARS = 16


def sweep_digest(scene_text: str, test: Success) -> str:
    """What a sweep's runs were judged on: the first 16 hex digits of SHA-256 over the scene's
    text and the success test (the runs' seeds and overrides have columns of their own)."""
    stated = json.dumps({"scene": scene_text, "success": test.as_dict()}, sort_keys=True)
    return hashlib.sha256(stated.encode()).hexdigest()[:DIGEST_CHARS]


def _number(value: float | None) -> str:
    if value is None:
        return ""
    return "nan" if math.isnan(value) else repr(float(value))


def overrides_text(overrides: tuple[tuple[str, object], ...]) -> str:
    """The overrides as JSON (floats by their shortest repr: exact)."""
    return json.dumps([[key, value] for key, value in overrides], separators=(",", ":"))


def row(result: Result, values: tuple[float, ...], digest: str = "") -> dict[str, str]:
    """The CSV row of a run of the sweep `digest` (`sweep_digest`)."""
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
        "sweep": digest,
    }


def identity(task: Task, digest: str = "") -> dict[str, str]:
    """The identity columns of a planned run of the sweep `digest`."""
    return {
        "sweep": digest,
        "run": str(task.index),
        "criterion": task.criterion,
        "level": str(task.level),
        "repeat": str(task.repeat),
        "seed": str(task.seed),
        "overrides": overrides_text(task.overrides),
    }


def _count(text: str, signed: bool = False) -> bool:
    """Whether `text` is a whole number as `str(int)` writes it (ASCII digits, no sign unless
    `signed`, no leading zeros): "²" and "07" are not."""
    digits = text[1:] if signed and text.startswith("-") else text
    return digits.isascii() and digits.isdigit() and str(int(digits)) == digits


def _canonical_number(text: str) -> bool:
    """Whether `text` is a result number as `row` writes it: a finite float's repr, or nan."""
    try:
        value = float(text)
    except ValueError:
        return False
    return (math.isnan(value) or math.isfinite(value)) and _number(value) == text


def _values(text: str) -> bool:
    """Whether `text` is a level's values as `row` writes them: a JSON list of finite numbers."""
    try:
        values = json.loads(text, parse_constant=lambda name: None)
    except ValueError:
        return False
    return isinstance(values, list) and all(
        isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v) for v in values
    )


def problem(found: dict[str, str]) -> str | None:
    """Why `found` is not a row `row` wrote (the column and its value), or None."""
    for column in COUNTS:
        if not _count(found[column]):
            return f"{column} = {abbreviate(found[column])!r} is not a whole number"
    if found["status"] and not _count(found["status"], signed=True):
        return f"status = {abbreviate(found['status'])!r} is not an exit status"
    if found["outcome"] not in OUTCOMES:
        return f"outcome = {abbreviate(found['outcome'])!r} is not one of {', '.join(OUTCOMES)}"
    for column in NUMBERS:
        if not _canonical_number(found[column]):
            return f"{column} = {abbreviate(found[column])!r} is not a number ipgen writes (finite or nan)"
    try:
        seconds = float(found["seconds"])
    except ValueError:
        seconds = math.nan
    if not (math.isfinite(seconds) and seconds >= 0):
        return f"seconds = {abbreviate(found['seconds'])!r} is not a wall time"
    if not _values(found["values"]):
        return f"values = {abbreviate(found['values'])!r} is not a JSON list of finite numbers"
    return None


def read(path: Path) -> list[dict[str, str]]:
    """The complete rows of a runs.csv (a last line cut off by an interruption is dropped); a
    damaged file (not UTF-8, not CSV, a field not as `row` writes it) is a one-line SweepError."""
    shown = shown_path(path)
    try:
        data = path.read_bytes()
    except OSError as error:
        raise SweepError(f"cannot read {shown}: {error.strerror}") from None
    if b"\n" in data:  # a last line cut off by an interruption, maybe inside a character: dropped below
        data = data[: data.rfind(b"\n") + 1]
    try:
        lines = data.decode("utf-8").splitlines(keepends=True)
    except UnicodeDecodeError as error:
        raise SweepError(
            f"{shown} is damaged (byte {error.start} is not UTF-8): pass another -o, or --force to start over"
        ) from None
    if not lines:
        return []
    header = lines[0].rstrip("\r\n").split(",")
    if header == list(OLD_COLUMNS):
        raise SweepError(
            f"{shown} was written by an older ipgen (no sweep digest to check it against): "
            "pass another -o, or --force to start over"
        )
    if header != list(COLUMNS):
        raise SweepError(f"{shown} is not a sweep's runs.csv: pass another -o, or --force to replace it")
    rows = []
    body = lines[1:]
    try:
        for number, parsed in enumerate(csv.DictReader(body, fieldnames=COLUMNS)):
            whole = body[number].endswith("\n") and None not in parsed and None not in parsed.values()
            wrong = problem(parsed) if whole else "cut off"
            if wrong is not None:
                if number == len(body) - 1 and not body[number].endswith("\n"):
                    break  # cut off mid-line by an interruption: that run is run again
                raise SweepError(
                    f"{shown}: line {number + 2} is damaged ({wrong}); pass --force to start over"
                )
            rows.append(parsed)
    except csv.Error as error:
        raise SweepError(
            f"{shown} is damaged ({abbreviate(str(error))}); pass --force to start over"
        ) from None
    return rows


def resumable(path: Path, tasks: list[Task], force: bool, digest: str = "") -> dict[int, dict[str, str]]:
    """The finished runs of an earlier, interrupted run of the same sweep (`digest`, and the same
    planned runs), by run number."""
    if force or not path.exists():
        return {}
    planned = {task.index: identity(task, digest) for task in tasks}
    done = {}
    for found in read(path):
        want = planned.get(int(found["run"]))
        if want is None or any(found[column] != want[column] for column in IDENTITY):
            scene = want is not None and found["sweep"] != digest
            what = "its scene or success test" if scene else "its runs"
            raise SweepError(
                f"{shown_path(path)} is from another sweep ({what} differ, run {found['run']}): "
                "pass another -o, or --force to start over"
            )
        done[int(found["run"])] = found
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
    with files.replacing(path) as partial, partial.open("w", newline="", encoding="utf-8") as f:
        writer = csv.DictWriter(f, fieldnames=COLUMNS, lineterminator="\n")
        writer.writeheader()
        writer.writerows(rows)
