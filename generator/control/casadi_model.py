"""ipgen's exact model as CasADi expressions, for swing-up planning and time-varying LQR.

The sympy views of `ipgen.derive` (M(θ), the bias N θ̇ + P, the energies) are lambdified once per
system onto CasADi's `sin`/`cos` and called with CasADi symbols for the state and plain floats for
the parameters, so the constants fold into the expression graph. Nothing is inverted
symbolically: the planner keeps M θ̈ + bias = B u as an implicit constraint (`residual`), and the
explicit θ̈ (`acceleration`, for the discrete flow map) is a numerical linear solve inside the
graph, which CasADi differentiates exactly.

State x = [θ; θ̇] (2·dof entries; θ0 the cart position [m] or arm angle [rad], θ1..θn absolute
link angles [rad] from upright), input u the cart force [N] or arm torque [N m], B = (1, 0, …, 0)ᵀ.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import lru_cache
from typing import TYPE_CHECKING, Any

from ipgen.common.install import install_hint
from ipgen.control.linear import ControlError, as_pendulum
from ipgen.model.pendulum import Pendulum, PendulumError
from ipgen.model.system import System

if TYPE_CHECKING:
    import casadi as ca
    import numpy as np

__all__ = ["CasadiModel", "Plant", "as_plant", "casadi_model", "plant"]

_INSTALL_HINT = (
    f"swing-up planning needs CasADi: {install_hint('casadi')}; "
    'method "energy" (one link) runs without it'
)


def import_casadi() -> Any:
    """The casadi module, or a ControlError saying how to install it."""
    try:
        import casadi
    except ImportError:  # pragma: no cover - depends on the environment
        raise ControlError(_INSTALL_HINT) from None
    return casadi


@dataclass(frozen=True)
class Plant:
    """A `Pendulum` as the planners see it: the direct model's numbers in one flat tuple
    `params` (m0..mn, l0..ln, δ0..δn, g, then com, J, J_axial, tip with the rods filled in:
    `Pendulum.flat`, `Dynamics`' order). A "dc_motor" pendulum is planned on its folded model
    (`Pendulum.folded`; u is then the force or torque, b · V)."""

    pendulum: Pendulum

    @property
    def system(self) -> System:
        return self.pendulum.system

    @property
    def params(self) -> tuple[float, ...]:
        p = self.pendulum
        return tuple((p.folded() if p.actuator.is_motor else p).flat())

    @property
    def dof(self) -> int:
        return self.pendulum.dof

    @property
    def links(self) -> int:
        return self.pendulum.links

    @property
    def m(self) -> tuple[float, ...]:
        return self.params[: self.dof]

    @property
    def l(self) -> tuple[float, ...]:  # noqa: E743 (the paper's name)
        return self.params[self.dof : 2 * self.dof]

    @property
    def delta(self) -> tuple[float, ...]:
        return self.params[2 * self.dof : 3 * self.dof]

    @property
    def g(self) -> float:
        return self.params[3 * self.dof]

    @property
    def links_as_built(self) -> dict[str, tuple[float, ...]]:
        """com, J, J_axial, tip (dof entries each)."""
        start, dof = 3 * self.dof + 1, self.dof
        groups = ("com", "J", "J_axial", "tip")
        return {group: self.params[start + k * dof : start + (k + 1) * dof] for k, group in enumerate(groups)}

    def with_params(
        self,
        m: Sequence[float] | None = None,
        l: Sequence[float] | None = None,  # noqa: E741
        delta: Sequence[float] | None = None,
    ) -> Plant:
        """The same system with some parameter arrays replaced (robustness studies); the links
        as built keep their values (the rods' of the original where not given)."""
        changes = {name: value for name, value in (("m", m), ("l", l), ("delta", delta)) if value is not None}
        p = self.pendulum
        try:
            return Plant(p.replace(**self.links_as_built, **changes) if changes else p)
        except PendulumError as exc:
            raise ControlError(str(exc)) from None


def as_plant(system: Plant | Pendulum, what: str) -> Plant:
    """`system` as a Plant, for the swing-up planners.

    Parameters
    ----------
    system : Plant or Pendulum
        A Plant is returned as it is; a Pendulum with a "direct" or "acceleration" drive wrapped.
    what : str
        What plans, for the message.

    Returns
    -------
    Plant

    Raises
    ------
    ControlError
        A "dc_motor" Pendulum (a plan's u is a force or torque: plan on `p.folded()` with
        u_max · `p.gain`; a scene's [swingup] does that and converts the law to volts), one in a
        rig's coordinates (plan on `p.canonical()`), or something else than a Plant or a Pendulum.

    Examples
    --------
    >>> p = Pendulum("rotary", 1, [0.5, 0.275], [0.6, 0.5], [0.3, 0.01])
    >>> as_plant(p, "a test").params == plant(p).params
    True
    """
    if isinstance(system, Plant):
        return system
    if isinstance(system, Pendulum) and system.actuator.is_motor:
        raise ControlError(
            f"{what} plans a force or torque, this Pendulum is driven by a dc_motor: pass p.folded() "
            "and u_max times p.gain (volts times the force per volt)"
        )
    if isinstance(system, Pendulum) and not system.coordinates.is_canonical:
        raise ControlError(  # its laws and plans take and give states in ipgen's coordinates
            f"{what} works in ipgen's coordinates (absolute angles from upright, clockwise), this Pendulum "
            "is in a rig's: pass p.canonical() and map states with p.coordinates (a scene's [swingup] does)"
        )
    if isinstance(system, Pendulum):
        return Plant(system)
    raise ControlError(f"{what} needs an ipgen.Pendulum or a Plant, got {type(system).__name__}")


def plant(*args: Any, **kwargs: Any) -> Plant:
    """A validated `Plant`: ``plant(p)`` of a `Pendulum`, or (the keyword API) ``plant(type,
    links, m, l, delta, g=9.81, inertia="pivot", *, com=None, J=None, J_axial=None, tip=None)``,
    the arguments of `as_pendulum`.

    Parameters
    ----------
    p : Pendulum
        The system to plan for.

    Returns
    -------
    Plant

    Raises
    ------
    ControlError
        With the keyword API, a value the `Pendulum` refuses (one line).

    Examples
    --------
    >>> plant("rotary", 1, [0.5, 0.275], [0.6, 0.5], [0.3, 0.01]).dof
    2
    """
    if args and isinstance(args[0], Pendulum) and len(args) == 1 and not kwargs:
        return Plant(args[0])
    return Plant(as_pendulum(*args, **kwargs))


@lru_cache(maxsize=16)
def _lambdified(system: System) -> tuple[Callable[..., Any], Callable[..., Any]]:
    """(mass/bias, energies) as Python functions of (θ, θ̇, params) calling casadi's sin and cos."""
    import sympy as sp

    from ipgen.model.derivation import derive

    casadi = import_casadi()
    equations = derive(system)
    s = equations.symbols
    arguments = [*s.q, *s.qd, *s.parameters, *s.link_parameters]
    modules = [{"sin": casadi.sin, "cos": casadi.cos, "sqrt": casadi.sqrt}]
    dynamics = sp.lambdify(
        arguments, [list(equations.mass_matrix), list(equations.bias)], modules=modules, cse=True
    )
    energies = sp.lambdify(
        arguments, [equations.kinetic_energy, equations.potential_energy], modules=modules, cse=True
    )
    return dynamics, energies


def rk4_substeps(period: float) -> int:
    """The RK4 steps of `CasadiModel.flow_map` over `period`: steps of at most 1 ms, at least 4."""
    return max(4, math.ceil(period / 1e-3 - 1e-9))


def rk4_growth(z: complex) -> float:
    """|R(z)|, RK4's growth over one step for the mode s at z = h s (stable steps: <= 1); inf where
    it overflows (δ = 1e200)."""
    try:
        return abs(1 + z + z * z / 2 + z**3 / 6 + z**4 / 24)
    except OverflowError:
        return math.inf


def rk4_unstable_mode(a: np.ndarray, step: float) -> complex | None:
    """The mode s of the linear model `a` that does not grow (Re s <= 0) but that RK4 with steps
    of `step` makes grow the most (|R(h s)| > 1: a stiff mode), or None if it makes none grow."""
    import numpy as np

    settled = [complex(mode) for mode in np.linalg.eigvals(a) if np.isfinite(mode) and mode.real <= 0]
    worst = max(settled, key=lambda mode: rk4_growth(step * mode), default=None)
    return worst if worst is not None and rk4_growth(step * worst) > 1 + 1e-9 else None


@dataclass(frozen=True)
class CasadiModel:
    """CasADi functions of one plant (SX graphs, parameters folded in as constants).

    - `mass(q)` → M (dof × dof); `bias(q, qd)` → N θ̇ + P (dof);
    - `residual(q, qd, qdd, u)` → M θ̈ + bias − B u (zero on the equations of motion);
    - `acceleration(q, qd, u)` → θ̈ (a linear solve in the graph, no symbolic inverse);
    - `energy(q, qd)` → (T, V).
    """

    plant: Plant
    mass: ca.Function
    bias: ca.Function
    residual: ca.Function
    acceleration: ca.Function
    energy: ca.Function

    def flow_map(self, period: float, substeps: int | None = None) -> ca.Function:
        """F(x, u): the state after `period` seconds with u held, by classical RK4 in `substeps`
        steps (default: steps of at most 1 ms, at least 4), as a CasADi function (AD-exact
        Jacobians of the discretised map)."""
        return _flow_map(self, float(period), substeps or rk4_substeps(period))

    def flow_jacobians(self, period: float, substeps: int | None = None) -> ca.Function:
        """(F, ∂F/∂x, ∂F/∂u) of `flow_map` as one CasADi function of (x, u)."""
        casadi = import_casadi()
        step = self.flow_map(period, substeps)
        n = 2 * self.plant.dof
        x = casadi.SX.sym("x", n)
        u = casadi.SX.sym("u")
        xn = step(x, u)
        return casadi.Function("flow_jacobians", [x, u], [xn, casadi.jacobian(xn, x), casadi.jacobian(xn, u)])

    def state_jacobians(self) -> ca.Function:
        """(ẋ, ∂ẋ/∂x, ∂ẋ/∂u) of the continuous dynamics as one CasADi function of (x, u)."""
        return _state_jacobians(self)



@lru_cache(maxsize=64)
def _flow_map(model: CasadiModel, period: float, substeps: int) -> ca.Function:
    casadi = import_casadi()
    dof = model.plant.dof
    x = casadi.SX.sym("x", 2 * dof)
    u = casadi.SX.sym("u")

    def f(state: Any) -> Any:
        return casadi.vertcat(state[dof:], model.acceleration(state[:dof], state[dof:], u))

    h = period / substeps
    state = x
    for _ in range(substeps):
        k1 = f(state)
        k2 = f(state + h / 2 * k1)
        k3 = f(state + h / 2 * k2)
        k4 = f(state + h * k3)
        state = state + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    return casadi.Function("flow_map", [x, u], [state])


@lru_cache(maxsize=32)
def _state_jacobians(model: CasadiModel) -> ca.Function:
    casadi = import_casadi()
    dof = model.plant.dof
    x = casadi.SX.sym("x", 2 * dof)
    u = casadi.SX.sym("u")
    xdot = casadi.vertcat(x[dof:], model.acceleration(x[:dof], x[dof:], u))
    return casadi.Function(
        "state_jacobians", [x, u], [xdot, casadi.jacobian(xdot, x), casadi.jacobian(xdot, u)]
    )


@lru_cache(maxsize=32)
def casadi_model(plant: Plant) -> CasadiModel:
    """The CasADi functions of `plant` (built once per process and plant)."""
    casadi = import_casadi()
    dof = plant.dof
    dynamics, energies = _lambdified(plant.system)
    q = casadi.SX.sym("q", dof)
    qd = casadi.SX.sym("qd", dof)
    qdd = casadi.SX.sym("qdd", dof)
    u = casadi.SX.sym("u")
    arguments = [*casadi.vertsplit(q), *casadi.vertsplit(qd), *plant.params]
    mass_entries, bias_entries = dynamics(*arguments)
    mass = casadi.reshape(casadi.vertcat(*[casadi.SX(e) for e in mass_entries]), dof, dof).T
    bias = casadi.vertcat(*[casadi.SX(e) for e in bias_entries])
    b = casadi.DM.zeros(dof)
    b[0] = 1.0
    residual = casadi.mtimes(mass, qdd) + bias - b * u
    kinetic, potential = energies(*arguments)
    # θ̈ by a linear solve kept in the graph (MX, differentiable), never a symbolic inverse.
    mass_f = casadi.Function("mass", [q], [mass])
    bias_f = casadi.Function("bias", [q, qd], [bias])
    qm = casadi.MX.sym("q", dof)
    qdm = casadi.MX.sym("qd", dof)
    um = casadi.MX.sym("u")
    accel = casadi.solve(mass_f(qm), b * um - bias_f(qm, qdm), "symbolicqr")
    acceleration = casadi.Function("acceleration", [qm, qdm, um], [accel]).expand()
    return CasadiModel(
        plant=plant,
        mass=mass_f,
        bias=bias_f,
        residual=casadi.Function("residual", [q, qd, qdd, u], [residual]),
        acceleration=acceleration,
        energy=casadi.Function(
            "energy", [q, qd], [casadi.SX(kinetic) + 0 * q[0], casadi.SX(potential) + 0 * q[0]]
        ),
    )
