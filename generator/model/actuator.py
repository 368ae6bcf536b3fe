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
import numbers
from collections.abc import Callable, Mapping
from dataclasses import dataclass, fields
from decimal import Decimal
from typing import Any

from ipgen.common.safetext import abbreviate
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


MOTOR_TERM_RANGE = 1e100  # the motor's b, c and reflected inertia stay within [1e-100, 1e100]


class ActuatorError(Error, ValueError):
    """An actuator that cannot be used; the message names the constant and the fix."""


@dataclass(frozen=True)
class Actuator:
    """The base's drive, for the `actuator=` argument of `ipgen.derive`, `linearize` and `lqr`.

    Parameters
    ----------
    kind : {"direct", "dc_motor", "acceleration"}
        direct: u is the force [N] on the cart or the torque [N m] on the arm (the paper's
        model; every other field unused). dc_motor: u is the motor voltage [V]. acceleration:
        u is the base's acceleration θ̈0 [m/s² on a cart, rad/s² on an arm], imposed by a servo
        (no constants).
    Rm, kt, km : float
        dc_motor, required: armature resistance [Ω], torque constant [N m/A], back-EMF
        constant [V s/rad].
    Kg, eta_g, eta_m : float
        dc_motor: gear ratio (motor turns per output turn), gearbox and motor efficiencies in
        (0, 1]; default 1.
    Jm : float
        dc_motor: rotor inertia [kg m²], default 0.
    r : float
        dc_motor on a cart, required there: the pinion radius [m]; refused on an arm.

    Raises
    ------
    ActuatorError
        (an `ipgen.Error`, one line) when used on a system it cannot drive (`check`): a missing
        or non-physical constant, r on an arm, an unknown kind.

    Examples
    --------
    >>> import ipgen
    >>> motor = ipgen.Actuator("dc_motor", Rm=8.4, kt=0.042, km=0.042)
    >>> ipgen.derive("rotary", 1, actuator=motor).system.links
    1
    """

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
        """Whether u is a DC motor's voltage (kind "dc_motor")."""
        return self.kind == "dc_motor"

    @property
    def is_acceleration(self) -> bool:
        """u is the base's acceleration θ̈0 (the base coordinate is kinematic)."""
        return self.kind == "acceleration"

    def unit(self, system: str) -> str:
        """u's unit on `system` ("classical": a cart, else an arm or a fixed chain's joints): V for
        a DC motor, the base's acceleration's for "acceleration", else a force's or a torque's."""
        if self.is_motor:
            return "V"
        if self.is_acceleration:
            return "m/s²" if system == "classical" else "rad/s²"
        return "N" if system == "classical" else "N m"

    def check(self, system: System) -> None:
        """Check that this actuator can drive `system`.

        Parameters
        ----------
        system : System
            The cart or arm it drives (a motor's lever r applies to a cart only).

        Raises
        ------
        ActuatorError
            One line naming the problem: an unknown kind, a motor constant without a motor, a
            missing or non-positive constant.
        """
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
            value = _constant(name, value)
            if not math.isfinite(value):
                raise ActuatorError(f"actuator {name} = {value}: must be a finite number")
            if name in ("eta_g", "eta_m") and not 0 < value <= 1:
                raise ActuatorError(f"actuator {name} = {value:g}: an efficiency is in (0, 1]")
            if name == "Jm" and value < 0:
                raise ActuatorError(f"actuator Jm = {value:g}: an inertia cannot be negative (0 for none)")
            if name not in ("eta_g", "eta_m", "Jm") and value <= 0:
                raise ActuatorError(f"actuator {name} = {value:g}: must be > 0 [{MOTOR_CONSTANTS[name][0]}]")
        for what, value in (
            ("gain", _or_inf(self.gain)),  # inf past 1.8e308 (or OverflowError from a huge int)
            ("back-EMF damping", _or_inf(self.damping)),
            ("rotor inertia", _or_inf(self.inertia)),
        ):
            if not math.isfinite(value):
                raise ActuatorError(
                    f"the motor's {what} overflows a double ({value}): check Rm, kt, km, Kg, Jm and r"
                )
            # Gains in volts divide by b and weights by b²: outside this range they over- or underflow.
            if value > MOTOR_TERM_RANGE or (what == "gain" and value < 1 / MOTOR_TERM_RANGE):
                raise ActuatorError(
                    f"the motor's {what} is {value:.3g}, outside [{1 / MOTOR_TERM_RANGE:g}, "
                    f"{MOTOR_TERM_RANGE:g}]: check the units of Rm, kt, km, Kg, Jm and r"
                )

    def constants(self) -> dict[str, float]:
        """The motor's constants by name (`MOTOR_CONSTANTS`; r only when given, i.e. on a cart).

        Returns
        -------
        dict
            {"Rm": ..., "kt": ..., ...}: what `motor_terms` takes.

        Examples
        --------
        >>> sorted(Actuator("dc_motor", Rm=8.4, kt=0.042, km=0.042).constants())
        ['Jm', 'Kg', 'Rm', 'eta_g', 'eta_m', 'km', 'kt']
        """
        # as floats: a Decimal or numpy constant (check() takes them) would not mix with the floats
        given = {name: getattr(self, name) for name in MOTOR_CONSTANTS}
        return {name: _constant(name, value) for name, value in given.items() if value is not None}

    def gain(self) -> float:
        """b: the generalised force on θ0 per unit of u (1 for "direct"; N m/V or N/V)."""
        return motor_terms(self.constants())[0] if self.is_motor else 1.0

    def damping(self) -> float:
        """c: the back-EMF's damping on θ0 (N m s/rad on an arm, N s/m on a cart; 0 for "direct")."""
        return motor_terms(self.constants())[1] if self.is_motor else 0.0

    def inertia(self) -> float:
        """The rotor's inertia reflected to θ0: η_g K_g² J_m [kg m²] (arm), / r² [kg] (cart)."""
        return motor_terms(self.constants())[2] if self.is_motor else 0.0


def motor_terms(constants: Mapping[str, Any]) -> tuple[Any, Any, Any]:
    """(b, c, I_r) of a DC motor: the input gain, the back-EMF damping and the rotor's reflected
    inertia (module docstring), in whatever arithmetic the constants are: floats, Fractions or
    sympy expressions. This is the motor's one formula; everything that folds a motor into the
    direct model (`fold_base`, `Actuator.gain`, the derivation's sympy views, a scene's exact
    values, the identification model) computes it here.

    Parameters
    ----------
    constants : mapping
        Rm, kt, km (required), Kg, eta_g, eta_m (default 1), Jm (default 0) and r: the pinion
        radius of a cart; absent or None on an arm.

    Returns
    -------
    tuple
        (b, c, I_r): b = η_g K_g η_m k_t / R_m (/ r on a cart), c = b K_g k_m (/ r on a cart),
        I_r = η_g K_g² J_m (/ r² on a cart).

    Raises
    ------
    KeyError
        Rm, kt or km missing (an `Actuator` checks them before it calls this).

    Examples
    --------
    >>> from fractions import Fraction
    >>> motor_terms({"Rm": Fraction(8), "kt": Fraction(1, 2), "km": Fraction(1, 2)})
    (Fraction(1, 16), Fraction(1, 32), 0)
    """
    kg, eta_g, eta_m = constants.get("Kg", 1), constants.get("eta_g", 1), constants.get("eta_m", 1)
    radius = constants.get("r")
    # The operations in the order the float results have always had (byte-identical outputs). The
    # headers print these operations as they are (codegen/motor.py): squares are products, which
    # round correctly everywhere (libm's pow(x, 2), Python's float x**2, is off by one bit for
    # about 1 in 1500 doubles with glibc 2.36) and are what C compilers make of pow(x, 2) anyway.
    gain = eta_g * kg * eta_m * constants["kt"] / constants["Rm"]
    if radius is not None:
        gain = gain / radius
    damping = gain * kg * constants["km"]
    if radius is not None:
        damping = damping / radius
    inertia = eta_g * (kg * kg) * constants.get("Jm", 0)
    if radius is not None:
        inertia = inertia / (radius * radius)
    return gain, damping, inertia


def fold_base(
    constants: Mapping[str, Any], rotary: bool, m0: Any, delta0: Any, J0: Any
) -> tuple[Any, Any, Any, Any]:
    """(m0, δ0, J0, b) of the direct model a DC motor with `constants` is (`motor_terms`).

    Parameters
    ----------
    constants : mapping
        The motor's constants, as for `motor_terms`.
    rotary : bool
        True for an arm (the rotor's inertia adds to J0), False for a cart (to m0).
    m0, delta0, J0
        The base's mass, damping and inertia (J0: the arm's about the vertical; a cart's unused).

    Returns
    -------
    tuple
        (m0, δ0 + c, J0 + I_r, b) on an arm, (m0 + I_r, δ0 + c, J0, b) on a cart, in the
        arithmetic of the arguments (floats, Fractions, sympy: exact where they are).

    Raises
    ------
    KeyError
        Rm, kt or km missing from `constants`.

    Examples
    --------
    >>> from fractions import Fraction as F
    >>> fold_base({"Rm": F(8), "kt": F(1, 2), "km": F(1, 2), "Jm": F(1, 100)}, True, F(1), F(0), F(1, 10))
    (Fraction(1, 1), Fraction(1, 32), Fraction(11, 100), Fraction(1, 16))
    """
    gain, damping, inertia = motor_terms(constants)
    if rotary:
        return m0, delta0 + damping, J0 + inertia, gain
    return m0 + inertia, delta0 + damping, J0, gain


DIRECT = Actuator()


def _constant(name: str, value: Any) -> float:
    """A motor constant as a float: a real number (Decimal and numpy's included), else one line
    (text, bools and complex numbers are not constants; an integer beyond a double is refused)."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real | Decimal):
        raise ActuatorError(f"actuator {name} = {value!r}: expected a number [{MOTOR_CONSTANTS[name][0]}]")
    try:
        return float(value)
    except OverflowError:
        raise ActuatorError(f"actuator {name} = {abbreviate(str(value))}: too large for a double") from None


def _or_inf(value: Callable[[], float]) -> float:
    """value(), or inf where it overflows a double (OverflowError: an int too large for a float)."""
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
        return Actuator(**{k: (v if k == "kind" or v is None else _constant(k, v)) for k, v in value.items()})
    raise ActuatorError(f"actuator must be an ipgen Actuator, a dict or None, got {type(value).__name__}")


def fold(
    actuator: Actuator, system: System, m: list[float], delta: list[float], J: list[float]
) -> tuple[list[float], list[float], list[float], float]:
    """(m, delta, J, b) of the equivalent direct model (`fold_base`): δ0 + c, the reflected
    inertia on m0 (cart) or J0 (arm; `J` has every entry, the rods' filled in), and the input
    gain b. kind "acceleration" has no equivalent direct model: ActuatorError."""
    actuator.check(system)
    if actuator.is_acceleration:
        raise ActuatorError("an acceleration-driven base is not a folded direct model (see reduced_dynamics)")
    m, delta, J = list(m), list(delta), list(J)
    if not actuator.is_motor:
        return m, delta, J, 1.0
    m[0], delta[0], J[0], gain = fold_base(actuator.constants(), system.is_rotary, m[0], delta[0], J[0])
    return m, delta, J, gain
