"""Identification of a fixed-pivot chain from measured joint torques: a linear regression.

The generalised forces M q̈ + bias + friction = B τ are linear in the per-link inertial
parameters m_i, h_i = m_i com_i (first moment about the pivot) and I_i = J_i + m_i com_i² (inertia
about the pivot), in the joint damping δ_i, the Coulomb coefficients c_i (the law and its rate
known) and the rotor inertias Ir_k (the lengths, g and the gear ratios known):

    Y(q, q̇, q̈) φ = B τ,   φ = (I_i, h_i, δ_i, c_i, Ir_k, m_i).

Y comes from ipgen's own derivation (`model.fixed_equations`, the chain in the rig's
coordinates) by substituting com = h/m, J = I − h²/m and differentiating with respect to φ.
Not every φ can be found from any data: the **base parameters** are the independent
combinations, found structurally (Y at random states; a column is kept, in the order above, when
it raises the rank; each dropped column is a combination of the kept ones, exactly) — e.g. m_1
never enters a fixed chain's equations, m_2 only as m_2 l_1 beside h_1 and m_2 l_1² beside I_1.
Each measured torque may carry a constant bias o_k (the drive's torque reading at rest, sensor
offset): τ_measured = τ + o, so Y φ + B o = B τ_measured, and o (one per input) joins β as a base
parameter (`offset=True`, the default).

Two fits (`method`):

- "sequential" (the default): tip first, the way a chain's equations are triangular in its
  links' parameters. The last joint's equation contains only the outermost link's parameters
  (and its rotor's and its torque's offset); they are fitted by least squares on that equation
  alone. Each equation inward then fits only the base parameters it adds, with the outer ones
  fixed at their estimates. An error of the model in an inner joint's equation (the shoulder's
  larger unmodelled torque) thus cannot move an outer link's estimates.
- "joint": all equations together, each joint's equation weighted by the inverse of its
  residual's standard deviation (two passes).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from ipgen.errors import Error
from ipgen.identification.recording import Filtered
from ipgen.model.fixed import FixedPendulum
from ipgen.model.fixed_equations import equations_of

STRUCTURE_SAMPLES = 60
RANK_TOLERANCE = 1e-9
Z95 = 1.959963984540054
PASSES = 2
FIT_METHODS = ("sequential", "joint")
DEFAULT_METHOD = "sequential"
# φ's kinds that physics keeps ≥ 0 (inertias about the joint, rotor inertias, masses, damping and
# Coulomb coefficients); a first moment h = m·c is negative for a centre of mass behind the joint.
NONNEGATIVE_KINDS = ("I", "Ir", "m", "delta", "cf")


class TorqueFitError(Error, ValueError):
    """A torque regression that cannot be carried out; one line."""


@dataclass(frozen=True)
class Regressor:
    """Y(q, q̇, q̈) of `Y φ = B τ` for one chain (module docstring).

    `names` are φ's names (I1, h1, delta1, cf1, Ir1, m1, ...), `matrix(q, qd, qdd)` gives Y for N
    samples as an (N·n) × p array (sample-major: the n equations of sample 0, then of sample 1),
    and `B` the chain's input matrix.
    """

    pendulum: FixedPendulum
    names: tuple[str, ...]
    _entries: Callable[..., list]
    B: np.ndarray

    def matrix(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> np.ndarray:
        q, qd, qdd = (np.atleast_2d(np.asarray(x, dtype=float)) for x in (q, qd, qdd))
        count, n = q.shape
        values = self._entries(*q.T, *qd.T, *qdd.T)
        y = np.empty((count, n, len(self.names)))
        for i, row in enumerate(values):
            for k, entry in enumerate(row):
                y[:, i, k] = np.broadcast_to(np.asarray(entry, dtype=float), (count,))
        return y.reshape(count * n, len(self.names))

    def parameters(self, pendulum: FixedPendulum) -> np.ndarray:
        """φ of `pendulum` (of the same structure), in the order of `names`."""
        com, inertia = pendulum.resolved("com"), pendulum.resolved("J")
        values: dict[str, float] = {}
        for i in range(pendulum.links):
            k = i + 1
            m, c = pendulum.m[i], com[i]
            values |= {f"m{k}": m, f"h{k}": m * c, f"I{k}": inertia[i] + m * c * c}
            values |= {
                f"delta{k}": pendulum.delta[i],
                f"cf{k}": (pendulum.coulomb or (0.0,) * pendulum.links)[i],
            }
        for k, rotor in enumerate(pendulum.motor("Ir"), start=1):
            values[f"Ir{k}"] = rotor
        return np.array([values[name] for name in self.names])

    def torques(self, y_phi: np.ndarray) -> np.ndarray:
        """τ (N × m) from the generalised forces Y φ (N·n): B⁺ applied sample by sample."""
        n = self.B.shape[0]
        forces = y_phi.reshape(-1, n)
        return forces @ np.linalg.pinv(self.B).T


def regressor(pendulum: FixedPendulum) -> Regressor:
    """The `Regressor` of `pendulum`'s structure with its known values (l, g, gr, the Coulomb
    law's rate) substituted."""
    import sympy as sp

    e = equations_of(pendulum)
    n = pendulum.links
    known = pendulum.numbers()
    symbols = {s.name: s for s in e.residual.free_symbols}
    inertial = {}
    unknown: list[sp.Symbol] = []
    for kind in ("I", "h", "delta", "cf"):
        unknown += [sp.Symbol(f"{kind}{k}") for k in range(1, n + 1)]
    unknown += [sp.Symbol(f"Ir{k}") for k in range(1, pendulum.inputs + 1)]
    unknown += [sp.Symbol(f"m{k}") for k in range(1, n + 1)]
    for k in range(1, n + 1):
        m, h, inertia = sp.Symbol(f"m{k}"), sp.Symbol(f"h{k}"), sp.Symbol(f"I{k}")
        inertial[symbols.get(f"com{k}", sp.Symbol(f"com{k}"))] = h / m
        inertial[symbols.get(f"J{k}", sp.Symbol(f"J{k}"))] = inertia - h**2 / m
    renamed = {symbols[s.name]: s for s in unknown if s.name in symbols}  # the model's, with assumptions
    fixed = {
        symbols[name]: sp.Float(known[name], 17)
        for name in symbols
        if name.startswith(("l", "gr", "coulomb_rate")) or name == "g"
    }
    residual = e.residual.xreplace(inertial).xreplace(fixed).xreplace(renamed)
    residual = residual.applyfunc(sp.expand)
    jacobian = residual.jacobian(unknown)
    remainder = (residual - jacobian * sp.Matrix(unknown)).applyfunc(sp.expand)
    if any(entry != 0 for entry in remainder):  # not expected: the equations are linear in φ
        raise TorqueFitError("the chain's equations are not linear in its inertial parameters")
    arguments = (*e.q, *e.qd, *e.qdd)
    entries = sp.lambdify(arguments, jacobian.tolist(), modules="numpy", cse=True)
    return Regressor(
        pendulum, tuple(str(s) for s in unknown), entries, np.array(e.input_matrix.tolist(), float)
    )


@dataclass(frozen=True)
class BaseParameters:
    """The identifiable combinations β = φ_kept + K φ_dropped (module docstring)."""

    kept: tuple[int, ...]  # indices into Regressor.names
    dropped: tuple[int, ...]
    combination: np.ndarray  # K: len(kept) × len(dropped)
    names: tuple[str, ...]  # φ's names

    def labels(self) -> list[str]:
        """Each base parameter written out, e.g. "I1 + 0.04·m2 + 36·Ir1"."""
        labels = []
        for row, index in enumerate(self.kept):
            parts = [self.names[index]]
            for column, other in enumerate(self.dropped):
                factor = self.combination[row, column]
                if abs(factor) > RANK_TOLERANCE:
                    sign = "−" if factor < 0 else "+"
                    number = f"{abs(factor):.6g}"
                    parts.append(
                        f"{sign} {self.names[other]}"
                        if number == "1"
                        else f"{sign} {number}·{self.names[other]}"
                    )
            labels.append(" ".join(parts))
        return labels

    def of(self, phi: np.ndarray) -> np.ndarray:
        """β of the full parameter vector φ."""
        return phi[list(self.kept)] + self.combination @ phi[list(self.dropped)]

    def sign_definite(self) -> list[bool]:
        """Per base parameter: whether physics makes it ≥ 0, a sum with positive factors of
        quantities that cannot be negative (inertias I and Ir, masses m, damping delta, Coulomb
        cf; a first moment h can)."""

        def nonnegative(index: int) -> bool:
            return self.names[index].rstrip("0123456789") in NONNEGATIVE_KINDS

        return [
            nonnegative(index)
            and all(
                factor >= 0 and nonnegative(other)
                for other, factor in zip(self.dropped, self.combination[row], strict=True)
                if factor != 0
            )
            for row, index in enumerate(self.kept)
        ]

    def unidentifiable(self) -> list[str]:
        """The φ that enter no base parameter alone: dropped, absorbed into others."""
        return [self.names[i] for i in self.dropped]


def base_parameters(reg: Regressor, seed: int = 0) -> BaseParameters:
    """The structural base parameters of `reg` (module docstring)."""
    rng = np.random.default_rng(seed)
    n = reg.pendulum.links
    samples = [rng.uniform(-np.pi, np.pi, (STRUCTURE_SAMPLES, n)), rng.uniform(-5, 5, (STRUCTURE_SAMPLES, n))]
    y = reg.matrix(*samples, rng.uniform(-20, 20, (STRUCTURE_SAMPLES, n)))
    scale = np.maximum(np.linalg.norm(y, axis=0), 1e-300)
    scaled = y / scale
    kept: list[int] = []
    for column in range(y.shape[1]):
        if np.linalg.norm(y[:, column]) == 0:
            continue
        trial = scaled[:, [*kept, column]]
        if np.linalg.matrix_rank(trial, tol=RANK_TOLERANCE * np.sqrt(trial.shape[0])) == len(kept) + 1:
            kept.append(column)
    dropped = [c for c in range(y.shape[1]) if c not in kept]
    if dropped:
        combination, *_ = np.linalg.lstsq(y[:, kept], y[:, dropped], rcond=None)
        combination[np.abs(combination) < RANK_TOLERANCE] = 0.0
    else:
        combination = np.zeros((len(kept), 0))
    return BaseParameters(tuple(kept), tuple(dropped), combination, reg.names)


@dataclass(frozen=True)
class TorqueFit:
    """The base parameters fitted to measured torques, with 95 % intervals."""

    regressor: Regressor
    base: BaseParameters
    estimate: np.ndarray  # β̂, then the torque offsets ô (one per input) with `offset`
    stderr: np.ndarray
    weights: np.ndarray  # per equation (joint): 1/σ of its residual
    samples: int
    stride: int  # samples per independent one (the filter's correlation), for the intervals
    method: str = DEFAULT_METHOD
    offset: bool = False

    def labels(self) -> list[str]:
        """The estimates' names: the base parameters', then "offset tau_k" per input."""
        extra = [f"offset tau{k}" for k in range(1, self.regressor.B.shape[1] + 1)] if self.offset else []
        return self.base.labels() + extra

    def reference(self, pendulum: FixedPendulum) -> np.ndarray:
        """`pendulum`'s values of the estimates (its base parameters; no torque offsets: zeros)."""
        offsets = np.zeros(self.regressor.B.shape[1] if self.offset else 0)
        return np.concatenate([self.base.of(self.regressor.parameters(pendulum)), offsets])

    @cached_property
    def interval(self) -> np.ndarray:
        """(len(β), 2): β̂ ∓ 1.96 se."""
        return np.column_stack([self.estimate - Z95 * self.stderr, self.estimate + Z95 * self.stderr])

    def predict(self, data: Filtered) -> np.ndarray:
        """τ̂ (N × m) at the filtered states of `data`."""
        y = _columns(self.regressor, self.base, data, self.offset)
        return self.regressor.torques(y @ self.estimate)


def _columns(reg: Regressor, base: BaseParameters, data: Filtered, offset: bool) -> np.ndarray:
    """The base regressor of `data` ((N·n) × len(β)), with `offset` the offsets' columns B."""
    y = reg.matrix(data.q, data.qd, data.qdd)[:, list(base.kept)]
    if not offset:
        return y
    return np.hstack([y, np.tile(reg.B, (len(data.t), 1))])


def _stacked(
    reg: Regressor, base: BaseParameters, recordings: Sequence[Filtered], offset: bool
) -> tuple[np.ndarray, np.ndarray]:
    rows, targets = [], []
    for data in recordings:
        rows.append(_columns(reg, base, data, offset))
        targets.append((data.tau @ reg.B.T).reshape(-1))
    return np.vstack(rows), np.concatenate(targets)


def _solve(y: np.ndarray, target: np.ndarray, weights: np.ndarray) -> np.ndarray:
    w = np.tile(weights, len(target) // len(weights))
    estimate, *_ = np.linalg.lstsq(y * w[:, None], target * w, rcond=None)
    return estimate


def _unexcited(rank: int, columns: int) -> TorqueFitError:
    return TorqueFitError(
        f"the recordings do not excite every base parameter (rank {rank} of {columns}): "
        "add recordings that move every joint"
    )


def _joint(y: np.ndarray, target: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """β̂, its covariance (one sample per sample) and the weights of the weighted fit of all
    equations together (module docstring)."""
    weights = np.ones(n)
    for _ in range(PASSES):  # each joint's equation weighted by 1/σ of its residual
        estimate = _solve(y, target, weights)
        spread = (target - y @ estimate).reshape(-1, n).std(axis=0)
        weights = np.where(spread > 0, 1 / np.maximum(spread, 1e-12), 1.0)
    estimate = _solve(y, target, weights)
    w = np.tile(weights, len(target) // n)
    weighted = y * w[:, None]
    dof = max(1, len(target) - y.shape[1])
    variance = float(np.sum(((target - y @ estimate) * w) ** 2)) / dof
    information = weighted.T @ weighted
    rank = np.linalg.matrix_rank(information)
    if rank < y.shape[1]:
        raise _unexcited(rank, y.shape[1])
    return estimate, variance * np.linalg.inv(information), weights


def _sequential(y: np.ndarray, target: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """β̂ and its covariance by the tip-first fit (module docstring). Each stage's covariance adds
    the outer estimates' propagated through it (b_new = A⁺ (t − E b_outer)); the joints' noises
    are taken as independent."""
    p = y.shape[1]
    estimate, covariance = np.zeros(p), np.zeros((p, p))
    known: list[int] = []
    for joint in reversed(range(n)):
        rows, aims = y[joint::n], target[joint::n]
        new = [c for c in range(p) if c not in known and np.any(rows[:, c] != 0)]
        if not new:
            continue
        a, e = rows[:, new], rows[:, known]
        rank = np.linalg.matrix_rank(a)
        if rank < len(new):
            raise _unexcited(rank, len(new))
        pseudo = np.linalg.pinv(a)
        values = pseudo @ (aims - e @ estimate[known])
        residual = aims - a @ values - e @ estimate[known]
        variance = float(residual @ residual) / max(1, len(aims) - len(new))
        gain = pseudo @ e  # how the outer estimates move these
        own = variance * np.linalg.inv(a.T @ a) + gain @ covariance[np.ix_(known, known)] @ gain.T
        cross = -gain @ covariance[np.ix_(known, known)]
        estimate[new] = values
        covariance[np.ix_(new, new)] = own
        covariance[np.ix_(new, known)] = cross
        covariance[np.ix_(known, new)] = cross.T
        known += new
    if len(known) < p:
        raise _unexcited(len(known), p)
    spread = (target - y @ estimate).reshape(-1, n).std(axis=0)
    weights = np.where(spread > 0, 1 / np.maximum(spread, 1e-12), 1.0)
    return estimate, covariance, weights


def fit_torques(
    reg: Regressor,
    recordings: Sequence[Filtered],
    stride: int = 1,
    *,
    method: str = DEFAULT_METHOD,
    offset: bool = True,
) -> TorqueFit:
    """The base parameters (and with `offset` each torque's constant bias) fitted to
    `recordings` (module docstring).

    Parameters
    ----------
    reg : Regressor
    recordings : sequence of Filtered
        The fit recordings, filtered.
    stride : int
        How many consecutive samples count as one independent one in the intervals (the
        low-pass correlates neighbours: about the sampling rate over twice the cutoff).
    method : {"sequential", "joint"}
        Tip first, one equation at a time (the default), or all equations together, weighted.
        A chain whose tip joint is not driven (a pendubot) is fitted jointly either way (its
        `method` says so): the tip's equation has no torque to fix its parameters' scale.
    offset : bool
        Fit a constant offset of each measured torque.

    Returns
    -------
    TorqueFit

    Raises
    ------
    TorqueFitError
        One line: no recordings, an unknown method, a base parameter the recordings do not excite.
    """
    if not recordings:
        raise TorqueFitError("no recordings to fit: give at least one --data file")
    if method not in FIT_METHODS:
        raise TorqueFitError(f"fit method {method!r}: expected one of {', '.join(FIT_METHODS)}")
    base = base_parameters(reg)
    y, target = _stacked(reg, base, recordings, offset)
    n = reg.pendulum.links
    if method == "sequential" and not np.any(reg.B[-1] != 0):
        # a passive tip's equation has no torque (Y_n β = 0): it fixes no scale, so tip first
        # would fit its parameters to 0; all equations together need no driven tip
        method = "joint"
    solver = _sequential if method == "sequential" else _joint
    estimate, covariance, weights = solver(y, target, n)
    stderr = np.sqrt(np.maximum(np.diag(covariance), 0) * stride)
    return TorqueFit(reg, base, estimate, stderr, weights, len(target) // n, stride, method, offset)


def rms(predicted: np.ndarray, measured: np.ndarray) -> np.ndarray:
    """Per-column RMS of predicted − measured."""
    return np.sqrt(np.mean((predicted - measured) ** 2, axis=0))


def reference_torques(reg: Regressor, pendulum: FixedPendulum, data: Filtered) -> np.ndarray:
    """τ̂ (N × m) of `pendulum`'s own values (a scene's, e.g. DFKI's model_3.0) at `data`'s states."""
    y = reg.matrix(data.q, data.qd, data.qdd)
    return reg.torques(y @ reg.parameters(pendulum))
