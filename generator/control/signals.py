"""Excitation signals for experiments on a rig: a chirp (swept sine) and a multisine.

Both are defined here once; the scene reader (`experiment.scene.InputSpec`) evaluates them for
Python, and it writes a multisine's lines (frequencies, phases, scale) into the resolved config
so that the C++ simulator sums exactly the same cosines (cpp/include/ipsim/input.hpp).

Chirp, τ = t − start, D = duration, on for 0 <= τ < D (u = 0 outside):

    u = A sin(φ(τ)),  linear sweep:      f(τ) = f0 + (f1 − f0) τ / D,
                                         φ(τ) = 2π (f0 τ + (f1 − f0) τ² / (2 D));
                      logarithmic sweep: f(τ) = f0 k^(τ/D), k = f1 / f0 (f0 > 0),
                                         φ(τ) = 2π f0 D (k^(τ/D) − 1) / ln k.

f(τ) = φ'(τ) / 2π is the instantaneous frequency; u starts at 0 (φ(0) = 0), so it is continuous
at `start` and jumps only at the end.

Multisine with period T in the band [f_min, f_max]: the lines are every harmonic f_k = k / T in
the band (k = k_lo..k_hi, N of them), equal amplitudes, Schroeder's phases (M. R. Schroeder,
"Synthesis of low-peak-factor signals and binary sequences with low autocorrelation", 1970)
φ_j = −π j (j − 1) / N (j = 1..N), which keep the crest factor low for a flat spectrum:

    u = A · s · Σ_j cos(2π f_j t + φ_j),   s = 1 / max_t |Σ_j cos(2π f_j t + φ_j)|,

so that max |u| = A exactly (the peak is found on an FFT grid over one period and refined by
Newton's method on the derivative); u is periodic with period T and smooth.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

SWEEPS: tuple[str, ...] = ("linear", "logarithmic")
# The most lines a multisine may have (every RHS evaluation sums them) and the highest harmonic
# f_max · period (the FFT grid of the peak search grows with it).
MAX_LINES = 1000
MAX_HARMONIC = 100_000


@dataclass(frozen=True)
class Multisine:
    """The lines of a multisine: u(t) = amplitude · scale · Σ cos(2π f_j t + φ_j)."""

    frequencies: tuple[float, ...]  # Hz
    phases: tuple[float, ...]  # rad
    scale: float  # 1 / peak of the unit-amplitude sum
    period: float  # s

    @property
    def crest_factor(self) -> float:
        """Peak over RMS of the signal: 1 / (scale · sqrt(N / 2))."""
        return 1.0 / (self.scale * math.sqrt(len(self.frequencies) / 2.0))


def harmonics(f_min: float, f_max: float, period: float) -> tuple[int, int]:
    """(k_lo, k_hi): the harmonics k / period in [f_min, f_max] (k >= 1); empty when k_lo > k_hi.
    Beyond MAX_HARMONIC (or an infinite product) k_hi is MAX_HARMONIC + 1, which callers refuse."""
    top, bottom = f_max * period, f_min * period
    if not top <= MAX_HARMONIC + 1:  # beyond the limit, inf or nan
        return 1, MAX_HARMONIC + 1
    k_lo = max(1, math.ceil(bottom - 1e-9))
    k_hi = math.floor(top + 1e-9)
    return k_lo, k_hi


def schroeder_phases(count: int) -> np.ndarray:
    """Schroeder's phases φ_j = −π j (j − 1) / N for N = count equal lines, j = 1..N [rad],
    each reduced to [−π, π] (the same cosines; smaller arguments keep the sums accurate)."""
    return np.array(
        [math.remainder(-math.pi * j * (j - 1) / count, 2.0 * math.pi) for j in range(1, count + 1)]
    )


def multisine(f_min: float, f_max: float, period: float) -> Multisine:
    """The multisine of every harmonic of 1/period in [f_min, f_max] with Schroeder's phases,
    scaled to a peak of exactly 1. Raises ValueError when the band holds no harmonic, or more
    than MAX_LINES, or reaches beyond MAX_HARMONIC."""
    k_lo, k_hi = harmonics(f_min, f_max, period)
    if k_hi > MAX_HARMONIC:
        raise ValueError(
            f"f_max · period = {f_max * period:g}, more than {MAX_HARMONIC} harmonics: shorten the period"
        )
    count = k_hi - k_lo + 1
    if count < 1:
        raise ValueError(
            f"no harmonic of 1/period = {1 / period:g} Hz lies in [{f_min:g}, {f_max:g}] Hz: "
            "widen the band or lengthen the period"
        )
    if count > MAX_LINES:
        raise ValueError(f"{count} lines, more than {MAX_LINES}: narrow the band or shorten the period")
    ks = np.arange(k_lo, k_hi + 1)
    phases = schroeder_phases(count)
    peak = _peak(ks, phases, period)
    frequencies = tuple(float(k) / period for k in ks)
    return Multisine(frequencies, tuple(float(p) for p in phases), 1.0 / peak, period)


def _peak(ks: np.ndarray, phases: np.ndarray, period: float) -> float:
    """max over one period of |Σ cos(2π k t / T + φ)|: an FFT grid, then Newton on the
    derivative from every grid point that can be near the maximum."""
    size = 1 << max(12, math.ceil(math.log2(32 * int(ks[-1]) + 2)))
    spectrum = np.zeros(size // 2 + 1, dtype=complex)
    spectrum[ks] = np.exp(1j * phases) * (size / 2.0)  # irfft: Σ cos(2π k n / size + φ)
    grid = np.fft.irfft(spectrum, size)
    h = period / size
    omega = 2.0 * math.pi * ks / period
    # Near a maximum p'' is bounded by Σ ω²: any grid point within that of the grid's best may
    # sit next to the true peak.
    slack = 0.5 * float(np.sum(omega**2)) * h * h
    best = float(np.max(np.abs(grid)))
    near = np.flatnonzero(np.abs(grid) >= best - slack)
    candidates = near[np.argsort(-np.abs(grid[near]))[:256]]  # the highest first
    peak = best
    for index in candidates:
        t = index * h
        for _ in range(20):
            arg = omega * t + phases
            d1 = -float(np.sum(omega * np.sin(arg)))
            d2 = -float(np.sum(omega**2 * np.cos(arg)))
            if d2 == 0.0:
                break
            step = -d1 / d2
            step = max(-h, min(h, step))
            t += step
            if abs(step) < 1e-15 * period:
                break
        value = abs(float(np.sum(np.cos(omega * t + phases))))
        if abs(t - index * h) <= 2 * h:
            peak = max(peak, value)
    return peak


def multisine_value(t: float, amplitude: float, lines: Multisine) -> float:
    """u(t) of a multisine (for every t: it is periodic)."""
    total = 0.0
    for f, phase in zip(lines.frequencies, lines.phases, strict=True):
        total += math.cos(2.0 * math.pi * f * t + phase)
    return amplitude * lines.scale * total


def chirp_phase(tau: float, f0: float, f1: float, duration: float, sweep: str) -> float:
    """φ(τ) [rad] of the chirp (the module's formula), 0 <= τ <= duration."""
    if sweep == "logarithmic":
        k = f1 / f0
        return 2.0 * math.pi * f0 * duration * math.expm1(math.log(k) * tau / duration) / math.log(k)
    return 2.0 * math.pi * (f0 * tau + (f1 - f0) * tau * tau / (2.0 * duration))


def chirp_value(
    t: float, amplitude: float, f0: float, f1: float, duration: float, start: float, sweep: str
) -> float:
    """u(t) of a chirp: on for start <= t < start + duration, 0 elsewhere."""
    tau = t - start
    if not 0.0 <= tau < duration:
        return 0.0
    return amplitude * math.sin(chirp_phase(tau, f0, f1, duration, sweep))


def multisine_values(t: np.ndarray, amplitude: float, lines: Multisine) -> np.ndarray:
    """`multisine_value` on an array of times (vectorised, in chunks of a few million cosines)."""
    t = np.asarray(t, dtype=float)
    f = np.asarray(lines.frequencies)
    phases = np.asarray(lines.phases)
    out = np.empty_like(t)
    chunk = max(1, 4_000_000 // len(f))
    for start in range(0, len(t), chunk):
        tt = t[start : start + chunk]
        out[start : start + chunk] = np.cos(2.0 * math.pi * np.outer(tt, f) + phases).sum(axis=1)
    return amplitude * lines.scale * out


def chirp_values(
    t: np.ndarray, amplitude: float, f0: float, f1: float, duration: float, start: float, sweep: str
) -> np.ndarray:
    """`chirp_value` on an array of times (vectorised)."""
    tau = np.asarray(t, dtype=float) - start
    on = (tau >= 0.0) & (tau < duration)
    tau = np.where(on, tau, 0.0)
    if sweep == "logarithmic":
        k = math.log(f1 / f0)
        phi = 2.0 * math.pi * f0 * duration * np.expm1(k * tau / duration) / k
    else:
        phi = 2.0 * math.pi * (f0 * tau + (f1 - f0) * tau * tau / (2.0 * duration))
    return np.where(on, amplitude * np.sin(phi), 0.0)
