"""How far an excitation moves a rig, predicted by the linear model about an equilibrium.

`response(a, b, u, t)` simulates ẋ = A x + B u(t) from rest at the equilibrium (scipy's `lsim`:
exact for an input linear between the grid's points, the grid fine against the signal's highest
frequency); `steady_peaks(a, b, lines, scale)` gives the periodic steady state of a multisine
from the frequency response G(jω) = (jωI − A)⁻¹ B at each line; `scale_to_limits` picks the
largest amplitude whose predicted excursions stay inside the limits with a margin.

The model is linear in u, so every excursion is proportional to the amplitude: the prediction is
made once for amplitude 1 and scaled.

`design(rig, u_max=..., ...)` is the experiment `ipgen excite` proposes: from a rig's model
(its parameters and actuator) and its limits — the largest |u| the drive may get and the base's
travel — an excitation about the hanging equilibrium: a multisine (default) or a chirp in a
frequency band, its amplitude the largest whose predicted motion keeps the base within
(1 − margin) of its travel and the links within (1 − margin) of `swing` of hanging, never above
u_max. The prediction is the linear model about hanging (with the rig's actuator) over the
whole experiment from rest, and for a multisine also its periodic steady state; the larger
counts. Coulomb friction is left out (it only slows the base). docs/excitation.md is the guide.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from decimal import ROUND_FLOOR, Decimal
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ipgen.common.safetext import abbreviate
from ipgen.errors import Error

if TYPE_CHECKING:
    import numpy as np

    from ipgen.control.signals import Multisine

# Grid points per period of the highest frequency for the time-domain prediction, and the most
# points allowed (2 million points of a 6-state model take a few seconds).
POINTS_PER_PERIOD = 40
MAX_POINTS = 2_000_000


def response(
    a: np.ndarray, b: np.ndarray, u: np.ndarray, t: np.ndarray, x0: np.ndarray | None = None
) -> np.ndarray:
    """The states x(t) (len(t) × n) of ẋ = A x + B u from x(0) = x0 (default 0), u given on the
    grid t."""
    import numpy as np
    from scipy.signal import lsim

    n = a.shape[0]
    start = np.zeros(n) if x0 is None else x0
    _, _, x = lsim((a, b, np.eye(n), np.zeros((n, 1))), u, t, X0=start, interp=True)
    return np.atleast_2d(x).reshape(len(t), n)


def frequency_response(a: np.ndarray, b: np.ndarray, frequencies: np.ndarray) -> np.ndarray:
    """G(j 2π f) = (j 2π f I − A)⁻¹ B for each f [Hz]: a len(f) × n complex array."""
    import numpy as np

    n = a.shape[0]
    out = np.empty((len(frequencies), n), dtype=complex)
    for i, f in enumerate(frequencies):
        out[i] = np.linalg.solve(1j * 2.0 * math.pi * f * np.eye(n) - a, b[:, 0])
    return out


def steady_peaks(a: np.ndarray, b: np.ndarray, lines: Multisine) -> np.ndarray:
    """max over a period of |x_i| in the periodic steady state of the unit-amplitude multisine,
    for each state i: Σ_j s |G_i(f_j)| cos(2π f_j t + φ_j + ∠G_i(f_j)) on a grid of 64 points
    per period of the highest line."""
    import numpy as np

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
    import numpy as np

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
    # Floor the shortest decimal that reads back as x (repr): 0.35 stays 0.35, and the result is
    # never above x (1.9999999999999996 gives 1.99, not 2.0, which would pass u_max).
    exact = Decimal(repr(x))
    step = Decimal(1).scaleb(exact.adjusted() - digits + 1)
    return float(exact.quantize(step, rounding=ROUND_FLOOR))


# ---------------------------------------------------------------------------- the design

FREE_DECAY = "free-decay"  # no input: link 1 released from an angle off hanging, at rest
SIGNALS: tuple[str, ...] = ("multisine", "chirp", FREE_DECAY)
DEFAULT_MARGIN = 0.3
DEFAULT_SWING = 0.5  # rad: the links' largest predicted swing about hanging
DEFAULT_PERIODS = 4
DEFAULT_CHIRP_DURATION = 40.0  # s


class ExcitationError(Error):
    """The excitation cannot be designed or written; the message says why and what to change."""


@dataclass(frozen=True)
class Design:
    """An excitation and what the linear model predicts it does."""

    signal: str  # multisine | chirp | free-decay
    amplitude: float  # peak |u| [N, N m or V]; free-decay: link 1's release angle from hanging [rad]
    limited_by: str  # u_max | travel | swing
    f_min: float  # the band [Hz] (a chirp's f0, f1)
    f_max: float
    period: float | None  # multisine
    lines: int  # multisine: number of lines; chirp: 0
    crest_factor: float  # peak / RMS of u
    duration: float  # the run's t_end [s]
    sample: float  # [s]
    sweep: str | None  # chirp
    base: float  # predicted max |θ0 − θ0(0)| at the amplitude [m or rad]
    swing: float  # predicted max |θi − π| [rad]
    u_max: float
    travel: float
    swing_limit: float
    margin: float
    gain_band: tuple[float, float]  # min and max |θ0/u| over the band (frequency response)
    natural: tuple[float, ...] = ()  # the hanging model's natural frequencies [Hz]
    u_unit: str = "N"  # N, N m or V (a dc_motor)
    base_unit: str = "m"  # m (cart) or rad (arm)
    written: Path | None = None  # the experiment scene, when one was written

    def report(self) -> str:
        """A paragraph: the signal, the amplitude and why, and the predicted excursions."""
        unit = self._units
        band = f"{self.f_min:g}–{self.f_max:g} Hz"
        what = (
            f"multisine, {self.lines} lines in {band} (period {self.period:g} s, Schroeder phases, "
            f"crest factor {self.crest_factor:.3g})"
            if self.signal == "multisine"
            else f"{self.sweep} chirp {band} over {self.duration:g} s"
        )
        reason = {
            "u_max": f"the drive's limit u_max = {self.u_max:g} {unit[0]}",
            "travel": f"the travel: (1 − {self.margin:g}) × {self.travel:g} {unit[1]}",
            "swing": f"the links' swing: (1 − {self.margin:g}) × {self.swing_limit:g} rad",
        }[self.limited_by]
        natural = ", ".join(f"{f:.3g}" for f in self.natural) or "none"
        if self.signal == FREE_DECAY:
            return (
                f"free decay: no input, link 1 released {self.amplitude:g} rad from hanging at rest, "
                f"limited by {reason}. Predicted by the linear model about hanging: base within "
                f"±{self.base:.3g} {unit[1]} (travel {self.travel:g}); the hanging pendulum's natural "
                f"frequencies {natural} Hz. Run length {self.duration:g} s, sampled every {self.sample:g} s."
            )
        return (
            f"{what}; amplitude {self.amplitude:g} {unit[0]}, limited by {reason}. Predicted by the linear "
            f"model about hanging: base within ±{self.base:.3g} {unit[1]} (travel {self.travel:g}), links "
            f"within ±{self.swing:.3g} rad of hanging; |θ0/u| from {self.gain_band[0]:.3g} to "
            f"{self.gain_band[1]:.3g} {unit[1]}/{unit[0]} over the band; the hanging pendulum's natural "
            f"frequencies {natural} Hz. Run length {self.duration:g} s, sampled every {self.sample:g} s."
        )

    @property
    def _units(self) -> tuple[str, str]:
        return self.u_unit, self.base_unit


def design(
    rig: Any,
    *,
    u_max: float | None = None,
    travel: float | None = None,
    signal: str = "multisine",
    f_min: float | None = None,
    f_max: float | None = None,
    period: float | None = None,
    periods: int = DEFAULT_PERIODS,
    duration: float | None = None,
    sweep: str = "logarithmic",
    margin: float = DEFAULT_MARGIN,
    swing: float = DEFAULT_SWING,
    sample: float | None = None,
) -> Design:
    """The excitation for `rig` (a `Scene`: its type, links, parameters, actuator, [initial]
    state, [limits] travel and sample) as `ipgen.excitation` documents it; raises
    `ExcitationError` with a one-line message. A free decay needs no `u_max` (it applies none)."""
    if signal not in SIGNALS:
        raise ExcitationError(f"signal {abbreviate(str(signal))!r}: expected one of {', '.join(SIGNALS)}")
    if u_max is None and signal != FREE_DECAY:
        raise ExcitationError(f"a {signal} needs u_max, the largest |u| the drive may get (--u-max)")
    travel = _check_limits(rig, math.inf if u_max is None else u_max, travel, margin, swing)
    a, b = _hanging_model(rig)
    natural = _natural_frequencies(a, rig.links)
    if signal == FREE_DECAY:
        f_lo, f_hi = 0.0, natural[-1] if natural else 1.0  # f_hi: the grid's and the sample's
    else:
        f_lo, f_hi = _band(f_min, f_max, natural, signal, sweep)
    if signal == "multisine":
        period = period if period is not None else max(10.0, float(math.ceil(2.0 / f_lo)))
        _positive("period", period, "s")
        if not (isinstance(periods, int) and 1 <= periods <= 1000):
            raise ExcitationError(f"periods = {periods!r}: expected a whole number from 1 to 1000")
        t_end = periods * period
    else:  # a chirp or a free decay: a duration
        duration = DEFAULT_CHIRP_DURATION if duration is None else duration
        _positive("duration", duration, "s")
        if signal == "chirp" and sweep not in ("linear", "logarithmic"):
            raise ExcitationError(f"sweep {abbreviate(str(sweep))!r}: expected linear or logarithmic")
        t_end = duration
    sample = sample if sample is not None else min(rig.sample, _nice(1.0 / (20.0 * f_hi)))
    _positive("sample", sample, "s")
    if t_end / sample > 1e7:
        raise ExcitationError(
            f"{t_end:g} s sampled every {sample:g} s is more than 1e7 samples: raise sample"
        )
    if signal == FREE_DECAY:
        predicted = _free_decay(rig, a, f_hi, t_end, travel, margin, swing)
    else:
        limit = float(u_max)  # type: ignore[arg-type]  # required above for a driven signal
        predicted = _predict(
            rig, a, b, signal, f_lo, f_hi, period, t_end, sweep, travel, limit, margin, swing
        )
    return replace(
        predicted,
        sample=sample,
        natural=natural,
        u_unit="V" if rig.actuator.is_motor else ("N" if rig.type == "classical" else "N m"),
        base_unit="m" if rig.type == "classical" else "rad",
    )


def _check_limits(rig: Any, u_max: float, travel: float | None, margin: float, swing: float) -> float:
    travel = travel if travel is not None else rig.travel
    if travel is None:
        raise ExcitationError(
            "no travel limit: pass --travel (m on a cart, rad on an arm) or give the scene [limits] travel"
        )
    if u_max != math.inf:
        _positive("u_max", u_max, "(the largest |u|)")
    _positive("travel", travel, "(m on a cart, rad on an arm)")
    _positive("swing", swing, "rad")
    if not (isinstance(margin, (int, float)) and 0.0 <= margin < 1.0):
        raise ExcitationError(f"margin = {margin!r}: expected a fraction in [0, 1), e.g. 0.3")
    return float(travel)


def _positive(name: str, value: object, unit: str) -> None:
    if (
        isinstance(value, bool)
        or not isinstance(value, (int, float))
        or not (math.isfinite(value) and value > 0)
    ):
        raise ExcitationError(f"{name} = {abbreviate(repr(value))}: expected a finite number > 0 {unit}")


def _nice(x: float) -> float:
    """x rounded down to 1, 2 or 5 times a power of ten (a sample time that reads well)."""
    exponent = math.floor(math.log10(x))
    for mantissa in (5.0, 2.0, 1.0):
        if mantissa * 10.0**exponent <= x:
            return float(f"{mantissa * 10.0**exponent:.3g}")
    return float(f"{10.0**exponent:.3g}")


def _hanging_model(rig: Any) -> tuple[np.ndarray, np.ndarray]:
    """(A, B) of the rig about hanging at rest (canonical coordinates; B per unit of u)."""
    from ipgen.control.linear import ControlError, linearize

    try:
        return linearize(rig.pendulum.canonical(), q=[0.0] + [math.pi] * rig.links)
    except ControlError as exc:
        raise ExcitationError(f"no linear model about hanging: {exc}") from None


def _natural_frequencies(a: np.ndarray, links: int) -> tuple[float, ...]:
    """The oscillatory modes' frequencies |λ| / 2π [Hz] of the hanging model, ascending."""
    import numpy as np

    eigenvalues = np.linalg.eigvals(np.asarray(a))
    modes = sorted({round(abs(ev) / (2.0 * math.pi), 9) for ev in eigenvalues if abs(ev.imag) > 1e-9})
    return tuple(float(f) for f in modes)


def _band(
    f_min: float | None, f_max: float | None, natural: tuple[float, ...], signal: str, sweep: str
) -> tuple[float, float]:
    default = (_nice(natural[0] / 5.0), float(f"{5.0 * natural[-1]:.2g}")) if natural else (0.1, 10.0)
    lo = default[0] if f_min is None else f_min
    hi = default[1] if f_max is None else f_max
    for name, value in (("f_min", lo), ("f_max", hi)):
        if (
            isinstance(value, bool)
            or not isinstance(value, (int, float))
            or not math.isfinite(value)
            or value < 0
        ):
            raise ExcitationError(f"{name} = {abbreviate(repr(value))}: expected a finite frequency >= 0 Hz")
    if not hi > lo:
        raise ExcitationError(f"f_max = {hi:g} Hz must be > f_min = {lo:g} Hz")
    if lo == 0 and (signal == "multisine" or sweep == "logarithmic"):
        raise ExcitationError(
            "f_min = 0 Hz: a multisine or a logarithmic chirp starts above 0 Hz; give f_min > 0"
        )
    return float(lo), float(hi)


def _predict(
    rig: Any,
    a: np.ndarray,
    b: np.ndarray,
    signal: str,
    f_lo: float,
    f_hi: float,
    period: float | None,
    t_end: float,
    sweep: str,
    travel: float,
    u_max: float,
    margin: float,
    swing: float,
) -> Design:
    import numpy as np

    from ipgen.control import signals

    a_, b_ = np.asarray(a), np.asarray(b)
    dof = rig.links + 1
    lines = None
    if signal == "multisine":
        assert period is not None
        try:
            lines = signals.multisine(f_lo, f_hi, period)
        except ValueError as exc:
            raise ExcitationError(f"multisine: {exc}") from None
    try:
        t = grid(t_end, f_hi)
    except ValueError as exc:
        raise ExcitationError(str(exc)) from None
    if lines is not None:
        u = signals.multisine_values(t, 1.0, lines)
    else:
        u = signals.chirp_values(t, 1.0, f_lo, f_hi, t_end, 0.0, sweep)
    x = response(a_, b_, u, t)
    base = float(np.max(np.abs(x[:, 0])))
    links_swing = float(np.max(np.abs(x[:, 1:dof]))) if dof > 1 else 0.0
    if lines is not None:
        steady = steady_peaks(a_, b_, lines)
        base = max(base, float(steady[0]))
        links_swing = max(links_swing, float(np.max(steady[1:dof])) if dof > 1 else 0.0)
    band = np.geomspace(max(f_lo, 1e-3), f_hi, 200) if f_lo > 0 else np.linspace(1e-3, f_hi, 200)
    gain = np.abs(frequency_response(a_, b_, band)[:, 0])
    try:
        scaled = scale_to_limits(
            base,
            links_swing,
            rig.theta[0],
            Limits(u_max, travel, swing, margin),
        )
    except ValueError as exc:
        raise ExcitationError(str(exc)) from None
    rms = float(np.sqrt(np.mean(u**2)))
    return Design(
        signal=signal,
        amplitude=scaled.amplitude,
        limited_by=scaled.limited_by,
        f_min=f_lo,
        f_max=f_hi,
        period=period if signal == "multisine" else None,
        lines=len(lines.frequencies) if lines is not None else 0,
        crest_factor=lines.crest_factor if lines is not None else (1.0 / rms if rms > 0 else math.inf),
        duration=t_end,
        sample=0.0,
        sweep=sweep if signal == "chirp" else None,
        base=scaled.base,
        swing=scaled.swing,
        u_max=u_max,
        travel=travel,
        swing_limit=swing,
        margin=margin,
        gain_band=(float(np.min(gain)), float(np.max(gain))),
    )


def _free_decay(
    rig: Any, a: np.ndarray, f_hi: float, t_end: float, travel: float, margin: float, swing: float
) -> Design:
    """Link 1 released from rest at the largest angle off hanging whose predicted motion (the
    linear model about hanging, no input) keeps the links within (1 − margin) of `swing` and the
    base within (1 − margin) of `travel`: what identifies the joints' damping (the decay of the
    swing) and, through the base's reaction, the base's."""
    import numpy as np

    try:
        t = grid(t_end, f_hi)
    except ValueError as exc:
        raise ExcitationError(str(exc)) from None
    dof = rig.links + 1
    released = np.zeros(2 * dof)
    released[1] = 1.0  # a unit release of link 1: the response scales with the angle
    a_ = np.asarray(a)
    x = response(a_, np.zeros((a_.shape[0], 1)), np.zeros_like(t), t, x0=released)
    try:
        scaled = scale_to_limits(
            float(np.max(np.abs(x[:, 0]))),
            float(np.max(np.abs(x[:, 1:dof]))),
            rig.theta[0],
            Limits(math.inf, travel, swing, margin),
        )
    except ValueError as exc:
        raise ExcitationError(str(exc)) from None
    return Design(
        signal=FREE_DECAY, amplitude=scaled.amplitude, limited_by=scaled.limited_by, f_min=0.0,
        f_max=0.0, period=None, lines=0, crest_factor=0.0, duration=t_end, sample=0.0, sweep=None,
        base=scaled.base, swing=scaled.swing, u_max=0.0, travel=travel, swing_limit=swing,
        margin=margin, gain_band=(0.0, 0.0),
    )  # fmt: skip
