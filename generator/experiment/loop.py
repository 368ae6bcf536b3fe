"""The measured loop of a scene ([sensors], [estimator] and the drive keys of [actuator], declared
in `scene.sensors`): `loop()` checks what spans tables and returns the `Loop` the simulator runs,
`design()` a kalman or ekf estimator's numbers (`ipgen.estimation`). The formulas are in
docs/scenes.md ("As a rig measures it") and cpp/include/ipsim/sensors.hpp.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from ipgen.common import limits
from ipgen.estimation.measurement import Sensors, cutoff_problem
from ipgen.estimation.printed import EstimatorNumbers
from ipgen.model.coordinates import Coordinates
from ipgen.model.pendulum import Pendulum
from ipgen.scene.fields import format_number
from ipgen.scene.sensors import DEFAULT_GAIN_DRIFT, EstimatorTable, SensorsTable

DEFAULT_CUTOFF = 50.0  # rad/s: Quanser's 50 s/(s + 50)
# A delay is a whole number of periods, at most MAX_DELAY_PERIODS (the simulator's rule too).
DELAY_TOLERANCE = limits.DELAY_TOLERANCE
MAX_DELAY_PERIODS = limits.MAX_DELAY_PERIODS


class SensorsError(Exception):
    """A [sensors], [estimator] or drive key that does not fit the rest of the scene (one line)."""


@dataclass(frozen=True)
class Loop:
    """What the simulator's measured loop needs (cpp/include/ipsim/sensors.hpp), in the scene's
    coordinates and input unit: the sensors and the estimator they feed (None and exact: only drive
    keys, no y_*/hat_* columns), the command delay and the drive's noise, lag and pulses."""

    sensors: Sensors | None = None  # measured coordinates, resolutions, noise σ, zero pose
    estimator: EstimatorNumbers = field(default_factory=EstimatorNumbers)
    delay: float = 0.0  # [s], a whole number of periods
    assumed_delay: float | None = None  # [s]: [estimator] delay, what the loop is built for (None: delay)
    seed: int = 0
    drive_noise: float = 0.0
    lag: float = 0.0
    pulses: tuple[tuple[float, float, float], ...] = ()


def _per_measured(value: float | tuple[float, ...], count: int, key: str) -> tuple[float, ...]:
    if isinstance(value, tuple):
        if len(value) != count:
            raise SensorsError(
                f"sensors.{key} has {len(value)} entries, expected one number or {count} "
                "(one per measured coordinate)"
            )
        return value
    return (float(value),) * count


def rest_pose(links: int, measured: tuple[int, ...], coordinates: Coordinates) -> tuple[float, ...]:
    """The rig at rest, where its encoders are zeroed when it is powered: the base centred (0) and
    every link hanging, as the measured coordinates in `coordinates` (e.g. −π for a link measured
    counter-clockwise from upright, 0 with zero = "hanging", 0 for a relative angle above link 1)."""
    import math

    import numpy as np

    state = np.zeros(2 * (links + 1))
    state[1 : links + 1] = math.pi
    user = coordinates.to_user(state, links)
    return tuple(float(user[i]) + 0.0 for i in measured)


def loop(
    sensors: SensorsTable | None,
    estimator: EstimatorTable | None,
    drive: Any,
    *,
    links: int,
    period: float | None,
    acceleration: bool,
    design: Any = None,
    coordinates: Coordinates | None = None,
    cart: bool = False,
) -> Loop | None:
    """The measured loop of a scene, or None when it has none (today's exact loop).

    `drive` is the [actuator] table (its `noise`, `lag`, `pulses`); `period` the sampled
    controller's or swing-up's (None: no sampled loop); `design(loop, table)` fills in a kalman
    or ekf estimator's matrices (the caller's: it knows the model); `coordinates` the scene's
    (default ipgen's), in which the encoders' default zero pose, the rig at rest (base centred,
    links hanging), is given; `cart` whether coordinate 0 is a cart's position [m]. Raises
    `SensorsError` with one line naming the key and the fix.
    """
    dof = links + 1
    drive_noise = 0.0 if drive.noise is None else float(drive.noise)
    lag = 0.0 if drive.lag is None else float(drive.lag)
    pulses = tuple(drive.pulses or ())
    if sensors is None and estimator is None and drive_noise == 0 and lag == 0 and not pulses:
        return None
    if acceleration and (lag > 0 or pulses):
        raise SensorsError(
            "actuator.lag and actuator.pulses need a force- or torque-driven base: an acceleration-driven "
            "base has no force to disturb (remove them or use kind direct or dc_motor)"
        )
    measured_loop = sensors is not None or estimator is not None
    if (measured_loop or drive_noise > 0) and period is None:
        what = "[sensors] and [estimator]" if measured_loop else "actuator.noise"
        raise SensorsError(
            f"{what} need a sampled loop: give [controller] a period (or use a [swingup]); the sensors "
            "are read and the noise is drawn once per sampling period"
        )
    if not measured_loop:
        return Loop(drive_noise=drive_noise, lag=lag, pulses=pulses)
    table = sensors if sensors is not None else SensorsTable()
    kind = "exact" if estimator is None else estimator.kind
    measured = tuple(range(dof)) if table.measured is None else table.measured
    resolution = _per_measured(table.resolution, len(measured), "resolution")
    noise = _per_measured(table.noise, len(measured), "noise")
    zero = rest_pose(links, measured, coordinates or Coordinates()) if table.zero is None else table.zero
    if len(zero) != len(measured):
        raise SensorsError(
            f"sensors.zero has {len(zero)} values for {len(measured)} measured coordinates "
            f"(sensors.measured = {list(measured)}): give one per measured coordinate"
        )
    assert period is not None
    periods = _whole_periods(0.0 if table.delay is None else float(table.delay), period, "sensors.delay")
    assumed = None if estimator is None or estimator.delay is None else float(estimator.delay)
    if assumed is not None:
        assumed = _whole_periods(assumed, period, "estimator.delay") * period
    if kind in ("difference", "filter") and measured != tuple(range(dof)):
        raise SensorsError(
            f'estimator kind "{kind}" needs every coordinate measured '
            f"(sensors.measured = {list(range(dof))}); "
            'with fewer, use "kalman" or "ekf"'
        )
    if kind == "ekf" and acceleration:
        raise SensorsError(
            'estimator kind "ekf" with an acceleration-driven base is not supported yet: use "kalman"'
        )
    cutoff = None
    if kind == "filter":
        cutoff = DEFAULT_CUTOFF if estimator is None or estimator.cutoff is None else float(estimator.cutoff)
        problem = cutoff_problem(cutoff, period)
        if problem:
            default = estimator is None or estimator.cutoff is None
            raise SensorsError(
                f"estimator.cutoff = {format_number(cutoff)} rad/s{' (the default)' if default else ''} "
                f"{problem}: give a lower estimator.cutoff, or a shorter period"
            )
    result = Loop(
        sensors=Sensors(measured, resolution, noise, cart=cart, zero=tuple(float(v) for v in zero)),
        estimator=EstimatorNumbers(
            kind,
            cutoff,
            predict=estimator is not None and estimator.predict,
            compensate_lag=estimator is not None and estimator.compensate_lag,
            lag=None if estimator is None or estimator.lag is None else float(estimator.lag),
            noise_memory=float((estimator and estimator.noise_memory) or 0.0),
            **_gain_learning(estimator),
        ),
        delay=periods * period,
        assumed_delay=assumed,
        seed=table.seed,
        drive_noise=drive_noise,
        lag=lag,
        pulses=pulses,
    )
    if kind in ("kalman", "ekf"):
        if design is None:
            raise SensorsError(f'estimator kind "{kind}" needs the model (no design given)')
        result = design(result, estimator)
    return result


def _noise_learning(memory: float, period: float, encoders: Any, rn: Any) -> dict[str, Any]:
    """The EKF's learnt measurement noise (noise_memory > 0): its margin, and per measured its floor,
    the encoders' own variance (`encoders`, the default Rn: quantization and sensors.noise), and
    its ceiling, NOISE_CEILING times Rn's diagonal (at least the floor); none with memory 0.
    Refuses a memory shorter than the period and an Rn that is not diagonal."""
    import numpy as np

    from ipgen.estimation.covariance import NOISE_CEILING, NOISE_MARGIN

    if memory <= 0:
        return {}
    if memory < period:
        raise SensorsError(
            f"estimator.noise_memory = {format_number(memory)} s is shorter than the loop's period "
            f"{format_number(period)} s: give at least one period"
        )
    if np.count_nonzero(rn - np.diag(np.diag(rn))):
        raise SensorsError(
            "estimator.noise_memory needs a diagonal estimator.measurement_noise (only its diagonal is "
            "learnt): give one variance per measured coordinate"
        )
    floor = [float(v) for v in np.diag(encoders)]
    ceiling = [max(NOISE_CEILING * float(v), low) for v, low in zip(np.diag(rn), floor, strict=True)]
    return {"noise_margin": NOISE_MARGIN, "noise_floor": tuple(floor), "noise_ceiling": tuple(ceiling)}


def _gain_learning(table: EstimatorTable | None) -> dict[str, float]:
    """The EKF's gain learning (gain_spread, gain_drift) of [estimator]: none unless gain_spread > 0."""
    if table is None or not table.gain_spread:
        return {}
    drift = DEFAULT_GAIN_DRIFT if table.gain_drift is None else float(table.gain_drift)
    return {"gain_spread": float(table.gain_spread), "gain_drift": drift}


def _whole_periods(delay: float, period: float, key: str) -> int:
    """A delay's whole number of sampling periods, or a one-line SensorsError naming `key`."""
    if not delay / period < MAX_DELAY_PERIODS + 0.5:  # so round() below is at most MAX_DELAY_PERIODS
        raise SensorsError(
            f"{key} = {format_number(delay)} s is more than {MAX_DELAY_PERIODS:,} periods of "
            f"{format_number(period)} s: is it in seconds?"
        )
    periods = round(delay / period)
    if abs(delay - periods * period) > DELAY_TOLERANCE * max(delay, period):
        raise SensorsError(
            f"{key} = {format_number(delay)} s is not a whole multiple of the period "
            f"{format_number(period)} s: "
            f"use k · {format_number(period)} s (e.g. {format_number(max(periods, 1) * period)} s)"
        )
    return periods


def covariance(value: Any, size: int, key: str) -> tuple[tuple[float, ...], ...]:
    """A full `size` × `size` matrix of a scalar, a diagonal or a matrix (symmetric, PSD not checked here)."""
    if isinstance(value, tuple) and value and isinstance(value[0], tuple):
        if len(value) != size or any(len(row) != size for row in value):
            raise SensorsError(
                f"estimator.{key} must be {size} × {size} (or a number, or {size} diagonal entries)"
            )
        return value
    diagonal = _per_size(value, size, key)
    return tuple(tuple(diagonal[i] if i == j else 0.0 for j in range(size)) for i in range(size))


def _per_size(value: Any, size: int, key: str) -> tuple[float, ...]:
    if isinstance(value, tuple):
        if len(value) != size:
            raise SensorsError(
                f"estimator.{key} has {len(value)} entries, expected one number, {size} or a matrix"
            )
        return value
    return (float(value),) * size


# ---------------------------------------------------------------------------- kalman and ekf


def design(
    loop_: Loop,
    table: EstimatorTable | None,
    *,
    pendulum: Pendulum,
    equilibrium: tuple[float, ...],
    period: float,
    input_scale: float,
) -> Loop:
    """`loop_` with a kalman or ekf estimator's numbers, from `ipgen.estimation`: Rn and Qn (the
    table's, or `estimation.default_covariances`) and, for kalman, `ipgen.kalman`'s ZOH model
    (A_d, B_d) of the exact linearisation at `equilibrium` and its current-form gain M.
    `pendulum` is the scene's (its coordinates and input unit)."""
    import dataclasses

    import numpy as np

    from ipgen.estimation import EstimationError, default_covariances, kalman

    dof = len(equilibrium) // 2
    given = loop_.sensors
    assert given is not None  # loop() designs only a measured loop
    size, count = 2 * dof, len(given.measured)
    try:
        sensors = Sensors.of(dof, given.measured, given.resolution, given.noise, cart=not pendulum.is_rotary)
        q_default, r_default = default_covariances(
            pendulum, period, sensors, input_noise=loop_.drive_noise, u_scale=input_scale,
            equilibrium=list(equilibrium[:dof]),
        )  # fmt: skip
    except EstimationError as exc:
        raise SensorsError(f"estimator: {exc}") from None
    given_q = None if table is None else table.process_noise
    given_r = None if table is None else table.measurement_noise
    qn = np.array(covariance(given_q, size, "process_noise")) if given_q is not None else q_default
    rn = np.array(covariance(given_r, count, "measurement_noise")) if given_r is not None else r_default
    for name, matrix in (("process_noise", qn), ("measurement_noise", rn)):
        scale = max(1.0, float(np.max(np.abs(matrix))))
        if (
            not np.allclose(matrix, matrix.T, rtol=1e-12, atol=0)
            or np.min(np.linalg.eigvalsh(matrix)) < -1e-12 * scale
        ):
            raise SensorsError(f"estimator.{name} must be symmetric positive semidefinite")
    if np.min(np.linalg.eigvalsh(rn)) <= 0:
        raise SensorsError("estimator.measurement_noise must be positive definite (every variance > 0)")
    rows = lambda m: tuple(tuple(float(x) for x in row) for row in np.atleast_2d(m))  # noqa: E731
    if loop_.estimator.kind == "ekf":
        numbers = dataclasses.replace(
            loop_.estimator,
            equilibrium=tuple(float(x) for x in equilibrium),
            process_noise=rows(qn),
            measurement_noise=rows(rn),
            **_noise_learning(loop_.estimator.noise_memory, period, r_default, rn),
        )
        return dataclasses.replace(loop_, estimator=numbers)
    try:
        gains = kalman(pendulum, period, qn, rn, measured=given.measured, equilibrium=list(equilibrium[:dof]))
    except EstimationError as exc:
        raise SensorsError(f"estimator: {exc}") from None
    numbers = dataclasses.replace(
        loop_.estimator,
        A=rows(gains.A),
        B=tuple(float(x) for x in np.asarray(gains.B).reshape(-1)),
        gain=rows(gains.M),
        equilibrium=tuple(float(x) for x in equilibrium),
        input_equilibrium=0.0,
    )
    return dataclasses.replace(loop_, estimator=numbers)
