"""A DC-motor-driven single pendulum worked out by hand, for the header tests of the motor
(tests/test_actuator.py: the C++ DcMotor; tests/test_motor_c.py: the C header's): the
manufacturer's torque (or force) and the rotor's reflected inertia added to the mechanics by
hand, not through ipgen's Actuator."""

from __future__ import annotations

import numpy as np

from ipgen.control.linear import dynamics
from ipgen.model.pendulum import Pendulum
from ipgen.model.system import System


def flat_parameters(system, m, l, delta, g, links=None):  # noqa: E741
    """`Dynamics`' flat parameters of these values (the Pendulum's `flat`)."""
    return Pendulum(system.type, system.links, m, l, delta, g, system.inertia, **(links or {})).flat()


# An SRV02-like motor and gearbox: Rm [Ω], kt [N m/A], km [V s/rad], Kg, ηg, ηm, Jm [kg m²], r [m].
RM, KT, KM, KG, ETA_G, ETA_M, JM, R = 2.6, 0.0077, 0.0075, 3.71, 0.9, 0.69, 3.9e-7, 6.35e-3
MOTOR = (RM, KT, KM, KG, ETA_G, ETA_M, JM)  # the motor struct's order; a cart adds R
Q, QD, VOLTS = np.array([0.3, -0.2]), np.array([1.5, -2.0]), 4.0  # the state and voltage tested


def rig(kind: str) -> tuple[list[float], list[float], list[float], list[float]]:
    """(m, l, delta, J) of the one-link system driven by the motor."""
    return [0.5, 0.2], [0.3 if kind == "rotary" else 0.0, 0.6], [0.2, 0.003], [0.004, 0.007]


def accelerations_by_hand(kind: str) -> np.ndarray:
    """θ̈ at (Q, QD) under VOLTS: rotary τ = ηg Kg ηm kt (V − Kg km θ̇0)/Rm with ηg Kg² Jm on the
    arm; cart F = ηg Kg ηm kt (V − Kg km ẋ/r)/(Rm r) with ηg Kg² Jm / r² on the cart."""
    m, l, delta, j = rig(kind)  # noqa: E741
    if kind == "rotary":
        force = ETA_G * KG * ETA_M * KT * (VOLTS - KG * KM * QD[0]) / RM
        m_hand, j_hand = m, [j[0] + ETA_G * KG**2 * JM, j[1]]
    else:
        force = ETA_G * KG * ETA_M * KT * (VOLTS - KG * KM * QD[0] / R) / (RM * R)
        m_hand, j_hand = [m[0] + ETA_G * KG**2 * JM / R**2, m[1]], j
    system = System(kind, 1)  # type: ignore[arg-type]
    params = flat_parameters(system, m_hand, l, delta, 9.81, {"J": j_hand})
    return dynamics(system).forward_dynamics(Q, QD, force, params)
