"""A fixed-pivot chain's equations with its numbers in: M(q), bias(q, q̇), friction(q̇), B, the
forward and inverse dynamics and the exact linearisation, as numpy functions (in the chain's own
coordinates, `FixedPendulum.coordinates`)."""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import numpy as np

from ipgen.model.fixed_equations import FixedEquations, equations_of

if TYPE_CHECKING:
    import sympy as sp

    from ipgen.model.fixed import FixedPendulum


def _numbers(equations: FixedEquations, values: dict[str, float]) -> dict[sp.Symbol, sp.Float]:
    import sympy as sp

    symbols: set[sp.Symbol] = set()
    for matrix in (equations.mass_matrix, equations.bias, equations.friction):
        symbols |= matrix.free_symbols
    states = {*equations.q, *equations.qd, *equations.qdd}
    return {s: sp.Float(values[s.name], 17) for s in symbols - states}


class FixedModel:
    """The numeric model of a `FixedPendulum` (module docstring).

    Parameters
    ----------
    pendulum : FixedPendulum

    Examples
    --------
    >>> from ipgen.model.fixed import FixedPendulum
    >>> model = FixedModel(FixedPendulum(1, m=[1.0], l=[1.0], delta=[0.0], g=10.0))
    >>> bool(np.isclose(model.forward_dynamics([0.1], [0.0], [0.0])[0], 15 * np.sin(0.1), rtol=1e-14))
    True
    """

    def __init__(self, pendulum: FixedPendulum) -> None:
        import sympy as sp

        self.pendulum = pendulum
        self.equations = e = equations_of(pendulum)
        numbers = _numbers(e, pendulum.numbers())
        state = (list(e.q), list(e.qd))
        bias = e.bias.xreplace(numbers)
        mass = e.mass_matrix.xreplace(numbers)
        qdd = sp.Matrix(e.qdd)
        residual = mass * qdd + bias

        def compiled(expr: sp.Matrix, *args: Any) -> Callable[..., Any]:
            return sp.lambdify(args or state, expr, modules="numpy", cse=True)

        self._mass = compiled(mass)
        self._bias = compiled(bias)
        self._friction = compiled(e.friction.xreplace(numbers))
        self._residual_dq = compiled(residual.jacobian(e.q), list(e.q), list(e.qd), list(e.qdd))
        self._residual_dqd = compiled(residual.jacobian(e.qd), list(e.q), list(e.qd), list(e.qdd))
        self.B = np.array(e.input_matrix.tolist(), dtype=float)

    def mass_matrix(self, q: Any) -> np.ndarray:
        """M(q), n × n."""
        return np.array(self._mass(list(q), [0.0] * len(q)), dtype=float)

    def bias(self, q: Any, qd: Any) -> np.ndarray:
        """Coriolis, centrifugal, gravity and viscous damping forces, n."""
        return np.array(self._bias(list(q), list(qd)), dtype=float).reshape(-1)

    def friction(self, q: Any, qd: Any) -> np.ndarray:
        """Coulomb friction's generalised forces, n."""
        return np.array(self._friction(list(q), list(qd)), dtype=float).reshape(-1)

    def generalised_force(self, q: Any, qd: Any, qdd: Any, *, coulomb: bool = True) -> np.ndarray:
        """M q̈ + bias (+ friction): what B u must equal (the inverse dynamics)."""
        force = self.mass_matrix(q) @ np.asarray(qdd, dtype=float) + self.bias(q, qd)
        return force + self.friction(q, qd) if coulomb else force

    def forward_dynamics(self, q: Any, qd: Any, u: Any, *, coulomb: bool = True) -> np.ndarray:
        """q̈ = M⁻¹ (B u − bias − friction)."""
        force = self.B @ np.asarray(u, dtype=float) - self.bias(q, qd)
        if coulomb:
            force = force - self.friction(q, qd)
        return np.linalg.solve(self.mass_matrix(q), force)

    def linearize(self, q: Any, qd: Any, u: Any) -> tuple[np.ndarray, np.ndarray]:
        """(A, B) of ẋ = f(x, u), x = [q; q̇], exactly (Coulomb friction not linearised):
        ∂q̈/∂x = −M⁻¹ ∂r/∂x at q̈ = f, ∂q̈/∂u = M⁻¹ B, r = M q̈ + bias."""
        n = self.pendulum.links
        qdd = self.forward_dynamics(q, qd, u, coulomb=False)
        args = (list(q), list(qd), list(qdd))
        mass = self.mass_matrix(q)
        a = np.zeros((2 * n, 2 * n))
        a[:n, n:] = np.eye(n)
        a[n:, :n] = -np.linalg.solve(mass, np.array(self._residual_dq(*args), dtype=float))
        a[n:, n:] = -np.linalg.solve(mass, np.array(self._residual_dqd(*args), dtype=float))
        b = np.zeros((2 * n, self.B.shape[1]))
        b[n:, :] = np.linalg.solve(mass, self.B)
        return a, b
