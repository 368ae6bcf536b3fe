"""Åström–Furuta energy control: swing a single link up, then catch it with LQR.

For a single pendulum (classical or rotary, links = 1) the link's energy relative to upright,

    E = ½ J θ̇1² + w (cos θ1 − 1),   J = J1 + m1 com1² + tip1 l1²,   w = g (m1 com1 + tip1 l1)

(J the link's inertia about its pivot, w its gravity moment's amplitude, the links as built of
docs/links.md; the paper's rod: J = m1 l1²/3, w = ½ m1 g l1) is 0 upright at rest and −2w
hanging at rest. The law commands a base acceleration a
(cart [m/s²] or arm [rad/s²]): with M θ̈ + bias = B u, the link's row gives
J θ̈1 − w sin θ1 = −M10 a − (damping and centrifugal terms), so Ė = −θ̇1 M10 a + …, and

    a = sat_{a_max}( k_E (E − E0) sign(θ̇1 M10) ) − k_x θ0 − k_v θ̇0

pumps energy in while E < E0 (Åström & Furuta 2000), the last two terms keep the cart or arm
near θ0 = 0. The force or torque that produces a is exact (ipgen's M and bias at the measured
state): θ̈1 = −(M10 a + bias1)/M11, u = M00 a + M01 θ̈1 + bias0, then clipped to |u| ≤ u_max.

The law plans nothing: M and bias come from CasADi's graph when CasADi is installed (the
swing-up extra), else from the same derivation evaluated with numpy, and the hold gain from the
exact one-period flow map (CasADi) or, without it, from the linear model discretised exactly for
a zero-order hold (matrix exponential): the energy method runs without CasADi.

Catch region: once |θ1 − 2πk| ≤ `catch_angle` (the nearest upright) and |θ̇1| ≤ `catch_rate`
(and, where set, E ≥ −`catch_deficit` and |θ0| ≤ `catch_base`), the controller switches to the
discrete LQR hold (`discrete_lqr`, same period) about that upright and stays there ("swing" →
"hold"), or with `release_angle` swings again once the link falls more than that from it
("hold" → "swing").

Each sample runs the law as written once in C (cpp/include/ipgen_loop.h's ipgen_loop_swingup_step,
the code of the firmware header and the simulator) through ctypes (`ipgen.common.loop_runtime`,
compiled on first use with the C compiler); Python holds the constants and the model.
"""

from __future__ import annotations

import ctypes
import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from ipgen.common.loop_runtime import (
    MASS_BIAS,
    PHASES,
    EnergyLaw,
    SwingUp,
    SwingUpState,
    address,
    library,
    swingup_work,
)
from ipgen.control.casadi_model import Plant, as_plant, casadi_model
from ipgen.control.linear import ControlError, discrete_lqr_gain, dynamics, linearize, weights
from ipgen.control.trajectory import PlanError, finite_number
from ipgen.control.tvlqr import discrete_lqr
from ipgen.model.pendulum import Pendulum

if TYPE_CHECKING:
    import numpy as np

__all__ = [
    "LAWS",
    "EnergySwingUp",
    "discrete_acceleration_lqr",
    "discrete_zoh_lqr",
    "energy_swingup",
    "link_constants",
    "link_energy",
    "mass_and_bias",
]

LAWS: tuple[str, ...] = ("energy", "proportional")  # ipgen's constants | Quanser's (energy_swingup)
QUANSER_GAIN = 50.0  # μ [m/s² per J at the arm tip]: Quanser's QUBE-Servo 2 swing-up lab
QUANSER_ACCEL = 6.0  # a_max [m/s² at the arm tip]: the same lab
ROD_TOLERANCE = 1e-12  # relative: com1 and J1 this near the rod's are the rod (link_constants)


def link_constants(plant: Plant) -> tuple[float, float]:
    """(J, w) of link 1's energy E = ½ J θ̇1² + w (cos θ1 − 1) (module docstring).

    Parameters
    ----------
    plant : Plant
        The planners' view of the pendulum, its links as built filled in.

    Returns
    -------
    tuple of (float, float)
        J = J1 + m1 com1² + tip1 l1², the link's inertia about its pivot [kg m²], and
        w = g (m1 com1 + tip1 l1) [J]. For the paper's rod (com1 = l1/2, J1 = m1 l1²/12 within
        ROD_TOLERANCE, as a rod's J written out as a decimal is; no tip) the rod's own
        expressions m1 l1²/3 and ½ m1 g l1, as ipgen computed them before the links as built, to
        the last bit: a scene's .cfg keeps its numbers.
    """
    m1, l1, g = plant.m[1], plant.l[1], plant.g
    built = plant.links_as_built
    com, inertia, tip = built["com"][1], built["J"][1], built["tip"][1]
    rod = math.isclose(com, l1 / 2, rel_tol=ROD_TOLERANCE) and tip == 0
    if rod and math.isclose(inertia, m1 * l1**2 / 12, rel_tol=ROD_TOLERANCE):
        return m1 * l1**2 / 3, 0.5 * m1 * g * l1
    return inertia + m1 * com**2 + tip * l1**2, g * (m1 * com + tip * l1)


def link_energy(plant: Plant, x: np.ndarray) -> float:
    """E of link 1 relative to upright at rest [J] (module docstring)."""
    inertia, weight = link_constants(plant)
    dof = plant.dof
    return 0.5 * inertia * float(x[dof + 1]) ** 2 + weight * (math.cos(float(x[1])) - 1.0)


@dataclass
class EnergySwingUp:
    """The sampled energy controller with its LQR catch; `control(k, x)` → (u, phase).

    Python holds the design (the constants below, the plant, the hold gain); each `control`
    runs cpp/include/ipgen_loop.h's swing-up (ipgen_loop_swingup_step: the catch test, the
    energy law, the hold) through ctypes (`ipgen.common.loop_runtime`), with M and bias from
    `mass_and_bias` called back from C.
    """

    plant: Plant
    u_max: float
    period: float
    hold_gain: np.ndarray
    gain_energy: float  # k_E [(m/s² or rad/s²) per J]
    gain_position: float  # k_x [1/s²]
    gain_velocity: float  # k_v [1/s]
    accel_max: float  # a_max of the energy term
    catch_angle: float  # rad
    catch_rate: float  # rad/s
    energy_target: float = 0.0  # E0 [J]
    acceleration: bool = False  # u is the base's acceleration ([actuator] kind "acceleration"): u = a
    release_angle: float = 0.0  # rad: the hold gives the link back to the swing beyond it (0: never)
    energy_step: float = 0.0  # J: the target's learning step (0: E0 fixed; energy_swingup's docstring)
    catch_deficit: float = 0.0  # J: a catch needs E >= -catch_deficit (0: any E)
    catch_base: float = 0.0  # rad or m: a catch needs |θ0| <= catch_base (0: anywhere)
    # ipgen_loop_swingup_state (the phase, the upright held); None until the first `control`
    _state: SwingUpState | None = field(default=None, init=False, repr=False, compare=False)
    _callback: Any = field(default=None, init=False, repr=False, compare=False)  # MASS_BIAS on the plant
    _failure: list[BaseException] = field(default_factory=list, init=False, repr=False, compare=False)
    # link_constants(plant), once: `control` runs every sample, and each Plant field it reads
    # folds the pendulum's parameters again
    _link: tuple[float, float] | None = field(default=None, init=False, repr=False, compare=False)

    def reset(self) -> None:
        """Start over: the next `control` swings (the catch forgotten)."""
        self._state = None

    def _mass_bias(self, context: Any, q: Any, qd: Any, mass: Any, bias: Any) -> int:
        """ipgen_loop_mass_bias on `mass_and_bias` (M row-major, bias), 1 if it raises."""
        import numpy as np

        dof = self.plant.dof
        try:
            angles = np.ctypeslib.as_array(q, shape=(dof,)).copy()
            m, b = mass_and_bias(self.plant, angles, np.ctypeslib.as_array(qd, shape=(dof,)).copy())
            np.ctypeslib.as_array(mass, shape=(dof * dof,))[:] = np.asarray(m, dtype=float).reshape(-1)
            np.ctypeslib.as_array(bias, shape=(dof,))[:] = np.asarray(b, dtype=float).reshape(-1)
        except Exception as exc:  # raised by control, after C returns
            self._failure.append(exc)
            return 1
        return 0

    def control(self, k: int, x: np.ndarray) -> tuple[float, str]:
        """The input at sample k for the state x (module docstring), and the phase.

        Parameters
        ----------
        k : int
            The sample (the energy law does not use it).
        x : array_like
            The state [θ; θ̇] (2·dof, ipgen's coordinates).

        Returns
        -------
        tuple of (float, str)
            u, clipped to ±u_max, and "swing" or "hold" (caught: the LQR hold from then on, but
            for a release past `release_angle`).
        """
        import numpy as np

        dof = self.plant.dof
        state = np.array(x, dtype=float).reshape(2 * dof)
        hold = np.array(self.hold_gain, dtype=float).reshape(2 * dof)
        target = np.zeros(2 * dof)  # upright at rest; the caught turn replaces θ1
        work = np.zeros(swingup_work(dof))
        if self._link is None:
            self._link = link_constants(self.plant)
        inertia, weight = self._link
        # link_energy's J and w; input gain 1: u is the force or torque itself
        energy = EnergyLaw(
            self.gain_energy, self.gain_position, self.gain_velocity, self.accel_max, self.catch_angle,
            self.catch_rate, self.energy_target, inertia, weight, int(self.acceleration),
            1.0, self.energy_step, self.catch_deficit, self.catch_base,
        )  # fmt: skip
        if self._callback is None:
            self._callback = MASS_BIAS(self._mass_bias)
        law = SwingUp(
            dof, self.u_max, address(hold), address(target), energy, 0, None, None, None, self._callback,
            None, None, None, None, 0, self.release_angle, None,
        )  # fmt: skip
        run = library()
        if self._state is None:
            self._state = SwingUpState()
            run.ipgen_loop_swingup_start(ctypes.byref(law), ctypes.byref(self._state))
        self._failure.clear()
        u = run.ipgen_loop_swingup_step(
            ctypes.byref(law), ctypes.byref(self._state), address(state), address(work)
        )
        if self._failure:
            raise self._failure[0]
        return float(u), PHASES[self._state.phase]


def energy_swingup(
    plant: Plant | Pendulum,
    *,
    u_max: float,
    period: float = 0.01,
    gain_energy: float | None = None,
    gain_position: float | None = None,
    gain_velocity: float | None = None,
    accel_max: float | None = None,
    catch_angle: float = 0.3,
    catch_rate: float = 3.0,
    q: np.ndarray | list[float] | None = None,
    r: float = 1.0,
    acceleration: bool = False,
    energy_target: float | None = None,
    design_speed: float = 0.0,
    law: str = "energy",
    release_angle: float | None = None,
    energy_step: float = 0.0,
    catch_deficit: float = 0.0,
    catch_base: float = 0.0,
) -> EnergySwingUp:
    """The energy swing-up of a single pendulum (`plant.links == 1`) with its discrete LQR catch.

    Defaults scale with the plant: a_max = u_max / M00 at hanging rest (the base acceleration
    the input limit buys), k_E = 10 a_max / (2w) so that the energy term saturates until
    E is within a tenth of the hanging pendulum's deficit, k_x and k_v a slow second-order
    centring (ω = 1 rad/s, ζ = 1). `q` and `r` weigh the hold LQR (default Q = I, R = 1).
    `acceleration`: u is the base's acceleration ([actuator] kind "acceleration"): the law's a
    is the input (clipped to u_max), a_max defaults to u_max, and the hold LQR is that of the
    acceleration-driven linear model (`discrete_acceleration_lqr`).
    `plant`: a `Plant` or an `ipgen.Pendulum` ("direct" or "acceleration" drive: a Pendulum's
    drive sets `acceleration`).

    `design_speed` ω_d [m/s or rad/s of the base, ≥ 0]: a_max (when not given) is the base
    acceleration the input buys while the base moves at ω_d, (u_max − δ0 ω_d) / M00, where δ0
    is the base's viscous damping of `plant` (for a dc_motor's folded model: the arm's damping
    plus the back-EMF kt km / Rm). ω_d = 0 (default) gives the stall acceleration.
    `energy_target` E0 [J, relative to upright at rest; default 0].
    `release_angle` [rad, catch_angle < it < π/2; default None: the hold is for good]: a hold that
    lets the link fall more than this from the upright it caught gives it back to the energy law,
    which swings it up for another catch.
    `energy_step` [J, ≥ 0; default 0: E0 fixed]: the law learns its target on a rig unlike its
    model. Entering the catch window (|θ1| ≤ catch_angle) faster than catch_rate lowers the
    target by this step; a swing that turns short of the window, above the horizontal and no
    nearer upright than the last turn (by more than catch_angle / 10), raises it
    (cpp/include/ipgen_loop.h, ipgen_loop_energy_learn).
    `catch_deficit` [J, ≥ 0; default 0: any E] and `catch_base` [rad or m, ≥ 0; default 0:
    anywhere]: a catch also needs E ≥ −catch_deficit (a link too slow to reach upright is left
    to the swing) and |θ0| ≤ catch_base (the hold starts with room to brake the base).

    `law = "proportional"`: Quanser's form of the same law (QUBE-Servo 2 swing-up lab), its
    constants in the rig's units at the base's tip (the arm's tip at l0 for a rotary base, the
    cart for a classical one): a_tip = sat_{a_max}(μ (E_r − E) sign(θ̇1 cos θ1)) with
    μ = `gain_energy` [m/s² per J, default 50], a_max = `accel_max` [m/s², default 6] and
    E_r = `energy_target` [J above hanging at rest, default 2w: upright]. They map onto the
    law above exactly: k_E = μ / l0, a_max / l0 and E0 = E_r − 2w (rotary; l0 → 1 for a
    cart). The input that produces the acceleration is ipgen's exact one (module docstring).
    """
    import numpy as np

    if isinstance(plant, Pendulum):
        acceleration = plant.actuator.is_acceleration
    try:
        plant = as_plant(plant, "the energy swing-up")
    except ControlError as exc:
        raise PlanError(str(exc)) from None
    if plant.links != 1:
        raise PlanError(
            f'energy swing-up is for a single link, this system has {plant.links}; use method "trajectory"'
        )
    for name, value, positive in (
        ("u_max", u_max, True),
        ("period", period, True),
        ("catch_angle", catch_angle, True),
        ("catch_rate", catch_rate, True),
    ):
        number = finite_number(name, value)
        if positive and number <= 0:
            raise PlanError(f"{name} = {value!r}: expected a finite number > 0")
    if not float(catch_angle) < math.pi / 2:
        raise PlanError(
            f"catch_angle = {catch_angle!r}: expected less than π/2 rad (a catch that wide takes a link "
            "below the horizontal, and the simulator stops a hold past π/2)"
        )
    release = 0.0 if release_angle is None else finite_number("release_angle", release_angle)
    if release_angle is not None and not float(catch_angle) < release < math.pi / 2:
        raise PlanError(
            f"release_angle = {release_angle!r}: expected more than catch_angle ({float(catch_angle):g} rad) "
            f"and less than π/2 rad (the simulator stops a hold past π/2)"
        )
    g = plant.g
    if not g > 0:  # k_E below divides by g: no gravity, no energy to pump
        raise PlanError(f'energy swing-up needs gravity: g = {g:g}; use method "trajectory"')
    if law not in LAWS:
        raise PlanError(f"law = {law!r}: expected {' or '.join(map(repr, LAWS))}")
    step = finite_number("energy_step", energy_step)
    if step < 0:
        raise PlanError(f"energy_step = {energy_step!r}: expected a finite number >= 0 (0: E0 fixed)")
    gates = {"catch_deficit": catch_deficit, "catch_base": catch_base}
    for name, value in gates.items():
        gates[name] = finite_number(name, value)
        if gates[name] < 0:
            raise PlanError(f"{name} = {value!r}: expected a finite number >= 0 (0: no such condition)")
    speed = finite_number("design_speed", design_speed)
    if speed < 0:
        raise PlanError(f"design_speed = {design_speed!r}: expected a finite number >= 0")
    if speed > 0 and (accel_max is not None or law == "proportional" or acceleration):
        why = (
            "accel_max is given" if accel_max is not None
            else 'law = "proportional" has its own a_max' if law == "proportional"
            else "u is the base's acceleration (a_max = u_max)"
        )  # fmt: skip
        raise PlanError(
            f"design_speed = {design_speed!r} sets a_max only when it is computed, but {why}; remove one"
        )
    if accel_max is not None and not finite_number("accel_max", accel_max) > 0:
        raise PlanError(f"accel_max = {accel_max!r}: expected a finite number > 0 (the law would never pump)")
    depth = 2 * link_constants(plant)[1]  # J: the hanging link at rest has E = −depth
    if law == "proportional":
        tip = plant.l[0] if plant.system.type == "rotary" else 1.0  # base tip travel per unit θ0
        mu = QUANSER_GAIN if gain_energy is None else finite_number("gain_energy", gain_energy)
        tip_accel = QUANSER_ACCEL if accel_max is None else finite_number("accel_max", accel_max)
        reference = depth if energy_target is None else finite_number("energy_target", energy_target)
        gain_energy, accel_max, energy_target = mu / tip, tip_accel / tip, reference - depth
    # The base acceleration the input limit buys at hanging rest (M00 there: cart plus link,
    # or the arm's inertia about the vertical with the link's mass at its tip), less what the
    # base's damping takes at the design speed.
    if accel_max is None and acceleration:
        a_max = float(u_max)
    elif accel_max is None:
        hanging = np.array([0.0, math.pi])
        inertia = float(mass_and_bias(plant, hanging, np.zeros(2))[0][0, 0])
        force = float(u_max) - plant.delta[0] * speed
        if force <= 0:
            raise PlanError(
                f"design_speed = {design_speed!r}: the base's damping takes the whole input there "
                f"(no-load speed u_max / delta0 = {float(u_max) / plant.delta[0]:.4g}); choose a lower one"
            )
        a_max = force / inertia
    else:
        a_max = finite_number("accel_max", accel_max)
    if depth == 0 and plant.m[1] * g * plant.l[1] == 0:  # g, m1 or l1 so small that m1 g l1 underflows
        raise PlanError(f"the link's potential energy m1 g l1 underflows to 0 (g = {g:g}): check g, m and l")
    if depth <= 0:  # com1 <= 0: the link's centre of mass at or beyond its pivot
        raise PlanError(
            f"the link's gravity moment g (m1 com1 + tip1 l1) = {depth / 2:.4g} J is not positive: its "
            "centre of mass lies at or beyond the pivot, so hanging is not its rest; check com[1] and tip[1]"
        )
    k_e = 10 * a_max / depth if gain_energy is None else finite_number("gain_energy", gain_energy)
    e0 = 0.0 if energy_target is None else finite_number("energy_target", energy_target)
    omega = 1.0
    k_x = omega**2 if gain_position is None else finite_number("gain_position", gain_position)
    k_v = 2 * omega if gain_velocity is None else finite_number("gain_velocity", gain_velocity)
    # accel_max first: gain_energy's default follows from it, and a message names what was given
    gains = {"accel_max": a_max, "gain_energy": k_e, "gain_position": k_x, "gain_velocity": k_v}
    for name, value in gains.items():
        if not math.isfinite(value) or value < 0:
            raise PlanError(f"{name} = {value!r}: expected a finite number >= 0")
    dof = plant.dof
    weights_q, weights_r = weights(np.ones(2 * dof) if q is None else q, r, 2 * dof)
    if acceleration:
        hold = discrete_acceleration_lqr(plant, float(period), weights_q, weights_r)
    elif _has_casadi():
        hold, _, _, _ = discrete_lqr(plant, float(period), weights_q, weights_r, np.zeros(2 * dof))
    else:
        hold = discrete_zoh_lqr(plant, float(period), weights_q, weights_r)
    if not np.all(np.isfinite(hold)):
        raise PlanError("the hold gain is not finite: a parameter is too large or too small for a double")
    return EnergySwingUp(
        plant=plant,
        u_max=float(u_max),
        period=float(period),
        hold_gain=hold,
        gain_energy=k_e,
        gain_position=k_x,
        gain_velocity=k_v,
        accel_max=a_max,
        catch_angle=float(catch_angle),
        catch_rate=float(catch_rate),
        energy_target=e0,
        acceleration=acceleration,
        release_angle=release,
        energy_step=step,
        catch_deficit=gates["catch_deficit"],
        catch_base=gates["catch_base"],
    )


def _has_casadi() -> bool:
    import importlib.util

    try:
        return importlib.util.find_spec("casadi") is not None
    except (ImportError, ValueError):  # a broken or blocked installation counts as absent
        return False


def mass_and_bias(plant: Plant, q: np.ndarray, qd: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(M(θ), bias(θ, θ̇)) of the plant at a numeric state: CasADi's graph when CasADi is
    installed, else the same derivation lambdified onto numpy (no CasADi needed)."""
    import numpy as np

    if _has_casadi():
        model = casadi_model(plant)
        return (
            np.asarray(model.mass(q), dtype=float),
            np.asarray(model.bias(q, qd), dtype=float).reshape(-1),
        )
    model_ = dynamics(plant.system)
    return model_.mass_matrix(q, plant.params), model_.bias(q, qd, plant.params)


def discrete_zoh_lqr(plant: Plant, period: float, q: np.ndarray, r: np.ndarray) -> np.ndarray:
    """The discrete LQR gain about upright at rest for a force or torque u held over `period`:
    the linear model of `linearize` discretised exactly for a zero-order hold (matrix
    exponential), then scipy's DARE (`tvlqr.discrete_lqr` without CasADi)."""
    return _zoh_lqr(plant, period, q, r, acceleration=False)


def discrete_acceleration_lqr(plant: Plant, period: float, q: np.ndarray, r: np.ndarray) -> np.ndarray:
    """The discrete LQR gain about upright at rest for an acceleration-driven base, u held over
    `period`: the linear model of `linearize(..., actuator="acceleration")` discretised exactly
    for a zero-order hold (matrix exponential), then scipy's DARE."""
    return _zoh_lqr(plant, period, q, r, acceleration=True)


def _zoh_lqr(plant: Plant, period: float, q: np.ndarray, r: np.ndarray, acceleration: bool) -> np.ndarray:
    import numpy as np
    from scipy.linalg import expm

    system = plant.system
    dof = plant.dof
    links: dict[str, Any] = plant.links_as_built  # Any: the keywords of linearize's overloads differ
    kind: dict[str, Any] = {"actuator": {"kind": "acceleration"}} if acceleration else {}
    a, b = linearize(
        system.type, system.links, plant.m, plant.l, plant.delta, plant.g, system.inertia,
        **kind, **links,
    )  # fmt: skip
    size = 2 * dof
    block = np.zeros((size + 1, size + 1))
    block[:size, :size], block[:size, size:] = a, b
    flow = expm(block * period)
    gain, _ = discrete_lqr_gain((flow[:size, :size], flow[:size, size:]), (a, b), q, r, period)
    return gain.reshape(-1)
