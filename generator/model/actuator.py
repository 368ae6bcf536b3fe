"""What drives the base: the input u as a force or torque ("direct"), a DC motor's voltage
("dc_motor") or the base's commanded acceleration ("acceleration").

A permanent-magnet DC motor through a gear (ratio Kg, efficiency eta_g) on the arm, or through a
gear and a pinion of radius r on the cart, as the manufacturers' manuals model it (Quanser's
SRV02, IP02 and QUBE-Servo courseware), armature inductance neglected (its time constant
L/R is ~0.1 ms, far below the pendulum's):

    rotary:  τ = η_g K_g η_m k_t (V − K_g k_m θ̇0) / R_m,   reflected inertia η_g K_g² J_m on the arm
    cart:    F = η_g K_g η_m k_t (V − K_g k_m ẋ/r) / (R_m r), reflected mass   η_g K_g² J_m / r²

Both are exact rewrites of the mechanical model: with b = η_g K_g η_m k_t / R_m (rotary) or
/(R_m r) (cart) the generalised force is b·V − c·θ̇0 with c = b K_g k_m (rotary) or b K_g k_m / r
(cart). So a motor is the direct model with the input scaled by b, the base damping δ0 raised
by c and the base inertia (J0 of the arm, m0 of the cart) raised by the reflected rotor inertia
(`fold`). docs/model.md, "A DC motor on the base", derives it.

kind "acceleration" (servo-driven rigs: the base follows a commanded acceleration u = θ̈0,
[m/s²] on a cart, [rad/s²] on an arm) is not a fold: the base coordinate becomes kinematic and
the links follow from the link rows of M θ̈ + b = e0 τ, θ̈_L = −M_LL⁻¹ (M_L0 u + b_L); the base
force that realises it is τ = M_0· θ̈ + b_0 (docs/model.md, "An acceleration-driven base").
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, fields

from ipgen.errors import Error
from ipgen.model.system import System

ACTUATOR_KINDS: tuple[str, ...] = ("direct", "dc_motor", "acceleration")
# The motor constants, their units and whether they have a default (None: required).
MOTOR_CONSTANTS: dict[str, tuple[str, float | None]] = {
    "Rm": ("Ω, armature resistance", None),
    "kt": ("N m/A, torque constant", None),
    "km": ("V s/rad, back-EMF constant", None),
    "Kg": ("gear ratio (motor turns per output turn)", 1.0),
    "eta_g": ("gearbox efficiency", 1.0),
    "eta_m": ("motor efficiency", 1.0),
    "Jm": ("kg m², rotor inertia", 0.0),
    "r": ("m, pinion radius (cart only)", None),
}


class ActuatorError(Error, ValueError):
    """An actuator that cannot be used; the message names the constant and the fix."""


@dataclass(frozen=True)
class Actuator:
    """The base's drive. kind "direct": u is the force [N] on the cart or torque [N m] on the
    arm (the paper's model; every other field unused). kind "dc_motor": u is the motor voltage
    [V]; Rm, kt, km are required, Kg, eta_g, eta_m default to 1, Jm to 0; r (pinion radius)
    is required on a cart and refused on an arm. kind "acceleration": u is the base's
    acceleration θ̈0 [m/s² on a cart, rad/s² on an arm], imposed by a servo; no constants."""

    kind: str = "direct"
    Rm: float | None = None
    kt: float | None = None
    km: float | None = None
    Kg: float = 1.0
    eta_g: float = 1.0
    eta_m: float = 1.0
    Jm: float = 0.0
    r: float | None = None

    @property
    def is_motor(self) -> bool:
        return self.kind == "dc_motor"

    @property
    def is_acceleration(self) -> bool:
        """u is the base's acceleration θ̈0 (the base coordinate is kinematic)."""
        return self.kind == "acceleration"

    def check(self, system: System) -> None:
        """ActuatorError (one line) unless this actuator can drive `system`."""
        if self.kind not in ACTUATOR_KINDS:
            raise ActuatorError(
                f"actuator kind {self.kind!r}: expected 'direct' or 'dc_motor' (u a force or a voltage) "
                "or 'acceleration' (u the base's acceleration)"
            )
        given = [f.name for f in fields(self) if f.name != "kind" and getattr(self, f.name) != f.default]
        if not self.is_motor:
            if given:
                raise ActuatorError(
                    f"actuator constant {given[0]} applies to kind 'dc_motor' only: "
                    "remove it or set kind = 'dc_motor'"
                )
            return
        for name in ("Rm", "kt", "km"):
            if getattr(self, name) is None:
                raise ActuatorError(f"a dc_motor needs {name} [{MOTOR_CONSTANTS[name][0]}]")
        if system.is_rotary and self.r is not None:
            raise ActuatorError("actuator r (pinion radius) is for a cart: a rotary arm is driven directly")
        if not system.is_rotary and self.r is None:
            raise ActuatorError("a dc_motor on a cart needs r, the pinion radius [m]")
        for name in MOTOR_CONSTANTS:
            value = getattr(self, name)
            if value is None:
                continue
            if not math.isfinite(value):
                raise ActuatorError(f"actuator {name} = {value}: must be a finite number")
            if name in ("eta_g", "eta_m") and not 0 < value <= 1:
                raise ActuatorError(f"actuator {name} = {value:g}: an efficiency is in (0, 1]")
            if name == "Jm" and value < 0:
                raise ActuatorError(f"actuator Jm = {value:g}: an inertia cannot be negative (0 for none)")
            if name not in ("eta_g", "eta_m", "Jm") and value <= 0:
                raise ActuatorError(f"actuator {name} = {value:g}: must be > 0 [{MOTOR_CONSTANTS[name][0]}]")
        for what, value in (
            ("gain", self.gain()),
            ("back-EMF damping", self.damping()),
            ("rotor inertia", _or_inf(self.inertia)),  # Kg**2 raises OverflowError past 1.8e308
        ):
            if not math.isfinite(value):
                raise ActuatorError(
                    f"the motor's {what} overflows a double ({value}): check Rm, kt, km, Kg, Jm and r"
                )

    def gain(self) -> float:
        """b: the generalised force on θ0 per unit of u (1 for "direct"; N m/V or N/V)."""
        if not self.is_motor:
            return 1.0
        assert self.Rm is not None and self.kt is not None
        b = self.eta_g * self.Kg * self.eta_m * self.kt / self.Rm
        return b / self.r if self.r is not None else b

    def damping(self) -> float:
        """c: the back-EMF's damping on θ0 (N m s/rad on an arm, N s/m on a cart; 0 for "direct")."""
        if not self.is_motor:
            return 0.0
        assert self.km is not None
        c = self.gain() * self.Kg * self.km
        return c / self.r if self.r is not None else c

    def inertia(self) -> float:
        """The rotor's inertia reflected to θ0: η_g K_g² J_m [kg m²] (arm), / r² [kg] (cart)."""
        if not self.is_motor:
            return 0.0
        reflected = self.eta_g * self.Kg**2 * self.Jm
        return reflected / self.r**2 if self.r is not None else reflected


DIRECT = Actuator()


def _or_inf(value: Callable[[], float]) -> float:
    """value(), or inf where a power overflows a double."""
    try:
        return value()
    except OverflowError:
        return math.inf


def as_actuator(value: Actuator | dict | None) -> Actuator:
    """An `Actuator` from one, a dict of its fields ({"kind": "dc_motor", "Rm": 8.4, ...}) or None
    (direct)."""
    if value is None:
        return DIRECT
    if isinstance(value, Actuator):
        return value
    if isinstance(value, dict):
        known = {f.name for f in fields(Actuator)}
        unknown = sorted(set(value) - known)
        if unknown:
            raise ActuatorError(
                f"unknown actuator constant {unknown[0]!r}: expected kind, {', '.join(MOTOR_CONSTANTS)}"
            )
        try:
            numbers = {k: (v if k == "kind" or v is None else float(v)) for k, v in value.items()}
        except (TypeError, ValueError):
            raise ActuatorError("actuator constants must be numbers") from None
        return Actuator(**numbers)
    raise ActuatorError(f"actuator must be an ipgen Actuator, a dict or None, got {type(value).__name__}")


def fold(
    actuator: Actuator, system: System, m: list[float], delta: list[float], J: list[float]
) -> tuple[list[float], list[float], list[float], float]:
    """(m, delta, J, b) of the equivalent direct model: δ0 + c, the reflected inertia on m0
    (cart) or J0 (arm; `J` has every entry, the rods' filled in), and the input gain b.
    kind "acceleration" has no equivalent direct model: ActuatorError."""
    actuator.check(system)
    if actuator.is_acceleration:
        raise ActuatorError("an acceleration-driven base is not a folded direct model (see reduced_dynamics)")
    m, delta, J = list(m), list(delta), list(J)
    delta[0] += actuator.damping()
    if system.is_rotary:
        J[0] += actuator.inertia()
    else:
        m[0] += actuator.inertia()
    return m, delta, J, actuator.gain()
