"""Independent numpy references of the sampled loop's algorithms, which the package runs from
cpp/include/ipgen_loop.h through ctypes (ipgen.common.loop_runtime): the estimators' step
(difference, derivative filter, steady-state Kalman, EKF), the encoder quantiser, ipgen.gym's
measured observation and delayed action, and the energy swing-up's control.

This is the package's numpy code before it ran the C header (commit 96ff51f), kept here as the
reference the ctypes runtime is checked against (tests/test_loop_runtime.py): written with numpy's
linear algebra (np.linalg.solve, not a Cholesky factor), Python's round(), numpy's clip. What it
is independent of is the loop's C code. The energy law's model is not re-derived here: its M and
bias are ipgen's own (`ipgen.control.energy.mass_and_bias`, which the C law calls back too), and
its energy constants the law's; the derivation is checked against Kane's method in
tests/test_independent.py, so these comparisons check the law, the catch and the learning rules.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np


def initial_state(dof: int, measured: tuple[int, ...], y: np.ndarray, x_eq: np.ndarray) -> np.ndarray:
    """x̂_{0|−1}: the measured coordinates y_0, the others x_eq, rates 0."""
    x = np.concatenate([x_eq[:dof], np.zeros(dof)])
    x[list(measured)] = y
    return x


class Difference:
    """θ̂ = y_k, θ̇̂_k = (y_k − y_{k−1}) / T, θ̇̂_0 = 0."""

    def __init__(self, period: float, dof: int) -> None:
        self.period, self.dof, self._last = period, dof, None

    def step(self, y: Any, u: float = 0.0) -> np.ndarray:
        values = np.asarray(y, dtype=float).reshape(-1)
        rates = np.zeros(self.dof) if self._last is None else (values - self._last) / self.period
        self._last = values.copy()
        return np.concatenate([values, rates])


class DerivativeFilter:
    """v_k = e^{−ωc T} v_{k−1} + ωc (y_k − y_{k−1}), v_0 = 0."""

    def __init__(self, period: float, dof: int, cutoff: float) -> None:
        self.dof, self.cutoff = dof, cutoff
        self.pole = math.exp(-cutoff * period)
        self._last: np.ndarray | None = None
        self._rates = np.zeros(dof)

    def step(self, y: Any, u: float = 0.0) -> np.ndarray:
        values = np.asarray(y, dtype=float).reshape(-1)
        if self._last is not None:
            self._rates = self.pole * self._rates + self.cutoff * (values - self._last)
        self._last = values.copy()
        return np.concatenate([values, self._rates])


class SteadyStateKalman:
    """The current form of `design` (an `ipgen.kalman` Kalman)."""

    def __init__(self, design: Any) -> None:
        self.design = design
        self.dof = design.A.shape[0] // 2
        self._x_eq = np.asarray(design.equilibrium, dtype=float)
        self._x: np.ndarray | None = None

    def step(self, y: Any, u: float = 0.0) -> np.ndarray:
        values = np.asarray(y, dtype=float).reshape(-1)
        d = self.design
        if self._x is None:
            prior = initial_state(self.dof, d.measured, values, self._x_eq)
        else:
            prior = self._x_eq + d.A @ (self._x - self._x_eq) + d.B[:, 0] * (float(u) - d.u_eq)
        self._x = prior + d.M @ (values - d.C @ prior)
        return self._x.copy()


class ExtendedKalman:
    """The EKF of an `ipgen.estimation.ExtendedKalman` `ekf` (its model, Qn, Rn, C, x_eq); with its
    gain_spread > 0 the state is [x; ρ], x' = f(x, ρ u), ρ' = 0, ∂f/∂ρ = u ∂f/∂u (the model's B),
    ρ's process noise gain_drift² T, ρ kept within [1/2, 2]. With its noise_memory > 0 each
    measured coordinate's variance is learnt: an exponential mean (weight T / noise_memory) of
    ν_r² − (C P⁻ Cᵀ)_rr, kept ≥ 0 (a non-finite one keeps the last), from Rn's diagonal /
    noise_margin; after the first sample the update uses Rn with the diagonal noise_margin times
    it, clipped to [noise_floor, noise_ceiling]."""

    def __init__(self, ekf: Any) -> None:
        self.ekf = ekf
        self.learns = getattr(ekf, "gain_spread", 0.0) > 0
        self.memory = getattr(ekf, "noise_memory", 0.0)
        self._x: np.ndarray | None = None
        self._p: np.ndarray | None = None
        self.learnt: np.ndarray | None = None  # the learnt variances (noise_memory > 0)

    def predict(self, x: np.ndarray, p: np.ndarray, u: float) -> tuple[np.ndarray, np.ndarray]:
        t, f, n = self.ekf.period, self.ekf.model.f, 2 * self.ekf.dof
        rho = x[n] if self.learns else 1.0
        xs, us = x[:n], u * rho
        _, a_c, b_c = self.ekf.model.jacobians(xs, us)
        k1 = f(xs, us)
        k2 = f(xs + 0.5 * t * k1, us)
        k3 = f(xs + 0.5 * t * k2, us)
        k4 = f(xs + t * k3, us)
        x_next = xs + t / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
        q = np.zeros((x.size, x.size))
        q[:n, :n] = self.ekf.Qn
        a = np.zeros((x.size, x.size))
        a[:n, :n] = a_c
        if self.learns:
            a[:n, n] = u * np.asarray(b_c, dtype=float).reshape(-1)
            q[n, n] = self.ekf.gain_drift**2 * t
            x_next = np.append(x_next, rho)
        ta = t * a
        transition = np.eye(x.size) + ta + 0.5 * ta @ ta
        p_next = transition @ p @ transition.T + q
        return x_next, 0.5 * (p_next + p_next.T)

    def noise(self, first: bool, innovation: np.ndarray, predicted: np.ndarray) -> np.ndarray:
        """The measurement covariance this sample's update uses (`predicted`: C P⁻ Cᵀ)."""
        e, rn = self.ekf, np.array(self.ekf.Rn, dtype=float)
        if self.memory <= 0:
            return rn
        if first:
            self.learnt = np.diag(rn) / e.noise_margin
            return rn
        assert self.learnt is not None
        weight = e.period / self.memory
        sample = innovation**2 - np.diag(predicted)
        mean = self.learnt + weight * (sample - self.learnt)
        self.learnt = np.maximum(np.where(np.isfinite(mean), mean, self.learnt), 0.0)
        used = np.clip(e.noise_margin * self.learnt, e.noise_floor, e.noise_ceiling)
        rn[np.diag_indices_from(rn)] = used
        return rn

    def update(
        self, x: np.ndarray, p: np.ndarray, y: np.ndarray, first: bool = False
    ) -> tuple[np.ndarray, np.ndarray]:
        c = self.ekf.C
        if self.learns:
            c = np.hstack([c, np.zeros((c.shape[0], 1))])
        rn = self.noise(first, y - c @ x, c @ p @ c.T)
        s = c @ p @ c.T + rn
        k = np.linalg.solve(s, c @ p).T
        x_new = x + k @ (y - c @ x)
        if self.learns:
            x_new[-1] = min(max(x_new[-1], 0.5), 2.0)
        i_kc = np.eye(x.size) - k @ c
        p_new = i_kc @ p @ i_kc.T + k @ rn @ k.T
        return x_new, 0.5 * (p_new + p_new.T)

    def step(self, y: Any, u: float = 0.0) -> np.ndarray:
        values = np.asarray(y, dtype=float).reshape(-1)
        e = self.ekf
        first = self._x is None or self._p is None
        if self._x is None or self._p is None:
            x = initial_state(e.dof, e.measured, values, e._x_eq)
            p = e.initial_covariance()
            if self.learns:
                x = np.append(x, 1.0)
                p = np.pad(p, ((0, 1), (0, 1)))
                p[-1, -1] = e.gain_spread**2
        else:
            x, p = self.predict(self._x, self._p, float(u))
        self._x, self._p = self.update(x, p, values, first)
        return self._x[: 2 * e.dof].copy()

    @property
    def gain(self) -> float:
        return float(self._x[-1]) if self.learns and self._x is not None else 1.0

    @property
    def covariance(self) -> np.ndarray | None:
        return None if self._p is None else self._p.copy()


def quantise(sensors: Any, theta: np.ndarray) -> np.ndarray:
    """`Sensors.quantise`: z + Δ floor((θ − z) / Δ + 1/2) of the measured coordinates."""
    from ipgen.estimation.measurement import grid_zero

    values = np.asarray(theta, dtype=float)[list(sensors.measured)]
    out = values.copy()
    for j, step in enumerate(sensors.steps()):
        if step > 0:
            z = grid_zero(sensors.zero[j], step) if sensors.zero else 0.0
            out[j] = z + step * math.floor((values[j] - z) / step + 0.5)
    return out


class MeasuredLoop:
    """ipgen.gym's measured observation and delayed action of N environments (`Sensing`)."""

    def __init__(self, sensing: Any, dof: int, n: int, dt: float) -> None:
        self.sensing, self.dof, self.dt = sensing, dof, dt
        self.previous = np.zeros((n, dof))
        self.rates = np.zeros((n, dof))
        self.queue = np.zeros((n, sensing.delay_steps))

    def measure(self, angles: np.ndarray, rngs: list[np.random.Generator]) -> np.ndarray:
        quantum = self.sensing.quantum
        steps = np.where(quantum > 0, quantum, 1)
        y = np.where(quantum > 0, quantum * np.floor(angles / steps + 0.5), angles)
        if self.sensing.noise:
            y = y + np.stack([rng.normal(0.0, self.sensing.noise, size=angles.shape[1]) for rng in rngs])
        return y

    def rate(self, y: np.ndarray, previous: np.ndarray, rate: np.ndarray) -> np.ndarray:
        if self.sensing.rates == "difference":
            return (y - previous) / self.dt
        return math.exp(-self.sensing.cutoff * self.dt) * rate + self.sensing.cutoff * (y - previous)

    def reset(self, rows: np.ndarray, state: np.ndarray, rngs: list[Any], obs: np.ndarray) -> None:
        with np.errstate(over="ignore", invalid="ignore"):
            y = self.measure(state[rows, : self.dof], [rngs[i] for i in rows])
            self.previous[rows], self.rates[rows], self.queue[rows] = y, 0.0, 0.0
            obs[rows] = self.layout(y, self.rates[rows])

    def apply(self, rows: np.ndarray, actions: np.ndarray, rngs: list[np.random.Generator]) -> np.ndarray:
        if self.sensing.delay_steps:
            applied = self.queue[rows, 0].copy()
            self.queue[rows] = np.column_stack([self.queue[rows, 1:], actions])
        else:
            applied = np.asarray(actions, dtype=np.float64).copy()
        if self.sensing.drive_noise:
            applied += np.array([rngs[i].normal(0.0, self.sensing.drive_noise) for i in rows])
        return applied

    def observe(self, rows: np.ndarray, state: np.ndarray, rngs: list[Any], obs: np.ndarray) -> np.ndarray:
        with np.errstate(over="ignore", invalid="ignore"):
            y = self.measure(state[rows, : self.dof], [rngs[i] for i in rows])
            self.rates[rows] = self.rate(y, self.previous[rows], self.rates[rows])
            self.previous[rows] = y
            observed = self.layout(y, self.rates[rows])
        obs[rows] = observed
        return rows[~np.isfinite(observed).all(axis=1)]

    def layout(self, y: np.ndarray, rates: np.ndarray) -> np.ndarray:
        columns = [y[:, :1]]
        for i in range(1, self.dof):
            columns += [np.sin(y[:, i : i + 1]), np.cos(y[:, i : i + 1])]
        return np.column_stack([*columns, rates]).astype(np.float32)


class EnergyControl:
    """`EnergySwingUp.control` of the law `law` (its constants, plant and hold gain), with M and
    bias from ipgen's `mass_and_bias` (the model is not what this reference checks)."""

    def __init__(self, law: Any) -> None:
        self.law = law
        self._caught: int | None = None
        # energy_step: the target's offset, and what the learning rules remember
        self.offset = 0.0
        self._in_window = False
        self._swinging = False
        self._rate_before = 0.0
        self._last_peak = 0.0

    def _learn(self, angle: float, rate: float) -> None:
        """docs/swingup.md's rules for the learnt target, at a swing sample."""
        law = self.law
        off = abs(angle - 2 * math.pi * math.floor(angle / (2 * math.pi) + 0.5))
        in_window = off <= law.catch_angle
        if in_window and not self._in_window and abs(rate) > law.catch_rate:
            self.offset -= law.energy_step  # entering the window too fast to be caught
        self._in_window = in_window
        self._swinging = self._swinging or abs(rate) > law.catch_rate
        if self._swinging and rate * self._rate_before < 0:  # a turn
            self._swinging = False
            if not in_window and off < math.pi / 2:
                if self._last_peak > 0 and off >= self._last_peak - 0.1 * law.catch_angle:
                    self.offset += law.energy_step  # no nearer upright than the last turn: stalled
                self._last_peak = off
            else:
                self._last_peak = 0.0
        if rate != 0:  # a rate read as exactly 0 (quantised) does not hide a turn
            self._rate_before = rate
        limit = law.plant.m[1] * law.plant.g * law.plant.l[1]  # 2 energy_weight
        self.offset = min(max(self.offset, -limit), limit)

    def control(self, k: int, x: np.ndarray) -> tuple[float, str]:
        from ipgen.control.energy import link_energy, mass_and_bias

        law = self.law
        x = np.asarray(x, dtype=float)
        dof = law.plant.dof
        turns = round(float(x[1]) / (2 * math.pi))
        release = getattr(law, "release_angle", 0.0)
        fallen = self._caught is not None and abs(float(x[1]) - 2 * math.pi * self._caught) > release
        if release > 0 and fallen:
            self._caught = None  # the hold gives the link back to the swing, which learns afresh
            self._in_window = self._swinging = False  # (what it has learnt, the offset, is kept)
            self._rate_before = self._last_peak = 0.0
        deficit, base = getattr(law, "catch_deficit", 0.0), getattr(law, "catch_base", 0.0)
        if (
            self._caught is None
            and abs(float(x[1]) - 2 * math.pi * turns) <= law.catch_angle
            and abs(float(x[dof + 1])) <= law.catch_rate
            and not (deficit > 0 and link_energy(law.plant, x) < -deficit)  # too slow to reach upright
            and not (base > 0 and abs(float(x[0])) > base)  # the base too far out to brake
        ):
            self._caught = turns
        if self._caught is not None:
            target = np.zeros(2 * dof)
            target[1] = 2 * math.pi * self._caught
            u = -float(law.hold_gain @ (x - target))
            return float(np.clip(u, -law.u_max, law.u_max)), "hold"
        q, qd = x[:dof], x[dof:]
        mass, bias = mass_and_bias(law.plant, q, qd)
        if getattr(law, "energy_step", 0.0) > 0:
            self._learn(float(x[1]), float(x[dof + 1]))
        energy = link_energy(law.plant, x)
        direction = math.copysign(1.0, float(qd[1]) * mass[1, 0]) if qd[1] * mass[1, 0] != 0 else 1.0
        pump = law.gain_energy * (energy - (law.energy_target + self.offset)) * direction
        a = float(np.clip(pump, -law.accel_max, law.accel_max))
        a -= law.gain_position * float(q[0]) + law.gain_velocity * float(qd[0])
        if law.acceleration:
            return float(np.clip(a, -law.u_max, law.u_max)), "swing"
        qdd1 = -(mass[1, 0] * a + bias[1]) / mass[1, 1]
        u = mass[0, 0] * a + mass[0, 1] * qdd1 + bias[0]
        return float(np.clip(u, -law.u_max, law.u_max)), "swing"
