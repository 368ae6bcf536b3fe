"""What a sweep varies: scene keys (`parameters.m[1]`), their levels (`LO:HI:N` or `v1,v2,…`) and
the criteria they make (one per `--vary` grid, or the scorecard's, `scorecard.py`).

Every problem with a specification is a `SweepError` with one line naming it and the fix.
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable
from dataclasses import dataclass, field

from ipgen.common.safetext import abbreviate
from ipgen.errors import Error
from ipgen.scene import schema

# Tables whose keys design the controller: overriding one designs it anew for that level; every
# other key changes the simulated plant (or the run) only, the controller staying the nominal one.
DESIGN_TABLES: tuple[str, ...] = ("controller", "swingup")
# Tables a sweep may not change: [system] names the model (another simulator), [input] and
# [outputs] are not robustness questions.
FIXED_TABLES: tuple[str, ...] = ("system", "input", "outputs")
# Keys that draw random numbers from the run's seed (noise, pulses): a run that sets one gets its
# own sensors.seed.
SEEDED_KEYS: tuple[str, ...] = ("sensors.noise", "actuator.noise", "actuator.pulses")
MAX_LEVELS = 10_000
GRID = "grid"  # the criterion of a 2-D --vary grid (its picture: grid.png)
# Runs of one sweep at most (levels × repetitions over every criterion): each is planned before the
# first one starts (its task, later its row), so the total is bounded before anything is built.
MAX_RUNS = 100_000
_KEY = re.compile(r"^([A-Za-z_]+)\.([A-Za-z_][A-Za-z0-9_]*)(?:\[(\d{1,4})\])?$")


class SweepError(Error, ValueError):
    """A sweep that cannot be run as specified; the message says what to change."""


@dataclass(frozen=True)
class Key:
    """A scene key to override: `table.name` or one entry `table.name[index]`."""

    table: str
    name: str
    index: int | None = None

    @property
    def text(self) -> str:
        """The key as written: parameters.m[1]."""
        return f"{self.table}.{self.name}" + ("" if self.index is None else f"[{self.index}]")

    @property
    def designs(self) -> bool:
        """Whether the key belongs to the controller's design (the controller is designed anew)."""
        return self.table in DESIGN_TABLES


def split_key(text: str, example: str = "parameters.m[1], initial.theta[1], controller.period") -> Key:
    """A `Key` from `table.name` or `table.name[i]`, its form checked only (a SweepError naming
    the form, with `example` keys); `parse_key` and a fixed chain's `parse_fixed_key` check it
    against their scenes."""
    match = _KEY.match(text.strip())
    if match is None:
        raise SweepError(
            f"--vary key {abbreviate(text)!r} is not a scene key: write table.key or table.key[i], "
            f"e.g. {example}"
        )
    table, name, index = match.group(1), match.group(2), match.group(3)
    return Key(table, name, None if index is None else int(index))


def parse_key(text: str) -> Key:
    """A `Key` from `table.name` or `table.name[i]`, checked against the scene format."""
    key = split_key(text)
    table, name = key.table, key.name
    if table not in schema.TABLES:
        raise SweepError(
            f"--vary {key.text}: unknown table [{abbreviate(table)}] (a scene has {', '.join(schema.TABLES)})"
        )
    if table in FIXED_TABLES:
        raise SweepError(
            f"--vary {key.text}: [{table}] cannot be swept (it changes the model or the experiment, not "
            "its robustness): sweep [parameters], [initial], [controller], ... keys"
        )
    if name not in schema.TABLES[table]:
        raise SweepError(
            f"--vary {key.text}: [{table}] has no key {abbreviate(name)!r} "
            f"(it has {', '.join(schema.TABLES[table])})"
        )
    return key


def _number(text: str, spec: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise SweepError(f"--vary {abbreviate(spec)!r}: {abbreviate(text)!r} is not a number") from None
    if not math.isfinite(value):
        raise SweepError(f"--vary {abbreviate(spec)!r}: {abbreviate(text)!r} is not a finite number")
    return value


def parse_levels(text: str, spec: str) -> tuple[float, ...]:
    """`LO:HI:N` (N evenly spaced values, both ends included) or `v1,v2,…` as floats."""
    text = text.strip()
    if not text:
        raise SweepError(f"--vary {abbreviate(spec)!r}: no values: write KEY=LO:HI:N or KEY=v1,v2,...")
    if ":" in text:
        parts = text.split(":")
        if len(parts) != 3:
            raise SweepError(f"--vary {abbreviate(spec)!r}: a range is LO:HI:N, e.g. 0.75:1.25:11")
        low, high = _number(parts[0], spec), _number(parts[1], spec)
        try:
            count = int(parts[2])
        except ValueError:
            raise SweepError(
                f"--vary {abbreviate(spec)!r}: N = {abbreviate(parts[2])!r} must be a whole number >= 1"
            ) from None
        if count < 1:
            raise SweepError(f"--vary {abbreviate(spec)!r}: the range is empty (N = {count}); use N >= 1")
        if count > MAX_LEVELS:
            raise SweepError(f"--vary {abbreviate(spec)!r}: N = {count} levels; at most {MAX_LEVELS}")
        if count == 1:
            if low != high:
                raise SweepError(f"--vary {abbreviate(spec)!r}: one level between two values; use N >= 2")
            return (low,)
        span = high - low
        if not math.isfinite(span * (count - 1)):  # ±1e308: a convex combination cannot overflow
            inner = [low * (1 - i / (count - 1)) + high * (i / (count - 1)) for i in range(1, count - 1)]
        else:
            inner = [low + span * i / (count - 1) for i in range(1, count - 1)]
        return (low, *inner, high)  # both ends as given (1 + (1.2e-38 - 1) rounds to 0.0)
    items = text.split(",")
    if any(not item.strip() for item in items):
        raise SweepError(f"--vary {abbreviate(spec)!r}: an empty value in the list; write v1,v2,...")
    if len(items) > MAX_LEVELS:
        raise SweepError(f"--vary {abbreviate(spec)!r}: {len(items)} levels; at most {MAX_LEVELS}")
    return tuple(_number(item, spec) for item in items)


def parse_vary(spec: str, parse: Callable[[str], Key] | None = None) -> tuple[Key, tuple[float, ...]]:
    """`KEY=LO:HI:N` or `KEY=v1,v2,…` as (key, levels); `parse` checks the key (default
    `parse_key`, a cart's or arm's scene; a fixed chain's: `sweeps.fixed.parse_fixed_key`)."""
    if "=" not in spec:
        raise SweepError(
            f"--vary {abbreviate(spec)!r}: expected KEY=LO:HI:N or KEY=v1,v2,..., "
            "e.g. parameters.m[1]=0.2:0.3:5"
        )
    key_text, _, levels = spec.partition("=")
    return (parse or parse_key)(key_text), parse_levels(levels, spec)


@dataclass(frozen=True)
class Level:
    """One level of a criterion: its value(s) as shown, and the scene overrides it means."""

    values: tuple[float, ...]
    overrides: tuple[tuple[str, object], ...]  # (key text, value): applied in order


@dataclass(frozen=True)
class Criterion:
    """A criterion: its levels, each run `repeat` times; `refused` says why it cannot run at all."""

    name: str
    label: str  # what is varied, for tables and plots, e.g. "masses ×"
    axes: tuple[str, ...]  # the level values' names (one per grid dimension)
    levels: tuple[Level, ...]
    repeat: int = 1
    refused: str = ""  # non-empty: not run, with this reason
    seeded: bool = False  # the runs draw random numbers (noise, pulses): repetitions differ
    extra: dict[str, object] = field(default_factory=dict)  # e.g. the pulses' draw, for the record
    axis_labels: tuple[str, ...] = ()  # a grid's axes as its plots title them (with units); () the axes

    @property
    def axis_titles(self) -> tuple[str, ...]:
        """The axes as plots title them: `axis_labels`, else the axes' names."""
        return self.axis_labels or self.axes


def grid(
    keys_levels: list[tuple[Key, tuple[float, ...]]], repeat: int, labels: tuple[str, ...] = ()
) -> Criterion:
    """The criterion of the `--vary` options: the Cartesian product of their levels (1-D, 2-D, …);
    `labels`: the keys as plots label them (`units.axis_label`), default their text."""
    import itertools

    seen = [key.text for key, _ in keys_levels]
    if labels and len(labels) != len(seen):
        raise ValueError(f"grid: {len(labels)} labels for {len(seen)} keys")
    duplicate = next((k for k in seen if seen.count(k) > 1), None)
    if duplicate is not None:
        raise SweepError(f"--vary {duplicate} is given twice: give each key once")
    count = math.prod(len(levels) for _, levels in keys_levels)
    if count > MAX_LEVELS:
        raise SweepError(f"--vary: the grid has {count} levels; at most {MAX_LEVELS}")
    levels = tuple(
        Level(values, tuple((key.text, value) for (key, _), value in zip(keys_levels, values, strict=True)))
        for values in itertools.product(*(levels for _, levels in keys_levels))
    )
    name = GRID
    label = " × ".join(seen)
    return Criterion(name, label, tuple(seen), levels, repeat=repeat, seeded=repeat > 1, axis_labels=labels)


def check_total(criteria: list[Criterion]) -> int:
    """The number of runs of `criteria` (levels × repetitions of each one not refused); a
    `SweepError` naming it and the fix when it exceeds `MAX_RUNS`, before any run is planned."""
    total = sum(len(c.levels) * c.repeat for c in criteria if not c.refused)
    if total > MAX_RUNS:
        counts = ", ".join(f"{c.name} {len(c.levels)} × {c.repeat}" for c in criteria if not c.refused)
        raise SweepError(
            f"the sweep would make {total:,} runs ({abbreviate(counts, 120)} levels × repetitions); "
            f"at most {MAX_RUNS:,}: give fewer levels or a smaller --repeat"
        )
    return total
