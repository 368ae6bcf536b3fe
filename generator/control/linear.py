"""From the model to a controller: linearisation about any state and LQR gains.

The state is x = [θ; θ̇] (2·dof entries: θ0 the cart position [m] or arm angle [rad], θ1..θn
the absolute link angles [rad] from upright, then their rates), the input u the force on the
cart [N] or the torque on the arm [N m] (or, with `actuator=`, a motor voltage or the base's
acceleration). About a state x* and input u*,

    ẋ ≈ f(x*, u*) + A (x − x*) + B (u − u*),   A = [[0, I], [∂θ̈/∂θ, ∂θ̈/∂θ̇]],   B = [0; ∂θ̈/∂u],

evaluated from the exact symbolic derivation (`ipgen.derive`, sympy views, differentiated by
sympy and lambdified once per system). An LQR gain K makes u = −K (x − x_eq) minimise
∫ (x − x_eq)ᵀ Q (x − x_eq) + R u² dt on the linear model; it comes from scipy's continuous
algebraic Riccati solver. The header's `linearize` (C++) computes the same A and B from the
exact derivatives of the generated code.
"""

from __future__ import annotations

import inspect
import math
import warnings
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from functools import lru_cache
from typing import TYPE_CHECKING, Any, TypeVar, get_overloads, overload

from ipgen.common.arrays import float_array
from ipgen.common.limits import MAX_SAMPLE_GROWTH
from ipgen.common.safetext import abbreviate
from ipgen.errors import Error
from ipgen.model.actuator import Actuator
from ipgen.model.coordinates import rests
from ipgen.model.links import resolve_links
from ipgen.model.pendulum import Pendulum, PendulumError
from ipgen.model.system import System

if TYPE_CHECKING:
    import numpy as np

__all__ = [
    "ControlError",
    "Dynamics",
    "EquilibriumWarning",
    "NotStabilisable",
    "VectorField",
    "as_pendulum",
    "check_stabilisable",
    "closed_loop_poles",
    "continuous_lqr_gain",
    "discrete_lqr_gain",
    "dynamics",
    "equilibrium_state",
    "linearize",
    "lqr",
    "vector_field",
    "weights",
]


# The largest weight in Q or R, and 1 / it the smallest R: beyond them the Riccati solvers work
# in overflow (a Q entry of 1e308 overflowed symmetrising it); only the ratio Q/R shapes K.
MAX_WEIGHT = 1e100


class ControlError(Error):
    """A controller that cannot be computed (bad weights, an uncontrollable pair, ...)."""


class NotStabilisable(ControlError):
    """The rank test's verdict that the input cannot move an unstable mode (`check_stabilisable`)."""


class CallError(ControlError, TypeError):
    """Arguments that fit none of a public function's forms (a TypeError, as Python's own)."""


class EquilibriumWarning(UserWarning):
    """`linearize` was asked for a state that is not an equilibrium for the given input."""


@dataclass(frozen=True)
class Dynamics:
    """Numerical θ̈ and its exact derivatives for one system (lambdified sympy expressions).

    Parameters are passed as one flat sequence `params` = (m0..mn, l0..ln, δ0..δn, g) and,
    optionally, (com0..comn, J0..Jn, J_axial0..J_axialn, tip0..tipn): the links as built
    (`model.links`; without them, the paper's rods).
    """

    system: System
    _mass: Callable[..., np.ndarray]  # M(θ, params)
    _bias: Callable[..., np.ndarray]  # bias(θ, θ̇, params)
    _mass_dq: Callable[..., np.ndarray]  # ∂M/∂θ_i stacked: (dof·dof) × dof, row-major over M's entries
    _bias_dq: Callable[..., np.ndarray]  # ∂bias/∂θ, dof × dof
    _bias_dqd: Callable[..., np.ndarray]  # ∂bias/∂θ̇, dof × dof

    def forward_dynamics(
        self, q: np.ndarray, qd: np.ndarray, u: float, params: Sequence[float]
    ) -> np.ndarray:
        """θ̈ from M θ̈ + bias = (u, 0, ..., 0)ᵀ."""
        import numpy as np

        params = self._complete(params)
        mass = np.asarray(self._mass(*q, *params), dtype=float)
        rhs = -np.asarray(self._bias(*q, *qd, *params), dtype=float).reshape(-1)
        rhs[0] += u
        return np.linalg.solve(mass, rhs)

    def mass_matrix(self, q: np.ndarray, params: Sequence[float]) -> np.ndarray:
        """M(θ) (dof × dof) at the angles q for the flat `params` (`Pendulum.flat`; m, l, delta,
        g alone: the rods)."""
        import numpy as np

        return np.asarray(self._mass(*q, *self._complete(params)), dtype=float)

    def bias(self, q: Sequence[float], qd: Sequence[float], params: Sequence[float]) -> np.ndarray:
        """bias(θ, θ̇) = N θ̇ + P, dof entries."""
        import numpy as np

        return np.asarray(self._bias(*q, *qd, *self._complete(params)), dtype=float).reshape(-1)

    def _complete(self, params: Sequence[float]) -> list[float]:
        """`params` with the rods' com, J, J_axial, tip appended if it has m, l, delta, g only."""
        dof = self.system.dof
        values = [float(v) for v in params]
        if len(values) == 3 * dof + 1:
            values += resolve_links(self.system, values[:dof], values[dof : 2 * dof], {}).flat()
        return values

    def jacobians(
        self, q: np.ndarray, qd: np.ndarray, u: float, params: Sequence[float]
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(θ̈, ∂θ̈/∂θ, ∂θ̈/∂θ̇, ∂θ̈/∂u), by implicit differentiation of M θ̈ + bias = B u."""
        import numpy as np

        dof = self.system.dof
        params = self._complete(params)
        mass = np.asarray(self._mass(*q, *params), dtype=float)
        rhs = -np.asarray(self._bias(*q, *qd, *params), dtype=float).reshape(-1)
        rhs[0] += u
        qdd = np.linalg.solve(mass, rhs)
        mass_dq = np.asarray(self._mass_dq(*q, *params), dtype=float).reshape(dof, dof, dof)  # [j, k, i]
        residual_dq = np.einsum("jki,k->ji", mass_dq, qdd) + np.asarray(
            self._bias_dq(*q, *qd, *params), float
        )
        residual_dqd = np.asarray(self._bias_dqd(*q, *qd, *params), dtype=float)
        unit = np.zeros(dof)
        unit[0] = 1.0
        return (
            qdd,
            -np.linalg.solve(mass, residual_dq),
            -np.linalg.solve(mass, residual_dqd),
            np.linalg.solve(mass, unit),
        )

    def acceleration_dynamics(
        self, q: np.ndarray, qd: np.ndarray, a: float, params: Sequence[float]
    ) -> tuple[np.ndarray, float]:
        """(θ̈, τ) for a base that follows the acceleration θ̈0 = a (actuator kind "acceleration"):
        the link rows of M θ̈ + bias = e0 τ give θ̈_L = −M_LL⁻¹ (M_L0 a + bias_L); τ = M_0· θ̈ +
        bias_0 is the force [N] or torque [N m] the base's drive must apply for it."""
        import numpy as np

        params = self._complete(params)
        mass = np.asarray(self._mass(*q, *params), dtype=float)
        bias = np.asarray(self._bias(*q, *qd, *params), dtype=float).reshape(-1)
        qdd = np.empty(self.system.dof)
        qdd[0] = a
        qdd[1:] = np.linalg.solve(mass[1:, 1:], -(mass[1:, 0] * a + bias[1:]))
        return qdd, float(mass[0] @ qdd + bias[0])

    def acceleration_jacobians(
        self, q: np.ndarray, qd: np.ndarray, a: float, params: Sequence[float]
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(θ̈, ∂θ̈/∂θ, ∂θ̈/∂θ̇, ∂θ̈/∂a) of `acceleration_dynamics`, by implicit differentiation
        of the link rows M_L· θ̈ + bias_L = 0 with θ̈0 = a: row 0 is (0, 0, 1)."""
        import numpy as np

        dof = self.system.dof
        qdd, _ = self.acceleration_dynamics(q, qd, a, params)
        params = self._complete(params)
        mass = np.asarray(self._mass(*q, *params), dtype=float)
        mass_dq = np.asarray(self._mass_dq(*q, *params), dtype=float).reshape(dof, dof, dof)  # [j, k, i]
        residual_dq = np.einsum("jki,k->ji", mass_dq, qdd) + np.asarray(
            self._bias_dq(*q, *qd, *params), float
        )
        residual_dqd = np.asarray(self._bias_dqd(*q, *qd, *params), dtype=float)
        links = mass[1:, 1:]
        dq, dqd, du = np.zeros((dof, dof)), np.zeros((dof, dof)), np.zeros(dof)
        dq[1:] = -np.linalg.solve(links, residual_dq[1:])
        dqd[1:] = -np.linalg.solve(links, residual_dqd[1:])
        du[0] = 1.0
        du[1:] = -np.linalg.solve(links, mass[1:, 0])
        return qdd, dq, dqd, du


@lru_cache(maxsize=32)
def dynamics(system: System) -> Dynamics:
    """The lambdified dynamics of `system` (derived once per process and system)."""
    import sympy as sp

    from ipgen.model.derivation import derive

    equations = derive(system)
    s = equations.symbols
    mass, bias = equations.mass_matrix, equations.bias
    params = (*s.parameters, *s.link_parameters)
    mass_dq = sp.Matrix([[sp.diff(entry, qi) for qi in s.q] for entry in mass])
    bias_dq = bias.jacobian(s.q)
    bias_dqd = bias.jacobian(s.qd)

    def compile_(expr: sp.Matrix, *arguments: Sequence[sp.Symbol]) -> Callable[..., np.ndarray]:
        flat = [symbol for group in arguments for symbol in group]
        return sp.lambdify(flat, expr, modules="numpy", cse=True)

    return Dynamics(
        system=system,
        _mass=compile_(mass, s.q, params),
        _bias=compile_(bias, s.q, s.qd, params),
        _mass_dq=compile_(mass_dq, s.q, params),
        _bias_dq=compile_(bias_dq, s.q, s.qd, params),
        _bias_dqd=compile_(bias_dqd, s.q, s.qd, params),
    )


def checked_vector(name: str, value: Sequence[float] | None, size: int, what: str) -> np.ndarray:
    """`value` as `size` finite floats (None: zeros), or a one-line ControlError naming `name`
    and `what` it holds."""
    import numpy as np

    if value is None:
        return np.zeros(size)
    try:
        array = float_array(value).reshape(-1)
    except (TypeError, ValueError):
        raise ControlError(f"{name} must be {size} numbers ({what})") from None
    if array.size != size:
        raise ControlError(f"{name} has {array.size} entries, expected {size} ({what})")
    if not np.all(np.isfinite(array)):
        raise ControlError(f"{name} must be finite")
    return array


def as_pendulum(
    type: str,
    links: int,
    m: Sequence[float],
    l: Sequence[float],  # noqa: E741
    delta: Sequence[float],
    g: float = 9.81,
    inertia: str = "pivot",
    *,
    com: Sequence[float] | None = None,
    J: Sequence[float] | None = None,
    J_axial: Sequence[float] | None = None,
    tip: Sequence[float] | None = None,
    actuator: Actuator | dict | None = None,
    angles: str = "absolute",
    zero: str = "upright",
    positive: str = "clockwise",
) -> Pendulum:
    """The `Pendulum` of the keyword API (`linearize`, `lqr` and `casadi_model.plant` called with
    type, links, m, l, delta, ...): a cart ignores `inertia` as it always has; a value the
    Pendulum refuses raises `ControlError` with the Pendulum's message.

    Parameters
    ----------
    type, links, m, l, delta, g, inertia, com, J, J_axial, tip, actuator, angles, zero, positive
        As for `Pendulum`.

    Returns
    -------
    Pendulum

    Raises
    ------
    ControlError
        The one-line message of the `PendulumError`.

    Examples
    --------
    >>> as_pendulum("classical", 1, [1.0, 0.1], [0.0, 0.5], [0.0, 0.0], inertia="full").inertia
    'pivot'
    """
    try:
        return Pendulum(
            type, links, m, l, delta, g, inertia if type == "rotary" else "pivot",
            com=com, J=J, J_axial=J_axial, tip=tip, actuator=actuator,
            angles=angles, zero=zero, positive=positive,
        )  # fmt: skip
    except PendulumError as exc:
        raise ControlError(str(exc)) from None


def _pendulum_call(name: str, args: tuple, kwargs: dict) -> tuple[Pendulum, tuple, dict]:
    """(p, rest) of a call `name(p, ...)`, or None-free: a TypeError naming the call if the first
    argument is missing."""
    if args:
        return args[0], args[1:], kwargs
    if "p" in kwargs:
        rest = dict(kwargs)
        return rest.pop("p"), (), rest
    raise TypeError(f"{name}() needs a Pendulum (or the keyword API's type, links, m, l, delta)")


def _is_pendulum_call(args: tuple, kwargs: dict) -> bool:
    return bool(args and isinstance(args[0], Pendulum)) or isinstance(kwargs.get("p"), Pendulum)


_Function = TypeVar("_Function", bound=Callable[..., Any])


def shown_as_first_form(function: _Function) -> _Function:
    """`function`, which takes several forms and tells them apart at run time (from *args and
    **kwargs, so that each form names its own wrong arguments), shown by help() and
    `inspect.signature` as its first `typing.overload`, the Pendulum's form; type checkers and
    IDEs read every overload."""
    function.__signature__ = inspect.signature(get_overloads(function)[0])  # type: ignore[attr-defined]
    return function


@overload
def linearize(
    p: Pendulum,
    q: Sequence[float] | np.ndarray | None = None,
    qd: Sequence[float] | np.ndarray | None = None,
    u: float = 0.0,
) -> tuple[np.ndarray, np.ndarray]: ...


@overload
def linearize(
    type: str,
    links: int,
    m: Sequence[float],
    l: Sequence[float],  # noqa: E741
    delta: Sequence[float],
    g: float = 9.81,
    inertia: str = "pivot",
    q: Sequence[float] | np.ndarray | None = None,
    qd: Sequence[float] | np.ndarray | None = None,
    u: float = 0.0,
    *,
    com: Sequence[float] | None = None,
    J: Sequence[float] | None = None,
    J_axial: Sequence[float] | None = None,
    tip: Sequence[float] | None = None,
    actuator: Actuator | Mapping[str, object] | None = None,
    angles: str = "absolute",
    zero: str = "upright",
    positive: str = "clockwise",
) -> tuple[np.ndarray, np.ndarray]: ...


@shown_as_first_form
def linearize(*args: Any, **kwargs: Any) -> tuple[np.ndarray, np.ndarray]:
    """(A, B) of ẋ = f(x, u), x = [θ; θ̇], about the state (q, qd) and input u.

    With a `FixedPendulum` (a chain on a fixed pivot, m torques at joints) it is
    ``linearize(p, q=None, qd=None, u=None)`` with n angles and rates and m torques, A 2n × 2n and
    B 2n × m in the chain's coordinates (`ipgen.linearize`, `control.fixed_linear`).

    Called as ``linearize(p, q=None, qd=None, u=0.0)`` with a `Pendulum` `p`, or (the keyword
    API, unchanged) as ``linearize(type, links, m, l, delta, g=9.81, inertia="pivot", q=None,
    qd=None, u=0.0, *, com=None, J=None, J_axial=None, tip=None, actuator=None,
    angles="absolute", zero="upright", positive="clockwise")``, which is
    ``linearize(as_pendulum(type, links, m, l, delta, g, inertia, com=..., ...), q, qd, u)``.

    Parameters
    ----------
    p : Pendulum
        The system: its parameters, the links as built, the drive and the rig's coordinates.
    q, qd : sequence of float, optional
        The state about which to linearise: dof = links + 1 angles (θ0 the cart position [m] or
        arm angle [rad]) and rates, in the pendulum's coordinates; default zero (upright at
        rest in ipgen's coordinates).
    u : float, default 0.0
        The input about which to linearise (a force [N] or torque [N m]; with a "dc_motor" a
        voltage [V]; with "acceleration" the base's acceleration).

    Returns
    -------
    A : numpy.ndarray
        2·dof × 2·dof, ∂f/∂x.
    B : numpy.ndarray
        2·dof × 1, ∂f/∂u (per volt for a "dc_motor").

    Raises
    ------
    ControlError
        A bad state or input (one line), or a linear model that overflows; with the keyword API
        also a value the `Pendulum` refuses.

    Warns
    -----
    EquilibriumWarning
        The state is not an equilibrium for u (θ̇ ≠ 0 or θ̈ ≠ 0): A and B then describe the
        motion about a moving point.

    Notes
    -----
    A "dc_motor" is folded into the direct model (`Pendulum.folded`): A has the back-EMF's
    damping and the rotor's reflected inertia, B is b times the direct one (docs/model.md, "A DC
    motor on the base"). With "acceleration" A's θ̈0 row is zero, B's is 1, and the links follow
    θ̈_L = −M_LL⁻¹ (M_L0 u + b_L) (docs/model.md, "An acceleration-driven base"); m0, δ0 (and J0
    of an arm) do not enter A or B. In a rig's own coordinates (`angles`, `zero`, `positive`)
    q, qd and the rows and columns of A and B are in them: A_u = P A P⁻¹, B_u = P B.

    Examples
    --------
    >>> import ipgen
    >>> p = ipgen.Pendulum("classical", 1, m=[1.0, 0.1], l=[0.0, 0.5], delta=[0.0, 0.0])
    >>> a, b = ipgen.linearize(p)
    >>> a.shape, b.shape
    ((4, 4), (4, 1))
    """
    if _is_pendulum_call(args, kwargs):
        p, rest, options = _pendulum_call("linearize", args, kwargs)
        return called("linearize", _linearize, p, *rest, **options)
    return called("linearize", _linearize_keywords, *args, **kwargs)


def _linearize_keywords(
    type: str,
    links: int,
    m: Sequence[float],
    l: Sequence[float],  # noqa: E741 (the paper's name for the lengths)
    delta: Sequence[float],
    g: float = 9.81,
    inertia: str = "pivot",
    q: Sequence[float] | None = None,
    qd: Sequence[float] | None = None,
    u: float = 0.0,
    *,
    com: Sequence[float] | None = None,
    J: Sequence[float] | None = None,
    J_axial: Sequence[float] | None = None,
    tip: Sequence[float] | None = None,
    actuator: Actuator | dict | None = None,
    angles: str = "absolute",
    zero: str = "upright",
    positive: str = "clockwise",
) -> tuple[np.ndarray, np.ndarray]:
    """`linearize`'s keyword API: the same A and B as `linearize(as_pendulum(...), q, qd, u)`."""
    p = as_pendulum(
        type, links, m, l, delta, g, inertia, com=com, J=J, J_axial=J_axial, tip=tip,
        actuator=actuator, angles=angles, zero=zero, positive=positive,
    )  # fmt: skip
    return _linearize(p, q, qd, u, stacklevel=4)


def _linearize(
    p: Pendulum,
    q: Sequence[float] | None = None,
    qd: Sequence[float] | None = None,
    u: float = 0.0,
    *,
    stacklevel: int = 3,
) -> tuple[np.ndarray, np.ndarray]:
    """`linearize` of a Pendulum, in its coordinates."""
    import numpy as np

    dof = p.dof
    convention = p.coordinates
    if not convention.is_canonical:
        x_user = np.concatenate(
            [
                checked_vector("q", q, dof, "one angle per coordinate"),
                checked_vector("qd", qd, dof, "one rate per coordinate"),
            ]
        )
        matrix, _ = convention.matrices(p.links)
        x = convention.to_canonical(x_user, p.links)
        a, b = _linearize_canonical(p, x[:dof], x[dof:], u, stacklevel + 1)
        return matrix @ a @ np.linalg.inv(matrix), matrix @ b
    return _linearize_canonical(
        p,
        checked_vector("q", q, dof, "one angle or position per degree of freedom"),
        checked_vector("qd", qd, dof, "one rate per degree of freedom"),
        u,
        stacklevel + 1,
    )


def _linearize_canonical(
    p: Pendulum, q: np.ndarray, qd: np.ndarray, u: object, stacklevel: int, warn: bool = True
) -> tuple[np.ndarray, np.ndarray]:
    """(A, B) in ipgen's coordinates about (q, qd, u); the motor folded (`Pendulum.folded`).
    `warn`: an EquilibriumWarning when (q, qd, u) is not a rest."""
    import numpy as np

    try:
        u = math.nan if isinstance(u, str | bytes) else float(u)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        u = math.nan
    if not math.isfinite(u):
        raise ControlError("u must be a finite number (the input about which to linearise)")
    system, dof = p.system, p.dof
    try:
        if p.actuator.is_acceleration:
            qdd, dq, dqd, du = dynamics(system).acceleration_jacobians(q, qd, u, p.flat())
            gain = 1.0
        else:
            gain = p.gain
            # u is the motor's voltage with a dc_motor: the folded model's force or torque is b u
            qdd, dq, dqd, du = dynamics(system).jacobians(q, qd, u * gain, p.folded().flat())
    except (OverflowError, np.linalg.LinAlgError):  # e.g. a length of 1e155 m: M's terms overflow
        raise ControlError(
            "the model's terms overflow a double or leave the mass matrix singular: check the masses, "
            "lengths and inertias (a value many orders of magnitude off?)"
        ) from None
    scale = max(1.0, float(np.max(np.abs(dq))) if dq.size else 1.0)
    if warn and (np.any(qd != 0.0) or float(np.max(np.abs(qdd))) > 1e-9 * scale):
        warnings.warn(
            f"linearize: the state is not an equilibrium for u = {u:g} (|θ̇| max {np.max(np.abs(qd)):.3g}, "
            f"|θ̈| max {np.max(np.abs(qdd)):.3g}); A and B describe the motion about a moving point",
            EquilibriumWarning,
            stacklevel=stacklevel + 1,
        )
    a = np.zeros((2 * dof, 2 * dof))
    a[:dof, dof:] = np.eye(dof)
    a[dof:, :dof] = dq
    a[dof:, dof:] = dqd
    b = np.zeros((2 * dof, 1))
    b[dof:, 0] = du * gain
    if not (np.all(np.isfinite(a)) and np.all(np.isfinite(b))):
        raise ControlError(
            f"the linear model overflows at this state and input (u = {u:g}): use a smaller u or state, "
            "or check the parameters' units (a mass or inertia near 0 divides)"
        )
    return a, b


@dataclass(frozen=True)
class VectorField:
    """ẋ = f(x, u) of one pendulum with numeric parameters, and its exact Jacobians, in the
    pendulum's coordinates x_user = P x + c (`Coordinates.matrices`; P = I, c = 0 for ipgen's).

    The same model as `linearize` (the drive folded in: u is the force or torque, the motor
    voltage or the base's acceleration), at any state: `f` is the forward dynamics, `jacobians`
    returns f with A = ∂f/∂x and B = ∂f/∂u (the derivatives of `Dynamics`, by implicit
    differentiation of M θ̈ + bias = B u, not finite differences). Built by `vector_field`.
    """

    pendulum: Pendulum
    params: tuple[float, ...]  # the flat parameters of `Dynamics`: the motor folded in
    input_gain: float  # b: the force or torque per unit of u (1 without a motor)
    acceleration: bool  # u is the base's acceleration
    transform: np.ndarray  # P of x_user = P x + c
    offset: np.ndarray  # c

    @property
    def system(self) -> System:
        return self.pendulum.system

    @property
    def dof(self) -> int:
        return self.pendulum.dof

    def _canonical(self, x: np.ndarray) -> np.ndarray:
        import numpy as np

        return np.linalg.solve(self.transform, np.asarray(x, dtype=float).reshape(-1) - self.offset)

    def f(self, x: np.ndarray, u: float) -> np.ndarray:
        """ẋ at the state x = [θ; θ̇] (2·dof entries, the pendulum's coordinates) and input u."""
        import numpy as np

        dof = self.dof
        xc = self._canonical(x)
        model = dynamics(self.system)
        if self.acceleration:
            qdd, _ = model.acceleration_dynamics(xc[:dof], xc[dof:], float(u), self.params)
        else:
            qdd = model.forward_dynamics(xc[:dof], xc[dof:], float(u) * self.input_gain, self.params)
        return self.transform @ np.concatenate([xc[dof:], qdd])

    def jacobians(self, x: np.ndarray, u: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(f, A, B) at (x, u): ẋ, ∂f/∂x (2·dof × 2·dof) and ∂f/∂u (2·dof × 1)."""
        import numpy as np

        dof = self.dof
        xc = self._canonical(x)
        model = dynamics(self.system)
        if self.acceleration:
            qdd, dq, dqd, du = model.acceleration_jacobians(xc[:dof], xc[dof:], float(u), self.params)
        else:
            qdd, dq, dqd, du = model.jacobians(xc[:dof], xc[dof:], float(u) * self.input_gain, self.params)
            du = du * self.input_gain
        a = np.zeros((2 * dof, 2 * dof))
        a[:dof, dof:] = np.eye(dof)
        a[dof:, :dof] = dq
        a[dof:, dof:] = dqd
        b = np.zeros((2 * dof, 1))
        b[dof:, 0] = du
        p = self.transform
        return p @ np.concatenate([xc[dof:], qdd]), p @ a @ np.linalg.inv(p), p @ b


def vector_field(*args: Any, **kwargs: Any) -> VectorField:
    """The nonlinear model ẋ = f(x, u) of a pendulum, for estimators and simulations that need
    it away from an equilibrium.

    Called as ``vector_field(p)`` with a `Pendulum`, or with the keyword API of `linearize`
    without the point (type, links, m, l, delta, g, inertia, com, J, J_axial, tip, actuator,
    angles, zero, positive). Bad arguments raise `ControlError` as `linearize` does.
    """
    p = args[0] if args and isinstance(args[0], Pendulum) else as_pendulum(*args, **kwargs)
    acceleration = p.actuator.is_acceleration
    params = p.flat() if acceleration else p.folded().flat()
    matrix, offset = p.coordinates.matrices(p.links)
    return VectorField(
        pendulum=p,
        params=tuple(float(v) for v in params),
        input_gain=1.0 if acceleration else float(p.gain),
        acceleration=acceleration,
        transform=matrix,
        offset=offset,
    )


def equilibrium_state(links: int, equilibrium: Sequence[float] | str | None) -> np.ndarray:
    """x_eq (2·dof) from "upright" (default), "hanging", or the dof angles (velocities zero).

    Angles: θ0 (base position or arm angle) and the absolute link angles; "hanging" puts every
    link at π. An angle of a link must be a multiple of π to be an equilibrium.
    """
    import numpy as np

    dof = links + 1
    x = np.zeros(2 * dof)
    if equilibrium is None or (isinstance(equilibrium, str) and equilibrium == "upright"):
        return x
    if isinstance(equilibrium, str):
        if equilibrium != "hanging":
            raise ControlError(
                f"equilibrium {equilibrium!r}: expected 'upright', 'hanging' or {dof} angles [θ0, θ1, ...]"
            )
        x[1:dof] = math.pi
        return x
    angles = checked_vector(
        "equilibrium", equilibrium, dof, "θ0 and one absolute angle per link; velocities are zero"
    )
    for i, angle in enumerate(angles[1:], start=1):
        if not rests(angle):
            raise ControlError(
                f"equilibrium[{i}] = {angle:g} is not an equilibrium angle: "
                "links rest upright (0) or hanging (π)"
            )
    x[:dof] = angles
    return x


def weights(
    Q: np.ndarray | Sequence, R: float | np.ndarray | Sequence, size: int, name: str = "Q"
) -> tuple[np.ndarray, np.ndarray]:
    """(Q, R) of an LQR as arrays, checked.

    Parameters
    ----------
    Q : array_like
        `size` diagonal weights (>= 0) or a symmetric positive semidefinite size × size matrix.
    R : float or array_like
        One number > 0, the weight of u².
    size : int
        The state's size, 2 (links + 1).
    name : str, optional
        What the messages call the matrix (Q, or an MPC's terminal weight P).

    Returns
    -------
    (numpy.ndarray, numpy.ndarray)
        Q as a size × size matrix (symmetrised), R as 1 × 1.

    Raises
    ------
    ControlError
        A wrong shape, a non-finite or negative weight, an asymmetric or indefinite Q, R <= 0.

    Examples
    --------
    >>> q, r = weights([1, 2], 0.5, 2)
    >>> q.tolist(), r.tolist()
    ([[1.0, 0.0], [0.0, 2.0]], [[0.5]])
    """
    import numpy as np

    try:
        q = float_array(Q)
    except (TypeError, ValueError):  # text, a ragged list
        raise ControlError(
            f"{name} = {abbreviate(repr(Q))}: expected {size} diagonal weights or a {size} x {size} matrix"
        ) from None
    if q.ndim == 1:
        if q.size != size:
            raise ControlError(f"{name} has {q.size} diagonal entries, expected {size} (2 · (links + 1))")
        if np.any(q < 0):
            raise ControlError(f"{name}'s diagonal weights must be >= 0")
        q = np.diag(q)
    if q.shape != (size, size):
        raise ControlError(
            f"{name} has shape {q.shape}, expected ({size}, {size}) or {size} diagonal entries"
        )
    if not np.all(np.isfinite(q)):
        raise ControlError(f"{name} must be finite")
    if float(np.max(np.abs(q))) > MAX_WEIGHT:
        raise ControlError(
            f"{name} has an entry above {MAX_WEIGHT:g}: only the ratio of Q to R matters, scale both down"
        )
    if not np.allclose(q, q.T, rtol=1e-12, atol=1e-12 * max(1.0, float(np.max(np.abs(q))))):
        raise ControlError(f"{name} must be symmetric")
    q = 0.5 * q + 0.5 * q.T
    if float(np.min(np.linalg.eigvalsh(q))) < -1e-12 * max(1.0, float(np.max(np.abs(q)))):
        raise ControlError(f"{name} must be positive semidefinite (an eigenvalue is negative)")
    try:
        r = float_array(R).reshape(-1)
    except (TypeError, ValueError):
        r = np.full(2, math.nan)  # refused below
    if r.size != 1 or not math.isfinite(float(r[0])) or float(r[0]) <= 0:
        raise ControlError(f"R = {abbreviate(repr(R))}: expected one number > 0 (the weight of u²)")
    if not 1 / MAX_WEIGHT <= float(r[0]) <= MAX_WEIGHT:
        raise ControlError(
            f"R = {float(r[0]):g} is outside [{1 / MAX_WEIGHT:g}, {MAX_WEIGHT:g}]: only the ratio of Q to R "
            "matters, scale both"
        )
    return q, r.reshape(1, 1)


def solve_dare(a: np.ndarray, b: np.ndarray, q: np.ndarray, r: np.ndarray, period: float) -> np.ndarray:
    """P of the discrete LQR (scipy's `solve_discrete_are`) of the sampled model (A_d, B_d) at
    `period` s; a problem scipy cannot solve (singular, or too ill-conditioned to order its
    Schur form: a parameter far from any rig's) is a one-line `ControlError`."""
    import numpy as np
    from scipy.linalg import solve_discrete_are

    try:
        return solve_discrete_are(a, b, q, r)
    except (np.linalg.LinAlgError, ValueError) as exc:
        reason = " ".join(str(exc).split())[:80]
        raise ControlError(
            f"the discrete Riccati equation at period {period:g} s has no solution ({reason}): "
            "check the parameters' units, the period and the weights"
        ) from None


def discrete_lqr_gain(
    sampled: tuple[np.ndarray, np.ndarray],
    continuous: tuple[np.ndarray, np.ndarray],
    q: np.ndarray,
    r: np.ndarray,
    period: float,
) -> tuple[np.ndarray, np.ndarray]:
    """(K, P) of the discrete LQR u_k = −K x_k for the `sampled` model (A_d, B_d) at `period` s
    (P from scipy's DARE, `solve_discrete_are`). Stabilisability and detectability are tested on
    the `continuous` model (A, B) it samples (`check_stabilisable`); as in `continuous_lqr_gain`,
    its "not stabilisable" stands only when the sampled gain does not stabilise either (all
    |eig(A_d − B_d K)| < 1): a stiff model defeats the rank test's tolerance. A gain that does not
    hold the sampled model (scipy's DARE inaccurate on an ill-conditioned one) is refused.

    Raises
    ------
    ControlError
        An unstabilisable or undetectable pair, a DARE scipy cannot solve, or a gain that is not
        finite or does not hold the sampled model; a mode growing more than `MAX_SAMPLE_GROWTH`-fold
        over a sample is named as the cause (the period).
    """
    import numpy as np

    ad, bd = sampled

    def refused(error: ControlError) -> ControlError:
        # A mode that grows past MAX_SAMPLE_GROWTH in a sample is the period's fault, whatever failed.
        growth = float(np.max(np.abs(np.linalg.eigvals(ad)))) if np.all(np.isfinite(ad)) else math.inf
        if growth < MAX_SAMPLE_GROWTH:
            return error
        return ControlError(
            f"period {period:g} s: the model's fastest-growing mode grows by {growth:.3g} over one sample, "
            "too much for a sampled LQR to hold in double precision: sample faster (a period well below "
            "the time the upright takes to fall)"
        )

    doubted: NotStabilisable | None = None
    try:
        check_stabilisable(*continuous, q)
    except NotStabilisable as refusal:
        doubted = refusal
    try:
        p = solve_dare(ad, bd, q, r, period)
    except ControlError as failure:
        raise refused(doubted or failure) from None
    gain = np.linalg.solve(r + bd.T @ p @ bd, bd.T @ p @ ad)  # R > 0, P >= 0: not singular
    if not np.all(np.isfinite(gain)):
        raise refused(
            doubted
            or ControlError("the sampled LQR gain is not finite: check the parameters' units and the weights")
        )
    # scipy's DARE may return an inaccurate P for an ill-conditioned model (a 10 µm link at 10 ms):
    # its gain is kept only if it holds the sampled model.
    radius = float(np.max(np.abs(np.linalg.eigvals(ad - bd @ gain))))
    if not radius < 1:
        raise refused(
            doubted
            or ControlError(
                f"the sampled LQR gain at period {period:g} s does not hold the sampled model (closed-loop "
                f"spectral radius {radius:.4g}): scipy's DARE lost its accuracy; check the parameters' "
                "units, or sample faster"
            )
        )
    return gain, p


def check_stabilisable(a: np.ndarray, b: np.ndarray, q: np.ndarray) -> None:
    """PBH tests: (A, B) stabilisable and (A, Q^½) detectable, or a ControlError naming the mode.

    Parameters
    ----------
    a, b : numpy.ndarray
        The continuous linear model (n × n, n × 1).
    q : numpy.ndarray
        The state weight (n × n, positive semidefinite).

    Raises
    ------
    ControlError
        A mode with Re s >= 0 that the input cannot move, or that Q does not see.

    Examples
    --------
    >>> import numpy as np
    >>> check_stabilisable(np.diag([1.0, -1.0]), np.array([[1.0], [0.0]]), np.eye(2))  # fine: None
    """
    import numpy as np
    from scipy.linalg import matrix_balance

    size = a.shape[0]
    eigenvalues = np.linalg.eigvals(a)
    # The rank tests run on the balanced model (the states rescaled: T⁻¹ A T, T⁻¹ B, C T) with each
    # input column and each weighted row of C scaled to A's size. None of that changes a rank, but
    # the units did: a 10⁷ kg cart's B is 10⁷ times smaller than a 1 kg cart's, and a 10 nm link's
    # A 10⁸ times larger than its B, below a tolerance absolute in A's units (refused as "not
    # stabilisable" where scipy's Riccati gain stabilises).
    balanced, (scaling, _) = matrix_balance(a, permute=False, separate=True)
    scale = max(1.0, float(np.linalg.norm(balanced, 2)))
    inputs = _rows_to(np.asarray(b, float).T / scaling, scale).T
    w, v = np.linalg.eigh(q)
    w = np.where(w > 1e-15 * max(float(w.max()), 0.0), w, 0.0)  # a semidefinite Q's rounding: no weight
    c = _rows_to((v * np.sqrt(w)).T * scaling, scale)  # Q = cᵀ c, then C T
    for lam in eigenvalues:
        if lam.real < -1e-9 * scale:
            continue  # a stable mode needs neither
        shifted = balanced - lam * np.eye(size)
        if np.linalg.matrix_rank(np.hstack([shifted, inputs]), tol=1e-9 * scale) < size:
            raise NotStabilisable(
                f"(A, B) is not stabilisable: the mode at s = {lam:.4g} cannot be moved by the input, to "
                "double precision: no gain can stabilise this equilibrium, unless parameters far apart in "
                "scale (a link of nanometres, damping far beyond the inertia) hide the input's reach"
            )
        if np.linalg.matrix_rank(np.vstack([shifted, c]), tol=1e-9 * scale) < size:
            raise ControlError(
                f"(A, Q) is not detectable: Q puts no weight on the mode at s = {lam:.4g}; "
                "give the states of that mode a positive weight"
            )


def linear_model_at(p: Pendulum, q: np.ndarray, qd: np.ndarray, u: float) -> tuple[np.ndarray, np.ndarray]:
    """(A, B) of `linearize` about (q, qd, u) in ipgen's coordinates, without its warning for a
    state that is not a rest: for a caller that checked it (a thread-safe replacement for
    silencing EquilibriumWarning around `linearize`)."""
    return _linearize_canonical(p, q, qd, u, 1, warn=False)


def _rows_to(matrix: np.ndarray, size: float) -> np.ndarray:
    """`matrix` with each nonzero row scaled to the 2-norm `size` (zero rows stay zero)."""
    import numpy as np

    norms = np.linalg.norm(matrix, axis=1, keepdims=True)
    return np.where(norms > 0, matrix * (size / np.where(norms > 0, norms, 1.0)), 0.0)


@overload
def lqr(
    p: Pendulum,
    Q: np.ndarray | Sequence,
    R: float | Sequence[float],
    equilibrium: Sequence[float] | str | None = None,
) -> np.ndarray: ...


@overload
def lqr(
    type: str,
    links: int,
    m: Sequence[float],
    l: Sequence[float],  # noqa: E741
    delta: Sequence[float],
    Q: np.ndarray | Sequence,
    R: float | Sequence[float],
    g: float = 9.81,
    inertia: str = "pivot",
    equilibrium: Sequence[float] | str | None = None,
    *,
    com: Sequence[float] | None = None,
    J: Sequence[float] | None = None,
    J_axial: Sequence[float] | None = None,
    tip: Sequence[float] | None = None,
    actuator: Actuator | Mapping[str, object] | None = None,
    angles: str = "absolute",
    zero: str = "upright",
    positive: str = "clockwise",
) -> np.ndarray: ...


@shown_as_first_form
def lqr(*args: Any, **kwargs: Any) -> np.ndarray:
    """The LQR gain K, a 1 × 2·dof array, of u = −K (x − x_eq) about an equilibrium.

    With a `FixedPendulum` it is ``lqr(p, Q, R, equilibrium=None)`` with Q 2n weights, R one
    number, m weights or m × m, and K m × 2n (`ipgen.lqr`, `control.fixed_linear`).

    Called as ``lqr(p, Q, R, equilibrium=None)`` with a `Pendulum` `p`, or (the keyword API,
    unchanged) as ``lqr(type, links, m, l, delta, Q, R, g=9.81, inertia="pivot",
    equilibrium=None, *, com=None, J=None, J_axial=None, tip=None, actuator=None,
    angles="absolute", zero="upright", positive="clockwise")``, which is
    ``lqr(as_pendulum(type, links, m, l, delta, g, inertia, com=..., ...), Q, R, equilibrium)``.

    Parameters
    ----------
    p : Pendulum
        The system (its drive says what u is: K is in volts per unit of state for a
        "dc_motor", in m/s² or rad/s² per unit for "acceleration").
    Q : array_like
        2·dof diagonal weights, or a symmetric positive semidefinite 2·dof × 2·dof matrix.
    R : float
        The weight of u², > 0.
    equilibrium : str or sequence of float, optional
        "upright" (default), "hanging", or the dof angles (e.g. [0, π, 0]: link 1 hanging, link 2
        upright); the velocities are zero there and u = 0.

    Returns
    -------
    numpy.ndarray
        K, 1 × 2·dof (python-control's shape: ``A - B @ K`` is the closed loop; ``K[0]`` the row).
        In a rig's own coordinates (the pendulum's `angles`, `zero`, `positive`) K, Q and an
        `equilibrium` given as angles are in them.

    Raises
    ------
    ControlError
        Bad weights, an unstabilisable (A, B) or undetectable (A, Q) pair (instead of a gain
        that does not stabilise), a Riccati equation without a stabilising solution; with the
        keyword API also a value the `Pendulum` refuses.

    Notes
    -----
    K comes from scipy's `solve_continuous_are` on `linearize`'s (A, B) about the equilibrium.

    Examples
    --------
    >>> import ipgen
    >>> p = ipgen.Pendulum("classical", 1, m=[1.0, 0.1], l=[0.0, 0.5], delta=[0.0, 0.0])
    >>> ipgen.lqr(p, Q=[1, 1, 1, 1], R=1.0).shape
    (1, 4)
    """
    if _is_pendulum_call(args, kwargs):
        p, rest, options = _pendulum_call("lqr", args, kwargs)
        return called("lqr", _lqr, p, *rest, **options)
    return called("lqr", _lqr_keywords, *args, **kwargs)


def called(name: str, function: Callable[..., Any], *args: Any, **kwargs: Any) -> Any:
    """`function(*args, **kwargs)`, one of public `name`'s forms; arguments that do not fit it (a
    misspelt keyword, one too many) are a ControlError naming `ipgen.name`, not its private form."""
    try:
        return function(*args, **kwargs)
    except TypeError as error:
        if error.__traceback__ is None or error.__traceback__.tb_next is not None:
            raise  # raised inside the function: not about its arguments
        message = str(error).replace(f"{function.__name__}()", f"ipgen.{name}()")
        raise CallError(f"{message}: help(ipgen.{name}) shows its forms") from None


def _lqr_keywords(
    type: str,
    links: int,
    m: Sequence[float],
    l: Sequence[float],  # noqa: E741
    delta: Sequence[float],
    Q: np.ndarray | Sequence,
    R: float | Sequence[float],
    g: float = 9.81,
    inertia: str = "pivot",
    equilibrium: Sequence[float] | str | None = None,
    *,
    com: Sequence[float] | None = None,
    J: Sequence[float] | None = None,
    J_axial: Sequence[float] | None = None,
    tip: Sequence[float] | None = None,
    actuator: Actuator | dict | None = None,
    angles: str = "absolute",
    zero: str = "upright",
    positive: str = "clockwise",
) -> np.ndarray:
    """`lqr`'s keyword API: the same K as `lqr(as_pendulum(...), Q, R, equilibrium)`."""
    p = as_pendulum(
        type, links, m, l, delta, g, inertia, com=com, J=J, J_axial=J_axial, tip=tip,
        actuator=actuator, angles=angles, zero=zero, positive=positive,
    )  # fmt: skip
    return _lqr(p, Q, R, equilibrium)


def _lqr(
    p: Pendulum,
    Q: np.ndarray | Sequence,
    R: float | Sequence[float],
    equilibrium: Sequence[float] | str | None = None,
) -> np.ndarray:
    """`lqr` of a Pendulum (its coordinates for K, Q and an equilibrium given as angles)."""
    import numpy as np

    convention = p.coordinates
    links, dof = p.links, p.dof
    if not convention.is_canonical and equilibrium is not None and not isinstance(equilibrium, str):
        user = np.concatenate(
            [checked_vector("equilibrium", equilibrium, dof, "θ0 and one angle per link"), np.zeros(dof)]
        )
        equilibrium = list(convention.to_canonical(user, links)[:dof])
        try:
            x_eq = equilibrium_state(links, equilibrium)
        except ControlError:  # named as the user wrote it (the canonical angle was named)
            given = abbreviate(repr([float(v) for v in user[:dof]]))
            raise ControlError(
                f"equilibrium {given} (in the pendulum's coordinates: angles {convention.angles}, zero "
                f"{convention.zero}, positive {convention.positive}) is no rest: each link upright or hanging"
            ) from None
    else:
        x_eq = equilibrium_state(links, equilibrium)
    a, b = _linearize_canonical(p, x_eq[:dof], x_eq[dof:], 0.0, stacklevel=3)
    if not convention.is_canonical:
        matrix, _ = convention.matrices(links)
        a, b = matrix @ a @ np.linalg.inv(matrix), matrix @ b
    q, r = weights(Q, R, 2 * dof)
    return continuous_lqr_gain(a, b, q, r).reshape(1, -1)


def continuous_lqr_gain(a: np.ndarray, b: np.ndarray, q: np.ndarray, r: np.ndarray) -> np.ndarray:
    """K = R⁻¹ Bᵀ P of the continuous LQR (scipy's `solve_continuous_are`), m × n, its closed loop
    A − B K checked stable; (A, B) stabilisable and (A, Q) detectable checked first
    (`check_stabilisable`). The rank test's "not stabilisable" stands only when the Riccati gain
    does not stabilise either: a rank decision needs a tolerance, which a stiff model (modes 10⁵
    apart: a 0.1 mm arm with damping) defeats, where the gain's poles are checked as they are.

    Raises
    ------
    ControlError
        An unstabilisable pair, an undetectable one, or a Riccati equation without a stabilising
        solution.
    """
    import numpy as np
    from scipy.linalg import LinAlgWarning, solve_continuous_are

    from ipgen.common.quiet import ignoring

    doubted: NotStabilisable | None = None
    try:
        check_stabilisable(a, b, q)
    except NotStabilisable as refusal:
        doubted = refusal
    try:
        with ignoring(LinAlgWarning):  # scipy's "QZ iteration failed": the gain is checked below
            riccati = solve_continuous_are(a, b, q, r)
    except (np.linalg.LinAlgError, ValueError) as exc:
        if doubted is not None:
            raise doubted from None
        raise ControlError(f"the Riccati equation has no stabilising solution ({exc})") from None
    k = np.linalg.solve(r, b.T @ riccati)
    poles = np.linalg.eigvals(a - b @ k)
    if not np.all(np.isfinite(k)) or not np.all(np.isfinite(poles)) or np.max(poles.real) >= 0:
        if doubted is not None:
            raise doubted from None
        raise ControlError(f"the LQR gain does not stabilise the linear model (poles {np.round(poles, 4)})")
    return k


def closed_loop_poles(a: np.ndarray, b: np.ndarray, k: np.ndarray) -> np.ndarray:
    """Eigenvalues of A − B K, sorted by real part then imaginary part."""
    import numpy as np

    poles = np.linalg.eigvals(a - b @ np.asarray(k, float).reshape(1, -1))
    return poles[np.lexsort((poles.imag, poles.real))]
