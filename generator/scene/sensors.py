"""The loop as a rig runs it: a scene's `[sensors]` and `[estimator]` tables and the drive keys of
`[actuator]` (noise, lag, pulses), with their value checks. All optional: without them a scene is
the exact loop, its .cfg and CSV as before. What spans tables (a sampled loop, the delay in whole
periods) is checked by `experiment.loop`, which also designs a kalman or ekf estimator. The
formulas: docs/scenes.md ("As a rig measures it") and cpp/include/ipsim/sensors.hpp.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field, PlainValidator, ValidationInfo, model_validator

from ipgen.common import limits
from ipgen.estimation.measurement import LARGEST, noise_problem, resolution_problem
from ipgen.scene.fields import show
from ipgen.scene.values import Real, Says, at, number, refuse, refuse_key, refuse_line

# per √s: [estimator] gain_drift's default, rho's standard deviation grows so much a √s (the
# prototype's; docs/mpc-robustness.md "A learnt input gain" compares 0.001 and 0.01 on the m4f
# preset's draws)
DEFAULT_GAIN_DRIFT = 0.003

ESTIMATORS: tuple[str, ...] = ("exact", "difference", "filter", "kalman", "ekf")


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


def _pose_entry(item: Any, context: dict[str, Any]) -> float:
    number = _finite(item, context)
    if abs(number) > 1e6:
        refuse("must be within ±1e6 (rad or m)")
    return number


def _pose(value: Any, context: dict[str, Any]) -> tuple[float, ...]:
    """The encoders' zero pose: an array of numbers, one per measured coordinate (length checked
    against `measured` later)."""
    if not isinstance(value, list) or not value:
        refuse("expected an array of numbers, one per measured coordinate [rad or m]")
    return tuple(at(i, _pose_entry, entry, context) for i, entry in enumerate(value))


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


Seed = Annotated[  # limits.MAX_INTEGER_SETTING: what the simulator's checks on doubles take
    int,
    Field(strict=True, ge=0, le=limits.MAX_INTEGER_SETTING),
    Says("must be an integer >= 0 and <= 2^63 - 1024"),
]
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
    zero: _custom(
        _pose,
        {"type": "array", "items": {"type": "number", "minimum": -1e6, "maximum": 1e6}},
        "the pose where the encoders read 0 (reset there), per measured coordinate, in the scene's "
        "coordinates [rad or m]; default: the rig at rest, the base centred and the links hanging",
    ) = None
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
    delay: Real(ge=0, says="must be >= 0 s") | None = Field(
        None,
        description="s: the delay the loop is built for (its estimator's input, the prediction), a whole "
        "multiple of the period; default sensors.delay (the rig's delay, known to the loop)",
    )
    gain_spread: Real(ge=0, le=1, says="must be a number from 0 to 1") | None = Field(
        None,
        description="ekf with a swing-up: the filter also learns the plant's input gain (a motor's "
        "torque per volt) over the model's, rho, and the swing-up divides its u by it; this is rho's "
        "standard deviation at the start (0.2: a gain within about ±20 %; default 0: not learnt)",
    )
    gain_drift: Real(ge=0, le=1, says="must be a number from 0 to 1 per √s") | None = Field(
        None,
        description="with gain_spread: rho's random walk, its standard deviation's growth per √s "
        f"(default {DEFAULT_GAIN_DRIFT}: the filter keeps learning)",
    )
    noise_memory: Real(gt=0, le=60, says="must be > 0 s and at most 60 s: is it in seconds?") | None = Field(
        None,
        description="ekf: the filter learns each measured coordinate's noise variance from its innovations, "
        "an exponential mean over this memory [s], and uses 10 times it, at least the encoders' own variance "
        "and at most 10 Rn (a rig noisier or quieter than Rn says; default: Rn fixed)",
    )
    predict: Annotated[bool, Field(strict=True)] = Field(
        False,
        description="exact, ekf: the law acts on the estimate carried over the delay (estimator.delay, "
        "default sensors.delay) by the model with the commands still in flight, the state its command "
        "will meet (a known delay compensated)",
    )
    compensate_lag: Annotated[bool, Field(strict=True)] = Field(
        False,
        description="the loop is built for the drive's first-order lag (estimator.lag, default [actuator] "
        "lag: the rig's, known): its estimator and prediction take each period's mean lagged input, and "
        "each command is the one whose lagged mean over its first period is the law's, within the law's "
        "bound; without a lag nothing changes",
    )
    lag: Real(ge=0, le=60, says="must be from 0 to 60 s: is it in seconds?") | None = Field(
        None,
        description="with compensate_lag: the drive lag the loop is built for [s], pinned while [actuator] "
        "lag (the rig's) differs; default [actuator] lag",
    )

    @model_validator(mode="after")
    def _relations(self, info: ValidationInfo) -> EstimatorTable:
        if self.cutoff is not None and self.kind != "filter":
            refuse_line(f'estimator.cutoff applies to kind = "filter" only (kind is "{self.kind}")')
        if self.predict and self.kind not in ("exact", "ekf"):
            refuse_line(
                f'estimator.predict needs kind = "ekf" or "exact": the prediction runs the model '
                f'(kind is "{self.kind}")'
            )
        context = info.context or {}
        learns = bool(self.gain_spread)
        if (learns or self.gain_drift is not None) and self.kind != "ekf":
            key = "gain_spread" if self.gain_spread is not None else "gain_drift"
            refuse_line(f'estimator.{key} applies to kind = "ekf" only (kind is "{self.kind}")')
        if self.noise_memory is not None and self.kind != "ekf":
            refuse_line(f'estimator.noise_memory applies to kind = "ekf" only (kind is "{self.kind}")')
        if self.gain_drift is not None and not learns:
            refuse_line(
                "estimator.gain_drift needs estimator.gain_spread > 0 (the gain it lets drift is not learnt)"
            )
        if learns and context.get("swingup_method") is None:
            refuse_line(
                "estimator.gain_spread needs a [swingup] (the swing-up divides its input by the learnt "
                "gain; a controller alone does not yet): remove gain_spread, or add a [swingup]"
            )
        if self.predict and context.get("swingup_method") == "trajectory":
            refuse_line(
                "estimator.predict with a trajectory swing-up is not supported yet (its plan would be "
                "read a delay early): remove predict, or use the energy swing-up"
            )
        if self.lag is not None and not self.compensate_lag:
            refuse_line(
                "estimator.lag needs estimator.compensate_lag = true (it is the lag the compensation "
                "is built for): add compensate_lag, or remove lag"
            )
        if self.compensate_lag and str(context.get("u_unit", "")).endswith("s^2"):
            refuse_line(
                "estimator.compensate_lag needs a force- or torque-driven base (an acceleration-driven "
                "base has no drive lag): remove compensate_lag"
            )
        if self.predict and str(context.get("u_unit", "")).endswith("s^2"):
            refuse_line(
                "estimator.predict with an acceleration-driven base is not supported yet (the "
                "prediction runs the force-driven model): remove predict"
            )
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
