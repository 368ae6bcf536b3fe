"""The RealAIGym simulation leaderboard's score (v2) of a double pendulum's swing-up.

The criteria and the v2 formula of DFKI's double_pendulum repository
(github.com/dfki-ric-underactuated-lab/double_pendulum, BSD-3-Clause:
src/python/double_pendulum/analysis/leaderboard.py, leaderboard_scores with score_version "v2",
and the weights and normalisations of leaderboard/{acrobot,pendubot}/simulation_v2/
calculate_leaderboard_score.py), re-implemented here from their definitions:

    score = success · (1 − (1/5) Σ_c tanh(π · w_c · value_c / norm_c))

over the five criteria with a weight (w = 1 each; max torque and integrated torque have w = 0):

- swing-up time (norm 20 s): the first sample from which the end point stays above
  0.9 (l1 + l2) (DFKI's scan runs from the second-to-last sample back to the second, stopping at
  the first sample below; success = that time < the last sample's time); infinite, so no
  success, for a record that ends before 0.99 of the episode's t_final (10 s);
- energy (norm 60 J): Σ_k |Δq_i,k · u_i,k| over both joints (u of the sample before the step);
- torque cost (norm 20): Σ_k u_kᵀ u_k Δt_k;
- torque smoothness (norm 0.1): std(Δu_1) + std(Δu_2) (numpy's population std);
- velocity cost (norm 400): Σ_k q̇_kᵀ q̇_k Δt_k.

States in DFKI's coordinates (q1 from hanging, q2 relative, counterclockwise), U with both
joints' torques (0 for the passive one), one row per sample (the leaderboard samples every 2 ms).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

WEIGHTS = {"swingup_time": 1.0, "energy": 1.0, "tau_cost": 1.0, "tau_smoothness": 1.0, "velocity_cost": 1.0}
NORMALIZE = {
    "swingup_time": 20.0,
    "energy": 60.0,
    "tau_cost": 20.0,
    "tau_smoothness": 0.1,
    "velocity_cost": 400.0,
}
HEIGHT = 0.9
T_FINAL = 10.0  # s: the leaderboard's episode; a shorter record has not stayed up for it


@dataclass(frozen=True)
class Score:
    """The criteria and the v2 score of one run."""

    success: bool
    swingup_time: float
    energy: float
    tau_cost: float
    tau_smoothness: float
    velocity_cost: float
    max_tau: float
    score: float


def swingup_time(
    t: np.ndarray, x: np.ndarray, l1: float, l2: float, height: float = HEIGHT, t_final: float = T_FINAL
) -> float:
    """The time from which the end point stays above height·(l1 + l2) (DFKI's scan; t[-1] if never;
    inf when the record ends before 0.99 `t_final`, as DFKI's get_swingup_time)."""
    if t[-1] < 0.99 * t_final:
        return math.inf
    q1, q2 = x[:, 0], x[:, 1]
    y = -l1 * np.cos(q1) - l2 * np.cos(q1 + q2)
    up = y > height * (l1 + l2)
    index = len(t) - 1
    for i in range(len(up) - 2, 0, -1):
        if up[i]:
            index = i
        else:
            break
    return float(t[index])


def score(
    t: np.ndarray, x: np.ndarray, u: np.ndarray, l1: float, l2: float, t_final: float = T_FINAL
) -> Score:
    """The v2 score of samples t (N), x (N × 4: q1, q2, q̇1, q̇2) and u (N × 2) of an episode of
    `t_final` seconds (the leaderboard's 10 s; a record shorter than 0.99 of it scores 0)."""
    t, x, u = (np.asarray(a, dtype=float) for a in (t, x, u))
    dt = np.diff(t)
    values = {
        "swingup_time": swingup_time(t, x, l1, l2, t_final=t_final),
        "energy": float(
            np.sum(np.abs(np.diff(x[:, 0]) * u[:-1, 0])) + np.sum(np.abs(np.diff(x[:, 1]) * u[:-1, 1]))
        ),
        "tau_cost": float(np.sum(np.sum(u[:-1] ** 2, axis=1) * dt)),
        "tau_smoothness": float(np.std(np.diff(u[:, 0])) + np.std(np.diff(u[:, 1]))),
        "velocity_cost": float(np.sum(np.sum(x[:-1, 2:] ** 2, axis=1) * dt)),
    }
    success = values["swingup_time"] < t[-1]
    penalty = sum(math.tanh(math.pi * WEIGHTS[c] * values[c] / NORMALIZE[c]) for c in WEIGHTS) / len(WEIGHTS)
    return Score(
        success=bool(success),
        max_tau=float(np.max(np.abs(u))),
        score=float(success) * (1.0 - penalty),
        **values,
    )


__all__ = ["NORMALIZE", "T_FINAL", "WEIGHTS", "Score", "score", "swingup_time"]
