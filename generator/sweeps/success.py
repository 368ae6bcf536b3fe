"""The success test of one run, stated and configurable.

A run passes when the simulator finished it (exit status 0: not diverged, not stopped at the
travel limit, no integration failure) and, over its last `hold` seconds, every link's angle stayed
within `angle` rad of the goal (angles compared modulo 2π: a link that turned over is upright
again) and every link's rate within `rate` rad/s, the base's |θ0| stayed within the travel limit
(`travel`, default the scene's limits.travel) and, if `base` is set, the base within `base` of the
goal (m or rad). The goal is the controller's equilibrium or the swing-up's target. Defaults as in
the DFKI double-pendulum leaderboard: 0.35 rad and 1 rad/s; held for the last 1 s.

A balance run (a [controller], no [swingup]) must also converge: over the last `hold` seconds
every link within `converge` (default 0.25) times the largest link angle error at the start. A
balance scene starts inside the leaderboard's tolerance (0.1 rad of tilt, say), so without it a
controller that does nothing — a link held by Coulomb friction where it started — passes. A run
that starts on the goal (no initial error) has nothing to converge from: the tolerance alone
judges it. A swing-up starts hanging, outside the tolerance: the leaderboard's test as it is.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import TYPE_CHECKING

from ipgen.sweeps.spec import SweepError

if TYPE_CHECKING:
    import numpy as np

# The simulator's exit statuses (cpp/src/simulate.cpp) and what they mean for a run.
STATUS_REASONS = {1: "integration failed", 3: "diverged", 4: "left the travel", 5: "lost the plan"}


@dataclass(frozen=True)
class Success:
    """The success test: tolerances about the goal, held for the last `hold` seconds."""

    angle: float = 0.35  # rad, each link
    rate: float = 1.0  # rad/s, each link
    hold: float = 1.0  # s: the last seconds of the run that must all be within
    base: float | None = None  # m or rad: the base's tolerance (None: not checked)
    travel: float | None = None  # |θ0| limit (None: the scene's limits.travel, if any)
    converge: float = 0.25  # balance: the final link error at most this fraction of the initial one

    def __post_init__(self) -> None:
        for name in ("angle", "rate", "hold", "base", "travel", "converge"):
            value = getattr(self, name)
            if value is None and name in ("base", "travel"):
                continue
            if not isinstance(value, (int, float)) or isinstance(value, bool) or not math.isfinite(value):
                raise SweepError(f"success {name} = {value!r}: expected a finite number")
            if value < 0 or (value == 0 and name != "hold"):
                raise SweepError(f"success {name} = {value!r}: must be > 0")

    def as_dict(self) -> dict[str, float | None]:
        """The test's fields, for scores.json."""
        return asdict(self)

    def text(self) -> str:
        """The test in one sentence, for scores.md."""
        parts = [f"|θi − goal| ≤ {self.angle:g} rad and |θ̇i| ≤ {self.rate:g} rad/s for every link"]
        if self.base is not None:
            parts.append(f"|θ0 − goal| ≤ {self.base:g}")
        travel = "the scene's travel limit" if self.travel is None else f"|θ0| ≤ {self.travel:g}"
        return (
            f"a run passes when the simulator finishes it and {', '.join(parts)} over its last "
            f"{self.hold:g} s, with {travel} honoured throughout; a balance run (no [swingup]) must also "
            f"converge: every link within {self.converge:g} × its largest initial link angle error over "
            f"those {self.hold:g} s (a do-nothing controller, a link frozen by friction where it started, "
            "fails); a level passes when more than half its runs pass"
        )


@dataclass(frozen=True)
class Judgement:
    """What the success test says about one trajectory."""

    passed: bool
    reason: str  # "" when passed
    angle_error: float  # at the last sample: the largest link angle error [rad]
    rate_error: float  # at the last sample: the largest link rate [rad/s]
    base_error: float  # at the last sample: |θ0 − goal| [m or rad]
    max_travel: float  # the largest |θ0| of the run
    t_final: float


def wrapped(angle: np.ndarray) -> np.ndarray:
    """Angles mapped to (−π, π]."""
    import numpy as np

    return np.pi - np.mod(np.pi - angle, 2.0 * np.pi)


def judge(
    test: Success,
    t: np.ndarray,
    states: np.ndarray,
    goal: tuple[float, ...],
    *,
    rotary: bool,
    status: int,
    travel: float | None,
    balance: bool = False,
    fixed: bool = False,
) -> Judgement:
    """Judge the run with times `t` and rows `states` = [θ0..θn, θ̇0..θ̇n], simulator exit `status`;
    `balance`: a balance run, which must also converge (`Success.converge`); `fixed`: a chain on
    a fixed pivot, every coordinate a link's (no base: its error and travel are 0)."""
    import numpy as np

    dof = states.shape[1] // 2
    first = 0 if fixed else 1  # the first link's coordinate
    goal_angles = np.asarray(goal[:dof])
    angles = states[:, :dof] - goal_angles
    links = np.abs(wrapped(angles[:, first:]))
    base = np.zeros(len(t)) if fixed else np.abs(wrapped(angles[:, 0]) if rotary else angles[:, 0])
    rates = np.abs(states[:, dof + first :])
    last = -1
    has_links = dof > first
    judgement = dict(
        angle_error=float(links[last].max()) if has_links else 0.0,
        rate_error=float(rates[last].max()) if has_links else 0.0,
        base_error=float(base[last]),
        max_travel=0.0 if fixed else float(np.abs(states[:, 0]).max()),
        t_final=float(t[last]),
    )
    limit = test.travel if test.travel is not None else travel
    start = float(links[0].max()) if has_links else 0.0  # the largest initial link error
    reason = STATUS_REASONS.get(status, f"simulator exit status {status}" if status else "")
    if not reason and limit is not None and judgement["max_travel"] > limit:
        reason = "left the travel"
    if not reason:
        window = t >= t[last] - test.hold - 1e-9
        if t[last] < test.hold - 1e-9:
            reason = "ended before the hold time"
        elif (links[window] > test.angle).any() or (rates[window] > test.rate).any():
            reason = (
                "not within the tolerance"
                if (links[last] > test.angle).any() or (rates[last] > test.rate).any()
                else "left the tolerance in the hold time"
            )
        elif test.base is not None and (base[window] > test.base).any():
            reason = "base not within the tolerance"
        # a balance run converges (one that starts on the goal: the tolerance alone judges it)
        elif balance and start > 0.0 and (links[window] > test.converge * start).any():
            reason = f"did not converge (not within {test.converge:g} × the initial error)"
    return Judgement(passed=not reason, reason=reason, **judgement)
