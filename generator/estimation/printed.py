"""The numbers of a scene's estimator that generated code carries (the C header's
`ipgen_<name>_estimator_*`): data only, filled in from the scene's measured loop by the command
stage and printed by codegen/c_header.py. Coordinates and input units are the scene's."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class PrintedEstimator:
    kind: str  # "difference" | "filter" | "kalman" | "ekf"
    period: float  # the sampled loop's period T [s]
    measured: tuple[int, ...]  # the measured coordinates, increasing
    delay: int = 0  # whole periods from sampling to applying a command
    cutoff: float | None = None  # filter: ω_c [rad/s]
    A: tuple[tuple[float, ...], ...] = ()  # kalman: A_d (2·dof × 2·dof)
    B: tuple[float, ...] = ()  # kalman: B_d (2·dof), per unit of the scene's input
    gain: tuple[tuple[float, ...], ...] = ()  # kalman: M (2·dof × measured), current form
    equilibrium: tuple[float, ...] = ()  # kalman, ekf: x_eq (2·dof)
    input_equilibrium: float = 0.0  # kalman: u_eq
    process_noise: tuple[tuple[float, ...], ...] = ()  # ekf: Qn
    measurement_noise: tuple[tuple[float, ...], ...] = ()  # ekf: Rn
    input_gain: float = 1.0  # ekf: the force or torque per unit of u (a dc_motor's b)
    # The firmware entry (ipgen_<name>_step): the encoders' counts per revolution (or metre, a
    # cart's position) per measured coordinate, all > 0, else () and no entry; the measured
    # coordinates' values where the counts are zero (the scene's initial pose); True when
    # coordinate 0 is a cart's position (Δ = 1 / resolution m instead of 2π / resolution rad).
    resolution: tuple[float, ...] = ()
    counts_zero: tuple[float, ...] = ()
    cart: bool = False
    # The parameters the loop was designed with, the motor folded in (Pendulum.folded().params()):
    # the swing-up's energy law and the EKF read them, so the firmware entry needs no arguments.
    params: dict[str, tuple[float, ...] | float] | None = None
