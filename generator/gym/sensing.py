"""What a rig measures, for the observation: encoders, noise, the rate filter and the delay.

The same measurement model as the simulator's `[sensors]` (docs/scenes.md), applied at every
control interval dt to a batch of environments at once:
- angle (or cart position) y = Δ floor(θ/Δ + 1/2) + n, Δ = 2π/resolution (per metre for a cart
  position: 1/resolution), n ~ N(0, σ²) drawn per step and coordinate from the env's generator;
- rates from the rigs' first-order derivative filter v_k = a v_{k−1} + ωc (y_k − y_{k−1}),
  a = exp(−ωc dt) (Quanser's (ωc z − ωc)/(z − e^{−ωc dt})), or the backward difference;
- the action takes effect `delay` later (a whole number of intervals), and drive noise is added
  to the applied input.

The quantiser, the rates and the delay are cpp/include/ipgen_loop.h's, called through ctypes once
per batch (`ipgen.common.loop_runtime`); the noise is drawn in Python from each env's generator.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from ipgen.common.loop_runtime import address, library
from ipgen.estimation.measurement import cutoff_problem, noise_problem, resolution_problem
from ipgen.gym.checks import GymError, is_number

KEYS = ("resolution", "noise", "delay", "rates", "cutoff", "drive_noise")
MAX_DOF = 64  # the coordinates ipgen_loop_batch_observe measures per environment


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


class MeasuredLoop:
    """The measured observation and the delayed, noisy action of a batch of N environments.

    Held per environment: the previous measurement, the rate estimate and the commands not yet
    applied (`pending`, ipgen_loop_delay's: `delay_steps` + 1 entries, the first the action
    applied last). `reset` starts the given rows over; `apply` turns the agent's actions into
    those the model sees this interval; `observe` writes the measured observation. Each is one
    call into ipgen_loop.h (cpp/src/ipgen_loop_batch.c: every row through ipgen_loop_quantise,
    _filter or _difference, and _delay); the noise is drawn here, from each environment's
    generator, in the order the environments are given.
    """

    def __init__(self, sensing: Sensing, dof: int, n: int, dt: float) -> None:
        if not 1 <= dof <= MAX_DOF:
            raise GymError(f"sensors: at most {MAX_DOF} coordinates, this system has {dof}")
        self.sensing, self.dof, self.dt = sensing, dof, dt
        self.previous = np.zeros((n, dof))
        self.rates = np.zeros((n, dof))
        self.pending = np.zeros((n, sensing.delay_steps + 1))
        self.quantum = np.ascontiguousarray(sensing.quantum, dtype=np.float64)
        self.pole = math.exp(-sensing.cutoff * dt)  # a = e^{−ωc dt}
        # Scratch of one call (the noise, the commands and actions, which rows are finite) and
        # the addresses of everything C reads or writes: numpy's address lookup costs more than
        # a small batch's whole measurement, so each is looked up once.
        self.noise = np.zeros((n, dof))
        self.commands, self.applied = np.zeros(n), np.zeros(n)
        self.finite = np.zeros(n, dtype=np.uint8)
        self._at = {
            name: address(getattr(self, name))
            for name in ("previous", "rates", "pending", "quantum", "noise", "commands", "applied", "finite")
        }
        self._known: dict[str, tuple[np.ndarray, int]] = {}  # the caller's arrays last passed

    def _address(self, name: str, array: np.ndarray) -> int:
        """The address of the caller's `array` passed as `name` (looked up when it changes)."""
        known = self._known.get(name)
        if known is None or known[0] is not array:
            known = self._known[name] = (array, address(array))
        return known[1]

    def _observe(
        self, rows: np.ndarray, state: np.ndarray, rngs: list[np.random.Generator], obs: np.ndarray, k: int
    ) -> np.ndarray:
        """Measure `rows` (sample k: 0 at a reset) into obs; the rows whose observation is not finite."""
        if state.dtype != np.float64 or obs.dtype != np.float32 or state.shape[1] != 2 * self.dof:
            raise TypeError("MeasuredLoop: state must be N × 2·dof float64, obs float32")
        rows = np.ascontiguousarray(rows, dtype=np.int64)
        count, sensing, at = len(rows), self.sensing, self._at
        if sensing.noise and count:
            draws = [rngs[i].normal(0.0, sensing.noise, size=self.dof) for i in rows]
            np.stack(draws, out=self.noise[:count])
        failed = library().ipgen_loop_batch_observe(
            count, self._address("rows", rows), self.dof, self._address("state", state), at["quantum"],
            at["noise"] if sensing.noise else None, int(sensing.rates == "filter"), self.pole, sensing.cutoff,
            self.dt, k, at["previous"], at["rates"], self._address("obs", obs), obs.shape[1], at["finite"],
        )  # fmt: skip
        return rows[self.finite[:count] == 0] if failed else rows[:0]

    def reset(
        self, rows: np.ndarray, state: np.ndarray, rngs: list[np.random.Generator], obs: np.ndarray
    ) -> None:
        """Start `rows` (indices) over from `state` (their rows): first measurement, zero rates,
        nothing pending. `state` is N × 2·dof float64, `obs` N rows of float32, both C-contiguous."""
        self.pending[rows] = 0.0
        self._observe(rows, state, rngs, obs, 0)

    def apply(self, rows: np.ndarray, actions: np.ndarray, rngs: list[np.random.Generator]) -> np.ndarray:
        """The actions the model sees now in `rows`: `delay_steps` old, plus drive noise (before
        the ±1 clip). `actions` has one entry per row."""
        rows = np.ascontiguousarray(rows, dtype=np.int64)
        count = len(rows)
        self.commands[:count] = actions
        library().ipgen_loop_batch_delay(
            count, self._address("rows", rows), self.sensing.delay_steps, self._at["pending"],
            self._at["commands"], self._at["applied"],
        )  # fmt: skip
        applied = self.applied[:count].copy()
        if self.sensing.drive_noise:
            applied += np.array([rngs[i].normal(0.0, self.sensing.drive_noise) for i in rows])
        return applied

    def observe(
        self, rows: np.ndarray, state: np.ndarray, rngs: list[np.random.Generator], obs: np.ndarray
    ) -> np.ndarray:
        """Measure `rows` after a step and write (y0, sin/cos of each y_i, rates) into obs; the
        rows (of `rows`) whose observation is not finite, which the caller ends as failed."""
        return self._observe(rows, state, rngs, obs, 1)
