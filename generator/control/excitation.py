"""How far an excitation moves a rig, predicted by the linear model about an equilibrium.

`response(a, b, u, t)` simulates ẋ = A x + B u(t) from rest at the equilibrium (scipy's `lsim`:
exact for an input linear between the grid's points, the grid fine against the signal's highest
frequency); `steady_peaks(a, b, lines, scale)` gives the periodic steady state of a multisine
from the frequency response G(jω) = (jωI − A)⁻¹ B at each line; `scale_to_limits` picks the
largest amplitude whose predicted excursions stay inside the limits with a margin.

The model is linear in u, so every excursion is proportional to the amplitude: the prediction is
made once for amplitude 1 and scaled.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ipgen.control.signals import Multisine

# Grid points per period of the highest frequency for the time-domain prediction, and the most
# points allowed (2 million points of a 6-state model take a few seconds).
POINTS_PER_PERIOD = 40
MAX_POINTS = 2_000_000


def response(a: np.ndarray, b: np.ndarray, u: np.ndarray, t: np.ndarray) -> np.ndarray:
    """The states x(t) (len(t) × n) of ẋ = A x + B u from x(0) = 0, u given on the grid t."""
    from scipy.signal import lsim

    n = a.shape[0]
    _, _, x = lsim((a, b, np.eye(n), np.zeros((n, 1))), u, t, X0=np.zeros(n), interp=True)
    return np.atleast_2d(x).reshape(len(t), n)


def frequency_response(a: np.ndarray, b: np.ndarray, frequencies: np.ndarray) -> np.ndarray:
    """G(j 2π f) = (j 2π f I − A)⁻¹ B for each f [Hz]: a len(f) × n complex array."""
    n = a.shape[0]
    out = np.empty((len(frequencies), n), dtype=complex)
    for i, f in enumerate(frequencies):
        out[i] = np.linalg.solve(1j * 2.0 * math.pi * f * np.eye(n) - a, b[:, 0])
    return out


def steady_peaks(a: np.ndarray, b: np.ndarray, lines: Multisine) -> np.ndarray:
    """max over a period of |x_i| in the periodic steady state of the unit-amplitude multisine,
    for each state i: Σ_j s |G_i(f_j)| cos(2π f_j t + φ_j + ∠G_i(f_j)) on a grid of 64 points
    per period of the highest line."""
    f = np.asarray(lines.frequencies)
    g = frequency_response(a, b, f)  # lines × n
    count = int(min(MAX_POINTS // max(1, len(f)), max(1024, 64 * round(f[-1] * lines.period))))
    t = np.linspace(0.0, lines.period, count, endpoint=False)
    peaks = np.zeros(a.shape[0])
    for start in range(0, count, 4096):
        tt = t[start : start + 4096]
        phase = 2.0 * math.pi * np.outer(tt, f) + np.asarray(lines.phases)  # points × lines
        wave = np.exp(1j * phase) @ g  # points × n, complex; the real part is the response
        peaks = np.maximum(peaks, np.max(np.abs(wave.real), axis=0) * lines.scale)
    return peaks


def grid(t_end: float, f_max: float) -> np.ndarray:
    """The time grid of the prediction: POINTS_PER_PERIOD per period of f_max (at least 2001
    points); ValueError when that is more than MAX_POINTS (the prediction would take minutes)."""
    count = max(2001, math.ceil(t_end * f_max * POINTS_PER_PERIOD) + 1)
    if count > MAX_POINTS:
        raise ValueError(
            f"{t_end:g} s up to {f_max:g} Hz needs {count} prediction points, more than {MAX_POINTS}: "
            "shorten the run or lower f_max"
        )
    return np.linspace(0.0, t_end, count)


@dataclass(frozen=True)
class Limits:
    """What an excitation must respect: |u| <= u_max, |θ0| <= travel, |θi − θi_eq| <= swing,
    each predicted excursion at most (1 − margin) of its limit."""

    u_max: float
    travel: float
    swing: float
    margin: float


@dataclass(frozen=True)
class Scaling:
    """The amplitude chosen and the excursions predicted at it."""

    amplitude: float
    limited_by: str  # "u_max", "travel" or "swing"
    base: float  # predicted max |θ0 − θ0(0)| [m or rad]
    swing: float  # predicted max |θi − θi_eq| over the links [rad]


def scale_to_limits(base_per_unit: float, swing_per_unit: float, offset: float, limits: Limits) -> Scaling:
    """The largest amplitude (3 significant digits, rounded down) with |θ0(0)| + base <= (1 −
    margin) travel and swing <= (1 − margin) swing limit, at most u_max. `offset` is |θ0(0)|."""
    keep = 1.0 - limits.margin
    room = keep * limits.travel - abs(offset)
    if room <= 0.0:
        raise ValueError(
            f"the base starts at |θ0| = {abs(offset):g}, outside (1 − margin) · travel = "
            f"{keep * limits.travel:g}: start it nearer the centre or widen the travel"
        )
    candidates = [("u_max", limits.u_max)]
    if base_per_unit > 0.0:
        candidates.append(("travel", room / base_per_unit))
    if swing_per_unit > 0.0:
        candidates.append(("swing", keep * limits.swing / swing_per_unit))
    limited_by, amplitude = min(candidates, key=lambda item: item[1])
    amplitude = _round_down(amplitude)
    return Scaling(amplitude, limited_by, amplitude * base_per_unit, amplitude * swing_per_unit)


def _round_down(x: float, digits: int = 3) -> float:
    """x rounded down to `digits` significant digits (a decimal that reads well in a scene)."""
    if x <= 0.0 or not math.isfinite(x):
        return x
    exponent = math.floor(math.log10(x)) - digits + 1
    step = 10.0**exponent
    value = math.floor(x / step * (1 + 1e-12)) * step
    return float(f"{value:.{digits}g}")
