"""What a rig's sensors give at a sample: quantised, noisy angles (the shared spec of issue 32).

    Δ = 2π / resolution (an angle) or 1 / resolution (a cart's position, m),
    y_k = z + Δ · floor((θ(t_k) − z) / Δ + 1/2) + n_k,   n_k ~ N(0, σ²)   (z: where the encoder reads 0)

(quantised first, then the noise; exact when resolution = 0, noiseless when σ = 0). `Sensors`
holds the [sensors] settings with their values per measured coordinate; its quantiser is
cpp/include/ipgen_loop.h's ipgen_loop_quantise, called through ctypes (`ipgen.common.loop_runtime`).
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

from ipgen.common.loop_runtime import library
from ipgen.estimation.pendulum import EstimationError

if TYPE_CHECKING:
    import numpy as np

# Noise σ and covariance entries are squared and multiplied; only their ratios matter, so values
# beyond this are unit slips that would overflow a double.
LARGEST = 1e100


def resolution_problem(counts: float) -> str | None:
    """Why an encoder resolution >= 0 cannot be used, or None: 0 (exact) or at least one count
    (the rule of `Sensors.of` and of a scene's [sensors])."""
    return "must be 0 (exact) or >= 1 count per revolution or metre" if 0 < counts < 1 else None


def noise_problem(sigma: float) -> str | None:
    """Why a noise σ (or a covariance entry's size) >= 0 cannot be used, or None."""
    if sigma > LARGEST:
        return f"must be <= {LARGEST:g} (only ratios of noises matter: scale them down)"
    return None


def cutoff_problem(cutoff: float, period: float) -> str | None:
    """Why a derivative filter's cutoff ωc [rad/s] > 0 cannot be used at sampling period
    `period` [s], or None: at most the Nyquist frequency π / period (a filter with ωc above the
    frequencies the samples carry is no filter, and ωc = 1e300 overflows its rates)."""
    nyquist = math.pi / period
    if not cutoff <= nyquist:
        return f"must be <= π / period = {nyquist:.6g} rad/s (the Nyquist frequency of the sampling)"
    return None


def per_coordinate(name: str, value: float | Sequence[float], count: int) -> tuple[float, ...]:
    """`value` as one finite number >= 0 per measured coordinate (a scalar is repeated)."""
    values = [value] * count if isinstance(value, int | float) else list(value)
    if len(values) != count:
        raise EstimationError(
            f"{name}: {len(values)} entries, expected 1 or {count} (one per measured coordinate)"
        )
    result = []
    for i, v in enumerate(values):
        try:
            number = float(v)
        except (TypeError, ValueError):
            raise EstimationError(f"{name}[{i}] = {v!r}: expected a number") from None
        if not math.isfinite(number) or number < 0:
            raise EstimationError(f"{name}[{i}] = {v!r}: expected a finite number >= 0")
        problem = resolution_problem(number) if name == "resolution" else noise_problem(number)
        if problem:
            raise EstimationError(f"{name}[{i}] = {v!r}: {problem}")
        result.append(number)
    return tuple(result)


def grid_zero(zero: float, step: float) -> float:
    """The encoder's zero pose as the quantiser uses it: 0 when `zero` is a whole number of counts
    `step` from 0 (the same grid as counting from 0, so the same numbers as before the [sensors]
    zero key), else `zero` (exact encoders, `step` 0: 0)."""
    if step <= 0:
        return 0.0
    counts = zero / step
    return 0.0 if abs(counts - round(counts)) <= 1e-9 * max(1.0, abs(counts)) else zero


@dataclass(frozen=True)
class Sensors:
    """The measured coordinates (indices of θ, 0 = base) and, per measured coordinate, the
    encoder resolution (counts per revolution or per metre; 0 = exact) and the noise σ."""

    measured: tuple[int, ...]
    resolution: tuple[float, ...]
    noise: tuple[float, ...]
    cart: bool = False  # coordinate 0 is a cart's position [m] (its Δ = 1 / resolution)
    zero: tuple[float, ...] = ()  # where each encoder reads 0 ([sensors] zero; empty: 0)

    @classmethod
    def of(
        cls,
        dof: int,
        measured: Sequence[int] | None = None,
        resolution: float | Sequence[float] = 0.0,
        noise: float | Sequence[float] = 0.0,
        *,
        cart: bool = False,
        zero: Sequence[float] = (),
    ) -> Sensors:
        """Checked settings for a system of `dof` coordinates (default: all measured); `zero`: the
        pose where each measured coordinate's encoder reads 0 (default 0)."""
        indices = tuple(range(dof)) if measured is None else tuple(measured)
        if not indices:
            raise EstimationError("measured: at least one coordinate must be measured")
        for i in indices:
            if isinstance(i, bool) or not isinstance(i, numbers.Integral) or not 0 <= i < dof:
                raise EstimationError(f"measured: {i!r} is not a coordinate index 0..{dof - 1}")
        indices = tuple(int(i) for i in indices)  # numpy's integers too
        if len(set(indices)) != len(indices) or list(indices) != sorted(indices):
            raise EstimationError(f"measured: {list(indices)} must be increasing without repeats")
        count = len(indices)
        poses = tuple(float(v) for v in zero)
        if poses and (len(poses) != count or not all(math.isfinite(v) for v in poses)):
            raise EstimationError(f"zero: expected {count} finite numbers, one per measured coordinate")
        return cls(
            measured=indices,
            resolution=per_coordinate("resolution", resolution, count),
            noise=per_coordinate("noise", noise, count),
            cart=cart,
            zero=poses,
        )

    def steps(self) -> tuple[float, ...]:
        """Δ per measured coordinate (0 for an exact one)."""
        result = []
        for index, counts in zip(self.measured, self.resolution, strict=True):
            if counts == 0:
                result.append(0.0)
            elif self.cart and index == 0:
                result.append(1.0 / counts)
            else:
                result.append(2.0 * math.pi / counts)
        return tuple(result)

    def quantise(self, theta: np.ndarray) -> np.ndarray:
        """z + Δ · floor((θ − z) / Δ + 1/2) of the measured coordinates of θ (dof angles), z the
        pose where the encoder reads 0 (`zero`, default 0): whole counts from it."""
        import numpy as np

        quantise = library().ipgen_loop_quantise  # ipgen_loop.h's quantiser (Δ = 0: θ itself)
        values = np.asarray(theta, dtype=float)[list(self.measured)]
        steps = self.steps()
        zeros = [grid_zero(z, step) for z, step in zip(self.zero, steps, strict=True)] if self.zero else None
        return np.array(
            [quantise(float(values[j]), zeros[j] if zeros else 0.0, step) for j, step in enumerate(steps)]
        )

    def sample(self, theta: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """y_k: quantised, then one Gaussian draw per measured coordinate (drawn even when σ = 0,
        so that the stream does not depend on which σ are zero)."""
        draws = rng.standard_normal(len(self.measured))
        return self.quantise(theta) + draws * self.noise
