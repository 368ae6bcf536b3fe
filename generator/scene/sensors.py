"""The loop as a rig runs it: a scene's `[sensors]`, `[estimator]` and the drive keys of `[actuator]`.

    [sensors]    measured = [0, 1]     coordinates of θ that are measured (default: all, 0 = the base)
                 resolution = 2048     encoder counts per revolution (angles) or per metre (a cart's
                                       position); 0 = exact; one number or one per measured coordinate
                 noise = 0.0           σ of additive Gaussian noise [rad or m], one or one per measured
                 delay = 0.0           s from sampling to applying the output: a whole multiple of the period
                 seed = 0              integer >= 0: every random stream of the run
    [estimator]  kind = "exact" | "difference" | "filter" | "kalman" | "ekf"
                 cutoff = 50.0         rad/s (filter)
                 process_noise, measurement_noise   Qn and Rn (kalman, ekf; default from the sensors)
    [actuator]   noise = 0.0           σ of the applied input's noise [N, N m or V], per sampling interval
                 lag = 0.0             s: first-order drive, u_applied' = (u_cmd − u_applied) / lag
                 pulses = [[start, duration, amplitude], ...]   disturbance force [N] or torque [N m]

Everything here is optional: a scene without these tables and keys is today's exact loop and its
resolved config (and so its CSV) is byte-identical. The sensors, an estimator and drive noise
need a sampled loop (a [controller] with a period, or a [swingup]); `loop()` checks what spans
tables and returns a `Loop` with everything the simulator needs, `config_lines()` its .cfg keys.
The formulas are in docs/scenes.md ("As a rig measures it") and cpp/include/ipsim/sensors.hpp.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field, PlainValidator, ValidationInfo, model_validator

from ipgen.estimation.measurement import LARGEST, noise_problem, resolution_problem
from ipgen.scene.fields import format_number, show
from ipgen.scene.values import Real, Says, at, number, refuse, refuse_key, refuse_line

ESTIMATORS: tuple[str, ...] = ("exact", "difference", "filter", "kalman", "ekf")
DEFAULT_CUTOFF = 50.0  # rad/s: Quanser's 50 s/(s + 50)
# A delay is a whole number of periods to this relative tolerance.
DELAY_TOLERANCE = 1e-9
MAX_DELAY_PERIODS = 10**6  # a longer delay is a unit slip (and would hold a queue of that many outputs)
MAX_SEED = 2**63 - 1


class SensorsError(Exception):
    """A [sensors], [estimator] or drive key that does not fit the rest of the scene (one line)."""


# ---------------------------------------------------------------------------- value checks


def _finite(item: Any, _: dict[str, Any]) -> float:
    """A finite number (the scene layer's own check of an array entry, `values.number`)."""
    return number(item)


def _non_negative(item: Any, context: dict[str, Any]) -> float:
    number = _finite(item, context)
    if number < 0:
        refuse("must be >= 0")
    return number


def _bounded(item: Any, context: dict[str, Any]) -> float:
    """A number in [0, 1e100]: noise σ and covariance entries are squared or multiplied, and only
    their ratios matter, so larger ones are unit slips that would overflow."""
    number = _non_negative(item, context)
    problem = noise_problem(number)
    if problem:
        refuse(problem)
    return number


def _counts(item: Any, context: dict[str, Any]) -> float:
    """An encoder resolution: 0 (exact) or at least one count per revolution or metre."""
    number = _non_negative(item, context)
    problem = resolution_problem(number)
    if problem:
        refuse(problem)
    return number


def _scalar_or_list(
    value: Any, context: dict[str, Any], item: Callable[[Any, dict[str, Any]], float] = _bounded
) -> float | tuple[float, ...]:
    """One number, or an array of them, each checked by `item` (the array's length is checked
    against `measured` later)."""
    if isinstance(value, list):
        if not value:
            refuse("expected a number or a non-empty array of numbers")
        return tuple(at(i, item, entry, context) for i, entry in enumerate(value))
    return item(value, context)


def _resolutions(value: Any, context: dict[str, Any]) -> float | tuple[float, ...]:
    return _scalar_or_list(value, context, _counts)


def _measured(value: Any, context: dict[str, Any]) -> tuple[int, ...]:
    """Ascending, distinct coordinates 0..links."""
    count = context.get("count")
    if count is None:  # [system] failed: its error is the one reported
        return ()
    if not isinstance(value, list) or not value:
        refuse(f"expected a non-empty array of coordinates 0..{count - 1} (0 = the base)")
    indices: list[int] = []
    for i, item in enumerate(value):
        if isinstance(item, bool) or not isinstance(item, int) or not 0 <= item < count:
            refuse_key(f" = {show(item)}: expected a coordinate 0..{count - 1} (0 = the base)", index=(i,))
        if indices and item <= indices[-1]:
            refuse_key(f" = {item}: list the measured coordinates once each, ascending", index=(i,))
        indices.append(item)
    return tuple(indices)


def _covariance(value: Any, context: dict[str, Any]) -> Any:
    """A number, a diagonal (array) or a full matrix (array of arrays); sizes checked in `loop()`."""
    if isinstance(value, list) and value and all(isinstance(row, list) for row in value):

        def entry(item: Any, ctx: dict[str, Any]) -> float:
            number = _finite(item, ctx)
            if abs(number) > LARGEST:
                refuse(f"must be within ±{LARGEST:g} (only ratios of noises matter: scale them down)")
            return number

        def row_of(row: list[Any], ctx: dict[str, Any]) -> tuple[float, ...]:
            return tuple(at(j, entry, item, ctx) for j, item in enumerate(row))

        return tuple(at(i, row_of, row, context) for i, row in enumerate(value))
    return _scalar_or_list(value, context)


def _pulses(value: Any, context: dict[str, Any]) -> tuple[tuple[float, float, float], ...]:
    """[[start s >= 0, duration s > 0, amplitude], ...]."""
    if not isinstance(value, list):
        refuse("expected an array of pulses [start s, duration s, amplitude]")

    def pulse(item: Any, ctx: dict[str, Any]) -> tuple[float, float, float]:
        if not isinstance(item, list) or len(item) != 3:
            refuse("a pulse is [start s, duration s, amplitude N or N m]")
        start, duration, amplitude = (at(j, _finite, x, ctx) for j, x in enumerate(item))
        if start < 0 or duration <= 0:
            refuse("a pulse needs start >= 0 s and duration > 0 s")
        return start, duration, amplitude

    return tuple(at(i, pulse, item, context) for i, item in enumerate(value))


Seed = Annotated[int, Field(strict=True, ge=0, lt=2**63), Says("must be an integer >= 0 and below 2^63")]
_NOISE = {"type": "number", "minimum": 0, "maximum": LARGEST}
_NOISE_SCHEMA = {"oneOf": [_NOISE, {"type": "array", "items": _NOISE}]}
_COUNTS = {"oneOf": [{"const": 0}, {"type": "number", "minimum": 1}]}
_COUNTS_SCHEMA = {"oneOf": [_COUNTS, {"type": "array", "items": _COUNTS}]}
_ENTRY = {"type": "number", "minimum": -LARGEST, "maximum": LARGEST}
_MATRIX_SCHEMA = {
    "oneOf": [
        _NOISE,
        {"type": "array", "items": _NOISE},
        {"type": "array", "items": {"type": "array", "items": _ENTRY}},
    ]
}


def _custom(check: Callable[[Any, dict[str, Any]], Any], schema: dict[str, Any], description: str) -> Any:
    """A key whose value `check(value, context)` validates (its errors one-line refusals)."""

    def validate(value: Any, info: ValidationInfo) -> Any:
        return check(value, info.context if info.context is not None else {})

    return Annotated[Any, PlainValidator(validate), Field(description=description, json_schema_extra=schema)]


# ---------------------------------------------------------------------------- the tables


class SensorsTable(BaseModel):
    """[sensors]: what the rig measures, how finely, how noisily, and how late its output arrives."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    measured: _custom(
        _measured,
        {"type": "array", "items": {"type": "integer", "minimum": 0}},
        "the measured coordinates of θ, ascending (0 = the base; default: all)",
    ) = None
    resolution: _custom(
        _resolutions,
        _COUNTS_SCHEMA,
        "encoder counts per revolution (angles) or per metre (a cart); 0 = exact",
    ) = 0.0
    noise: _custom(
        _scalar_or_list,
        _NOISE_SCHEMA,
        "σ of the Gaussian measurement noise [rad or m], one or per measured coordinate",
    ) = 0.0
    delay: Real(ge=0, says="must be >= 0 s") | None = Field(
        None, description="s from sampling to applying the output, a whole multiple of the period"
    )
    seed: Seed = Field(0, description="the seed of every random stream of the run (sensor and drive noise)")

    def context(self) -> dict[str, Any]:
        return {}


class EstimatorTable(BaseModel):
    """[estimator]: how the controller's state estimate x̂ is made from the measurements."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    kind: Literal[ESTIMATORS] = Field(
        "exact",
        description="exact: the true state; difference: backward difference of the angles; "
        "filter: the rigs' first-order derivative filter; kalman: steady-state Kalman filter on the "
        "linearisation; ekf: extended Kalman filter on the exact model",
    )
    cutoff: Real(gt=0, says="the cutoff must be > 0 rad/s") | None = Field(
        None, description="filter: the derivative filter's cutoff ω_c [rad/s] (default 50)"
    )
    process_noise: _custom(
        _covariance, _MATRIX_SCHEMA, "kalman, ekf: Qn, a number, 2 (links + 1) diagonal entries or a matrix"
    ) = None
    measurement_noise: _custom(
        _covariance, _MATRIX_SCHEMA, "kalman, ekf: Rn, a number, one per measured coordinate or a matrix"
    ) = None

    @model_validator(mode="after")
    def _relations(self) -> EstimatorTable:
        if self.cutoff is not None and self.kind != "filter":
            refuse_line(f'estimator.cutoff applies to kind = "filter" only (kind is "{self.kind}")')
        if self.kind not in ("kalman", "ekf"):
            for key in ("process_noise", "measurement_noise"):
                if getattr(self, key) is not None:
                    refuse_line(
                        f'estimator.{key} applies to kind = "kalman" or "ekf" only (kind is "{self.kind}")'
                    )
        return self

    def context(self) -> dict[str, Any]:
        return {}


# The drive's keys of [actuator] (any kind), declared here and listed in `schema.ActuatorTable`.
DriveNoise = Annotated[
    Real(ge=0, le=LARGEST, says=f"must be >= 0 and <= {LARGEST:g}") | None,
    Field(description="σ of the Gaussian noise on the applied input [N, N m or V], held per sample interval"),
]
DriveLag = Annotated[
    Real(ge=0, says="must be >= 0 s") | None,
    Field(description="the drive's first-order time constant [s] (default 0: none)"),
]
DrivePulses = _custom(
    _pulses,
    {"type": "array", "items": {"type": "array", "items": {"type": "number"}, "minItems": 3}},
    "disturbance pulses on the base: [[start s, duration s, amplitude N or N m], ...]",
)


# ---------------------------------------------------------------------------- the loop


@dataclass(frozen=True)
class Loop:
    """What the simulator's measured loop needs (cpp/include/ipsim/sensors.hpp), in the scene's
    coordinates and input unit. `sensors` False: only drive keys (no y_*/hat_* columns)."""

    sensors: bool = False
    measured: tuple[int, ...] = ()
    resolution: tuple[float, ...] = ()
    noise: tuple[float, ...] = ()
    delay: float = 0.0
    seed: int = 0
    estimator: str = "exact"
    cutoff: float | None = None
    drive_noise: float = 0.0
    lag: float = 0.0
    pulses: tuple[tuple[float, float, float], ...] = ()
    # kalman: A_d, B_d (2·dof × 2·dof, 2·dof), M (2·dof × measured), x_eq, u_eq; ekf: Qn, Rn, x_eq
    A: tuple[tuple[float, ...], ...] = ()
    B: tuple[float, ...] = ()
    gain: tuple[tuple[float, ...], ...] = ()
    equilibrium: tuple[float, ...] = ()
    input_equilibrium: float = 0.0
    process_noise: tuple[tuple[float, ...], ...] = ()
    measurement_noise: tuple[tuple[float, ...], ...] = ()


def _per_measured(value: float | tuple[float, ...], count: int, key: str) -> tuple[float, ...]:
    if isinstance(value, tuple):
        if len(value) != count:
            raise SensorsError(
                f"sensors.{key} has {len(value)} entries, expected one number or {count} "
                "(one per measured coordinate)"
            )
        return value
    return (float(value),) * count


def loop(
    sensors: SensorsTable | None,
    estimator: EstimatorTable | None,
    drive: Any,
    *,
    links: int,
    period: float | None,
    acceleration: bool,
    design: Any = None,
) -> Loop | None:
    """The measured loop of a scene, or None when it has none (today's exact loop).

    `drive` is the [actuator] table (its `noise`, `lag`, `pulses`); `period` the sampled
    controller's or swing-up's (None: no sampled loop); `design(loop, table)` fills in a kalman
    or ekf estimator's matrices (the caller's: it knows the model). Raises `SensorsError` with
    one line naming the key and the fix.
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
    delay = 0.0 if table.delay is None else float(table.delay)
    assert period is not None
    if delay / period > MAX_DELAY_PERIODS:
        raise SensorsError(
            f"sensors.delay = {format_number(delay)} s is more than {MAX_DELAY_PERIODS:,} periods of "
            f"{format_number(period)} s: is it in seconds?"
        )
    periods = round(delay / period)
    if abs(delay - periods * period) > DELAY_TOLERANCE * max(delay, period):
        raise SensorsError(
            f"sensors.delay = {format_number(delay)} s is not a whole multiple of the period "
            f"{format_number(period)} s: "
            f"use k · {format_number(period)} s (e.g. {format_number(max(periods, 1) * period)} s)"
        )
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
    result = Loop(
        sensors=True,
        measured=measured,
        resolution=resolution,
        noise=noise,
        delay=periods * period,
        seed=table.seed,
        estimator=kind,
        cutoff=cutoff,
        drive_noise=drive_noise,
        lag=lag,
        pulses=pulses,
    )
    if kind in ("kalman", "ekf"):
        if design is None:
            raise SensorsError(f'estimator kind "{kind}" needs the model (no design given)')
        result = design(result, estimator)
    return result


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


# ---------------------------------------------------------------------------- the .cfg


def config_lines(loop_: Loop | None) -> list[str]:
    """The simulator's keys for the loop (nothing without one: the config is as before)."""
    if loop_ is None:
        return []

    def numbers(values: Any) -> str:
        return " ".join(format_number(float(v)) for v in values)

    def matrix(rows: Any) -> str:
        return " ".join(numbers(row) for row in rows)

    lines: list[str] = []
    if loop_.drive_noise > 0:
        lines.append(f"actuator.noise = {format_number(loop_.drive_noise)}")
    if loop_.lag > 0:
        lines.append(f"actuator.lag = {format_number(loop_.lag)}")
    if loop_.pulses:
        lines.append(f"actuator.pulses = {matrix(loop_.pulses)}")
    if not loop_.sensors:
        return lines
    lines += [
        f"sensors.measured = {' '.join(str(i) for i in loop_.measured)}",
        f"sensors.resolution = {numbers(loop_.resolution)}",
        f"sensors.noise = {numbers(loop_.noise)}",
        f"sensors.delay = {format_number(loop_.delay)}",
        f"sensors.seed = {loop_.seed}",
        f"estimator = {loop_.estimator}",
    ]
    if loop_.cutoff is not None:
        lines.append(f"estimator.cutoff = {format_number(loop_.cutoff)}")
    if loop_.estimator in ("kalman", "ekf"):
        lines.append(f"estimator.equilibrium = {numbers(loop_.equilibrium)}")
    if loop_.estimator == "kalman":
        lines += [
            f"estimator.A = {matrix(loop_.A)}",
            f"estimator.B = {numbers(loop_.B)}",
            f"estimator.gain = {matrix(loop_.gain)}",
            f"estimator.input = {format_number(loop_.input_equilibrium)}",
        ]
    if loop_.estimator == "ekf":
        lines += [
            f"estimator.process_noise = {matrix(loop_.process_noise)}",
            f"estimator.measurement_noise = {matrix(loop_.measurement_noise)}",
        ]
    return lines


# ---------------------------------------------------------------------------- kalman and ekf


def design(
    loop_: Loop,
    table: EstimatorTable | None,
    *,
    pendulum: dict[str, Any],
    equilibrium: tuple[float, ...],
    period: float,
    input_scale: float,
) -> Loop:
    """`loop_` with a kalman or ekf estimator's numbers, from `ipgen.estimation`: Rn and Qn (the
    table's, or `estimation.default_covariances`) and, for kalman, `ipgen.kalman`'s ZOH model
    (A_d, B_d) of the exact linearisation at `equilibrium` and its current-form gain M.
    `pendulum` is `ipgen.linearize`'s keywords (the scene's coordinates and input unit)."""
    import dataclasses

    import numpy as np

    from ipgen.estimation import EstimationError, Sensors, default_covariances, kalman

    dof = len(equilibrium) // 2
    size, count = 2 * dof, len(loop_.measured)
    try:
        sensors = Sensors.of(
            dof, loop_.measured, loop_.resolution, loop_.noise, cart=pendulum["type"] == "classical"
        )
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
    if loop_.estimator == "ekf":
        return dataclasses.replace(
            loop_,
            equilibrium=tuple(float(x) for x in equilibrium),
            process_noise=rows(qn),
            measurement_noise=rows(rn),
        )
    try:
        gains = kalman(pendulum, period, qn, rn, measured=loop_.measured, equilibrium=list(equilibrium[:dof]))
    except EstimationError as exc:
        raise SensorsError(f"estimator: {exc}") from None
    return dataclasses.replace(
        loop_,
        A=rows(gains.A),
        B=tuple(float(x) for x in np.asarray(gains.B).reshape(-1)),
        gain=rows(gains.M),
        equilibrium=tuple(float(x) for x in equilibrium),
        input_equilibrium=0.0,
    )
