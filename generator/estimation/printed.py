"""A sampled loop's estimator as designed, in one record for every consumer.

`EstimatorNumbers` is what a scene's [estimator] becomes once designed (experiment/loop.py): its
kind and that kind's numbers. The simulator's measured loop (`experiment.loop.Loop`, written to the
.cfg) and the C header's estimator (`PrintedEstimator`, printed by codegen/c_header.py) both hold
it, beside the `Sensors` that feed it, so each number is named once. Coordinates and input units
are the scene's. Data only: the algorithms are ipgen_loop.h's.
"""

from __future__ import annotations

from dataclasses import dataclass

from ipgen.estimation.measurement import Sensors

Rows = tuple[tuple[float, ...], ...]


@dataclass(frozen=True)
class EstimatorNumbers:
    """An estimator's kind and the numbers it runs on (empty where its kind has none)."""

    kind: str = "exact"  # "exact" | "difference" | "filter" | "kalman" | "ekf"
    cutoff: float | None = None  # filter: ω_c [rad/s]
    A: Rows = ()  # kalman: A_d (2·dof × 2·dof)
    B: tuple[float, ...] = ()  # kalman: B_d (2·dof), per unit of the scene's input
    gain: Rows = ()  # kalman: M (2·dof × measured), current form
    equilibrium: tuple[float, ...] = ()  # kalman, ekf: x_eq (2·dof)
    input_equilibrium: float = 0.0  # kalman: u_eq
    process_noise: Rows = ()  # ekf: Qn
    measurement_noise: Rows = ()  # ekf: Rn
    predict: bool = False  # exact, ekf: the law sees the estimate carried over the delay (ipgen_loop_predict)
    gain_spread: float = 0.0  # ekf: > 0, the input gain is learnt (rho's prior σ); 0: not learnt
    gain_drift: float = 0.0  # ekf with gain_spread: rho's random walk, σ's growth per √s
    compensate_lag: bool = False  # the loop is built for the drive's lag ([actuator] lag, known)
    lag: float | None = None  # compensate_lag: the lag it is built for [s], pinned (None: the rig's)
    # ekf: > 0, each measured coordinate's noise variance is learnt over this memory [s]; the filter
    # uses noise_margin times it within [noise_floor, noise_ceiling] (per measured, rad² or m²)
    noise_memory: float = 0.0
    noise_margin: float = 0.0
    noise_floor: tuple[float, ...] = ()
    noise_ceiling: tuple[float, ...] = ()


@dataclass(frozen=True)
class PrintedEstimator:
    """The estimator the C header prints: its numbers, the sensors that feed it and the sampled
    loop it runs in."""

    numbers: EstimatorNumbers
    sensors: Sensors  # measured coordinates, encoder resolutions and zero pose, cart or arm
    period: float  # the sampled loop's period T [s]
    delay: int = 0  # whole periods from sampling to applying a command
    input_gain: float = 1.0  # ekf: the force or torque per unit of u (a dc_motor's b)
    # compensate_lag: the drive's lag [s] and the bound of the law's command [units of u]
    lag: float = 0.0
    lag_limit: float = float("inf")
    # The parameters the loop was designed with, the motor folded in (Pendulum.folded().params()):
    # the swing-up's energy law and the EKF read them, so the firmware entry needs no arguments.
    params: dict[str, tuple[float, ...] | float] | None = None

    @property
    def firmware(self) -> bool:
        """Whether the header gets the firmware entry (ipgen_<name>_step, encoder counts in):
        every measured coordinate has an encoder (resolution > 0)."""
        return bool(self.sensors.resolution) and all(r > 0 for r in self.sensors.resolution)
