"""The equations of motion of a fixed-pivot chain: M(q) q̈ + b(q, q̇) + F_c(q̇) = B u.

A fixed pivot is the chain of a cart whose cart never moves: ipgen's derivation of the classical
system (`derivation.derive`, Lagrange with Rayleigh dissipation) gives M and the bias of the
links' rows, which at θ0 = θ̇0 = 0 do not contain the cart at all (the cart's mass enters M00
only, its position no entry). To them this module adds (docs/model.md, "A fixed pivot"):

- the geared motors' rotors: the rotor of joint j turns at ω_{j−1} + gr (ω_j − ω_{j−1}) (ω_0 = 0
  the ground, ω_i = θ̇i), so its kinetic energy ½ Ir (vᵀ θ̇)² adds the constant Ir v vᵀ to M
  (v = gr e_j + (1 − gr) e_{j−1}); no Coriolis term;
- Coulomb friction per joint on the joint's relative rate w_j = θ̇j − θ̇(j−1) (w_1 = θ̇1):
  torque c_j·law(w_j), law tanh(k w) or atan(k w) (k = `coulomb_rate`), acting like the joint's
  viscous damper (+ on link j, − on link j−1);
- B: the torque u_k of the motor at joint j acts on link j and, reacting, on link j−1.

Everything is first derived in ipgen's coordinates θ (absolute, from upright, clockwise) and
then, as for the other systems, mapped to the rig's q with θ = R q + d: M_q = Rᵀ M R,
b_q = Rᵀ b, F_q = Rᵀ F, B_q = Rᵀ B (u is the torque in the rig's positive sense, so B_q = e_j in
relative coordinates).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cache
from typing import TYPE_CHECKING

from ipgen.model.coordinates import Coordinates

if TYPE_CHECKING:
    import numpy as np
    import sympy as sp

    from ipgen.model.fixed import FixedPendulum


@dataclass(frozen=True)
class FixedEquations:
    """M q̈ + bias + friction = B u of one fixed-pivot structure, as sympy matrices.

    `q`, `qd`, `qdd` are the coordinates' symbols (theta1.. in ipgen's coordinates, q1.. in a
    rig's), the parameters m1.., l1.., com1.., J1.., delta1.., cf1.. (Coulomb), g, coulomb_rate,
    Ir1.., gr1.. (per input) and the inputs u1...

    Examples
    --------
    >>> e = fixed_equations(1, (1,), "tanh", Coordinates())
    >>> e.input_matrix
    Matrix([[1]])
    """

    links: int
    joints: tuple[int, ...]
    coordinates: Coordinates
    q: tuple[sp.Symbol, ...]
    qd: tuple[sp.Symbol, ...]
    qdd: tuple[sp.Symbol, ...]
    u: tuple[sp.Symbol, ...]
    mass_matrix: sp.Matrix
    bias: sp.Matrix  # Coriolis, centrifugal, gravity and viscous damping (column)
    friction: sp.Matrix  # Coulomb friction's generalised forces (column)
    input_matrix: sp.Matrix  # n × m
    kinetic_energy: sp.Expr
    potential_energy: sp.Expr

    @property
    def residual(self) -> sp.Matrix:
        """M q̈ + bias + friction: the generalised forces the inputs must supply, B u."""
        import sympy as sp

        return self.mass_matrix * sp.Matrix(self.qdd) + self.bias + self.friction


def angle_map(coordinates: Coordinates, links: int) -> tuple[np.ndarray, float]:
    """(R, z) of θ = R q + z: R = s·I (absolute) or s·(lower triangle of ones) (relative), z = 0
    or π on every link."""
    import numpy as np

    sign = 1.0 if coordinates.positive == "clockwise" else -1.0
    ones = np.eye(links) if coordinates.angles == "absolute" else np.tril(np.ones((links, links)))
    return sign * ones, (np.pi if coordinates.zero == "hanging" else 0.0)


def state_map(coordinates: Coordinates, links: int) -> tuple[np.ndarray, np.ndarray]:
    """(P, c) of x_user = P x + c for a chain's 2n states [q; q̇] in `coordinates` against ipgen's
    [θ; θ̇] (`angle_map` inverted: q = R⁻¹ (θ − z), q̇ = R⁻¹ θ̇)."""
    import numpy as np

    rotation, zero = angle_map(coordinates, links)
    inverse = np.linalg.inv(rotation)
    matrix = np.zeros((2 * links, 2 * links))
    matrix[:links, :links] = matrix[links:, links:] = inverse
    return matrix, np.concatenate([-inverse @ np.full(links, zero), np.zeros(links)])


@cache
def fixed_equations(
    links: int, joints: tuple[int, ...], coulomb_law: str, coordinates: Coordinates
) -> FixedEquations:
    """The symbolic equations of a chain of `links` links driven at `joints`, in `coordinates`."""
    import sympy as sp

    canonical = _canonical(links, joints, coulomb_law)
    if coordinates.is_canonical:
        return canonical
    matrix, _ = angle_map(coordinates, links)
    rotation = sp.Matrix(links, links, lambda i, k: int(matrix[i, k]))
    zero = sp.pi if coordinates.zero == "hanging" else sp.Integer(0)
    q = tuple(sp.Symbol(f"q{i}", real=True) for i in range(1, links + 1))
    qd = tuple(sp.Symbol(f"dq{i}", real=True) for i in range(1, links + 1))
    qdd = tuple(sp.Symbol(f"ddq{i}", real=True) for i in range(1, links + 1))
    angles = rotation * sp.Matrix(q)
    rates = rotation * sp.Matrix(qd)
    change = {canonical.q[i]: zero + angles[i] for i in range(links)}
    change |= {canonical.qd[i]: rates[i] for i in range(links)}

    def mapped(expr: sp.Expr) -> sp.Expr:
        return expr.xreplace(change)

    return FixedEquations(
        links=links,
        joints=joints,
        coordinates=coordinates,
        q=q,
        qd=qd,
        qdd=qdd,
        u=canonical.u,
        mass_matrix=(rotation.T * canonical.mass_matrix * rotation).applyfunc(mapped),
        bias=(rotation.T * canonical.bias).applyfunc(mapped),
        friction=(rotation.T * canonical.friction).applyfunc(mapped),
        input_matrix=rotation.T * canonical.input_matrix * _sign(coordinates),
        kinetic_energy=mapped(canonical.kinetic_energy),
        potential_energy=mapped(canonical.potential_energy),
    )


def _sign(coordinates: Coordinates) -> int:
    return 1 if coordinates.positive == "clockwise" else -1


@cache
def _canonical(links: int, joints: tuple[int, ...], coulomb_law: str) -> FixedEquations:
    """The equations in ipgen's coordinates, u in the clockwise sense."""
    import sympy as sp

    from ipgen.model.derivation import derive
    from ipgen.model.system import System

    chain = derive(System("classical", links))
    s = chain.symbols
    still = {s.qd[0]: 0, **{tip: 0 for tip in s.tip}}
    mass = chain.mass_matrix[1:, 1:].xreplace(still)
    bias = chain.bias[1:, :].xreplace(still)
    q, qd, qdd = s.q[1:], s.qd[1:], s.qdd[1:]

    def rate_before(j: int) -> sp.Expr:  # the rate of the body before joint j (1-based)
        return qd[j - 2] if j >= 2 else sp.Integer(0)

    inputs = len(joints)
    u = tuple(sp.Symbol(f"u{k}", real=True) for k in range(1, inputs + 1))
    input_matrix = sp.zeros(links, inputs)
    for k, j in enumerate(joints, start=1):
        rotor, ratio = sp.Symbol(f"Ir{k}", nonnegative=True), sp.Symbol(f"gr{k}", real=True)
        lever = sp.zeros(links, 1)
        lever[j - 1] += ratio
        if j >= 2:
            lever[j - 2] += 1 - ratio
        mass += rotor * lever * lever.T
        input_matrix[j - 1, k - 1] = 1
        if j >= 2:
            input_matrix[j - 2, k - 1] = -1

    rate = sp.Symbol("coulomb_rate", positive=True)
    law = sp.tanh if coulomb_law == "tanh" else sp.atan
    friction = sp.zeros(links, 1)
    for j in range(1, links + 1):
        torque = sp.Symbol(f"cf{j}", nonnegative=True) * law(rate * (qd[j - 1] - rate_before(j)))
        friction[j - 1] += torque
        if j >= 2:
            friction[j - 2] -= torque
    velocity = sp.Matrix(qd)
    return FixedEquations(
        links=links,
        joints=joints,
        coordinates=Coordinates(),
        q=q,
        qd=qd,
        qdd=qdd,
        u=u,
        mass_matrix=mass,
        bias=bias,
        friction=friction,
        input_matrix=input_matrix,
        kinetic_energy=sp.expand((velocity.T * mass * velocity)[0, 0] / 2),
        potential_energy=chain.potential_energy.xreplace(still),
    )


def equations_of(pendulum: FixedPendulum) -> FixedEquations:
    """The symbolic equations of `pendulum`'s structure, in its coordinates."""
    return fixed_equations(pendulum.links, tuple(pendulum.joints), pendulum.coulomb_law, pendulum.coordinates)
