"""Scores from the table of runs: a level passes when more than half its runs pass; a criterion's
score is the fraction of its levels that pass (levels the scene refuses are not counted); the
sweep's score is the mean of its criteria's scores (criteria refused entirely not counted).
"""

from __future__ import annotations

import itertools
import json
from dataclasses import dataclass

from ipgen.sweeps.spec import Criterion
from ipgen.sweeps.success import Success


@dataclass(frozen=True)
class LevelScore:
    """One level: its values, runs passed/failed/refused, and whether it passes."""

    values: tuple[float, ...]
    passed: int
    failed: int
    refused: int
    reasons: tuple[str, ...]  # distinct reasons of failures or refusals

    @property
    def counted(self) -> bool:
        """Whether the level counts towards the score (some run was not refused)."""
        return self.passed + self.failed > 0

    @property
    def passes(self) -> bool:
        """More than half of its (not refused) runs passed."""
        return self.counted and self.passed > (self.passed + self.failed) / 2


@dataclass(frozen=True)
class CriterionScore:
    """A criterion's levels and score (None: nothing to count)."""

    criterion: Criterion
    levels: tuple[LevelScore, ...]

    @property
    def score(self) -> float | None:
        """The fraction of counted levels that pass."""
        counted = [level for level in self.levels if level.counted]
        if self.criterion.refused or not counted:
            return None
        return sum(level.passes for level in counted) / len(counted)


def score(criteria: list[Criterion], rows: list[dict[str, str]]) -> list[CriterionScore]:
    """The scores of `criteria` from the table's `rows`."""
    found = []
    for criterion in criteria:
        mine = [row for row in rows if row["criterion"] == criterion.name]
        levels = []
        for index, level in enumerate(criterion.levels):
            runs = [row for row in mine if int(row["level"]) == index]
            reasons = tuple(dict.fromkeys(row["reason"] for row in runs if row["reason"]))
            levels.append(
                LevelScore(
                    level.values,
                    sum(row["outcome"] == "pass" for row in runs),
                    sum(row["outcome"] == "fail" for row in runs),
                    sum(row["outcome"] == "refused" for row in runs),
                    reasons,
                )
            )
        found.append(CriterionScore(criterion, tuple(levels)))
    return found


def total(scores: list[CriterionScore]) -> float | None:
    """The mean of the criteria's scores (None if none can be counted)."""
    counted = [s.score for s in scores if s.score is not None]
    return sum(counted) / len(counted) if counted else None


def as_json(scene: str, test: Success, scores: list[CriterionScore], seed: int, note: str = "") -> str:
    """scores.json: the scene, the success test (`note`: what it adds for this scene, e.g. a
    fixed chain's torque bound), each criterion's levels and score, the total."""
    document = {
        "scene": scene,
        "success": test.as_dict(),
        "success_text": test.text() + note,
        "seed": seed,
        "score": total(scores),
        "criteria": [
            {
                "name": s.criterion.name,
                "varies": s.criterion.label,
                "axes": list(s.criterion.axes),
                "repeat": s.criterion.repeat,
                "refused": s.criterion.refused or None,
                "score": s.score,
                "levels": [
                    {
                        "values": list(level.values),
                        "passed": level.passed,
                        "failed": level.failed,
                        "refused": level.refused,
                        "passes": level.passes,
                        "reasons": list(level.reasons),
                    }
                    for level in s.levels
                ],
            }
            for s in scores
        ],
    }
    return json.dumps(document, indent=2, ensure_ascii=False) + "\n"


def _percent(value: float | None) -> str:
    return "—" if value is None else f"{100 * value:.0f} %"


def _value(name: str, value: float) -> str:
    """A level's value as scores.md shows it: encoder resolution 0 is the exact angle."""
    return "exact" if name == "resolution" and value == 0 else f"{value:g}"


def _range(s: CriterionScore) -> str:
    """The levels: "first … last" when they run one way, else every level in order (the
    resolution's exact, 8192, …, 64 is not a range from 0 to 64)."""
    values = [level.values for level in s.criterion.levels]
    if not values:
        return "—"
    if len(values[0]) == 1:
        single = [v[0] for v in values]
        pairs = list(itertools.pairwise(single))
        if all(a <= b for a, b in pairs) or all(a >= b for a, b in pairs):
            first, last = _value(s.criterion.name, single[0]), _value(s.criterion.name, single[-1])
            return f"{first} … {last} ({len(values)} levels)"
        return f"{', '.join(_value(s.criterion.name, v) for v in single)} ({len(values)} levels)"
    return f"{len(values)} grid points"


def _first_failure(s: CriterionScore) -> str:
    """The first level (in order) that does not pass, and why."""
    for level in s.levels:
        if level.counted and not level.passes:
            shown = ", ".join(_value(s.criterion.name, v) for v in level.values)
            return f"{shown}: {level.reasons[0] if level.reasons else 'failed'}"
    refused = [level for level in s.levels if not level.counted]
    if refused and refused[0].reasons:
        return f"refused levels: {len(refused)} ({refused[0].reasons[0]})"
    return "—"


def as_markdown(scene: str, test: Success, scores: list[CriterionScore], runs: int, note: str = "") -> str:
    """scores.md: the scorecard as a table, the test stated (and `note`, as in `as_json`)."""
    lines = [
        f"# Robustness of {scene}",
        "",
        f"Score {_percent(total(scores))} (the mean of the criteria's scores; {runs} runs). Success test: "
        f"{test.text()}{note}.",
        "",
        "| criterion | varies | levels | runs per level | levels passed | score | first level that fails |",
        "|---|---|---|---|---|---|---|",
    ]
    for s in scores:
        if s.criterion.refused:
            lines.append(
                f"| {s.criterion.name} | {s.criterion.label} | {_range(s)} | {s.criterion.repeat} | — | "
                f"not run | "
                f"{s.criterion.refused} |"
            )
            continue
        passed = sum(level.passes for level in s.levels)
        counted = sum(level.counted for level in s.levels)
        lines.append(
            f"| {s.criterion.name} | {s.criterion.label} | {_range(s)} | {s.criterion.repeat} | "
            f"{passed}/{counted} | {_percent(s.score)} | {_first_failure(s)} |"
        )
    return "\n".join(lines) + "\n"
