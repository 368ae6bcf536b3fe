"""Swing-up planning: a trajectory from hanging to upright at rest, optimised on the exact model.

Direct collocation (Hermite–Simpson, separated form) with CasADi and IPOPT. On N intervals of
equal length h = duration / N, the decision variables are the state x = [θ; θ̇], the input u and
the accelerations θ̈ at every knot and interval midpoint; the input is piecewise linear (u_mid the
mean of its knots: no ringing of the midpoint inputs where |u| ≤ u_max is active). The
constraints are

- the equations of motion, kept implicit at every knot and midpoint: M(θ) θ̈ + bias(θ, θ̇) = B u
  (M and the bias are ipgen's exact expressions; no inverse of M anywhere);
- Hermite–Simpson: x_mid = (x_k + x_k+1)/2 + h/8 (ẋ_k − ẋ_k+1) and
  x_k+1 − x_k = h/6 (ẋ_k + 4 ẋ_mid + ẋ_k+1), with ẋ = [θ̇; θ̈];
- the start state (default: every link hanging, at rest) and the target (upright, at rest, u = 0);
- |u| ≤ u_max everywhere, and |θ0| ≤ x_max (cart travel [m] or arm angle [rad]) when given.

The cost is ∫ u² dt (Simpson's rule) plus a small regularisation ε ∫ |θ̈|² dt that makes the
optimum unique where the input does not matter. The initial guess interpolates the angles linearly
from start to target. When IPOPT does not converge from it, the fallback is a homotopy in the
limits: the problem is solved with u_max four times larger and no travel limit, then the limits
are tightened in steps (×2, ×1.4, ×1), each solve warm-started from the previous one. A plan that
still cannot be found raises `PlanError`, one line naming what to relax.
"""

from __future__ import annotations

import math
import numbers
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from ipgen.control.casadi_model import Plant, as_plant, casadi_model, import_casadi
from ipgen.control.linear import ControlError
from ipgen.model.pendulum import Pendulum

if TYPE_CHECKING:
    import numpy as np

__all__ = ["Plan", "PlanError", "finite_number", "plan_swingup"]

MAX_INTERVALS = 2000
REGULARISATION = 1e-4  # ε: weight of ∫|θ̈|² dt against ∫u² dt
SUCCESS = ("Solve_Succeeded", "Solved_To_Acceptable_Level")


class PlanError(ControlError):
    """No swing-up plan: bad planning input, or IPOPT found none within the limits."""


@dataclass(frozen=True)
class Plan:
    """A planned swing-up: knots and midpoints of the collocation, and how it was found.

    `states` is (N+1) × 2·dof, `inputs` N+1, `accelerations` (N+1) × dof at the knot `times`;
    `mid_*` the same at the N interval midpoints. `state(t)` and `input(t)` evaluate the
    collocation's own interpolants (cubic Hermite state, quadratic input).
    """

    plant: Plant
    duration: float
    u_max: float
    x_max: float | None
    times: np.ndarray
    states: np.ndarray
    inputs: np.ndarray
    accelerations: np.ndarray
    mid_states: np.ndarray
    mid_inputs: np.ndarray
    mid_accelerations: np.ndarray
    iterations: int  # IPOPT iterations, summed over every solve it took
    solve_time: float  # s, wall clock of the IPOPT calls
    build_time: float  # s, building the NLP (CasADi graphs)
    attempts: tuple[str, ...] = field(default=())  # the strategies tried, the last one succeeded

    @property
    def intervals(self) -> int:
        return len(self.times) - 1

    def _locate(self, t: float) -> tuple[int, float, float]:
        h = self.duration / self.intervals
        k = min(max(math.floor(t / h), 0), self.intervals - 1)
        return k, h, min(max((t - k * h) / h, 0.0), 1.0)

    def state(self, t: float) -> np.ndarray:
        """x(t): the cubic Hermite interpolant of the knot states and their derivatives."""
        import numpy as np

        k, h, s = self._locate(t)
        dof = self.plant.dof
        x0, x1 = self.states[k], self.states[k + 1]
        f0 = np.concatenate([x0[dof:], self.accelerations[k]])
        f1 = np.concatenate([x1[dof:], self.accelerations[k + 1]])
        h00 = 2 * s**3 - 3 * s**2 + 1
        h10 = s**3 - 2 * s**2 + s
        h01 = -2 * s**3 + 3 * s**2
        h11 = s**3 - s**2
        return h00 * x0 + h10 * h * f0 + h01 * x1 + h11 * h * f1

    def input(self, t: float) -> float:
        """u(t): the quadratic through u_k, u_mid, u_k+1 on the interval holding t (a line:
        u_mid is their mean)."""
        k, _, s = self._locate(t)
        u0, um, u1 = self.inputs[k], self.mid_inputs[k], self.inputs[k + 1]
        return float(u0 * (2 * s - 1) * (s - 1) + um * 4 * s * (1 - s) + u1 * s * (2 * s - 1))

    def input_average(self, t0: float, t1: float) -> float:
        """The mean of u over [t0, t1] (Simpson's rule on the quadratic pieces, 8 panels)."""
        panels = 8
        h = (t1 - t0) / panels
        total = self.input(t0) + self.input(t1)
        for i in range(1, panels):
            total += (4 if i % 2 else 2) * self.input(t0 + i * h)
        return total * h / 3 / (t1 - t0)


def _finite(name: str, value: object) -> float:
    """`value` as a float if it is a finite real number (not a bool or text), else PlanError."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise PlanError(f"{name} = {value!r}: expected a number")
    number = float(value)
    if not math.isfinite(number):
        raise PlanError(f"{name} = {number}: expected a finite number")
    return number


finite_number = _finite  # shared with tvlqr, energy and swingup


def _state(name: str, value: Sequence[float] | None, default: np.ndarray) -> np.ndarray:
    import numpy as np

    if value is None:
        return default
    try:
        array = np.asarray(value, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        raise PlanError(f"{name}: expected {default.size} numbers [θ0..θn, θ̇0..θ̇n]") from None
    if array.size != default.size:
        raise PlanError(f"{name} has {array.size} entries, expected {default.size} ([θ0..θn, θ̇0..θ̇n])")
    if not np.all(np.isfinite(array)):
        raise PlanError(f"{name} must be finite")
    return array


def _check(
    plant: Plant,
    duration: object,
    u_max: object,
    x_max: object | None,
    start: Sequence[float] | None,
    target: Sequence[float] | None,
    intervals: object | None,
) -> tuple[float, float, float | None, np.ndarray, np.ndarray, int]:
    import numpy as np

    duration_ = _finite("duration", duration)
    if duration_ <= 0:
        raise PlanError(f"duration = {duration_:g} s: expected a manoeuvre time > 0 (e.g. 3)")
    u_max_ = _finite("u_max", u_max)
    if u_max_ <= 0:
        raise PlanError(f"u_max = {u_max_:g}: expected an input limit > 0 (N on a cart, N m on an arm)")
    x_max_ = None
    if x_max is not None:
        x_max_ = _finite("x_max", x_max)
        if x_max_ <= 0:
            raise PlanError(f"x_max = {x_max_:g}: expected a travel limit > 0, or none")
    dof = plant.dof
    hanging = np.zeros(2 * dof)
    hanging[1:dof] = math.pi
    x0 = _state("start", start, hanging)
    x1 = _state("target", target, np.zeros(2 * dof))
    if np.any(x1[dof:] != 0):
        raise PlanError("target: the rates must be 0 (the plan ends at rest)")
    for i, angle in enumerate(x1[1:dof], start=1):
        if abs(math.remainder(angle, 2 * math.pi)) > 1e-9:
            raise PlanError(f"target θ{i} = {angle:g}: a link must end upright (a multiple of 2π)")
    if x_max_ is not None:
        for name, x in (("start", x0), ("target", x1)):
            if abs(x[0]) > x_max_:
                raise PlanError(f"{name} θ0 = {x[0]:g} is outside |θ0| ≤ x_max = {x_max_:g}")
    if intervals is None:
        n = int(min(max(round(duration_ / 0.05), 20), 300))
    else:
        if isinstance(intervals, bool) or not isinstance(intervals, int | np.integer):
            raise PlanError(f"intervals = {intervals!r}: expected a whole number >= 4")
        n = int(intervals)
        if not 4 <= n <= MAX_INTERVALS:
            raise PlanError(f"intervals = {n}: expected 4 ... {MAX_INTERVALS}")
    return duration_, u_max_, x_max_, x0, x1, n


@dataclass
class _Nlp:
    """The collocation NLP of one plant, start, target and grid; limits enter through bounds."""

    solver: Any
    unpack: Any  # flat solution -> (X, U, A, Xm, Um, Am)
    size: int
    dof: int
    intervals: int
    variables: tuple[str, ...]


def _build(plant: Plant, duration: float, intervals: int, max_iter: int) -> _Nlp:
    ca = import_casadi()
    model = casadi_model(plant)
    dof = plant.dof
    nx = 2 * dof
    n = intervals
    h = duration / n
    # Decision variables, one column per knot or midpoint.
    xk = ca.SX.sym("x", nx, n + 1)
    uk = ca.SX.sym("u", 1, n + 1)
    ak = ca.SX.sym("a", dof, n + 1)
    xm = ca.SX.sym("xm", nx, n)
    um = ca.SX.sym("um", 1, n)
    am = ca.SX.sym("am", dof, n)
    residual_knots = model.residual.map(n + 1)
    residual_mids = model.residual.map(n)
    fk = ca.vertcat(xk[dof:, :], ak)
    fm = ca.vertcat(xm[dof:, :], am)
    g = [
        ca.vec(residual_knots(xk[:dof, :], xk[dof:, :], ak, uk)),
        ca.vec(residual_mids(xm[:dof, :], xm[dof:, :], am, um)),
        ca.vec(um - (uk[:, :-1] + uk[:, 1:]) / 2),
        ca.vec(xm - (xk[:, :-1] + xk[:, 1:]) / 2 - h / 8 * (fk[:, :-1] - fk[:, 1:])),
        ca.vec(xk[:, 1:] - xk[:, :-1] - h / 6 * (fk[:, :-1] + 4 * fm + fk[:, 1:])),
    ]
    u2 = ca.sumsqr(uk[:-1]) + ca.sumsqr(uk[1:]) + 4 * ca.sumsqr(um)
    a2 = ca.sumsqr(ak[:, :-1]) + ca.sumsqr(ak[:, 1:]) + 4 * ca.sumsqr(am)
    cost = h / 6 * (u2 + REGULARISATION * a2)
    w = ca.vertcat(ca.vec(xk), ca.vec(uk), ca.vec(ak), ca.vec(xm), ca.vec(um), ca.vec(am))
    problem = {"x": w, "f": cost, "g": ca.vertcat(*g)}
    options = {
        "print_time": False,
        "ipopt": {
            "print_level": 0,
            "sb": "yes",
            "max_iter": max_iter,
            "tol": 1e-8,
            "acceptable_tol": 1e-6,
            "max_wall_time": 120.0,
        },
    }
    solver = ca.nlpsol("swingup", "ipopt", problem, options)
    shapes = [(nx, n + 1), (1, n + 1), (dof, n + 1), (nx, n), (1, n), (dof, n)]

    def unpack(flat: Any) -> list[np.ndarray]:
        import numpy as np

        values = np.asarray(flat, dtype=float).reshape(-1)
        parts, offset = [], 0
        for rows, cols in shapes:
            parts.append(values[offset : offset + rows * cols].reshape(cols, rows).T)
            offset += rows * cols
        return parts

    return _Nlp(solver, unpack, int(w.numel()), dof, n, ("x", "u", "a", "xm", "um", "am"))


def _bounds(
    nlp: _Nlp, x0: np.ndarray, x1: np.ndarray, u_max: float, x_max: float | None
) -> tuple[np.ndarray, np.ndarray]:
    import numpy as np

    dof, n = nlp.dof, nlp.intervals
    nx = 2 * dof
    inf = np.inf
    blocks_lo: list[np.ndarray] = []
    blocks_hi: list[np.ndarray] = []
    travel = inf if x_max is None else x_max
    # knot states: column-major (one knot after the other)
    lo = np.full((nx, n + 1), -inf)
    hi = np.full((nx, n + 1), inf)
    lo[0, :], hi[0, :] = -travel, travel
    lo[:, 0] = hi[:, 0] = x0
    lo[:, n] = hi[:, n] = x1
    blocks_lo.append(lo.T.reshape(-1))
    blocks_hi.append(hi.T.reshape(-1))
    lo_u = np.full(n + 1, -u_max)
    hi_u = np.full(n + 1, u_max)
    lo_u[n] = hi_u[n] = 0.0  # at rest upright: no input
    blocks_lo.append(lo_u)
    blocks_hi.append(hi_u)
    blocks_lo.append(np.full(dof * (n + 1), -inf))
    blocks_hi.append(np.full(dof * (n + 1), inf))
    lo_m = np.full((nx, n), -inf)
    hi_m = np.full((nx, n), inf)
    lo_m[0, :], hi_m[0, :] = -travel, travel
    blocks_lo.append(lo_m.T.reshape(-1))
    blocks_hi.append(hi_m.T.reshape(-1))
    blocks_lo.append(np.full(n, -u_max))
    blocks_hi.append(np.full(n, u_max))
    blocks_lo.append(np.full(dof * n, -inf))
    blocks_hi.append(np.full(dof * n, inf))
    return np.concatenate(blocks_lo), np.concatenate(blocks_hi)


def _guess(nlp: _Nlp, x0: np.ndarray, x1: np.ndarray, duration: float) -> np.ndarray:
    """Angles interpolated linearly from start to target, their constant rates, u = θ̈ = 0."""
    import numpy as np

    dof, n = nlp.dof, nlp.intervals
    s_knots = np.linspace(0.0, 1.0, n + 1)
    s_mids = (s_knots[:-1] + s_knots[1:]) / 2
    rate = (x1[:dof] - x0[:dof]) / duration

    def states(s: np.ndarray) -> np.ndarray:
        q = x0[:dof, None] + (x1[:dof] - x0[:dof])[:, None] * s[None, :]
        qd = np.repeat(rate[:, None], s.size, axis=1)
        return np.vstack([q, qd])

    parts = [
        states(s_knots),
        np.zeros((1, n + 1)),
        np.zeros((dof, n + 1)),
        states(s_mids),
        np.zeros((1, n)),
        np.zeros((dof, n)),
    ]
    return np.concatenate([p.T.reshape(-1) for p in parts])


def _solve(
    nlp: _Nlp, guess: np.ndarray, bounds: tuple[np.ndarray, np.ndarray], warm: dict[str, Any] | None
) -> tuple[dict[str, Any], str, int, float]:
    import numpy as np

    arguments: dict[str, Any] = {"x0": guess, "lbx": bounds[0], "ubx": bounds[1], "lbg": 0.0, "ubg": 0.0}
    if warm is not None:
        arguments["lam_x0"] = warm["lam_x"]
        arguments["lam_g0"] = warm["lam_g"]
    start = time.perf_counter()
    result = nlp.solver(**arguments)
    elapsed = time.perf_counter() - start
    stats = nlp.solver.stats()
    status = str(stats.get("return_status", "unknown"))
    iterations = int(stats.get("iter_count", 0))
    if not np.all(np.isfinite(np.asarray(result["x"], dtype=float))):
        status = "non-finite result"
    return result, status, iterations, elapsed


def plan_swingup(
    plant: Plant | Pendulum,
    *,
    duration: float,
    u_max: float,
    x_max: float | None = None,
    start: Sequence[float] | None = None,
    target: Sequence[float] | None = None,
    intervals: int | None = None,
    max_iter: int = 1000,
    input_gain: float = 1.0,
) -> Plan:
    """Plan a swing-up of `plant` from `start` (default: hanging at rest) to `target` (default:
    upright at rest, θ0 = 0) in `duration` seconds with |u| ≤ `u_max` and, when given,
    |θ0| ≤ `x_max`; `intervals` collocation intervals (default: duration / 0.05 s, 20 … 300).
    `input_gain`: force or torque per unit of the rig's input (a dc_motor's b, then messages
    state the limit in volts).

    Returns a `Plan`; raises `PlanError` for bad input or when no plan is found (the message
    names what to relax). `plant`: a `Plant` or an `ipgen.Pendulum` (a "direct" drive).
    """
    import numpy as np

    try:
        plant = as_plant(plant, "a trajectory swing-up")
    except ControlError as exc:
        raise PlanError(str(exc)) from None
    duration_, u_max_, x_max_, x0, x1, n = _check(plant, duration, u_max, x_max, start, target, intervals)
    if not finite_number("input_gain", input_gain) > 0:
        raise PlanError(f"input_gain = {input_gain!r}: expected a finite number > 0 (force or torque per u)")
    t_build = time.perf_counter()
    nlp = _build(plant, duration_, n, max_iter)
    build_time = time.perf_counter() - t_build
    total_iterations = 0
    total_time = 0.0
    attempts: list[str] = []

    def run(guess: np.ndarray, u_lim: float, x_lim: float | None, warm: dict[str, Any] | None, label: str):
        nonlocal total_iterations, total_time
        result, status, iterations, elapsed = _solve(nlp, guess, _bounds(nlp, x0, x1, u_lim, x_lim), warm)
        total_iterations += iterations
        total_time += elapsed
        attempts.append(f"{label}: {status} ({iterations} iterations)")
        return result, status

    result, status = run(_guess(nlp, x0, x1, duration_), u_max_, x_max_, None, "linear guess")
    if status not in SUCCESS:
        # Homotopy in the limits: loose first, then tightened, each solve warm-started.
        guess = _guess(nlp, x0, x1, duration_)
        warm = None
        ok = True
        for factor in (4.0, 2.0, 1.4, 1.0):
            x_lim = None if (x_max_ is None or factor == 4.0) else x_max_ * factor
            trial, trial_status = run(guess, u_max_ * factor, x_lim, warm, f"homotopy ×{factor:g}")
            if trial_status not in SUCCESS:
                ok = False
                break
            guess = np.asarray(trial["x"], dtype=float).reshape(-1)
            warm = {"lam_x": trial["lam_x"], "lam_g": trial["lam_g"]}
            result, status = trial, trial_status
        if not ok:
            status = trial_status
    if status not in SUCCESS:
        volts = " V" if input_gain != 1.0 else ""
        limits = f"|u| ≤ {u_max_ / input_gain:g}{volts}" + ("" if x_max_ is None else f", |θ0| ≤ {x_max_:g}")
        raise PlanError(
            f"no swing-up plan found for {plant.system.type} n = {plant.links} in {duration_:g} s with "
            f"{limits} (IPOPT: {status}); relax {'u_max' if x_max_ is None else 'u_max, x_max'} "
            "or change the duration"
        )
    xk, uk, ak, xm, um, am = nlp.unpack(result["x"])
    return Plan(
        plant=plant,
        duration=duration_,
        u_max=u_max_,
        x_max=x_max_,
        times=np.linspace(0.0, duration_, n + 1),
        states=xk.T.copy(),
        inputs=uk.reshape(-1).copy(),
        accelerations=ak.T.copy(),
        mid_states=xm.T.copy(),
        mid_inputs=um.reshape(-1).copy(),
        mid_accelerations=am.T.copy(),
        iterations=total_iterations,
        solve_time=total_time,
        build_time=build_time,
        attempts=tuple(attempts),
    )
