"""Swing-up of a fixed-pivot chain (`FixedPendulum`, m inputs): plan, time-varying LQR, hold.

The cart/arm method (trajectory.py, tvlqr.py) generalised to a chain on a fixed pivot driven at
its `joints`, everything in the chain's own coordinates (DFKI's: q1 from hanging, q2 relative,
counterclockwise torques):

- **plan**: multiple shooting with CasADi + IPOPT on the exact equations (model/fixed_equations:
  M(q) q̈ + bias(q, q̇) = B u, Coulomb friction left out), the input held over each interval of
  `substeps` controller periods, the state carried between knots by RK4 at the controller period
  (the same map the tracking is linearised on). Start at rest hanging, end at rest upright, then
  stay there; |u| ≤ margin·u_max. Cost: Σ (|u|² + w_du |Δu|²/h² · h² + w_v |q̇|²) h — the
  torque cost, its rate of change and the velocities, which are the RealAIGym leaderboard's
  criteria (docs/bench/leaderboard.md).
- **track**: the backward discrete Riccati recursion along the plan at the controller period
  (A_k, B_k the exact Jacobians of one RK4 period), started from the discrete LQR at the upright;
- **hold**: that discrete LQR, u = −K_hold (x − x_target).

`fixed_swingup` returns a `SwingUpLaw` (control/swingup.py) whose inputs, states and gains are
what ipsim's [swingup] method "trajectory" reads (one input: m = 1).
"""

from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ipgen.control.casadi_model import import_casadi
from ipgen.control.fixed_linear import fixed_equilibrium
from ipgen.control.linear import ControlError
from ipgen.control.swingup import SwingUpLaw
from ipgen.control.trajectory import PlanError
from ipgen.model.fixed import FixedPendulum

__all__ = [
    "FixedPlan",
    "casadi_dynamics",
    "fixed_plan",
    "fixed_schedule",
    "fixed_swingup",
    "read_plan",
    "sampled_plan",
    "write_plan",
]


@dataclass(frozen=True)
class FixedPlan:
    """A planned swing-up sampled at the controller period: inputs K × m (held over each period),
    states (K+1) × 2n (x̄_0 the start, x̄_K the target), in the chain's coordinates."""

    period: float
    inputs: np.ndarray
    states: np.ndarray
    iterations: int
    seconds: float
    knots: np.ndarray  # (N+1) × 2n, every `substeps` periods
    held: np.ndarray  # N × m


def casadi_dynamics(chain: FixedPendulum) -> Any:
    """ẋ = f(x, u) as a CasADi Function of x (2n) and u (m): q̈ = M⁻¹ (B u − bias)."""
    import sympy as sp

    from ipgen.model.fixed_numeric import FixedModel

    ca = import_casadi()
    model = FixedModel(chain)
    e = model.equations
    values = chain.numbers()
    symbols = (e.mass_matrix.free_symbols | e.bias.free_symbols) - {*e.q, *e.qd, *e.qdd}
    numbers = {s: sp.Float(values[s.name], 17) for s in symbols}
    mass = e.mass_matrix.xreplace(numbers)
    bias = e.bias.xreplace(numbers)
    n, m = chain.links, chain.inputs
    x, u = ca.SX.sym("x", 2 * n), ca.SX.sym("u", m)
    modules = [{"sin": ca.sin, "cos": ca.cos, "sqrt": ca.sqrt, "atan": ca.atan, "tanh": ca.tanh}, "math"]
    args = list(e.q) + list(e.qd)
    flat = sp.lambdify(args, list(mass) + list(bias), modules=modules)(*[x[i] for i in range(2 * n)])
    mass_ca = ca.vertcat(*[ca.horzcat(*flat[i * n : (i + 1) * n]) for i in range(n)])
    bias_ca = ca.vertcat(*flat[n * n :])
    b = ca.DM(model.B)
    qdd = ca.solve(mass_ca, b @ u - bias_ca)
    return ca.Function("f", [x, u], [ca.vertcat(x[n:], qdd)])


def _rk4(f: Any, period: float) -> Any:
    ca = import_casadi()
    x, u = ca.MX.sym("x", f.size1_in(0)), ca.MX.sym("u", f.size1_in(1))
    k1 = f(x, u)
    k2 = f(x + period / 2 * k1, u)
    k3 = f(x + period / 2 * k2, u)
    k4 = f(x + period * k3, u)
    return ca.Function("step", [x, u], [x + period / 6 * (k1 + 2 * k2 + 2 * k3 + k4)])


def fixed_plan(
    chain: FixedPendulum,
    *,
    duration: float,
    u_max: float,
    period: float = 0.002,
    substeps: int = 5,
    margin: float = 0.95,
    weight_rate: float = 1e-4,
    weight_velocity: float = 0.0,
    max_iter: int = 3000,
) -> FixedPlan:
    """Plan from hanging at rest to upright at rest in `duration` s (module docstring)."""
    ca = import_casadi()
    n, m = chain.links, chain.inputs
    h = period * substeps
    intervals = round(duration / h)
    if intervals < 2 or abs(intervals * h - duration) > 1e-9:
        raise PlanError(f"duration = {duration!r}: expected a whole number (>= 2) of {h:g} s intervals")
    f = casadi_dynamics(chain)
    step = _rk4(f, period)
    flow = step.mapaccum("flow", substeps)  # the states after each period of one interval

    start = np.concatenate([fixed_equilibrium(chain, "hanging"), np.zeros(n)])
    target = np.concatenate([fixed_equilibrium(chain, "upright"), np.zeros(n)])
    opti = ca.Opti()
    x = opti.variable(2 * n, intervals + 1)
    u = opti.variable(m, intervals)
    cost = 0
    for k in range(intervals):
        xs = flow(x[:, k], ca.repmat(u[:, k], 1, substeps))
        opti.subject_to(xs[:, -1] == x[:, k + 1])
        cost += h * ca.sumsqr(u[:, k]) + h * weight_velocity * ca.sumsqr(x[n:, k])
        if k > 0:
            cost += weight_rate / h * ca.sumsqr(u[:, k] - u[:, k - 1])
    cost += weight_rate / h * (ca.sumsqr(u[:, 0]) + ca.sumsqr(u[:, -1]))  # from and back to rest
    opti.subject_to(x[:, 0] == start)
    opti.subject_to(x[:, -1] == target)
    opti.subject_to(opti.bounded(-margin * u_max, ca.vec(u), margin * u_max))
    opti.minimize(cost)
    # Guess: the angles from start to target along a cosine, the rates its derivative.
    s = np.linspace(0.0, 1.0, intervals + 1)
    blend = 0.5 - 0.5 * np.cos(math.pi * s)
    guess = start[:, None] + (target - start)[:, None] * blend[None, :]
    guess[n:, :] = (target - start)[:n, None] * (0.5 * math.pi * np.sin(math.pi * s) / duration)[None, :]
    opti.set_initial(x, guess)
    opti.set_initial(u, 0.0)
    opti.solver("ipopt", {"print_time": False}, {"print_level": 0, "max_iter": max_iter, "tol": 1e-8})
    began = time.perf_counter()
    try:
        solution = opti.solve()
    except RuntimeError as exc:
        raise PlanError(
            f"no swing-up plan of {duration:g} s within |u| <= {margin * u_max:g} ({exc}): "
            "try a longer duration or a larger torque limit"
        ) from None
    seconds = time.perf_counter() - began
    knots = np.asarray(solution.value(x), dtype=float).reshape(2 * n, intervals + 1).T
    held = np.asarray(solution.value(u), dtype=float).reshape(m, intervals).T
    iterations = int(solution.stats()["iter_count"])
    return sampled_plan(chain, period, substeps, knots, held, iterations, seconds)


def sampled_plan(
    chain: FixedPendulum,
    period: float,
    substeps: int,
    knots: np.ndarray,
    held: np.ndarray,
    iterations: int = 0,
    seconds: float = 0.0,
) -> FixedPlan:
    """The plan at every controller period from its knots ((N+1) × 2n) and held inputs (N × m):
    RK4 at the period from each knot over its interval (the shooting's own map)."""
    f = casadi_dynamics(chain)
    flow = _rk4(f, period).mapaccum("flow", substeps)
    states = [knots[0]]
    inputs = []
    for k in range(len(held)):
        xs = np.asarray(flow(knots[k], np.repeat(held[k][:, None], substeps, axis=1)), dtype=float)
        for j in range(substeps):
            inputs.append(held[k])
            states.append(xs[:, j])
    states[-1] = knots[-1]  # x̄_K the target itself (the plan meets it to IPOPT's tolerance)
    return FixedPlan(period, np.array(inputs), np.array(states), iterations, seconds, knots, held)


def write_plan(path: Path, plan: FixedPlan, note: str = "") -> None:
    """The plan's knots and held inputs as a CSV: t, u1..um (held from t; 0 on the last row),
    x1..x2n (the chain's coordinates)."""
    m = plan.held.shape[1]
    states = plan.knots.shape[1]
    h = plan.period * (len(plan.inputs) // len(plan.held))
    header = ",".join(["t"] + [f"u{k + 1}" for k in range(m)] + [f"x{i + 1}" for i in range(states)])
    rows = np.hstack(
        [
            (np.arange(len(plan.knots)) * h)[:, None],
            np.vstack([plan.held, np.zeros((1, m))]),
            plan.knots,
        ]
    )
    lines = [f"# {line}" for line in note.splitlines()] + [header]
    lines += [",".join(repr(float(v)) for v in row) for row in rows]
    Path(path).write_text("\n".join(lines) + "\n")


# A plan's knots: a swing-up lasts at most 20,000 controller periods (scene.swingup), so its CSV
# (83 columns at 41 links, about 2 KB a row) stays far below 64 MiB.
MAX_PLAN_ROWS = 20_001
MAX_PLAN_BYTES = 64 * 2**20
PLAN_END_TOLERANCE = 1e-6  # rad, rad/s: a plan CSV's first and last rows against hanging and upright at rest


def read_plan(chain: FixedPendulum, path: Path, period: float) -> FixedPlan:
    """A plan written by `write_plan`, sampled at `period` (`PlanError` if it does not fit the
    chain: its columns, its knots against the period, its ends hanging and upright at rest)."""
    try:
        size = Path(path).stat().st_size
        if size > MAX_PLAN_BYTES:  # before reading: 5 million rows took 2.8 GB to refuse
            raise PlanError(
                f"{path}: {size / 2**20:.0f} MiB, a plan CSV holds at most {MAX_PLAN_ROWS:,} knots "
                f"({MAX_PLAN_BYTES // 2**20} MiB): plan again (leave out swingup.plan)"
            )
        text = Path(path).read_text()
    except OSError as exc:
        from ipgen.common.presets import presets_dir

        name = Path(path).name  # a preset's plan, its scene copied alone (`ipgen presets NAME > S.toml`)
        shipped = next((found for found in presets_dir().rglob("*.csv") if found.name == name), None)
        hint = f": copy it from {shipped}, or leave out swingup.plan to plan anew" if shipped else ""
        raise PlanError(f"cannot read the plan {path}: {exc.strerror}{hint}") from None
    lines = text.count("\n")
    if lines > MAX_PLAN_ROWS + 100:  # a header and comments, then the knots; before splitting them
        raise PlanError(f"{path}: {lines:,} lines, a plan holds at most {MAX_PLAN_ROWS:,} knots: plan again")
    rows = [line.split(",") for line in text.splitlines() if line.strip() and not line.startswith("#")]
    try:
        header, body = rows[0], np.array([[float(v) for v in row] for row in rows[1:]])
    except (IndexError, ValueError):
        raise PlanError(f"{path}: not a plan CSV (a header, then rows of numbers)") from None
    n, m = chain.links, chain.inputs
    if len(header) != 1 + m + 2 * n or len(body) < 3:
        raise PlanError(f"{path}: expected columns t, u1..u{m}, x1..x{2 * n} and >= 3 rows")
    bad = np.flatnonzero(~np.all(np.isfinite(body), axis=1))
    if bad.size:
        raise PlanError(
            f"{path}: data row {bad[0] + 1} holds a value that is not finite: plan again "
            "(leave out swingup.plan) or repair the file"
        )
    h = body[1, 0] - body[0, 0]
    substeps = round(h / period)
    if substeps < 1 or abs(substeps * period - h) > 1e-9 or np.any(np.abs(np.diff(body[:, 0]) - h) > 1e-9):
        raise PlanError(f"{path}: its knots every {h:g} s are not a whole number of periods of {period:g} s")
    for row, where in ((0, "hanging"), (-1, "upright")):  # fixed_plan's ends: a plan of another chain
        end = np.concatenate([fixed_equilibrium(chain, where), np.zeros(n)])
        off = body[row, 1 + m :] - end
        off[:n] = np.remainder(off[:n] + math.pi, 2 * math.pi) - math.pi
        if np.max(np.abs(off)) > PLAN_END_TOLERANCE:
            first = "first" if row == 0 else "last"
            raise PlanError(
                f"{path}: its {first} row is not this chain {where} at rest (off by "
                f"{np.max(np.abs(off)):.3g}): a plan of another chain or start; plan again "
                "(leave out swingup.plan)"
            )
    return sampled_plan(chain, period, substeps, body[:, 1 + m :], body[:-1, 1 : 1 + m])


def fixed_schedule(
    chain: FixedPendulum,
    plan: FixedPlan,
    q: np.ndarray | None = None,
    r: float = 1.0,
) -> tuple[np.ndarray, np.ndarray]:
    """(gains K × m × 2n along the plan, hold gain m × 2n): the discrete TVLQR's backward
    Riccati recursion from the discrete LQR at the plan's target."""
    from scipy.linalg import solve_discrete_are

    from ipgen.control.tvlqr import riccati_recursion

    ca = import_casadi()
    n, m = chain.links, chain.inputs
    q_ = np.diag([10.0] * n + [1.0] * n) if q is None else np.asarray(q, dtype=float)
    r_ = np.eye(m) * r
    step = _rk4(casadi_dynamics(chain), plan.period)
    xs, us = ca.MX.sym("x", 2 * n), ca.MX.sym("u", m)
    out = step(xs, us)
    jac = ca.Function("step_jacobians", [xs, us], [ca.jacobian(out, xs), ca.jacobian(out, us)])
    steps = len(plan.inputs)
    jac_all = jac.map(steps)
    a_all, b_all = jac_all(plan.states[:-1].T, plan.inputs.T)
    a = np.asarray(a_all, dtype=float).reshape(2 * n, steps, 2 * n).transpose(1, 0, 2)
    b = np.asarray(b_all, dtype=float).reshape(2 * n, steps, m).transpose(1, 0, 2)
    ad, bd = (np.asarray(v, dtype=float) for v in jac(plan.states[-1], np.zeros(m)))
    try:
        p = solve_discrete_are(ad, bd, q_, r_)
    except (np.linalg.LinAlgError, ValueError) as exc:
        raise ControlError(f"no discrete LQR at the upright ({exc})") from None
    hold = np.linalg.solve(r_ + bd.T @ p @ bd, bd.T @ p @ ad)
    gains, _ = riccati_recursion(a, b, q_, r_, p)
    return gains, hold


def fixed_swingup(
    chain: FixedPendulum,
    *,
    duration: float,
    u_max: float,
    hold: float,
    period: float = 0.002,
    plan: FixedPlan | None = None,
    **options: Any,
) -> tuple[SwingUpLaw, FixedPlan]:
    """The `SwingUpLaw` (method "trajectory", one input) of a fixed chain's swing-up, and its plan
    (`plan` given: reused, e.g. from a cache)."""
    if chain.inputs != 1:
        raise ControlError(
            f"a fixed chain's swing-up in ipsim drives one joint; this one drives {chain.inputs}"
        )
    if plan is None:
        plan = fixed_plan(chain, duration=duration, u_max=u_max, period=period, **options)
    gains, hold_gain = fixed_schedule(chain, plan)
    law = SwingUpLaw(
        method="trajectory",
        u_max=float(u_max),
        period=plan.period,
        hold=float(hold),
        hold_gain=tuple(float(v) for v in hold_gain.reshape(-1)),
        target=tuple(float(v) for v in plan.states[-1]),
        inputs=tuple(float(v) for v in plan.inputs.reshape(-1)),
        states=tuple(float(v) for v in plan.states.reshape(-1)),
        gains=tuple(float(v) for v in gains.reshape(-1)),
        plan_iterations=plan.iterations,
        plan_time=plan.seconds,
    )
    return law, plan


def canonical_law(law: SwingUpLaw, chain: FixedPendulum) -> SwingUpLaw:
    """A fixed chain's `SwingUpLaw` (the rig's coordinates and torque sense, as `fixed_swingup`
    makes it and the simulator reads it) in ipgen's canonical coordinates, where the C header's
    loop works: its plan's states and target mapped (`canonical_states`), its inputs times the
    torque's sign, its gains and the hold's mapped (`canonical_gains`)."""
    from ipgen.control.fixed_linear import canonical_gains, canonical_states

    if chain.coordinates.is_canonical:
        return law
    size = 2 * chain.links

    def flat(values: np.ndarray) -> tuple[float, ...]:
        return tuple(float(v) for v in np.ravel(values))

    def rows(values: tuple[float, ...]) -> np.ndarray:
        return np.reshape(values, (-1, size))

    return dataclasses.replace(
        law, states=flat(canonical_states(chain, rows(law.states))),
        target=flat(canonical_states(chain, rows(law.target))),
        inputs=tuple(chain.coordinates.sign * u for u in law.inputs),
        gains=flat(canonical_gains(chain, rows(law.gains))),
        hold_gain=flat(canonical_gains(chain, rows(law.hold_gain))),
    )  # fmt: skip
