"""The model to identify: ipgen's equations with every parameter a symbol, the drive and friction.

The equations of motion of a rig (docs/model.md, docs/identify.md) are

    (M(θ) + J_r e0 e0ᵀ) θ̈ + bias(θ, θ̇) + c θ̇0 e0 − Q_c(θ̇) = b u e0

with M and bias from `derive` (the links as built; a group the scene does not give stays the
paper's rod, written in m and l, so that freeing m1 of a rod moves its inertia too), the DC
motor folded in (input gain b, back-EMF damping c, reflected rotor inertia J_r; b = 1 and
c = J_r = 0 for a direct drive) and the smooth Coulomb law Q_c (f_i = c_i tanh(w_i / v_s) on
the joint rate w_i, as in the simulator). Every physical constant is a sympy symbol; the
residual r = lhs − rhs is then expanded as a sum over monomials of the free parameters
(negative powers allowed: b = K_g k_t / R_m), r = Y_0 + Σ_k φ_k(p) Y_k, each Y_k a column of
the regressor, evaluated from data by lambdified numpy functions. The same symbols build a
CasADi function θ̈(θ, θ̇, u, p) for the output-error fit.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import lru_cache
from typing import TYPE_CHECKING, Any

from ipgen.errors import Error
from ipgen.model.actuator import MOTOR_CONSTANTS, motor_terms
from ipgen.model.pendulum import Pendulum
from ipgen.model.system import LINK_GROUPS, PARAMETER_GROUPS, System, group_indices, unused_parameter

if TYPE_CHECKING:
    import numpy as np
    import sympy as sp

__all__ = ["IdentifyError", "Monomial", "Setup", "StructuralModel", "structural_model"]


class IdentifyError(Error):
    """An identification that cannot be done as asked; the message says why and the fix."""


@dataclass(frozen=True)
class Setup:
    """What a fit starts from: the system, its drive and every parameter's prior value.

    `values` maps every name of `parameter_names()` to a float: m0.., l0.., delta0.., g, the
    link groups (com1.., J0.., J_axial1.., tip1..), the motor's constants (dc_motor only) and
    coulomb0..coulombn (0 without friction). `explicit` names the link groups the scene gives
    (the others are rods, m and l define them). `coulomb_speed` is v_s of the tanh law.
    """

    system: System
    actuator_kind: str
    values: tuple[tuple[str, float], ...]
    explicit: frozenset[str] = frozenset()
    friction: bool = False
    coulomb_speed: float = 0.01

    def value(self, name: str) -> float:
        return dict(self.values)[name]

    @classmethod
    def from_pendulum(cls, pendulum: Pendulum, free: Sequence[str] = ()) -> Setup:
        """The prior of a fit from a `Pendulum`: every parameter's value (the links' rods filled
        in, the motor's constants of a dc_motor, coulomb0.. when the pendulum has friction or a
        coulomb parameter is `free`).

        Parameters
        ----------
        pendulum : Pendulum
            The rig as known before the fit.
        free : sequence of str
            The names to be fitted (only their friction matters here).

        Returns
        -------
        Setup

        Examples
        --------
        >>> from ipgen.model.pendulum import Pendulum
        >>> setup = Setup.from_pendulum(Pendulum("classical", 1, [1.0, 0.1], [0.0, 0.5], [0.1, 0.0]))
        >>> setup.value("J1") == 0.1 * 0.5 * 0.5 / 12
        True
        """
        system, dof = pendulum.system, pendulum.dof
        values: dict[str, float] = {}
        for group in PARAMETER_GROUPS:
            for i, v in enumerate(getattr(pendulum, group)):
                values[f"{group}{i}"] = float(v)
        values["g"] = float(pendulum.g)
        built = pendulum.resolved_links()
        for group in LINK_GROUPS:
            for i in group_indices(group, pendulum.links):
                values[f"{group}{i}"] = float(getattr(built, group)[i])
        actuator = pendulum.actuator
        if actuator.is_motor:
            values.update({name: float(value) for name, value in actuator.constants().items()})
        coulomb = pendulum.coulomb
        friction = coulomb is not None or any(name.startswith("coulomb") for name in free)
        if friction:
            for i in range(dof):
                values[f"coulomb{i}"] = float(coulomb[i]) if coulomb is not None else 0.0
        return cls(
            system=system,
            actuator_kind=actuator.kind,
            values=tuple(values.items()),
            explicit=frozenset(pendulum.links_given()),
            friction=friction,
            coulomb_speed=float(pendulum.coulomb_speed),
        )

    def pendulum(self) -> Pendulum:
        """This setup's values as a `Pendulum`.

        Returns
        -------
        Pendulum
            Every link array given, as the values have them; the motor from its constants;
            friction if the setup has it.

        Raises
        ------
        PendulumError
            Values no system has (one line).

        Examples
        --------
        >>> p = Pendulum("classical", 1, [1.0, 0.1], [0.0, 0.5], [0.1, 0.0])
        >>> Setup.from_pendulum(p).pendulum().flat() == p.flat()
        True
        """
        values, system, dof = dict(self.values), self.system, self.system.dof

        def array(group: str) -> list[float]:
            return [values.get(f"{group}{i}", 0.0) for i in range(dof)]

        motor = {name: values[name] for name in MOTOR_CONSTANTS if name in values}
        return Pendulum(
            system.type, system.links, array("m"), array("l"), array("delta"), values["g"], system.inertia,
            **{group: array(group) for group in LINK_GROUPS},
            coulomb=array("coulomb") if self.friction else None,
            coulomb_speed=self.coulomb_speed,
            actuator={"kind": self.actuator_kind, **motor} if self.actuator_kind == "dc_motor" else
            {"kind": self.actuator_kind},
        )  # fmt: skip

    def parameter_names(self) -> tuple[str, ...]:
        """Every name a fit may free (those that change this model)."""
        return parameter_names(self.system, self.actuator_kind, self.explicit, self.friction)


def parameter_names(
    system: System, actuator_kind: str, explicit: frozenset[str], friction: bool
) -> tuple[str, ...]:
    links = system.links
    names = [f"{group}{i}" for group in PARAMETER_GROUPS for i in range(links + 1)]
    names.append("g")
    for group in LINK_GROUPS:
        names += [f"{group}{i}" for i in group_indices(group, links)]
    names = [n for n in names if unused_parameter(system.type, n, system.inertia) is None]
    if actuator_kind == "dc_motor":
        names += [k for k in MOTOR_CONSTANTS if k != "r" or not system.is_rotary]
    if friction:
        names += [f"coulomb{i}" for i in range(links + 1)]
    return tuple(names)


@dataclass(frozen=True)
class Monomial:
    """A product of powers of free parameters: ((name, exponent), ...) sorted by name; () is 1."""

    powers: tuple[tuple[str, int], ...]

    def text(self) -> str:
        if not self.powers:
            return "1"
        parts = []
        for name, power in self.powers:
            parts.append(name if power == 1 else f"{name}^{power}")
        return "·".join(parts)

    def value(self, values: dict[str, float]) -> float:
        out = 1.0
        for name, power in self.powers:
            out *= values[name] ** power
        return out


@dataclass(frozen=True, eq=False)  # hashed by identity: `structural_model` caches one per structure
class StructuralModel:
    """The residual's monomials in the free parameters and its numeric pieces (module docstring).

    `columns(q, qd, qdd, u, known)` → array (K + 1, dof, N): Y_0 (the part without free
    parameters) then Y_k for `monomials[k]`; `known` the values of `known_names` in order.
    `acceleration` (CasADi, built on first use) θ̈(q, qd, u, p) with p = (*free, *known).
    """

    system: System
    free: tuple[str, ...]
    known_names: tuple[str, ...]
    monomials: tuple[Monomial, ...]
    _columns: Callable[..., Any]
    _mass: Any  # sympy matrix, for the CasADi model
    _rhs: Any  # sympy column
    _symbols: Any  # Symbols-like: q, qd, u and the parameter symbols by name
    # Groups of monomials (indices) whose regressor columns are proportional for any data: the
    # data can only ever see a weighted sum of them (e.g. delta0 and kt·km, both on θ̇0).
    shared: tuple[tuple[int, ...], ...] = ()

    def columns(
        self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray, u: np.ndarray, known: Sequence[float]
    ) -> np.ndarray:
        import numpy as np

        n = q.shape[0]
        dof = self.system.dof
        out = self._columns(*q.T, *qd.T, *qdd.T, u, *known)
        result = np.zeros((len(self.monomials) + 1, dof, n))
        for k, column in enumerate(out):
            for i, entry in enumerate(column):
                result[k, i] = np.broadcast_to(np.asarray(entry, dtype=float), (n,))
        return result

    def exponents(self) -> list[list[int]]:
        """The exponent matrix: one row per monomial, one column per free parameter."""
        index = {name: j for j, name in enumerate(self.free)}
        rows = []
        for monomial in self.monomials:
            row = [0] * len(self.free)
            for name, power in monomial.powers:
                row[index[name]] = power
            rows.append(row)
        return rows

    @property
    def casadi_acceleration(self) -> Any:
        return _casadi_acceleration(self)

    def mass_diagonal(self, q: Sequence[float], params: Sequence[float]) -> list[float]:
        """The diagonal of the mass matrix (motor inertia included) at angles q; `params` the free
        then the known values."""
        return [float(v) for v in _mass_diagonal(self)(*q, *params)]


def _sympy_model(
    system: System, actuator_kind: str, explicit: frozenset[str], friction: bool
) -> tuple[Any, Any, dict[str, Any], Any]:
    """(M_eff, rhs_eff, symbols by name, (q, qd, qdd, u)) of the rig, every constant a symbol."""
    import sympy as sp

    from ipgen.model.derivation import derive

    equations = derive(system)
    s = equations.symbols
    dof = system.dof
    by_name: dict[str, sp.Symbol] = {}
    for group in (*PARAMETER_GROUPS, *LINK_GROUPS):
        for i, symbol in enumerate(getattr(s, group)):
            by_name[f"{group}{i}"] = symbol
    by_name["g"] = s.g
    # Groups the scene does not give: the paper's rods, in m and l.
    rods: dict[sp.Symbol, sp.Expr] = {}
    for i in range(dof):
        if "com" not in explicit:
            rods[s.com[i]] = s.l[i] / 2 if i else sp.Integer(0)
        if "J" not in explicit:
            if i == 0:
                rods[s.J[0]] = s.m[0] * s.l[0] ** 2 / 3 if system.is_rotary else sp.Integer(0)
            else:
                rods[s.J[i]] = s.m[i] * s.l[i] ** 2 / 12
        if "J_axial" not in explicit:
            rods[s.J_axial[i]] = sp.Integer(0)
        if "tip" not in explicit:
            rods[s.tip[i]] = sp.Integer(0)
    mass = equations.mass_matrix.xreplace(rods)
    bias = equations.bias.xreplace(rods)
    u = s.u
    gain: sp.Expr = sp.Integer(1)
    back_emf: sp.Expr = sp.Integer(0)
    reflected: sp.Expr = sp.Integer(0)
    if actuator_kind == "dc_motor":
        motor = {name: sp.Symbol(name, positive=True) for name in MOTOR_CONSTANTS}
        constants = {k: v for k, v in motor.items() if k != "r" or not system.is_rotary}
        by_name.update(constants)
        gain, back_emf, reflected = motor_terms(constants)  # the fold, in symbols
    mass = mass.copy()
    mass[0, 0] = mass[0, 0] + reflected
    rhs = sp.zeros(dof, 1)
    rhs[0] = gain * u - back_emf * s.qd[0]
    speed = sp.Symbol("coulomb_speed", positive=True)
    if friction:
        for i in range(dof):
            c = sp.Symbol(f"coulomb{i}", nonnegative=True)
            by_name[f"coulomb{i}"] = c
            rate = s.qd[i] - s.qd[i - 1] if i >= 2 else s.qd[i]
            f = c * sp.tanh(rate / speed)
            rhs[i] -= f
            if i >= 2:
                rhs[i - 1] += f
    by_name["coulomb_speed"] = speed
    rhs = rhs - bias
    return mass, rhs, by_name, (s.q, s.qd, s.qdd, u)


@lru_cache(maxsize=32)
def structural_model(
    system: System, actuator_kind: str, explicit: frozenset[str], friction: bool, free: tuple[str, ...]
) -> StructuralModel:
    """The residual's regressor for `free` (cached per structure; values enter at evaluation)."""
    import sympy as sp

    mass, rhs, by_name, (q, qd, qdd, u) = _sympy_model(system, actuator_kind, explicit, friction)
    allowed = parameter_names(system, actuator_kind, explicit, friction)
    for name in free:
        if name not in allowed:
            raise IdentifyError(
                f"free parameter {name!r} is not in this model: choose from {', '.join(allowed)}"
            )
    known_names = tuple(n for n in (*allowed, "coulomb_speed") if n not in free)
    free_symbols = [by_name[n] for n in free]
    residual = mass * sp.Matrix(qdd) - rhs
    # Monomials in the free parameters: each term of the expanded residual split into a product
    # of powers of free symbols (the monomial) and the rest (its coefficient, a data function).
    coefficients: dict[tuple[tuple[str, int], ...], list[sp.Expr]] = {}
    names = {symbol: name for name, symbol in zip(free, free_symbols, strict=True)}
    for i in range(system.dof):
        expanded = sp.expand(residual[i])
        for term in sp.Add.make_args(expanded):
            powers: dict[str, int] = {}
            rest: list[sp.Expr] = []
            for factor in sp.Mul.make_args(term):
                base, exponent = factor.as_base_exp()
                if base in names and exponent.is_Integer:
                    powers[names[base]] = powers.get(names[base], 0) + int(exponent)
                else:
                    if factor.free_symbols & set(free_symbols):
                        raise IdentifyError(
                            f"free parameters {', '.join(free)} enter this model non-polynomially "
                            f"({factor}); free fewer of them"
                        )
                    rest.append(factor)
            key = tuple(sorted((n, p) for n, p in powers.items() if p != 0))
            entry = coefficients.setdefault(key, [sp.Integer(0)] * system.dof)
            entry[i] = entry[i] + sp.Mul(*rest)
    constant = coefficients.pop((), [sp.Integer(0)] * system.dof)
    keys = sorted(coefficients, key=lambda k: (sum(abs(p) for _, p in k), k))
    monomials = tuple(Monomial(k) for k in keys)
    known_symbols = [by_name[n] for n in known_names]
    matrix = [constant, *(coefficients[k] for k in keys)]
    arguments = [*q, *qd, *qdd, u, *known_symbols]
    columns = sp.lambdify(arguments, matrix, modules="numpy", cse=True)
    shared = _proportional_columns(columns, 3 * system.dof + 1, len(arguments), len(keys))
    return StructuralModel(
        system=system,
        free=tuple(free),
        known_names=known_names,
        monomials=monomials,
        _columns=columns,
        _mass=mass,
        _rhs=rhs,
        _symbols=(q, qd, u, [by_name[n] for n in (*free, *known_names)]),
        shared=shared,
    )


def _proportional_columns(
    columns: Callable[..., Any], data: int, arguments: int, count: int
) -> tuple[tuple[int, ...], ...]:
    """Groups of monomial columns that are proportional, found by evaluating every column at a
    few random data points (the first `data` arguments; the known parameters drawn at random
    once): two columns whose entries keep one ratio at every point and in every row are the same
    function of the data up to a constant."""
    import numpy as np

    rng = np.random.default_rng(20261124)
    points = rng.uniform(0.3, 1.7, size=(arguments, 4))
    points[data:] = points[data:, :1]  # the known parameters: the same at every point
    values = np.array(
        [[np.broadcast_to(np.asarray(e, dtype=float), (4,)) for e in column] for column in columns(*points)]
    )[1:]  # (count, dof, points)
    flat = values.reshape(count, -1)
    parent = list(range(count))

    def root(k: int) -> int:
        while parent[k] != k:
            k = parent[k]
        return k

    for a in range(count):
        for b in range(a + 1, count):
            x, y = flat[a], flat[b]
            if not np.any(x) or not np.any(y) or np.any((x == 0) != (y == 0)):
                continue
            ratio = x[x != 0] / y[y != 0]
            if np.allclose(ratio, ratio[0], rtol=1e-9, atol=0.0):
                parent[root(b)] = root(a)
    groups: dict[int, list[int]] = {}
    for k in range(count):
        groups.setdefault(root(k), []).append(k)
    return tuple(tuple(g) for g in groups.values() if len(g) > 1)


@lru_cache(maxsize=32)
def _mass_diagonal(model: StructuralModel) -> Callable[..., Any]:
    import sympy as sp

    q, _, _, params = model._symbols
    dof = model.system.dof
    return sp.lambdify([*q, *params], [model._mass[i, i] for i in range(dof)], modules="math")


@lru_cache(maxsize=32)
def _casadi_acceleration(model: StructuralModel) -> Any:
    """θ̈(q, qd, u, p) as a CasADi Function (p = free then known values), by a linear solve."""
    import casadi
    import sympy as sp

    q, qd, u, params = model._symbols
    dof = model.system.dof
    modules = [{"sin": casadi.sin, "cos": casadi.cos, "tanh": casadi.tanh, "sqrt": casadi.sqrt}]
    build = sp.lambdify(
        [*q, *qd, u, *params], [list(model._mass), list(model._rhs)], modules=modules, cse=True
    )
    qs = casadi.SX.sym("q", dof)
    qds = casadi.SX.sym("qd", dof)
    us = casadi.SX.sym("u")
    ps = casadi.SX.sym("p", len(params))
    mass_entries, rhs_entries = build(
        *casadi.vertsplit(qs), *casadi.vertsplit(qds), us, *casadi.vertsplit(ps)
    )
    mass = casadi.reshape(casadi.vertcat(*[casadi.SX(e) for e in mass_entries]), dof, dof)
    rhs = casadi.vertcat(*[casadi.SX(e) for e in rhs_entries])
    accel = casadi.solve(mass, rhs) if dof > 1 else rhs / mass
    return casadi.Function("acceleration", [qs, qds, us, ps], [accel])


