"""Fitting the free parameters: equation-error least squares, then an output-error refinement.

1. Derivatives: the angles are smoothed and differentiated by Savitzky–Golay filters (scipy) on a
   uniform grid (non-uniform samples are first interpolated onto one), giving θ, θ̇, θ̈.
2. Equation error: the residual of the equations of motion is Y_0 + Σ_k φ_k(p) Y_k
   (model.py); the free parameters p minimise its weighted sum of squares (reduced to a K × K
   problem by one QR factorisation, then scipy's least_squares in p).
3. Output error: from that start, scipy's least_squares fits the simulated angles to the
   measured ones over p and the initial state, the simulation (RK4 on the samples' grid) and its
   exact sensitivities from one CasADi function (forward-mode AD through `mapaccum`).
4. Statistics from the output-error Jacobian at the optimum: covariance σ² (JᵀJ)⁻¹ on the
   directions the data determine (singular values above a relative 1e-8), standard errors,
   95 % intervals and the correlation matrix; the directions below are reported as undetermined
   (with the structural statement from the monomials' exponents, `structure.py`).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ipgen.common.safetext import quote_path
from ipgen.common.version import __version__
from ipgen.errors import Error
from ipgen.identification.data import DataError, Measurements, check_measurements
from ipgen.identification.model import IdentifyError, Setup, StructuralModel, structural_model
from ipgen.identification.structure import structural_statements
from ipgen.model.pendulum import Pendulum
from ipgen.model.system import LINK_GROUPS

if TYPE_CHECKING:
    import numpy as np

__all__ = ["Fit", "identify_measurements"]

Z95 = 1.959963984540054  # the normal distribution's 97.5 % quantile
RANK_TOLERANCE = 1e-8  # singular values below this fraction of the largest: not determined
SMOOTHING_SECONDS = 0.1  # Savitzky–Golay window for the derivatives of the start
OUTPUT_ERROR_POINTS = 6000  # at most this many samples enter the output-error fit (evenly spaced)
MAX_STEP = 5e-3  # RK4 substep of the output-error simulation [s]
# Simulations with more RK4 substeps than this are compiled (CasADi's JIT through the system's C
# compiler: ~2 s once, then ~10× faster evaluations); smaller ones run in CasADi's interpreter.
COMPILE_FROM_SUBSTEPS = 20_000
MAX_ITERATIONS = 80  # output-error simulations (with sensitivities) at most, then a polish
# Parameters that cannot be negative (everything else, com and g, may have either sign)
NONNEGATIVE = (
    "m",
    "l",
    "delta",
    "J",
    "J_axial",
    "tip",
    "coulomb",
    "Rm",
    "kt",
    "km",
    "Kg",
    "eta_g",
    "eta_m",
    "Jm",
    "r",
)
GAIN = ("kt", "Rm", "Kg", "eta_g", "eta_m", "r")  # a motor's constants that scale u


@dataclass
class Fit:
    """What `identify_measurements` found (docs/identify.md explains each part)."""

    free: tuple[str, ...]
    prior: dict[str, float]  # every parameter's value before the fit
    start: dict[str, float]  # the equation-error estimate of the free ones
    estimate: dict[str, float]  # the output-error estimate
    stderr: dict[str, float]  # inf where the data do not determine it
    interval: dict[str, tuple[float, float]]  # 95 %
    correlation: list[list[float]]  # free × free (nan where undetermined)
    determined: dict[str, bool]
    statements: list[str]  # identifiability: structural, then from the data
    monomials: tuple[str, ...]  # the regressor's parameter combinations
    singular_values: list[float]  # of the scaled output-error Jacobian (parameters only), descending
    noise: tuple[float, ...]  # estimated measurement noise per coordinate (rms of the residual)
    rms_start: tuple[float, ...]  # simulated − measured rms per coordinate, at the start
    rms: tuple[float, ...]  # the same at the estimate
    t: Any  # the output-error samples' times
    measured: Any  # their measured angles (N × dof)
    simulated: Any  # the simulated angles at the estimate (N × dof)
    simulated_start: Any  # the same at the equation-error start
    seconds: dict[str, float] = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)

    def values(self) -> dict[str, float]:
        """Every parameter: the prior with the estimates in."""
        return {**self.prior, **self.estimate}

    def table(self) -> str:
        """The estimates as text, one parameter a line."""
        lines = [f"{'parameter':<10} {'estimate':>13} {'std. error':>11} {'95 % interval':>29}   prior"]
        for name in self.free:
            value, se = self.estimate[name], self.stderr[name]
            low, high = self.interval[name]
            if math.isfinite(se):
                span = f"[{low:.6g}, {high:.6g}]"
                shown = f"{se:11.3g}"
            else:
                span, shown = "not determined", f"{'-':>11}"
            lines.append(f"{name:<10} {value:13.6g} {shown} {span:>29}   {self.prior[name]:.6g}")
        return "\n".join(lines)


def _explicit_groups(setup: Setup, free: Sequence[str]) -> frozenset[str]:
    groups = set(setup.explicit)
    for name in free:
        group = name.rstrip("0123456789")
        if group in LINK_GROUPS:
            groups.add(group)
    return frozenset(groups)


def _check_free(setup: Setup, free: Sequence[str]) -> tuple[str, ...]:
    names = tuple(dict.fromkeys(n.strip() for n in free))
    if not names or any(not n for n in names):
        raise IdentifyError("no free parameters: name those to identify, e.g. --free m1,delta0,delta1")
    if len(names) != len(tuple(free)):
        raise IdentifyError("a free parameter is named twice: name each once")
    allowed = setup.parameter_names()
    for name in names:
        if name not in allowed:
            raise IdentifyError(
                f"free parameter {name!r} is not in this model: choose from {', '.join(allowed)}"
            )
    return names


def identify_measurements(
    setup: Setup,
    data: Measurements,
    free: Sequence[str],
    *,
    input_fn: Callable[[np.ndarray], np.ndarray] | None = None,
    output_error: bool = True,
    progress: Callable[[str], None] | None = None,
) -> Fit:
    """Fit `free` of `setup` to `data` (module docstring); `input_fn(t)` gives u when the data
    have no u column. Raises `IdentifyError` (one line) when the data cannot identify them."""
    import numpy as np

    try:
        with np.errstate(over="ignore", invalid="ignore"):  # a diverging trial is judged by its cost
            return _identify(setup, data, free, input_fn, output_error, progress)
    except Error:
        raise
    except (ValueError, ArithmeticError, np.linalg.LinAlgError) as e:  # the solvers' own failures
        raise IdentifyError(
            f"the fit failed numerically ({' '.join(str(e).split())[:120]}): the data cannot be fitted "
            "with these free parameters; check the recording for outliers, or fix more parameters"
        ) from None


def _identify(
    setup: Setup,
    data: Measurements,
    free: Sequence[str],
    input_fn: Callable[[np.ndarray], np.ndarray] | None,
    output_error: bool,
    progress: Callable[[str], None] | None,
) -> Fit:
    import numpy as np

    report = progress or (lambda message: None)
    clock = time.perf_counter()
    seconds: dict[str, float] = {}
    free = _check_free(setup, free)
    if data.dof != setup.system.dof:
        raise DataError(f"{data.source}: {data.dof} coordinates, the scene has {setup.system.dof}")
    explicit = _explicit_groups(setup, free)
    prior = {**dict(setup.values), "coulomb_speed": setup.coulomb_speed}
    model = structural_model(setup.system, setup.actuator_kind, explicit, setup.friction, free)
    if data.u is not None:
        u = np.asarray(data.u, dtype=float)
    elif input_fn is not None:
        u = np.asarray(input_fn(data.t), dtype=float)
    else:
        raise DataError(
            f"{data.source}: no u column, and no input signal to compute it from (a scene's [input], "
            "not feedback): record u as a column"
        )
    check_measurements(data, u)  # values the fit's squares take, a bounded resampling grid
    _check_excitation(data, u, free, setup)
    seconds["structure"] = time.perf_counter() - clock

    report("derivatives (Savitzky-Golay) and the equation-error fit")
    clock = time.perf_counter()
    grid, theta, rates, accel, u_grid, noise_level = _derivatives(data, u)
    known = [prior[n] for n in model.known_names]
    columns = model.columns(theta, rates, accel, u_grid, known)
    if not np.any(columns[0]):
        raise IdentifyError(
            f"every term of the equations contains one of {', '.join(free)}: their common scale cannot "
            "be determined; keep one known (e.g. a mass or the motor's kt)"
        )
    start = _equation_error(model, columns, {n: prior[n] for n in free})
    seconds["equation error"] = time.perf_counter() - clock

    clock = time.perf_counter()
    values = {**prior, **start}
    exact_input = input_fn if data.u is None else None  # the scene's [input]: exact between samples
    oe = _OutputError(model, data, u, known, _largest_step(model, setup, data, values), exact_input)
    x0 = _initial_state(data, grid, theta, rates)
    what = "output-error fit on" if output_error else "simulating the estimate for its statistics:"
    report(f"{what} {oe.points} samples ({oe.steps} RK4 steps of the model, exact sensitivities)")
    # Start from the equation-error estimate, or from the prior if that simulates closer to the
    # data (errors in the differentiated signals bias the equation error, most where an equation
    # has no known term: a pendulum's own equation when its mass moment and inertia are free).
    candidates = {
        "equation error": np.array([start[n] for n in free]),
        "prior": np.array([prior[n] for n in free]),
    }
    costs = {}
    for label, p in candidates.items():
        simulated = oe.simulate(x0, p)
        costs[label] = float(np.sum(((simulated - oe.measured) / noise_level) ** 2))
        if not math.isfinite(costs[label]):
            costs[label] = math.inf
    chosen = min(costs, key=lambda k: costs[k])
    if not math.isfinite(costs[chosen]):
        raise IdentifyError(
            "the model simulated from the equation-error estimate and from the prior diverges: the data may "
            "come from a closed loop or an unstable experiment; record one about the hanging position"
        )
    p_start = candidates[chosen]
    sim_start = oe.simulate(x0, candidates["equation error"])
    if not np.all(np.isfinite(sim_start)):
        sim_start = oe.simulate(x0, p_start)
    rms_start = tuple(float(v) for v in np.sqrt(np.mean((sim_start - oe.measured) ** 2, axis=0)))
    if output_error:
        report(f"output error from the {chosen}")
        x0_hat, p_hat, jac, residual = oe.fit(x0, p_start, [prior[n] for n in free], noise_level, report)
    else:
        x0_hat, p_hat = x0, candidates["equation error"]
        residual, jac = oe.residual_and_jacobian(x0, p_hat)
    seconds["output error"] = time.perf_counter() - clock

    simulated = oe.simulate(x0_hat, p_hat)
    noise = tuple(float(v) for v in np.sqrt(np.mean((simulated - oe.measured) ** 2, axis=0)))
    estimate = {n: float(v) for n, v in zip(free, p_hat, strict=True)}
    stats = _statistics(free, estimate, prior, residual, jac, oe.state_size)
    statements = list(dict.fromkeys([*structural_statements(model), *stats.pop("statements")]))
    return Fit(
        free=free,
        prior={n: prior[n] for n in setup.parameter_names()},
        start=start,
        estimate=estimate,
        monomials=tuple(m.text() for m in model.monomials),
        noise=noise,
        rms_start=rms_start,
        rms=noise,
        t=oe.t,
        measured=oe.measured,
        simulated=simulated,
        simulated_start=sim_start,
        seconds=seconds,
        statements=statements,
        **stats,
    )


def _check_excitation(data: Measurements, u: np.ndarray, free: Sequence[str], setup: Setup) -> None:
    import numpy as np

    if not np.all(np.isfinite(u)):
        raise DataError(f"{data.source}: the input u is not finite")
    duration = float(data.t[-1] - data.t[0])
    dt = duration / (data.samples - 1)
    shortest, fewest = 20 * SMOOTHING_SECONDS, 10 * (len(free) + 2 * data.dof)
    if duration < shortest or data.samples < fewest:
        raise DataError(
            f"{data.source}: {data.samples} samples over {duration:.3g} s are too short to identify "
            f"{len(free)} parameters: record at least {shortest:g} s and {fewest} samples"
        )
    if dt > 0.01 * (1 + 1e-9):
        raise DataError(
            f"{data.source}: samples {dt:.3g} s apart are too sparse for the derivatives: "
            "record at 100 Hz or faster"
        )
    scale = max(1.0, float(np.max(np.abs(u))))
    constant_u = float(np.ptp(u)) <= 1e-12 * scale
    spread = np.ptp(data.theta, axis=0)
    if constant_u and not np.any(spread[1:] > 1e-6):
        raise DataError(
            f"{data.source}: no excitation: u is constant and the links do not swing; "
            "record with a varying input (sine, chirp, multisine)"
        )
    gain = sorted(set(free) & set(GAIN)) if setup.actuator_kind == "dc_motor" else []
    if constant_u and gain:
        raise DataError(
            f"{data.source}: u is constant, so the motor's gain ({', '.join(gain)}) cannot be "
            "identified: record with a varying input (sine, chirp, multisine)"
        )


def _odd(n: int) -> int:
    return n if n % 2 else n + 1


def _derivatives(data: Measurements, u: np.ndarray) -> tuple[np.ndarray, ...]:
    """(t, θ, θ̇, θ̈, u) on a uniform grid, smoothed, the filters' edges cut off."""
    import numpy as np
    from scipy.signal import savgol_filter

    t = data.t
    steps = np.diff(t)
    dt = float(np.median(steps))
    if np.ptp(steps) > 1e-3 * dt:  # non-uniform: interpolate onto a uniform grid
        grid = np.arange(t[0], t[-1] + 0.5 * dt, dt)
        grid = grid[grid <= t[-1]]
        theta = np.column_stack([np.interp(grid, t, data.theta[:, i]) for i in range(data.dof)])
        u = np.interp(grid, t, u)
    else:
        grid, theta = t, data.theta
    window = min(_odd(max(7, round(SMOOTHING_SECONDS / dt))), _odd(len(grid) // 4) - 2)
    order = 4 if window > 9 else 2
    smooth = savgol_filter(theta, window, order, axis=0)
    rates = savgol_filter(theta, window, order, deriv=1, delta=dt, axis=0)
    accel = savgol_filter(theta, window, order, deriv=2, delta=dt, axis=0)
    cut = slice(window, len(grid) - window)
    # the measurement noise per coordinate: the smoothing's residual, corrected for the part of
    # the noise the filter keeps (its central coefficient c0: E r² = σ² (1 − c0))
    from scipy.signal import savgol_coeffs

    kept = float(savgol_coeffs(window, order)[window // 2])
    spread = np.sqrt(np.mean((theta - smooth)[cut] ** 2, axis=0) / (1.0 - kept))
    noise = np.maximum(spread, 1e-9 * np.maximum(np.ptp(theta, axis=0), 1e-9))
    return grid[cut], smooth[cut], rates[cut], accel[cut], u[cut], noise


def _phi(model: StructuralModel, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """φ_k(p) and ∂φ_k/∂p_j."""
    import numpy as np

    exponents = np.array(model.exponents(), dtype=float).reshape(len(model.monomials), len(model.free))
    with np.errstate(divide="ignore", invalid="ignore"):
        phi = np.prod(np.power(p[None, :], exponents), axis=1)
        jac = np.zeros_like(exponents)
        for j in range(len(p)):
            reduced = exponents.copy()
            reduced[:, j] -= 1
            jac[:, j] = exponents[:, j] * np.prod(np.power(p[None, :], reduced), axis=1)
    jac[exponents == 0] = 0.0
    return phi, jac


def _equation_error(model: StructuralModel, columns: np.ndarray, prior: dict[str, float]) -> dict[str, float]:
    """The free parameters minimising ‖Y_0 + Σ φ_k(p) Y_k‖ (rows weighted per coordinate)."""
    import numpy as np
    from scipy.optimize import least_squares

    free = model.free
    K, dof, n = columns.shape
    # Weight each coordinate's equation by the size of its known part (its units differ).
    weights = np.ones(dof)
    for i in range(dof):
        norm = float(np.sqrt(np.mean(columns[:, i, :] ** 2)))
        weights[i] = 1.0 / norm if norm > 0 else 1.0
    p0 = np.array([prior[n] for n in free])
    scale = np.where(np.abs(p0) > 0, np.abs(p0), 1.0)
    lower = np.array([_lower(n, p) for n, p in zip(free, p0, strict=True)])
    estimate = p0.copy()
    for _ in range(2):  # the second pass reweights by the first one's residuals
        A = (columns[1:] * weights[None, :, None]).reshape(K - 1, dof * n).T
        b = (columns[0] * weights[:, None]).reshape(dof * n)
        q, r = np.linalg.qr(A)
        c = q.T @ b
        prior_weight = 1e-6 * float(np.linalg.norm(r, 2))

        def fun(p: np.ndarray, r: np.ndarray = r, c: np.ndarray = c, w: float = prior_weight) -> np.ndarray:
            phi, _ = _phi(model, p)
            return np.concatenate([r @ phi + c, w * (p - p0) / scale])

        def jac(p: np.ndarray, r: np.ndarray = r, w: float = prior_weight) -> np.ndarray:
            _, dphi = _phi(model, p)
            return np.vstack([r @ dphi, w * np.diag(1.0 / scale)])

        start = np.clip(estimate, lower + 1e-12 * scale, None)
        solution = least_squares(fun, start, jac=jac, bounds=(lower, np.inf), x_scale=scale, method="trf")
        estimate = solution.x
        phi, _ = _phi(model, estimate)
        res = (columns[0] + np.tensordot(phi, columns[1:], axes=1)) * weights[:, None]
        for i in range(dof):
            rms = float(np.sqrt(np.mean(res[i] ** 2)))
            if rms > 0:
                weights[i] /= rms
    return {n: float(v) for n, v in zip(free, estimate, strict=True)}


def _lower(name: str, value: float) -> float:
    group = name.rstrip("0123456789")
    if group in NONNEGATIVE or name in NONNEGATIVE:
        return (
            1e-9 * abs(value) if name in ("Rm", "r", "Kg", "eta_g", "eta_m") or group in ("m", "l") else 0.0
        )
    return -math.inf


def _initial_state(data: Measurements, grid: np.ndarray, theta: np.ndarray, rates: np.ndarray) -> np.ndarray:
    """x(t0): the measured angles and rates at t0 (rates from the smoothed fit if not measured)."""
    import numpy as np

    q0 = data.theta[0]
    if data.dtheta is not None:
        qd0 = data.dtheta[0]
    else:  # the smoothed rate at the first grid point, taken back to t0 (edges were cut)
        qd0 = rates[0] - (grid[0] - data.t[0]) * (rates[1] - rates[0]) / max(grid[1] - grid[0], 1e-12)
        q0 = theta[0] - (grid[0] - data.t[0]) * rates[0]
    return np.concatenate([q0, qd0]).astype(float)


def _largest_step(
    model: StructuralModel, setup: Setup, data: Measurements, values: dict[str, float]
) -> float:
    """MAX_STEP, or less where Coulomb friction is stiff: its slope c_i / v_s over the
    coordinate's inertia M_ii is an eigenvalue λ of the linearised rates, and RK4 needs h λ ≲ 2.8
    to stay stable; h ≤ 1/λ keeps it accurate too (c_i the larger of the prior and the start)."""
    import numpy as np

    if not setup.friction:
        return MAX_STEP
    dof = setup.system.dof
    friction = [max(abs(values.get(f"coulomb{i}", 0.0)), abs(setup.value(f"coulomb{i}"))) for i in range(dof)]
    if not any(friction):
        return MAX_STEP
    parameters = [values[n] for n in (*model.free, *model.known_names)]
    rows = np.linspace(0, data.samples - 1, 20).astype(int)
    diagonal = np.min([model.mass_diagonal(data.theta[k], parameters) for k in rows], axis=0)
    slope = max(c / setup.coulomb_speed / max(m, 1e-300) for c, m in zip(friction, diagonal, strict=True))
    return min(MAX_STEP, 1.0 / slope) if slope > 0 else MAX_STEP


class _OutputError:
    """The output-error problem on evenly spaced samples of the data (module docstring)."""

    def __init__(
        self,
        model: StructuralModel,
        data: Measurements,
        u: np.ndarray,
        known: Sequence[float],
        largest_step: float = MAX_STEP,
        input_fn: Callable[[np.ndarray], np.ndarray] | None = None,
    ) -> None:
        import numpy as np

        self.model = model
        self.dof = model.system.dof
        self.state_size = 2 * self.dof
        stride = max(1, math.ceil(data.samples / OUTPUT_ERROR_POINTS))
        keep = np.arange(0, data.samples, stride)
        self.t = data.t[keep]
        self.measured = data.theta[keep]
        self.points = len(keep)
        h = np.diff(self.t)
        substeps = max(1, math.ceil(float(np.max(h)) / largest_step - 1e-9))
        self.steps = (len(keep) - 1) * substeps
        # u at each substep's start, midpoint and end: the samples where they fall on one, a cubic
        # spline through the samples in between (u is taken to be smooth; see docs/identify.md)
        from scipy.interpolate import CubicSpline

        fractions = np.arange(2 * substeps + 1) / (2 * substeps)
        times = self.t[:-1, None] + h[:, None] * fractions[None, :]
        if input_fn is not None:
            inside = np.asarray(input_fn(times.reshape(-1)), dtype=float).reshape(times.shape)
        else:
            inside = CubicSpline(data.t, u)(times)
        self.inputs = np.vstack([inside.T, h[None, :]])
        self.known = np.asarray(known, dtype=float)
        compiled = self.steps > COMPILE_FROM_SUBSTEPS
        self.function, self.simulation = _simulator(model, substeps, len(keep) - 1, compiled)
        self.weights = np.ones(self.dof)

    def simulate(self, x0: np.ndarray, p: np.ndarray) -> np.ndarray:
        import numpy as np

        y = self.simulation(x0, p, self.known, self.inputs)
        return np.asarray(y)[: self.dof].T

    def residual_and_jacobian(self, x0: np.ndarray, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Weighted residual (measured − simulated)/σ_i flattened sample-major, and its Jacobian
        with respect to (x0, p)."""
        import numpy as np

        out = np.asarray(self.function(x0, p, self.known, self.inputs))
        n, dof = self.state_size, self.dof
        y = out[:dof].T  # N × dof
        # vec(S) is column-major: entry (i, j) at row n + j n + i; the angles are i < dof
        nz = (out.shape[0] - n) // n
        sens = out[n:].reshape(nz, n, -1)[:, :dof, :]  # [j, i, sample]
        jac = sens.transpose(2, 1, 0).reshape(-1, nz)  # rows sample-major, then coordinate
        w = np.tile(self.weights, self.points)
        return (self.measured - y).reshape(-1) * w, -jac * w[:, None]

    def fit(
        self,
        x0: np.ndarray,
        p: np.ndarray,
        prior: Sequence[float],
        noise: np.ndarray,
        report: Callable[[str], None],
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Least squares over (x0, p), each coordinate's residual divided by its `noise`."""
        import numpy as np
        from scipy.optimize import least_squares

        n = self.state_size
        prior_p = np.asarray(prior, dtype=float)
        scale_p = np.where(np.abs(p) > 0, np.abs(p), np.where(np.abs(prior_p) > 0, np.abs(prior_p), 1.0))
        scale = np.concatenate([np.full(n, 0.1), scale_p])
        lower = np.concatenate(
            [np.full(n, -np.inf), [_lower(m, v) for m, v in zip(self.model.free, p, strict=True)]]
        )
        z = np.concatenate([x0, np.maximum(p, lower[n:])])
        start = z.copy()
        self.weights = 1.0 / noise
        cache: dict[bytes, tuple[np.ndarray, np.ndarray]] = {}
        calls = [0]

        def both(z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            key = z.tobytes()
            if key not in cache:
                cache.clear()
                calls[0] += 1
                r, j = self.residual_and_jacobian(z[:n], z[n:])
                if not np.all(np.isfinite(r)):
                    r = np.full_like(r, 1e10)
                cache[key] = (r, j)
            return cache[key]

        solution = least_squares(
            lambda z: both(z)[0],
            z,
            jac=lambda z: both(z)[1],
            bounds=(lower, np.inf),
            x_scale=scale,
            method="trf",
            xtol=1e-10,
            ftol=1e-10,
            max_nfev=MAX_ITERATIONS,
        )
        z = solution.x
        # Gauss-Newton polish: the trust region stops early in long, narrow valleys (a link's
        # com and J, correlated -0.999); full Gauss-Newton steps (SVD, scaled) finish the descent.
        residual, jac = self.residual_and_jacobian(z[:n], z[n:])
        cost = float(residual @ residual)
        polish = 0
        for _ in range(6):
            u_, sv, vt = np.linalg.svd(jac * scale[None, :], full_matrices=False)
            keep = sv > RANK_TOLERANCE * sv[0]
            step = -scale * ((vt[keep].T / sv[keep]) @ (u_[:, keep].T @ residual))
            improved = False
            for fraction in (1.0, 0.5, 0.25):
                trial = np.maximum(z + fraction * step, lower)
                r, j = self.residual_and_jacobian(trial[:n], trial[n:])
                polish += 1
                value = float(r @ r)
                if np.isfinite(value) and value < cost:
                    z, residual, jac, improved = trial, r, j, cost - value > 1e-12 * cost
                    cost = value
                    break
            if not improved:
                break
        # What the data cannot determine stays where it started (near the prior, as the report says):
        # the trust region's steps drift along the null directions (a parameter that does not
        # enter the equations went from 0.095 to 5.7 kg); the step's part along them is removed
        # where that costs nothing (first order: it costs nothing at all).
        _, sv, vt = np.linalg.svd(jac * scale[None, :], full_matrices=False)
        null = vt[sv <= RANK_TOLERANCE * sv[0]]
        if null.size:
            step = (z - start) / scale
            back = np.maximum(start + (step - null.T @ (null @ step)) * scale, lower)
            r, j = self.residual_and_jacobian(back[:n], back[n:])
            value = float(r @ r)
            if np.isfinite(value) and value <= cost * (1 + 1e-9) + 1e-300:
                z, residual, jac, cost = back, r, j, value
        report(
            f"output error: {solution.nfev} + {polish} simulations with sensitivities, cost {cost / 2:.6g}"
        )
        return z[:n], z[n:], jac, residual


@lru_cache(maxsize=16)
def _simulator(model: StructuralModel, substeps: int, steps: int, compiled: bool = False) -> Any:
    """CasADi function (x0, p_free, p_known, inputs) → the states and their sensitivities at
    every sample: rows x (2 dof) then vec(∂x/∂(x0, p_free)) (column-major), one column a sample.

    The sensitivities are propagated with the state through each RK4 step (S ← ∂F/∂x S + ∂F/∂p,
    the exact derivative of the discrete map, by CasADi's AD of one step): a few times the cost
    of the simulation alone."""
    import casadi

    dof = model.system.dof
    n = 2 * dof
    accel = model.casadi_acceleration
    nf, nk = len(model.free), len(model.known_names)
    nz = n + nf
    x = casadi.SX.sym("x", n)
    w = casadi.SX.sym("w", 2 * substeps + 2)  # u at the 2·substeps + 1 sub-points, then h
    pf = casadi.SX.sym("pf", nf)
    pk = casadi.SX.sym("pk", nk)
    p = casadi.vertcat(pf, pk)
    h = w[-1] / substeps

    def f(state: Any, u: Any) -> Any:
        return casadi.vertcat(state[dof:], accel(state[:dof], state[dof:], u, p))

    state = x
    for s in range(substeps):
        u0, um, u1 = w[2 * s], w[2 * s + 1], w[2 * s + 2]
        k1 = f(state, u0)
        k2 = f(state + h / 2 * k1, um)
        k3 = f(state + h / 2 * k2, um)
        k4 = f(state + h * k3, u1)
        state = state + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    sens = casadi.SX.sym("S", n, nz)
    next_sens = casadi.mtimes(casadi.jacobian(state, x), sens) + casadi.horzcat(
        casadi.SX.zeros(n, n), casadi.jacobian(state, pf)
    )
    augmented = casadi.vertcat(x, casadi.vec(sens))
    step = casadi.Function("step", [augmented, w, pf, pk], [casadi.vertcat(state, casadi.vec(next_sens))])
    plain = casadi.Function("plain", [x, w, pf, pk], [state])
    x0 = casadi.MX.sym("x0", n)
    pfm = casadi.MX.sym("pf", nf)
    pkm = casadi.MX.sym("pk", nk)
    inputs = casadi.MX.sym("inputs", 2 * substeps + 2, steps)
    start = casadi.vertcat(x0, casadi.vec(casadi.horzcat(casadi.MX.eye(n), casadi.MX.zeros(n, nf))))
    repeated = (casadi.repmat(pfm, 1, steps), casadi.repmat(pkm, 1, steps))
    states = step.mapaccum("run", steps)(start, inputs, *repeated)
    only = plain.mapaccum("simulate", steps)(x0, inputs, *repeated)
    arguments = [x0, pfm, pkm, inputs]
    sensitivities = casadi.Function("output_error", arguments, [casadi.horzcat(start, states)])
    simulation = casadi.Function("simulate", arguments, [casadi.horzcat(x0, only)])
    if compiled:
        try:
            options = {"jit": True, "compiler": "shell", "jit_options": {"flags": ["-O1"], "verbose": False}}
            sensitivities = casadi.Function("output_error_c", arguments, [sensitivities(*arguments)], options)
        except RuntimeError:  # no C compiler: the interpreter, slower but the same numbers
            pass
    return sensitivities, simulation


def _statistics(
    free: Sequence[str],
    estimate: dict[str, float],
    prior: dict[str, float],
    residual: np.ndarray,
    jac: np.ndarray,
    states: int,
) -> dict[str, Any]:
    """Standard errors, 95 % intervals, correlations and undetermined directions (module docstring)."""
    import numpy as np

    m, k = jac.shape
    dof_res = max(m - k, 1)
    sigma2 = float(residual @ residual) / dof_res
    p = np.array([prior.get(n, 0.0) for n in free])
    fallback = np.array([abs(estimate[n]) or 1.0 for n in free])
    scale = np.concatenate([np.ones(states), np.where(np.abs(p) > 0, np.abs(p), fallback)])
    scaled = jac * scale[None, :]
    _, s, vt = np.linalg.svd(scaled, full_matrices=False)
    keep = s > RANK_TOLERANCE * s[0]
    inverse = (vt[keep].T / s[keep] ** 2) @ vt[keep]
    cov = sigma2 * inverse * np.outer(scale, scale)
    cov_p = cov[states:, states:]
    null = vt[~keep][:, states:]
    determined = {}
    for j, name in enumerate(free):
        determined[name] = not np.any(np.abs(null[:, j]) > 1e-6) if null.size else True
    stderr = {
        n: float(np.sqrt(max(cov_p[j, j], 0.0))) if determined[n] else math.inf for j, n in enumerate(free)
    }
    interval = {n: (estimate[n] - Z95 * stderr[n], estimate[n] + Z95 * stderr[n]) for n in free}
    corr = [[math.nan] * len(free) for _ in free]
    for a, na in enumerate(free):
        for b, nb in enumerate(free):
            if determined[na] and determined[nb] and stderr[na] > 0 and stderr[nb] > 0:
                corr[a][b] = float(cov_p[a, b] / (stderr[na] * stderr[nb]))
    statements = []
    # The undetermined directions of the parameters alone: an orthonormal basis of the null space's
    # projection onto them (the null space's own vectors mix in the initial state, and several of
    # them can project onto the same parameter direction: one finding, said once).
    directions = []
    if null.size:
        _, weights, basis = np.linalg.svd(null, full_matrices=False)
        directions = [row for row, weight in zip(basis, weights, strict=True) if weight > 1e-6]
    for direction in directions:
        norm = float(np.max(np.abs(direction)))
        if norm < 1e-6:
            continue
        direction = direction if direction[np.argmax(np.abs(direction))] > 0 else -direction
        terms = [
            f"{'−' if c < 0 else '+'} {abs(c) / norm:.2g}·Δ{name}/{name}"
            for c, name in zip(direction, free, strict=True)
            if abs(c) > 1e-3 * norm
        ]
        text = " ".join(terms).lstrip("+ ")
        statements.append(f"the data cannot determine the relative change {text} (kept near the prior)")
    statements = list(dict.fromkeys(statements))
    # the parameters' own singular values (the initial state projected out)
    _, s_p, _ = np.linalg.svd(scaled[:, states:], full_matrices=False)
    return {
        "stderr": stderr,
        "interval": interval,
        "correlation": corr,
        "determined": determined,
        "singular_values": [float(v) for v in s_p],
        "statements": statements,
    }


def identify_pendulum(
    pendulum: Pendulum,
    data: str | Path | Measurements,
    free: str | Sequence[str],
    *,
    input_fn: Callable[[np.ndarray], np.ndarray] | None = None,
    output_error: bool = True,
    progress: Callable[[str], None] | None = None,
) -> Fit:
    """Fit the `free` parameters of a `Pendulum` to measurements (what `ipgen.identify(p, ...)`
    does; a scene file instead also writes the updated scene, the report and a PNG).

    Parameters
    ----------
    pendulum : Pendulum
        The prior: every parameter's value, the drive, the friction and the rig's coordinates.
    data : str, Path or Measurements
        A CSV in the simulator's format (t, theta0..thetan[, dtheta0..][, u]) or measurements,
        in the pendulum's coordinates.
    free : str or sequence of str
        The parameters to fit ("m1,delta0" or ["m1", "delta0"]): m, l, delta, g, the links as
        built, the motor's constants, coulomb.
    input_fn : callable, optional
        u(t) for data without a u column.
    output_error : bool, default True
        Refine the equation-error estimate by simulation (output error; needs CasADi).
    progress : callable, optional
        Called with a short message at each stage.

    Returns
    -------
    Fit
        Estimates, standard errors, 95 % intervals, correlations and what the data cannot
        determine (`Fit.table()`, `Fit.statements`).

    Raises
    ------
    IdentifyError
        One line: a free name this model has not, data that cannot identify them, a bad file.

    Examples
    --------
    >>> import ipgen  # doctest: +SKIP
    >>> fit = ipgen.identify(ipgen.Pendulum.preset("qube_servo2"), "rig.csv", "J1,delta0")  # doctest: +SKIP
    """
    from ipgen.identification.data import read_measurements

    if not isinstance(pendulum, Pendulum):
        raise IdentifyError(
            f"identify needs an ipgen.Pendulum or a scene file, got {type(pendulum).__name__}"
        )
    names = [n.strip() for n in free.split(",")] if isinstance(free, str) else list(free)
    measured = data if isinstance(data, Measurements) else read_measurements(Path(data), pendulum.dof)
    return identify_measurements(
        Setup.from_pendulum(pendulum, names),
        measured.canonical(pendulum.coordinates),
        names,
        input_fn=input_fn,
        output_error=output_error,
        progress=progress,
    )


def report_text(fit: Fit, scene_path: str | Path, data_path: str | Path) -> str:
    """The report of a fit as plain text: estimates, standard errors, 95 % intervals, the
    regressor's combinations, identifiability, correlations, residuals and times.

    Parameters
    ----------
    fit : Fit
        What `identify_measurements` or `identify_pendulum` returned.
    scene_path, data_path : str or Path
        Where the prior and the data came from (named in the report's second line).

    Returns
    -------
    str
        Lines ending in a newline; user text (the paths) percent-encoded.

    Examples
    --------
    >>> report_text(fit, "qube.toml", "rig.csv").splitlines()[1]  # doctest: +SKIP
    'scene qube.toml, data rig.csv'
    """
    lines = [
        f"Generated by ipgen {__version__} identify",
        f"scene {quote_path(str(scene_path))}, data {quote_path(str(data_path))}",
        "",
        fit.table(),
        "",
        "combinations of the free parameters in the equations (regressor columns): "
        + ", ".join(fit.monomials),
        "",
    ]
    if fit.statements:
        lines += ["identifiability:", *(f"  {s}" for s in fit.statements)]
    else:
        lines.append("identifiability: the data determine every free parameter")
    svals = fit.singular_values
    if svals and svals[-1] > 0:
        lines.append(f"  condition of the scaled sensitivity matrix: {svals[0] / svals[-1]:.3g}")
    names = list(fit.free)
    lines += ["", "correlation:", " " * 10 + "".join(f"{n:>10}" for n in names)]
    for a, row in zip(names, fit.correlation, strict=True):
        lines.append(f"{a:<10}" + "".join(f"{v:10.3f}" if math.isfinite(v) else f"{'-':>10}" for v in row))
    lines += [
        "",
        "fit residual (rms of measured − simulated angles per coordinate): "
        + ", ".join(f"θ{i} {v:.3g}" for i, v in enumerate(fit.rms))
        + " (at the equation-error start: "
        + ", ".join(f"{v:.3g}" for v in fit.rms_start)
        + ")",
        "time: " + ", ".join(f"{k} {v:.2f} s" for k, v in fit.seconds.items()),
    ]
    return "\n".join(lines) + "\n"
