"""What a rig measures, for the observation: encoders, noise, the rate filter and the delay.

The same measurement model as the simulator's `[sensors]` (docs/scenes.md), applied at every
control interval dt to a batch of environments at once:
- angle (or cart position) y = Δ floor(θ/Δ + 1/2) + n, Δ = 2π/resolution (per metre for a cart
  position: 1/resolution), n ~ N(0, σ²) drawn per step and coordinate from the env's generator;
- rates from the rigs' first-order derivative filter v_k = a v_{k−1} + ωc (y_k − y_{k−1}),
  a = exp(−ωc dt) (Quanser's (ωc z − ωc)/(z − e^{−ωc dt})), or the backward difference;
- the action takes effect `delay` later (a whole number of intervals), and drive noise is added
  to the applied input.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from ipgen.estimation.measurement import cutoff_problem, noise_problem, resolution_problem
from ipgen.gym.checks import GymError, is_number

KEYS = ("resolution", "noise", "delay", "rates", "cutoff", "drive_noise")


@dataclass(frozen=True)
class Sensing:
    """The rig's measurement of one environment's coordinates (see the module docstring).

    Attributes
    ----------
    quantum : numpy.ndarray
        Δ per coordinate (0: exact).
    noise : float
        σ of the additive measurement noise [rad or m].
    delay_steps : int
        Intervals between an action and its effect.
    rates : str
        "filter" or "difference".
    cutoff : float
        The filter's ωc [rad/s].
    drive_noise : float
        σ of the noise on the applied input, as a fraction of u_max.
    """

    quantum: np.ndarray
    noise: float = 0.0
    delay_steps: int = 0
    rates: str = "filter"
    cutoff: float = 50.0
    drive_noise: float = 0.0

    @classmethod
    def from_options(cls, options: Mapping[str, object], type: str, dof: int, dt: float) -> Sensing:
        """From `sensors={...}`: resolution (counts per revolution, per metre for a cart;
        0 = exact; default 2048), noise, delay [s] (a whole multiple of dt), rates ("filter" or
        "difference"), cutoff [rad/s], drive_noise (fraction of u_max). The values obey a
        scene's rules ([sensors], [estimator], `ipgen.estimation.measurement`): a resolution is 0
        or >= 1 count, a noise at most 1e100, the cutoff at most the Nyquist frequency π / dt."""
        unknown = sorted(set(options) - set(KEYS))
        if unknown:
            raise GymError(f"sensors has no key {unknown[0]!r:.40}: choose from {', '.join(KEYS)}")
        resolution = options.get("resolution", 2048)
        entries = resolution if isinstance(resolution, list | tuple) else [resolution]
        if not (
            len(entries) in (1, dof)
            and all(is_number(c) and 0 <= c < math.inf and not resolution_problem(c) for c in entries)
        ):
            raise GymError(
                f"sensors.resolution must be 0 (exact) or >= 1 count per revolution or metre, "
                f"one number or {dof} numbers"
            )
        counts = np.broadcast_to(np.asarray(entries, dtype=np.float64), (dof,)).copy()
        per_unit = np.array([1.0 if (i == 0 and type == "classical") else 2 * math.pi for i in range(dof)])
        quantum = np.where(counts > 0, per_unit / np.where(counts > 0, counts, 1.0), 0.0)
        delay = options.get("delay", 0.0)
        steps = round(delay / dt) if is_number(delay) and 0 <= delay <= 1000 * dt else -1
        if steps < 0 or not math.isclose(steps * dt, delay, rel_tol=1e-9, abs_tol=1e-12):  # type: ignore[arg-type]
            raise GymError(
                f"sensors.delay = {delay!r:.40} must be a whole multiple of dt = {dt!r} (0 to 1000 dt)"
            )
        rates = options.get("rates", "filter")
        if rates not in ("filter", "difference"):
            raise GymError(f"sensors.rates = {rates!r:.40}: choose filter or difference")
        numbers = {k: options.get(k, d) for k, d in (("noise", 0.0), ("cutoff", 50.0), ("drive_noise", 0.0))}
        if not all(is_number(v) and 0 <= v < math.inf for v in numbers.values()) or not numbers["cutoff"]:
            raise GymError("sensors.noise and drive_noise must be numbers >= 0 and cutoff > 0, all finite")
        noise, cutoff, drive_noise = (float(numbers[k]) for k in ("noise", "cutoff", "drive_noise"))  # type: ignore[arg-type]
        for key, value in (("noise", noise), ("drive_noise", drive_noise)):
            problem = noise_problem(value)
            if problem:
                raise GymError(f"sensors.{key} = {value!r:.40} {problem}")
        problem = cutoff_problem(cutoff, dt)
        if problem:
            raise GymError(f"sensors.cutoff = {cutoff!r:.40} {problem}: give a lower cutoff or a shorter dt")
        return cls(quantum, noise, steps, str(rates), cutoff, drive_noise)

    def measure(self, angles: np.ndarray, rngs: list[np.random.Generator]) -> np.ndarray:
        """y for a batch of coordinates (N × dof): quantised, then noise drawn per env."""
        y = np.where(
            self.quantum > 0,
            self.quantum * np.floor(angles / np.where(self.quantum > 0, self.quantum, 1) + 0.5),
            angles,
        )
        if self.noise:
            y = y + np.stack([rng.normal(0.0, self.noise, size=angles.shape[1]) for rng in rngs])
        return y

    def rate(self, y: np.ndarray, previous: np.ndarray, rate: np.ndarray, dt: float) -> np.ndarray:
        """The estimated rates from this and the previous measurement."""
        if self.rates == "difference":
            return (y - previous) / dt
        return math.exp(-self.cutoff * dt) * rate + self.cutoff * (y - previous)


class MeasuredLoop:
    """The measured observation and the delayed, noisy action of a batch of N environments.

    Held per environment: the previous measurement, the rate estimate and the queue of actions
    not yet applied. `reset` starts the given rows over; `apply` turns the agent's actions into
    those the model sees this interval; `observe` writes the measured observation.
    """

    def __init__(self, sensing: Sensing, dof: int, n: int, dt: float) -> None:
        self.sensing, self.dof, self.dt = sensing, dof, dt
        self.previous = np.zeros((n, dof))
        self.rates = np.zeros((n, dof))
        self.queue = np.zeros((n, sensing.delay_steps))

    def reset(
        self, rows: np.ndarray, state: np.ndarray, rngs: list[np.random.Generator], obs: np.ndarray
    ) -> None:
        """Start `rows` (indices) over from `state` (their rows): first measurement, zero rates."""
        with np.errstate(over="ignore", invalid="ignore"):  # checked for finiteness by the caller
            y = self.sensing.measure(state[rows, : self.dof], [rngs[i] for i in rows])
            self.previous[rows], self.rates[rows], self.queue[rows] = y, 0.0, 0.0
            obs[rows] = self.layout(y, self.rates[rows])

    def apply(self, rows: np.ndarray, actions: np.ndarray, rngs: list[np.random.Generator]) -> np.ndarray:
        """The actions the model sees now in `rows`: `delay_steps` old, plus drive noise (before
        the ±1 clip). `actions` has one entry per row."""
        if self.sensing.delay_steps:
            applied = self.queue[rows, 0].copy()
            self.queue[rows] = np.column_stack([self.queue[rows, 1:], actions])
        else:
            applied = np.asarray(actions, dtype=np.float64).copy()
        if self.sensing.drive_noise:
            applied += np.array([rngs[i].normal(0.0, self.sensing.drive_noise) for i in rows])
        return applied

    def observe(
        self, rows: np.ndarray, state: np.ndarray, rngs: list[np.random.Generator], obs: np.ndarray
    ) -> np.ndarray:
        """Measure `rows` after a step and write (y0, sin/cos of each y_i, rates) into obs; the
        rows (of `rows`) whose observation is not finite, which the caller ends as failed."""
        with np.errstate(over="ignore", invalid="ignore"):  # a non-finite row is returned, not warned
            y = self.sensing.measure(state[rows, : self.dof], [rngs[i] for i in rows])
            self.rates[rows] = self.sensing.rate(y, self.previous[rows], self.rates[rows], self.dt)
            self.previous[rows] = y
            observed = self.layout(y, self.rates[rows])
        obs[rows] = observed
        return rows[~np.isfinite(observed).all(axis=1)]

    def layout(self, y: np.ndarray, rates: np.ndarray) -> np.ndarray:
        """The observation's layout of the measured values (as the exact one's)."""
        columns = [y[:, :1]]
        for i in range(1, self.dof):
            columns += [np.sin(y[:, i : i + 1]), np.cos(y[:, i : i + 1])]
        return np.column_stack([*columns, rates]).astype(np.float32)
