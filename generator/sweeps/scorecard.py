"""The robustness scorecard: the criteria of the DFKI double-pendulum leaderboard (model
parameters, noise, delay, drive, perturbations) plus encoder resolution and sample rate.

Each criterion varies one thing over stated levels (`CRITERIA`, overridable with
`--criterion NAME=LO:HI:N`); the model parameters are scaled on every coordinate at once in the
plant while the controller (and the scene's estimator) stays the one designed on the nominal
scene; the measurement, delay and drive criteria set [sensors] and [actuator] keys.
"""

from __future__ import annotations

import hashlib
import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING

from ipgen.sweeps.overrides import nominal_array
from ipgen.sweeps.spec import MAX_RUNS, Criterion, Key, Level, SweepError, parse_levels

if TYPE_CHECKING:
    from ipgen.experiment.scene import Scene


@dataclass(frozen=True)
class Default:
    """A scorecard criterion: what it varies, its default levels and repetitions."""

    name: str
    label: str
    levels: str  # LO:HI:N or v1,v2,... (parse_levels)
    repeat: int = 1
    relative: bool = False  # levels are fractions of the input limit (u_max or the saturation)


CRITERIA: tuple[Default, ...] = (
    Default("mass", "masses ×", "0.75:1.25:21"),
    Default("com", "mass·CoG (com) ×", "0.75:1.25:21"),
    Default("inertia", "inertias J ×", "0.75:1.25:21"),
    Default("damping", "damping δ ×", "0:2:21"),
    Default("coulomb", "Coulomb friction [N or N m]", "0:0.1:21"),
    Default("period", "controller period [s]", "0.0005,0.001,0.002,0.005,0.01,0.02,0.05"),
    Default("resolution", "encoder counts", "0,8192,4096,2048,1024,512,256,128,64"),
    Default("sensor_noise", "angle noise σ [rad or m]", "0:0.02:21", repeat=10),
    Default("delay", "delay [s]", "0:0.04:21"),  # multiples of the period: delay_levels
    Default("drive_noise", "drive noise σ / u limit", "0:0.2:21", repeat=10, relative=True),
    Default("lag", "drive lag τ [s]", "0:0.05:21"),
    Default(
        "pulses",
        "pulse amplitude / input limit (as force)",
        "0:0.5:5",
        repeat=10,
        relative=True,
    ),
)
NAMES = tuple(default.name for default in CRITERIA)
MEASUREMENT = ("resolution", "sensor_noise")  # criteria that act through the estimator only
PULSE_DURATION = 0.05  # s: one pulse per run, at a time drawn from the run's seed


def seed_of(base: int, criterion: str, level: int, repeat: int) -> int:
    """The run's seed: the first 4 bytes of SHA-256("base/criterion/level/repeat") (stated, stable)."""
    digest = hashlib.sha256(f"{base}/{criterion}/{level}/{repeat}".encode()).digest()
    return int.from_bytes(digest[:4], "big")


def input_limit(scene: Scene) -> float:
    """The input's limit the relative criteria scale by: the sampled law's bound
    (`job.command_bound`: u_max, the saturation), else 1."""
    from ipgen.pipeline.job import command_bound

    bound = command_bound(scene)
    return bound if math.isfinite(bound) else 1.0


def force_limit(scene: Scene) -> float:
    """The input limit as a force or torque on the base [N or N m] (pulses act there): with a
    dc_motor the voltage limit times the motor's gain (N m or N per volt)."""
    limit = input_limit(scene)
    return limit * scene.actuator.gain() if scene.actuator.is_motor else limit


def _scaled(scene: Scene, name: str, factor: float) -> list[float]:
    values = nominal_array(scene, Key("parameters", name))
    assert values is not None
    return [value * factor for value in values]


def _overrides(scene: Scene, name: str, value: float) -> tuple[tuple[str, object], ...]:
    """The overrides of criterion `name` at level `value` (pulses: drawn per run, see `pulse`)."""
    if name == "mass":
        return (("parameters.m", _scaled(scene, "m", value)),)
    if name == "com":
        return (("parameters.com", _scaled(scene, "com", value)),)
    if name == "inertia":
        return (("parameters.J", _scaled(scene, "J", value)),)
    if name == "damping":
        return (("parameters.delta", _scaled(scene, "delta", value)),)
    if name == "coulomb":
        return (("parameters.coulomb", [value] * (scene.links + 1)),)
    if name == "period":
        table = "swingup" if scene.swingup is not None else "controller"
        return ((f"{table}.period", value),)
    if name == "resolution":
        return (("sensors.resolution", int(value)),)
    if name == "sensor_noise":
        return (("sensors.noise", value),)
    if name == "delay":
        return (("sensors.delay", value),)
    if name == "drive_noise":
        return (("actuator.noise", value * input_limit(scene)),)
    if name == "lag":
        return (("actuator.lag", value),)
    return ()


def pulse(scene: Scene, amplitude: float, seed: int) -> list[list[float]]:
    """One pulse of `PULSE_DURATION` s on the base, `amplitude` times `force_limit`, sign and start
    drawn from `seed` (numpy PCG64): its start uniform in [1 s, t_end − 2 s] (the run has time to
    recover before the hold window)."""
    import numpy as np

    rng = np.random.default_rng(seed)
    start = float(rng.uniform(1.0, max(1.0, scene.t_end - 2.0)))
    sign = 1.0 if rng.random() < 0.5 else -1.0
    return [[round(start, 6), PULSE_DURATION, sign * amplitude * force_limit(scene)]]


def delay_levels(scene: Scene) -> str:
    """The delay levels: whole multiples of the loop's period from 0 to 40 ms (at most 21 of them,
    evenly spaced), as a delay must be a multiple of the period; "" without a period."""
    period = (
        scene.swingup.period
        if scene.swingup is not None
        else (scene.controller.period if scene.controller is not None else None)
    )
    if not period:
        return ""
    steps = int(0.04 / period + 1e-9)
    stride = max(1, -(-steps // 20))
    return ",".join(repr(k * period) for k in range(0, steps + 1, stride))


def check_names(chosen: tuple[str, ...] | None, levels: Mapping[str, str]) -> None:
    """SweepError unless every criterion named (--only, --criterion) is one, and every one given
    levels runs (a --criterion outside --only was dropped without a word)."""
    unknown = [name for name in [*(chosen or ()), *levels] if name not in NAMES]
    if unknown:
        raise SweepError(
            f"scorecard criterion {unknown[0]!r} is unknown: the criteria are {', '.join(NAMES)}"
        )
    left_out = [name for name in levels if chosen is not None and name not in chosen]
    if left_out:
        raise SweepError(
            f"--criterion {left_out[0]}=...: {left_out[0]} is not among --only {','.join(chosen or ())}: "
            "add it there, or drop its levels"
        )


def criteria(
    scene: Scene,
    chosen: tuple[str, ...] | None = None,
    levels: dict[str, str] | None = None,
    repeat: int | None = None,
    estimator: str = "exact",
) -> list[Criterion]:
    """The scorecard's criteria for `scene` (`chosen`: a subset by name; `levels`: new levels by
    name; `repeat`: the repetitions of the seeded criteria; `estimator`: the scene's
    [estimator] kind — with "exact" the controller sees the true state, so the measurement's
    resolution and noise change nothing and those criteria are not run)."""
    levels = dict(levels or {})
    check_names(chosen, levels)
    if scene.controller is None and scene.swingup is None:
        raise SweepError(
            "--scorecard needs a scene with a [controller] or a [swingup]: it scores a closed loop"
        )
    found = []
    for default in CRITERIA:
        if chosen is not None and default.name not in chosen:
            continue
        text = levels.get(default.name) or delay_levels(scene) if default.name == "delay" else None
        text = text or levels.get(default.name, default.levels)
        values = parse_levels(text, f"{default.name}={text}")
        reps = default.repeat if repeat is None or default.repeat == 1 else repeat
        seeded = default.repeat > 1
        refused = ""
        if default.name == "period" and scene.controller is not None and scene.controller.period is None:
            refused = "the scene's controller is continuous (no controller.period): nothing to vary"
        elif default.name == "pulses" and scene.actuator.is_acceleration:
            refused = "the base follows the commanded acceleration: a force pulse on it changes nothing"
        elif default.name in MEASUREMENT and estimator == "exact":
            refused = (
                'the controller sees the exact state ([estimator] kind = "exact"): the measurement changes '
                "nothing; give the scene an estimator to score it"
            )
        built = tuple(
            Level((value,), _overrides(scene, default.name, value) if not refused else ()) for value in values
        )
        found.append(Criterion(default.name, default.label, (default.label,), built, reps, refused, seeded))
    return found


RANDOM_SPREAD = 0.2  # --spread: ±20 % on every mass, damping coefficient and a motor's resistance
HANGING_TILT = 0.1  # rad: a hanging start's links within π ± this, at rest
UPRIGHT_TILT, UPRIGHT_RATE = 0.2, 0.5  # rad, rad/s: a near-upright start's links and their rates
BASE_OFFSET = 0.1  # m or rad: the base's start within ± this of 0


def random_start(scene: Scene, spread: float, seed: int, hanging: bool) -> tuple[tuple[str, object], ...]:
    """The overrides of one random start, drawn from `seed` (numpy PCG64): every mass and every
    damping coefficient, and a dc_motor's resistance Rm, times U(1 − spread, 1 + spread) each; the
    base at U(−BASE_OFFSET, BASE_OFFSET) at rest; the links hanging (π ± HANGING_TILT, at rest)
    or near upright (±UPRIGHT_TILT, rates ±UPRIGHT_RATE), drawn in ipgen's coordinates and
    written in the scene's."""
    import numpy as np

    rng = np.random.default_rng(seed)
    dof = scene.links + 1

    def scaled(values: list[float]) -> list[float]:
        return [float(v * rng.uniform(1.0 - spread, 1.0 + spread)) for v in values]

    overrides: list[tuple[str, object]] = [
        (f"parameters.{name}", scaled(list(nominal_array(scene, Key("parameters", name)) or ())))
        for name in ("m", "delta")
    ]
    if scene.actuator.is_motor:
        overrides.append(("actuator.Rm", scaled([scene.actuator.Rm])[0]))
    x = np.zeros(2 * dof)
    x[0] = rng.uniform(-BASE_OFFSET, BASE_OFFSET)
    if hanging:
        x[1:dof] = np.pi + rng.uniform(-HANGING_TILT, HANGING_TILT, dof - 1)
    else:
        x[1:dof] = rng.uniform(-UPRIGHT_TILT, UPRIGHT_TILT, dof - 1)
        x[dof + 1 :] = rng.uniform(-UPRIGHT_RATE, UPRIGHT_RATE, dof - 1)
    user = scene.coordinates.to_user(x, scene.links)
    overrides.append(("initial.theta", [float(v) for v in user[:dof]]))
    overrides.append(("initial.dtheta", [float(v) for v in user[dof:]]))
    return tuple(overrides)


def random_starts(scene: Scene, count: int, spread: float, seed: int) -> Criterion:
    """`count` runs from random starts (`random_start`), each one level of one run, so that the
    criterion's score is the fraction of runs that pass: with a [swingup] the even runs start
    hanging and the odd ones near upright; a balance scene (a [controller] alone) starts near
    upright only (from hanging it fails by construction)."""
    if not isinstance(count, int) or count < 1:
        raise SweepError(f"--random {count!r}: give a number of random starts >= 1")
    if count > MAX_RUNS:  # before drawing them: a billion starts filled the memory first
        raise SweepError(f"--random {count:,}: a sweep makes at most {MAX_RUNS:,} runs; give fewer starts")
    if not (0.0 <= spread < 1.0):
        raise SweepError(f"--spread {spread!r}: give a fraction in [0, 1), e.g. 0.2 for ±20 %")
    if scene.controller is None and scene.swingup is None:
        raise SweepError("--random needs a scene with a [controller] or a [swingup]: it scores a closed loop")
    if scene.specialise:
        raise SweepError(
            "--random draws the parameters, which this specialised scene compiles in: set specialise = false"
        )
    swings = scene.swingup is not None
    levels = tuple(
        Level((float(i),), random_start(scene, spread, seed_of(seed, "random", i, 0), swings and i % 2 == 0))
        for i in range(count)
    )
    label = f"random start (±{100 * spread:g} % on m, δ{', Rm' if scene.actuator.is_motor else ''})"
    return Criterion("random", label, ("random start",), levels, 1, "", True, {"spread": spread})
