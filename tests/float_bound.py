"""A first-order a-priori bound on |float result − exact result| for the C header in float mode.

With u = 2⁻²⁴ (float's unit roundoff) and every input rounded to float once:

- A generated polynomial p (an entry of M, the bias, P, N, T, V, D, or of the derivative
  right-hand sides Rq, Rqd) is Σ_k c_k Π_f x_f over N terms. However the common-subexpression
  pass regroups it, each expanded term passes through at most N − 1 additions and d + 2
  multiplications or constant roundings (d factors, the rational constant and its division), and
  a partial sum is bounded by the sum of the absolute values of the terms under it, so
      |fl(p) − p| ≤ Σ_k |c_k| [ (N − 1 + d_k + 2) u Π_f a_f + Σ_f e_f Π_{g≠f} a_g ],
  where a_f bounds |x_f| and e_f bounds its input error: parameters and velocities a = |x|,
  e = u|x|; a trigonometric letter (sin/cos of a float angle |q| ≤ π, or cos/sin(θj − θk) =
  cj ck ± sj sk built from them) a = 1, e = 24u (sinf within one ulp, the angle's rounding
  ≤ π u, the difference formula's own three roundings); a named quantity (r_i = ½ l_i s_i …)
  its own bound recursively; an acceleration θ̈_j (in Rq) |θ̈_j| and the bound below.
- θ̈ solves M θ̈ = B u − b with M̂ = M + E, r̂ = r + e (the bounds above, plus u|r_0| for
  `b[0] -= u` and u|u| for the input) and the float L D Lᵀ factorisation and solves, which are
  backward stable: (M̂ + F) θ̂ = r̂ with |F| ≤ γ_{3n} |L| |D| |Lᵀ| (Higham, Accuracy and Stability
  of Numerical Algorithms, Thm 10.3 and §10.4; n = dof, γ_k = k u / (1 − k u)). To first order
      |θ̂ − θ̈| ≤ |M⁻¹| (|e| + (|E| + |F|) |θ̈|),
  and the same for each column X of the Jacobians (M X = R): |ΔX| ≤ |M⁻¹| (|ΔR| + (|E| + |F|) |X|).
- The whole bound is multiplied by 1.25 for the second-order terms neglected (all of order
  (N u)² relative, below 1e-6 of the first-order part here).

The exact values are the double header's (their own error is ~1e-16, 8 orders smaller).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ipgen.model.derivation import Equations
from ipgen.model.polynomial import ACCELERATION, LETTER, NAMED, PARAMETER, VELOCITY, Poly, sparse

U = 2.0**-24
LETTER_ERROR = 24 * U
SECOND_ORDER = 1.25
ROD_DEFAULT_ERROR = 8 * U  # relative error of a com or J the header computes from m and l


@dataclass
class Inputs:
    """The magnitudes and input errors of the generators at one state."""

    params: dict[str, float]
    qd: np.ndarray
    qdd: np.ndarray  # |θ̈| (for the Jacobian right-hand sides)
    qdd_error: np.ndarray  # bound on |Δθ̈|


def _factor(
    eqs: Equations, g: int, inputs: Inputs, named: dict[int, tuple[float, float]]
) -> tuple[float, float]:
    """(a, e): a bound on |generator g| and on its error in float."""
    info = eqs.algebra.generators[g]
    if info.kind == PARAMETER:
        a = abs(inputs.params[info.name])
        # A rod default the header computes (m l²/12: the constant's rounding and three products)
        return a, (ROD_DEFAULT_ERROR if info.group in ("com", "J") else U) * a
    if info.kind == VELOCITY:
        a = abs(float(inputs.qd[info.index]))
        return a, U * a
    if info.kind == ACCELERATION:
        return abs(float(inputs.qdd[info.index])), float(inputs.qdd_error[info.index])
    if info.kind == LETTER:
        return 1.0, LETTER_ERROR
    if info.kind == NAMED:
        if g not in named:
            named[g] = polynomial_bound(eqs, eqs.algebra.named[g], inputs, named)
        return named[g]
    raise ValueError(f"unexpected generator {info.name} ({info.kind})")


def polynomial_bound(
    eqs: Equations, p: Poly, inputs: Inputs, named: dict[int, tuple[float, float]] | None = None
) -> tuple[float, float]:
    """(Σ |terms|, bound on |fl(p) − p|) for one generated polynomial (see the module docstring)."""
    named = {} if named is None else named
    terms, den = sparse(p)  # {monomial (generator indices): numerator}, common denominator
    n_terms = len(terms)
    magnitude = error = 0.0
    for monomial, numerator in terms.items():
        c = abs(numerator) / den
        factors = [_factor(eqs, g, inputs, named) for g in monomial]
        product = c * float(np.prod([a for a, _ in factors])) if factors else c
        propagated = 0.0
        for i, (_, e) in enumerate(factors):
            others = [a for j, (a, _) in enumerate(factors) if j != i]
            propagated += c * e * float(np.prod(others)) if others else c * e
        magnitude += product
        error += (max(n_terms - 1, 0) + len(monomial) + 2) * U * product + propagated
    return magnitude, error


def matrix_bound(eqs: Equations, key: str, inputs: Inputs) -> np.ndarray:
    """Entrywise bounds on the float error of the matrix `Equations.poly[key]` (flat, row-major)."""
    rows = eqs.poly[key]
    bound = [[0.0 if p.is_zero() else polynomial_bound(eqs, p, inputs)[1] for p in row] for row in rows]
    return np.array(bound)


def _gamma(k: int) -> float:
    return k * U / (1 - k * U)


def _ldlt_backward(m: np.ndarray) -> np.ndarray:
    """|L| |D| |Lᵀ| of the L D Lᵀ factorisation of the symmetric positive definite m."""
    c = np.linalg.cholesky(m)
    d = np.diag(c) ** 2
    lower = c / np.diag(c)
    return np.abs(lower) @ np.diag(d) @ np.abs(lower).T


def solve_bound(m: np.ndarray, e_m: np.ndarray, x: np.ndarray, e_r: np.ndarray) -> np.ndarray:
    """Bound on |Δx| for M x = r solved in float with M, r known to within e_m, e_r (columns of x)."""
    n = m.shape[0]
    f = _gamma(3 * n) * _ldlt_backward(m)
    return np.abs(np.linalg.inv(m)) @ (e_r + (e_m + f) @ np.abs(x))


def float_bounds(
    eqs: Equations, params: dict[str, float], qd: np.ndarray, u: float, double: dict[str, np.ndarray]
) -> dict[str, np.ndarray]:
    """Bounds on |float − exact| for the driver's quantities at one state (flat arrays)."""
    n = eqs.system.dof
    zeros = np.zeros(n)
    inputs = Inputs(params, qd, zeros, zeros)
    bounds: dict[str, np.ndarray] = {}
    for key, poly_key in (("M", "mass_matrix"), ("N", "n_matrix"), ("bias", "bias"), ("gravity", "gravity")):
        bounds[key] = matrix_bound(eqs, poly_key, inputs).reshape(-1)
    for key, poly_key in (("T", "kinetic_energy"), ("V", "potential_energy"), ("D", "dissipation")):
        bounds[key] = matrix_bound(eqs, poly_key, inputs).reshape(-1)
    m = double["M"].reshape(n, n)
    e_m = bounds["M"].reshape(n, n)
    qdd = double["qdd"]
    r = -double["bias"].copy()
    r[0] += u
    e_r = bounds["bias"].copy()
    e_r[0] += U * abs(r[0]) + U * abs(u)
    bounds["qdd"] = solve_bound(m, e_m, qdd[:, None], e_r[:, None]).reshape(-1)
    inputs = Inputs(params, qd, np.abs(qdd), bounds["qdd"])
    e_rq = matrix_bound(eqs, "residual_dq", inputs)
    e_rqd = matrix_bound(eqs, "residual_dqd", inputs)
    bounds["dqdd_dq"] = solve_bound(m, e_m, double["dqdd_dq"].reshape(n, n), e_rq).reshape(-1)
    bounds["dqdd_dqd"] = solve_bound(m, e_m, double["dqdd_dqd"].reshape(n, n), e_rqd).reshape(-1)
    bounds["dqdd_du"] = solve_bound(m, e_m, double["dqdd_du"][:, None], np.zeros((n, 1))).reshape(-1)
    a = np.zeros((2 * n, 2 * n))
    a[n:, :n] = bounds["dqdd_dq"].reshape(n, n)
    a[n:, n:] = bounds["dqdd_dqd"].reshape(n, n)
    bounds["A"] = a.reshape(-1)
    bounds["B"] = np.concatenate([np.zeros(n), bounds["dqdd_du"]])
    return {key: SECOND_ORDER * value for key, value in bounds.items()}


def parameter_values(system_dof: int, params: Sequence[np.ndarray | float]) -> dict[str, float]:
    """{m0: …, l0: …, delta0: …, g: …} from (m, l, delta, g) arrays, and the links as built at
    the homogeneous rods' values (com = l/2, J = m l²/12, J0 = m0 l0²/3, tip = J_axial = 0), which
    the header computes when no links struct is given."""
    m, lengths, delta, g = params
    values = {"g": float(g)}  # type: ignore[arg-type]
    for i in range(system_dof):
        values[f"m{i}"] = float(m[i])  # type: ignore[index]
        values[f"l{i}"] = float(lengths[i])  # type: ignore[index]
        values[f"delta{i}"] = float(delta[i])  # type: ignore[index]
        values[f"J{i}"] = values[f"m{i}"] * values[f"l{i}"] ** 2 / (12 if i else 3)
        if i:
            values[f"com{i}"] = values[f"l{i}"] / 2
            values[f"J_axial{i}"] = values[f"tip{i}"] = 0.0
    return values
