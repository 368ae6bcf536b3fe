"""The default noise covariances of the Kalman filters (the shared spec of issue 32).

Measurement: each measured coordinate's error is its encoder's rounding, uniform on ±Δ/2
(variance Δ²/12), plus the additive noise σ²:

    Rn = diag(σ_i² + Δ_i²/12),  each at least RN_FLOOR = (1e-6)² (Rn > 0 with exact sensors).

Process: the input the model sees is uncertain by the drive's noise σ_u and by a fraction
INPUT_FRACTION of its scale (unmodelled drive gain, friction, cogging), and the rates take a
random walk of intensity q_rate (unmodelled accelerations):

    Qn = B_d B_dᵀ · (σ_u² + (INPUT_FRACTION · u_scale)²) + T · diag(0 for angles, q_rate for rates).

Choices (issue 32 left them to the estimator): u_scale is the controller's input limit (its
saturation) when there is one, else 1 unit of input (1 N, 1 N m or 1 V); q_rate = Q_RATE =
1 (unit/s)²/s per rate. docs/estimation.md shows that these make the QUBE-Servo 2 preset balance
with 2048-count encoders at 1 kHz and 500 Hz (bench/estimation.py).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

from ipgen.estimation.measurement import Sensors
from ipgen.estimation.pendulum import EstimationError

if TYPE_CHECKING:
    import numpy as np

RN_FLOOR = 1e-12  # (1e-6)²: rad² or m²
INPUT_FRACTION = 0.01  # σ of the input's model error, as a fraction of u_scale
Q_RATE = 1.0  # (rad/s)²/s or (m/s)²/s: the rates' random walk
# [estimator] noise_memory (ipgen_loop_ekf's learnt noise): the filter uses NOISE_MARGIN times the
# learnt variance (quantization is not white: coarse encoders need the filter slower than their
# variance says; 4 lost the QUBE's 256 counts, 10 kept them) and at most NOISE_CEILING times Rn.
NOISE_MARGIN = 10.0
NOISE_CEILING = 10.0


def measurement_covariance(sensors: Sensors) -> np.ndarray:
    """Rn (len(measured) square, diagonal) of `sensors`."""
    import numpy as np

    values = [
        max(sigma**2 + step**2 / 12.0, RN_FLOOR)
        for sigma, step in zip(sensors.noise, sensors.steps(), strict=True)
    ]
    return np.diag(values)


def process_covariance(
    b_d: np.ndarray,
    period: float,
    *,
    input_noise: float = 0.0,
    u_scale: float = 1.0,
    q_rate: float | Sequence[float] = Q_RATE,
) -> np.ndarray:
    """Qn (2·dof square) from the discrete input matrix B_d (2·dof × 1) and the period T."""
    import numpy as np

    b = np.asarray(b_d, dtype=float).reshape(-1, 1)
    size = b.shape[0]
    dof = size // 2
    for name, value in (("input_noise", input_noise), ("u_scale", u_scale), ("period", period)):
        if not (np.isfinite(value) and value >= 0):
            raise EstimationError(f"{name} = {value!r}: expected a finite number >= 0")
    rates = np.broadcast_to(np.asarray(q_rate, dtype=float), (dof,))
    if not np.all(np.isfinite(rates)) or np.any(rates < 0):
        raise EstimationError(f"q_rate = {q_rate!r}: expected finite numbers >= 0")
    variance = float(np.float64(input_noise) ** 2 + np.float64(INPUT_FRACTION * u_scale) ** 2)
    if not np.isfinite(variance):
        cause = f"input_noise = {input_noise:.3g}" if input_noise > u_scale else f"u_scale = {u_scale:.3g}"
        raise EstimationError(f"{cause}: the input's variance overflows; give the input a realistic size")
    q = (b @ b.T) * variance
    q[dof:, dof:] += period * np.diag(rates)
    return 0.5 * (q + q.T)
