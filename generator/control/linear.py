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

import math
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import lru_cache
from typing import TYPE_CHECKING

from ipgen.control.coordinates import CoordinateError, Coordinates
from ipgen.errors import Error
from ipgen.model.actuator import Actuator, ActuatorError, as_actuator, fold
from ipgen.model.links import LinkError, resolve_links, rod_value
from ipgen.model.system import System

if TYPE_CHECKING:
    import numpy as np

__all__ = [
    "ControlError",
    "Dynamics",
    "EquilibriumWarning",
    "closed_loop_poles",
    "dynamics",
    "equilibrium_state",
    "linearize",
    "lqr",
]


class ControlError(Error):
    """A controller that cannot be computed (bad weights, an uncontrollable pair, ...)."""


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

    def mass(self, q: Sequence[float], params: Sequence[float]) -> np.ndarray:
        """M(θ), dof × dof."""
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


def _system(type: str, links: int, inertia: str) -> System:
    try:
        return System(type, links, inertia if type == "rotary" else "pivot")  # type: ignore[arg-type]
    except (ValueError, TypeError) as exc:
        raise ControlError(
            f"{exc}: expected type 'classical' or 'rotary', links >= 1, inertia 'pivot' or 'full'"
        ) from None


def _params(
    system: System,
    m: Sequence[float],
    l: Sequence[float],  # noqa: E741
    delta: Sequence[float],
    g: float,
    links: dict[str, Sequence[float] | None] | None = None,
) -> list[float]:
    """The flat parameters of `Dynamics`; `links`: com, J, J_axial, tip (None: the rods)."""
    dof = system.dof
    for name, values in (("m", m), ("l", l), ("delta", delta)):
        if len(values) != dof:
            raise ControlError(f"{name} has {len(values)} entries, expected {dof} (links + 1 = base + links)")
    values = [float(v) for v in (*m, *l, *delta, g)]
    if not all(math.isfinite(v) for v in values):
        raise ControlError("parameters must be finite numbers")
    try:
        built = resolve_links(system, values[:dof], values[dof : 2 * dof], links or {})
    except LinkError as exc:
        raise ControlError(str(exc)) from None
    return values + built.flat()


def _vector(name: str, value: Sequence[float] | None, size: int, what: str) -> np.ndarray:
    import numpy as np

    if value is None:
        return np.zeros(size)
    array = np.asarray(value, dtype=float).reshape(-1)
    if array.size != size:
        raise ControlError(f"{name} has {array.size} entries, expected {size} ({what})")
    if not np.all(np.isfinite(array)):
        raise ControlError(f"{name} must be finite")
    return array


def linearize(
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
    """(A, B) of ẋ = f(x, u), x = [θ; θ̇], about the state (q, qd) and input u.

    `com`, `J`, `J_axial`, `tip` (dof entries each, index 0 the base) describe the links as built
    (docs/model.md): CoG distances, inertias about the CoGs (J[0]: the rotary arm's about the
    vertical), about the links' axes (rotary "full" only) and tip masses; each left out is the
    paper's rod (l/2, m l²/12 and m0 l0²/3, 0, 0). Values no body has raise `ControlError`.

    A is 2·dof × 2·dof, B is 2·dof × 1 (dof = links + 1); both are numpy float arrays. q and qd
    default to zero (upright, at rest). A state that is not an equilibrium for `u` (θ̇ ≠ 0 or
    θ̈ ≠ 0) is allowed — A and B are then the Jacobians along a moving trajectory — but warned
    about with an `EquilibriumWarning`.

    `actuator` (an `ipgen.Actuator`, a dict of its fields, or None: "direct") says what u is: with
    kind "dc_motor" u is the motor voltage [V], B is per volt and A has the back-EMF's damping
    and the rotor's reflected inertia (docs/model.md, "A DC motor on the base"); with kind
    "acceleration" u is the base's acceleration θ̈0 [m/s² or rad/s²]: A's θ̈0 row is zero, B's
    is 1, and the links follow θ̈_L = −M_LL⁻¹ (M_L0 u + b_L) (docs/model.md, "An
    acceleration-driven base"); m0, δ0 (and J0 of an arm) then do not enter A or B.

    `angles` ("absolute" | "relative"), `zero` ("upright" | "hanging") and `positive`
    ("clockwise" | "counterclockwise") give the link angles in the rig's own convention
    (`control.coordinates`): q, qd are then in it, and so are the rows and columns of A and B.
    """
    import numpy as np

    convention = _coordinates(angles, zero, positive)
    if not convention.is_canonical:
        dof = links + 1
        x_user = np.concatenate(
            [
                _vector("q", q, dof, "one angle per coordinate"),
                _vector("qd", qd, dof, "one rate per coordinate"),
            ]
        )
        p, _ = convention.matrices(links)
        x = convention.to_canonical(x_user, links)
        a, b = linearize(
            type, links, m, l, delta, g, inertia, q=x[:dof], qd=x[dof:], u=u,
            com=com, J=J, J_axial=J_axial, tip=tip, actuator=actuator,
        )  # fmt: skip
        return p @ a @ np.linalg.inv(p), p @ b

    system = _system(type, links, inertia)
    m, delta, J, gain = _with_actuator(system, m, l, delta, J, actuator)
    params = _params(system, m, l, delta, g, {"com": com, "J": J, "J_axial": J_axial, "tip": tip})
    dof = system.dof
    q_ = _vector("q", q, dof, "one angle or position per degree of freedom")
    qd_ = _vector("qd", qd, dof, "one rate per degree of freedom")
    try:
        u = float(u)
    except (TypeError, ValueError):
        u = math.nan
    if not math.isfinite(u):
        raise ControlError("u must be a finite number (the input about which to linearise)")
    if as_actuator(actuator).is_acceleration:  # checked by _with_actuator
        qdd, dq, dqd, du = dynamics(system).acceleration_jacobians(q_, qd_, float(u), params)
    else:
        qdd, dq, dqd, du = dynamics(system).jacobians(q_, qd_, float(u), params)
    scale = max(1.0, float(np.max(np.abs(dq))) if dq.size else 1.0)
    if np.any(qd_ != 0.0) or float(np.max(np.abs(qdd))) > 1e-9 * scale:
        warnings.warn(
            f"linearize: the state is not an equilibrium for u = {u:g} (|θ̇| max {np.max(np.abs(qd_)):.3g}, "
            f"|θ̈| max {np.max(np.abs(qdd)):.3g}); A and B describe the motion about a moving point",
            EquilibriumWarning,
            stacklevel=2,
        )
    a = np.zeros((2 * dof, 2 * dof))
    a[:dof, dof:] = np.eye(dof)
    a[dof:, :dof] = dq
    a[dof:, dof:] = dqd
    b = np.zeros((2 * dof, 1))
    b[dof:, 0] = du * gain
    if not (np.all(np.isfinite(a)) and np.all(np.isfinite(b))):
        raise ControlError(
            f"the linear model overflows at this state and input (u = {u:g}): use a smaller u or state"
        )
    return a, b


def _coordinates(angles: str, zero: str, positive: str) -> Coordinates:
    try:
        return Coordinates(angles, zero, positive)
    except CoordinateError as exc:
        raise ControlError(str(exc)) from None


def _with_actuator(
    system: System,
    m: Sequence[float],
    l: Sequence[float],  # noqa: E741
    delta: Sequence[float],
    J: Sequence[float] | None,
    actuator: Actuator | dict | None,
) -> tuple[Sequence[float], Sequence[float], Sequence[float] | None, float]:
    """(m, delta, J, b) of the direct model equivalent to `actuator` driving the base (`fold`)."""
    try:
        drive = as_actuator(actuator)
        drive.check(system)
    except ActuatorError as exc:
        raise ControlError(str(exc)) from None
    if not drive.is_motor:  # direct, or acceleration (m0, δ0 and J0 then do not enter θ̈)
        return m, delta, J, 1.0
    dof = system.dof
    if len(m) != dof or len(l) != dof or len(delta) != dof:
        return m, delta, J, 1.0  # _params names the wrong length
    inertias = list(J) if J is not None else [rod_value(system, "J", i, m, l) for i in range(dof)]
    if len(inertias) != dof:
        return m, delta, J, 1.0  # resolve_links names the wrong length
    m_, delta_, J_, gain = fold(drive, system, [float(x) for x in m], [float(x) for x in delta], inertias)
    return m_, delta_, J_ if (J is not None or system.is_rotary) else None, gain


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
    angles = _vector(
        "equilibrium", equilibrium, dof, "θ0 and one absolute angle per link; velocities are zero"
    )
    for i, angle in enumerate(angles[1:], start=1):
        if abs(math.remainder(angle, math.pi)) > 1e-9:
            raise ControlError(
                f"equilibrium[{i}] = {angle:g} is not an equilibrium angle: "
                "links rest upright (0) or hanging (π)"
            )
    x[:dof] = angles
    return x


def _weights(
    Q: np.ndarray | Sequence, R: float | np.ndarray | Sequence, size: int
) -> tuple[np.ndarray, np.ndarray]:
    import numpy as np

    q = np.asarray(Q, dtype=float)
    if q.ndim == 1:
        if q.size != size:
            raise ControlError(f"Q has {q.size} diagonal entries, expected {size} (2 · (links + 1))")
        if np.any(q < 0):
            raise ControlError("Q's diagonal weights must be >= 0")
        q = np.diag(q)
    if q.shape != (size, size):
        raise ControlError(f"Q has shape {q.shape}, expected ({size}, {size}) or {size} diagonal entries")
    if not np.all(np.isfinite(q)):
        raise ControlError("Q must be finite")
    if not np.allclose(q, q.T, rtol=1e-12, atol=1e-12 * max(1.0, float(np.max(np.abs(q))))):
        raise ControlError("Q must be symmetric")
    q = 0.5 * (q + q.T)
    if float(np.min(np.linalg.eigvalsh(q))) < -1e-12 * max(1.0, float(np.max(np.abs(q)))):
        raise ControlError("Q must be positive semidefinite (an eigenvalue is negative)")
    r = np.asarray(R, dtype=float).reshape(-1)
    if r.size != 1 or not math.isfinite(float(r[0])) or float(r[0]) <= 0:
        raise ControlError(f"R = {np.asarray(R).tolist()}: expected one number > 0 (the weight of u²)")
    return q, r.reshape(1, 1)


def _check_stabilisable(a: np.ndarray, b: np.ndarray, q: np.ndarray) -> None:
    """PBH tests: (A, B) stabilisable and (A, Q^½) detectable, or a ControlError naming the mode."""
    import numpy as np

    size = a.shape[0]
    eigenvalues = np.linalg.eigvals(a)
    scale = max(1.0, float(np.linalg.norm(a, 2)))
    w, v = np.linalg.eigh(q)
    c = (v * np.sqrt(np.clip(w, 0.0, None))).T  # Q = cᵀ c
    for lam in eigenvalues:
        if lam.real < -1e-9 * scale:
            continue  # a stable mode needs neither
        shifted = a - lam * np.eye(size)
        if np.linalg.matrix_rank(np.hstack([shifted, b]), tol=1e-9 * scale) < size:
            raise ControlError(
                f"(A, B) is not stabilisable: the mode at s = {lam:.4g} cannot be moved by the input; "
                "no gain can stabilise this equilibrium"
            )
        if np.linalg.matrix_rank(np.vstack([shifted, c]), tol=1e-9 * scale) < size:
            raise ControlError(
                f"(A, Q) is not detectable: Q puts no weight on the mode at s = {lam:.4g}; "
                "give the states of that mode a positive weight"
            )


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
    actuator: Actuator | dict | None = None,
    angles: str = "absolute",
    zero: str = "upright",
    positive: str = "clockwise",
) -> np.ndarray:
    """The LQR gain K, a 1 × 2·dof array, of u = −K (x − x_eq) about an equilibrium.

    The shape is python-control's (`control.lqr`), so the textbook `A - B @ K` is the closed
    loop's matrix; `K[0]` or `K.ravel()` is the row as a vector.

    `Q` is 2·dof diagonal weights or a symmetric positive semidefinite 2·dof × 2·dof matrix, `R`
    the weight of u² (> 0). `equilibrium` is "upright" (default), "hanging", or the dof angles
    (e.g. [0, π, 0]: link 1 hanging, link 2 upright); velocities are zero there and u = 0.
    An unstabilisable (A, B) or undetectable (A, Q) pair raises `ControlError` instead of
    returning a gain that does not stabilise. K comes from scipy's `solve_continuous_are`.
    `com`, `J`, `J_axial`, `tip`: the links as built, as for `linearize` (default: the rods);
    `actuator`: as for `linearize` (a "dc_motor" gives K in volts per unit of state, an
    "acceleration" K in m/s² or rad/s² per unit of state).
    `angles`, `zero`, `positive`: the rig's convention, as for `linearize`: K (and Q, and an
    `equilibrium` given as angles) are then in the rig's coordinates.
    """
    import numpy as np
    from scipy.linalg import solve_continuous_are

    convention = _coordinates(angles, zero, positive)
    dof = links + 1
    if not convention.is_canonical and equilibrium is not None and not isinstance(equilibrium, str):
        user = np.concatenate(
            [_vector("equilibrium", equilibrium, dof, "θ0 and one angle per link"), np.zeros(dof)]
        )
        equilibrium = list(convention.to_canonical(user, links)[:dof])
    x_eq = equilibrium_state(links, equilibrium)
    a, b = linearize(
        type,
        links,
        m,
        l,
        delta,
        g,
        inertia,
        q=x_eq[:dof],
        qd=x_eq[dof:],
        u=0.0,
        com=com,
        J=J,
        J_axial=J_axial,
        tip=tip,
        actuator=actuator,
    )
    if not convention.is_canonical:
        p, _ = convention.matrices(links)
        a, b = p @ a @ np.linalg.inv(p), p @ b
    q, r = _weights(Q, R, 2 * dof)
    _check_stabilisable(a, b, q)
    try:
        p = solve_continuous_are(a, b, q, r)
    except (np.linalg.LinAlgError, ValueError) as exc:
        raise ControlError(f"the Riccati equation has no stabilising solution ({exc})") from None
    k = np.linalg.solve(r, b.T @ p).reshape(1, -1)
    poles = np.linalg.eigvals(a - b @ k)
    if not np.all(np.isfinite(k)) or np.max(poles.real) >= 0:
        raise ControlError(f"the LQR gain does not stabilise the linear model (poles {np.round(poles, 4)})")
    return k


def closed_loop_poles(a: np.ndarray, b: np.ndarray, k: np.ndarray) -> np.ndarray:
    """Eigenvalues of A − B K, sorted by real part then imaginary part."""
    import numpy as np

    poles = np.linalg.eigvals(a - b @ np.asarray(k, float).reshape(1, -1))
    return poles[np.lexsort((poles.imag, poles.real))]
