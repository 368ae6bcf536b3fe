"""The sweep's pictures (PNG, matplotlib's Agg backend): per criterion each run's end-state
error (over the tolerance) across the levels with the success band, a bar chart of the scores,
a heatmap of a 2-D grid.
"""

from __future__ import annotations

import itertools
import math
from pathlib import Path

from ipgen.common import files
from ipgen.sweeps.scores import CriterionScore
from ipgen.sweeps.success import Success

FLOOR = 1e-8  # relative errors below are drawn at the floor of the log axis
COLOURS = {"pass": "#2a9d3a", "fail": "#d62728", "refused": "#999999"}


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _save(figure, path: Path) -> Path:
    with files.replacing(path) as partial:
        figure.savefig(partial, dpi=110, format="png")
    return path


def criterion_plot(s: CriterionScore, rows: list[dict[str, str]], test: Success, path: Path) -> Path:
    """Each run's end-state error over the tolerance at each level (log axis), the band shaded,
    the levels that pass marked on top; refused levels drawn grey on the floor."""
    plt = _pyplot()
    levels = s.criterion.levels
    labels = [f"{level.values[0]:g}" for level in levels]
    uniform = len(levels) > 2 and all(
        math.isclose(
            levels[i + 1].values[0] - levels[i].values[0],
            levels[1].values[0] - levels[0].values[0],
            rel_tol=1e-6,
        )
        for i in range(len(levels) - 1)
    )
    xs = [level.values[0] for level in levels] if uniform else list(range(len(levels)))
    figure, axis = plt.subplots(figsize=(7.5, 4.0))
    axis.axhspan(FLOOR, 1.0, color="#2a9d3a", alpha=0.12, label="success band (within the tolerance)")
    seen = set()
    for row in rows:
        if row["criterion"] != s.criterion.name:
            continue
        level = int(row["level"])
        error = _relative(row, test)
        outcome = row["outcome"]
        y = FLOOR if math.isnan(error) or outcome == "refused" else min(max(error, FLOOR), 30.0)
        axis.scatter(
            xs[level],
            y,
            s=16,
            color=COLOURS[outcome],
            alpha=0.7,
            label=outcome if outcome not in seen else None,
            zorder=3,
        )
        seen.add(outcome)
    for x, level in zip(xs, s.levels, strict=True):
        marker = "✓" if level.passes else ("×" if level.counted else "–")
        axis.annotate(
            marker,
            (x, 1.0),
            xycoords=("data", "axes fraction"),
            ha="center",
            va="bottom",
            color=COLOURS["pass" if level.passes else "fail" if level.counted else "refused"],
        )
    axis.set_yscale("log")
    axis.set_ylim(FLOOR / 2, 50)
    axis.set_ylabel(
        f"end-state error / tolerance\n(max of angle/{test.angle:g} rad, rate/{test.rate:g} rad/s)"
    )
    axis.set_xlabel(s.criterion.axis_labels[0] if s.criterion.axis_labels else s.criterion.label)
    if not uniform:
        axis.set_xticks(xs, labels, rotation=45 if len(levels) > 8 else 0)
    score = "—" if s.score is None else f"{100 * s.score:.0f} %"
    axis.set_title(f"{s.criterion.name}: score {score} (✓ level passes, × fails, – refused)", pad=18)
    axis.legend(loc="center left", fontsize=8, framealpha=0.8)
    axis.grid(alpha=0.3)
    figure.tight_layout()
    _save(figure, path)
    plt.close(figure)
    return path


def _relative(row: dict[str, str], test: Success) -> float:
    """The end state's error in units of the tolerance: the larger of angle and rate."""
    try:
        return max(float(row["angle_error"]) / test.angle, float(row["rate_error"]) / test.rate)
    except ValueError:
        return math.nan


def scores_plot(scores: list[CriterionScore], total: float | None, scene: str, path: Path) -> Path:
    """A horizontal bar per criterion: its score (criteria not run labelled so)."""
    plt = _pyplot()
    figure, axis = plt.subplots(figsize=(7.0, 0.45 * len(scores) + 1.4))
    names = [s.criterion.name for s in scores]
    values = [0.0 if s.score is None else 100 * s.score for s in scores]
    bars = axis.barh(range(len(scores)), values, color="#3b75af")
    for bar, s in zip(bars, scores, strict=True):
        text = "not run" if s.criterion.refused else ("—" if s.score is None else f"{100 * s.score:.0f} %")
        axis.text(bar.get_width() + 1, bar.get_y() + bar.get_height() / 2, text, va="center", fontsize=8)
    axis.set_yticks(range(len(scores)), names)
    axis.invert_yaxis()
    axis.set_xlim(0, 112)
    axis.set_xlabel("levels passed [%]")
    shown = "—" if total is None else f"{100 * total:.0f} %"
    axis.set_title(f"{scene}: robustness score {shown}")
    axis.grid(axis="x", alpha=0.3)
    figure.tight_layout()
    _save(figure, path)
    plt.close(figure)
    return path


def heatmap(s: CriterionScore, path: Path) -> Path:
    """A 2-D grid: each point's fraction of passing runs (refused points hatched grey)."""
    import numpy as np

    plt = _pyplot()
    first = sorted({level.values[0] for level in s.criterion.levels})
    second = sorted({level.values[1] for level in s.criterion.levels})
    grid = np.full((len(second), len(first)), np.nan)
    for level in s.levels:
        if level.counted:
            grid[second.index(level.values[1]), first.index(level.values[0])] = level.passed / (
                level.passed + level.failed
            )
    figure, axis = plt.subplots(figsize=(6.5, 5.0))
    axis.set_facecolor("#bbbbbb")
    # a cell per point, its edges halfway to the neighbours: the points of a list need not be evenly
    # spaced (--vary KEY=v1,v2,...), and each is drawn where its value is
    image = axis.pcolormesh(
        cell_edges(first), cell_edges(second), np.ma.masked_invalid(grid), cmap="RdYlGn", vmin=0, vmax=1
    )
    points = [(level.values[0], level.values[1]) for level in s.criterion.levels]
    axis.plot(*zip(*points, strict=True), "k.", markersize=4)  # the value each cell was run at
    figure.colorbar(image, ax=axis, label="fraction of runs passed (grey: refused; dots: the points run)")
    axis.set_xlabel(s.criterion.axis_titles[0])
    axis.set_ylabel(s.criterion.axis_titles[1])
    score = "—" if s.score is None else f"{100 * s.score:.0f} %"
    axis.set_title(f"{s.criterion.label}: {score} of the grid passes")
    figure.tight_layout()
    _save(figure, path)
    plt.close(figure)
    return path


def cell_edges(values: list[float]) -> list[float]:
    """The edges of the cells of sorted `values` on an axis: halfway between neighbours, the outer
    ones as far out as the inner next to them (±0.5 about a single value)."""
    if len(values) == 1:
        return [values[0] - 0.5, values[0] + 0.5]
    middles = [(a + b) / 2 for a, b in itertools.pairwise(values)]
    return [2 * values[0] - middles[0], *middles, 2 * values[-1] - middles[-1]]
