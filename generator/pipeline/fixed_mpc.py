"""A fixed scene's `[controller] kind = "mpc"` for `ipgen run` (docs/mpc.md, "On a fixed pivot"):
its keys checked in one line each, resolved by `experiment.feedback` as a cart's (`ipgen.mpc` on
the chain, the problem mapped to ipgen's coordinates), and `[swingup] tracking`."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ipgen.common import limits
from ipgen.model.fixed import FixedPendulum
from ipgen.pipeline.fixed_fields import FixedController, controller_period, numbers, scalar, weight_matrix
from ipgen.scene import controller as rules
from ipgen.scene.fields import Reader

# kind = "mpc" (docs/mpc.md): the cart's and arm's keys but travel (a fixed chain has no base)
MPC_KEYS: tuple[str, ...] = (
    "horizon", "p", "u_max", "soft_bounds", "soft_penalty", "mode", "iterations", "qp_iterations", "substeps",
    "barrier", "sensitivities",
)  # fmt: skip


@dataclass(frozen=True)
class _MpcTable:
    """A fixed scene's [controller] kind = "mpc", checked: the attributes `experiment.feedback`
    reads from a cart's or arm's validated table (no travel: a fixed chain has no base)."""

    period: float
    u_max: float
    q: Any = None
    r: float = 1.0
    p: Any = None
    equilibrium: Any = "upright"
    horizon: int | None = None
    substeps: int | None = None
    soft_bounds: tuple[tuple[int, float, float], ...] | None = None
    soft_penalty: tuple[float, float] | None = None
    mode: str | None = None
    iterations: int | None = None
    qp_iterations: int | None = None
    barrier: float | None = None
    sensitivities: str | None = None
    travel: None = None
    kind: str = "mpc"


def fixed_mpc(reader: Reader, table: Any, chain: FixedPendulum, settings: dict[str, Any]) -> FixedController:
    """[controller] kind = "mpc" of a fixed chain (one driven joint): the problem of `ipgen.mpc`,
    its weights, equilibrium and soft bounds in the chain's coordinates (mapped to ipgen's, where
    the step works, by `experiment.feedback`); u_max [N m] and period [s] required."""
    from ipgen.control.fixed_linear import fixed_equilibrium
    from ipgen.control.linear import ControlError
    from ipgen.experiment.feedback import GainError, controller
    from ipgen.model.fixed_equations import state_map

    n = chain.links
    if chain.inputs != 1:
        reader.fail(
            f'controller.kind = "mpc" drives one joint; this chain drives {chain.inputs} ({chain.joints})'
        )
    for key in ("saturation", "gain"):
        if key in table:
            reader.fail(
                f'controller.{key}: kind = "mpc" bounds u by u_max and computes its input (remove {key})'
            )
    for key in ("period", "u_max"):
        if key not in table:
            reader.fail(
                f"missing required key 'controller.{key}' "
                '(kind = "mpc": the sample period [s], |u| <= u_max [N m])'
            )
    period = controller_period(reader, table, settings)
    assert period is not None
    u_max = float(numbers(reader, "controller.u_max", table["u_max"], (1,), "a number > 0 [N m]")[0])
    if u_max <= 0:
        reader.bad("controller.u_max", table["u_max"], "expected a number > 0 [N m]")

    def whole(key: str, low: int, high: int) -> int | None:
        if key not in table:
            return None
        value = table[key]
        if isinstance(value, bool) or not isinstance(value, int) or not low <= value <= high:
            reader.bad(f"controller.{key}", value, f"expected an integer in {low}..{high}")
        return int(value)

    def weights(key: str) -> Any:
        return None if key not in table else weight_matrix(reader, f"controller.{key}", table[key], 2 * n)

    soft = None
    if "soft_bounds" in table:
        rows = table["soft_bounds"]
        what = f"[[index, min, max], ...]: index 0..{2 * n - 1} (θ1.. then θ̇1..), min < max"
        if not isinstance(rows, list) or not rows:
            reader.bad("controller.soft_bounds", rows, what)
        soft = []
        for row in rows:
            values = numbers(reader, "controller.soft_bounds", row, (3,), what)
            if values[0] != round(values[0]) or not 0 <= values[0] < 2 * n or values[1] >= values[2]:
                reader.bad("controller.soft_bounds", row, what)
            if any(index == int(values[0]) for index, _, _ in soft):
                reader.bad("controller.soft_bounds", rows, f"{what}; each state index may be bounded once")
            soft.append((int(values[0]), float(values[1]), float(values[2])))
    penalty = None
    if "soft_penalty" in table:
        top = limits.MAX_SOFT_PENALTY
        what = f"[rho1, rho2]: 0 <= rho1 <= {top:g}, 0 < rho2 <= {top:g}"
        values = numbers(reader, "controller.soft_penalty", table["soft_penalty"], (2,), what)
        if not (0 <= values[0] <= top and 0 < values[1] <= top):
            reader.bad("controller.soft_penalty", table["soft_penalty"], what)
        if soft is None:
            reader.fail(f"controller.soft_penalty {rules.PENALTY_WITHOUT_BOUNDS}")
        penalty = (float(values[0]), float(values[1]))
    mode = table.get("mode")
    if mode is not None and mode not in ("rti", "converged"):
        reader.bad("controller.mode", mode, 'expected "rti" or "converged"')
    barrier = None
    if "barrier" in table:
        what = f"a weight >= 0 and <= {limits.MAX_MPC_BARRIER:g} (0: the interior point)"
        barrier = scalar(reader, "controller.barrier", table["barrier"], what)
        if not 0 <= barrier <= limits.MAX_MPC_BARRIER:
            reader.bad("controller.barrier", table["barrier"], f"expected {what}")
    sensitivities = table.get("sensitivities")
    if sensitivities is not None and sensitivities not in rules.MPC_SENSITIVITIES:
        reader.bad("controller.sensitivities", sensitivities, 'expected "exact", "frozen" or "shifted"')
    r = float(numbers(reader, "controller.r", table.get("r", 1.0), (1,), "one weight > 0")[0])
    if r <= 0:
        reader.bad("controller.r", table["r"], "expected one weight > 0")
    try:
        equilibrium = fixed_equilibrium(chain, table.get("equilibrium"))  # checked: links upright or hanging
        given = table.get("equilibrium", "upright")
        checked = _MpcTable(
            period=period, u_max=u_max, q=weights("q"), r=r, p=weights("p"),
            equilibrium=given if isinstance(given, str) else [float(v) for v in equilibrium],
            horizon=whole("horizon", 1, rules.MAX_HORIZON),
            substeps=whole("substeps", 1, rules.MAX_SUBSTEPS),
            soft_bounds=tuple(soft) if soft else None, soft_penalty=penalty, mode=mode,
            iterations=whole("iterations", 1, rules.MAX_ITERATIONS),
            qp_iterations=whole("qp_iterations", 1, rules.MAX_ITERATIONS), barrier=barrier,
            sensitivities=sensitivities,
        )  # fmt: skip
        resolved = controller(checked, chain)
    except (ControlError, GainError) as exc:
        reader.fail(f"[controller]: {exc}")
    state = np.concatenate([equilibrium, np.zeros(n)])
    # K: the discrete LQR's at the reference (what the unconstrained MPC is near it), as the
    # dataclass holds it: in the chain's coordinates and its input's sense (u_rig = sign u)
    matrix, _ = state_map(chain.coordinates, n)
    sign = -1.0 if chain.positive == "counterclockwise" else 1.0
    gain = sign * np.asarray(resolved.gain).reshape(1, 2 * n) @ np.linalg.inv(matrix)
    return FixedController("mpc", gain, state, (u_max,), period, resolved.mpc)


def swingup_tracking(reader: Reader, table: Any, controller: FixedController | None) -> str:
    """swingup.tracking: "lqr" (the plan's time-varying LQR, the default) or "mpc" (the [controller]
    kind = "mpc" tracks the plan, its reference per stage); with an MPC either way it holds."""
    tracking = table.get("tracking", "lqr")
    if tracking not in ("lqr", "mpc"):
        reader.bad("swingup.tracking", tracking, 'expected "lqr" or "mpc"')
    if tracking == "mpc" and (controller is None or controller.mpc is None):
        reader.fail(
            'swingup.tracking = "mpc" needs a [controller] of kind = "mpc" (the MPC that tracks the plan)'
        )
    return str(tracking)
