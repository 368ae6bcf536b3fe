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
The base parameters β are fitted by least squares on the samples of all fit recordings, each
joint's equation weighted by the inverse of its residual's standard deviation (two passes).
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
    estimate: np.ndarray  # β̂
    stderr: np.ndarray
    weights: np.ndarray  # per equation (joint): 1/σ
    samples: int
    stride: int  # samples per independent one (the filter's correlation), for the intervals

    @cached_property
    def interval(self) -> np.ndarray:
        """(len(β), 2): β̂ ∓ 1.96 se."""
        return np.column_stack([self.estimate - Z95 * self.stderr, self.estimate + Z95 * self.stderr])

    def predict(self, data: Filtered) -> np.ndarray:
        """τ̂ (N × m) at the filtered states of `data`."""
        y = self.regressor.matrix(data.q, data.qd, data.qdd)[:, list(self.base.kept)]
        return self.regressor.torques(y @ self.estimate)


def _stacked(reg: Regressor, recordings: Sequence[Filtered]) -> tuple[np.ndarray, np.ndarray]:
    rows, targets = [], []
    for data in recordings:
        rows.append(reg.matrix(data.q, data.qd, data.qdd))
        targets.append((data.tau @ reg.B.T).reshape(-1))
    return np.vstack(rows), np.concatenate(targets)


def _solve(y: np.ndarray, target: np.ndarray, weights: np.ndarray) -> np.ndarray:
    w = np.tile(weights, len(target) // len(weights))
    estimate, *_ = np.linalg.lstsq(y * w[:, None], target * w, rcond=None)
    return estimate


def fit_torques(reg: Regressor, recordings: Sequence[Filtered], stride: int = 1) -> TorqueFit:
    """β̂ by weighted least squares on `recordings` (module docstring); `stride`: how many
    consecutive samples count as one independent one in the intervals (the low-pass correlates
    neighbours: about the sampling rate over twice the cutoff)."""
    if not recordings:
        raise TorqueFitError("no recordings to fit: give at least one --data file")
    base = base_parameters(reg)
    y, target = _stacked(reg, recordings)
    y = y[:, list(base.kept)]
    n = reg.pendulum.links
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
        raise TorqueFitError(
            f"the recordings do not excite every base parameter (rank {rank} of {y.shape[1]}): "
            "add recordings that move every joint"
        )
    covariance = variance * np.linalg.inv(information) * stride
    return TorqueFit(reg, base, estimate, np.sqrt(np.diag(covariance)), weights, len(target) // n, stride)


def rms(predicted: np.ndarray, measured: np.ndarray) -> np.ndarray:
    """Per-column RMS of predicted − measured."""
    return np.sqrt(np.mean((predicted - measured) ** 2, axis=0))


def reference_torques(reg: Regressor, pendulum: FixedPendulum, data: Filtered) -> np.ndarray:
    """τ̂ (N × m) of `pendulum`'s own values (a scene's, e.g. DFKI's model_3.0) at `data`'s states."""
    y = reg.matrix(data.q, data.qd, data.qdd)
    return reg.torques(y @ reg.parameters(pendulum))
