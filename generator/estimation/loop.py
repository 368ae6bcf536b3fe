"""A sampled closed loop with sensors and an estimator, in Python (for the bench and tests).

At t_k = k T: y_k = the sensors' sample of the true state; x̂_k = the estimator's step (or the
true state, estimator None); with `predict`, x̂_k carried over the delay by the model with the
commands in flight (ipgen_loop_predict); u_k = sat(−K (x̂_k − x_eq)); u_k is applied from
t_k + j T (delay of j periods; 0 before the first arrives) and held. Between samples the model ẋ = f(x, ū) is
integrated by CasADi's RK4 flow map (`control.casadi_model`) in `substeps` steps per period
(default steps of at most 0.1 ms), in ipgen's own coordinates; the estimator and controller
see the pendulum's coordinates. The saturation and the delay are cpp/include/ipgen_loop.h's
(ipgen_loop_saturate, ipgen_loop_delay, through ctypes: `ipgen.common.loop_runtime`), as is the
estimator's step. Needs CasADi (the [test], [swingup] or [bench] extras).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from ipgen.common.loop_runtime import FIELD, address, library
from ipgen.estimation.pendulum import EstimationError

if TYPE_CHECKING:
    import numpy as np

    from ipgen.control.linear import VectorField
    from ipgen.estimation.estimators import Estimator
    from ipgen.estimation.measurement import Sensors

FAIL_ANGLE = math.pi / 2  # a link this far from the equilibrium has fallen: the run stops
BALANCED_ANGLE = 0.05  # rad: every link within this of x_eq over the last second = balanced


@dataclass(frozen=True)
class LoopRun:
    """One closed-loop run at the sample times (the pendulum's coordinates): true states `x`,
    measurements `y`, estimates `estimate`, commands `u` and the inputs `applied` over
    [t_k, t_{k+1}); `fallen` if a link passed FAIL_ANGLE (the arrays then end there)."""

    t: np.ndarray
    x: np.ndarray
    y: np.ndarray
    estimate: np.ndarray
    u: np.ndarray
    applied: np.ndarray
    fallen: bool
    equilibrium: np.ndarray

    @property
    def balanced(self) -> bool:
        """Not fallen, and every link within BALANCED_ANGLE of x_eq over the last second."""
        import numpy as np

        if self.fallen:
            return False
        dof = self.x.shape[1] // 2
        period = float(self.t[1] - self.t[0])
        last = self.x[-max(1, round(1.0 / period)) :, 1:dof] - self.equilibrium[1:dof]
        return bool(np.all(np.abs(last) < BALANCED_ANGLE))

    def rms_error(self) -> np.ndarray:
        """RMS of x̂_k − x(t_k) per state over the run."""
        import numpy as np

        return np.sqrt(np.mean((self.estimate - self.x) ** 2, axis=0))


def flow(model: VectorField, period: float, substeps: int | None = None) -> Any:
    """x(t + T) = F(x, u) in ipgen's coordinates, u in the model's input units (CasADi RK4)."""
    from ipgen.control.casadi_model import Plant, casadi_model

    plant = Plant(model.pendulum)  # its params fold a motor in: u is then b · V
    steps = substeps or max(1, math.ceil(period / 1e-4 - 1e-9))
    return casadi_model(plant).flow_map(period, steps)


def _field_of(model: VectorField) -> Any:
    """ipgen_loop_field over model.f (the pendulum's coordinates, u in its input unit: gain 1);
    code 1 where M(q) is singular."""
    import numpy as np

    def field(context: Any, x: Any, u: float, f: Any, a: Any) -> int:
        size = 2 * model.dof
        try:
            value = model.f(np.ctypeslib.as_array(x, shape=(size,)).copy(), u)
        except np.linalg.LinAlgError:
            return 1
        np.ctypeslib.as_array(f, shape=(size,))[:] = value
        return 0

    return field


def closed_loop(
    model: VectorField,
    gain: Sequence[float] | np.ndarray,
    equilibrium: Sequence[float] | np.ndarray,
    estimator: Estimator | None,
    sensors: Sensors,
    period: float,
    t_end: float,
    initial: Sequence[float] | np.ndarray,
    *,
    saturation: float | None = None,
    delay: int = 0,
    seed: int = 0,
    substeps: int | None = None,
    predict: bool = False,
) -> LoopRun:
    """Run the loop (module docstring) from `initial` (2·dof, the pendulum's coordinates) for
    `t_end` seconds; `delay` in whole periods; the sensor noise drawn from numpy's PCG64 seeded
    with `seed`; `predict`: the gain acts on the estimate carried over the delay (the loop knows
    it), as the simulator's `[estimator] predict`."""
    import numpy as np

    if model.acceleration:
        raise EstimationError("closed_loop: an acceleration-driven base is not supported here")
    if delay < 0:
        raise EstimationError(f"delay = {delay}: expected a whole number of periods >= 0")
    rng = np.random.default_rng(seed)
    step = flow(model, period, substeps)
    dof = model.dof
    k_row = np.asarray(gain, dtype=float).reshape(-1)
    x_eq = np.asarray(equilibrium, dtype=float).reshape(-1)
    p, c = model.transform, model.offset
    p_inv = np.linalg.inv(p)
    x = p_inv @ (np.asarray(initial, dtype=float) - c)  # ipgen's coordinates
    steps = round(t_end / period)
    run = library()  # ipgen_loop.h: the saturation and the delay
    pending = np.zeros(delay + 1)  # ipgen_loop_delay's: the commands on their way, oldest first
    if estimator is not None:
        estimator.reset()
    field = FIELD(_field_of(model)) if predict else None  # kept alive while C may call it back
    ahead, work = np.zeros(2 * dof), np.zeros(12 * dof)
    ts, xs, ys, hats, us, applied_ = [], [], [], [], [], []
    last_applied = 0.0
    fallen = False
    for k in range(steps + 1):
        x_user = p @ x + c
        if not np.all(np.isfinite(x_user)) or np.any(np.abs(x_user[1:dof] - x_eq[1:dof]) > FAIL_ANGLE):
            fallen = True
            break
        y = sensors.sample(x_user[:dof], rng)
        hat = x_user.copy() if estimator is None else estimator.step(y, last_applied)
        seen = hat
        if predict and delay > 0:  # a failed prediction (code 1) leaves ahead = the estimate
            estimate = np.ascontiguousarray(hat, dtype=float)
            run.ipgen_loop_predict(field, None, 2 * dof, period, 1.0, delay, address(pending),
                                   address(estimate), address(ahead), address(work))  # fmt: skip
            seen = ahead
        u = -float(k_row @ (seen - x_eq))
        if saturation is not None:
            u = run.ipgen_loop_saturate(u, saturation)
        applied = run.ipgen_loop_delay(address(pending), delay, u)
        ts.append(k * period)
        xs.append(x_user)
        ys.append(y)
        hats.append(hat)
        us.append(u)
        applied_.append(applied)
        last_applied = applied
        if k < steps:
            x = np.asarray(step(x, applied * model.input_gain), dtype=float).reshape(-1)
    return LoopRun(
        t=np.asarray(ts),
        x=np.asarray(xs),
        y=np.asarray(ys),
        estimate=np.asarray(hats),
        u=np.asarray(us),
        applied=np.asarray(applied_),
        fallen=fallen,
        equilibrium=x_eq,
    )
