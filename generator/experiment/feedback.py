"""The feedback of a scene's [controller]: its LQR gain (`control.lqr`) or the gain it gives, in
the scene's coordinates and units of u (the table's keys and rules: `scene.controller`)."""

from __future__ import annotations

from typing import Any

from ipgen.control.controller import Controller, MpcDesign
from ipgen.model.fixed import FixedPendulum
from ipgen.model.pendulum import Pendulum


class GainError(Exception):
    """No LQR gain for this scene (the message says why)."""


def controller(table: Any, p: Pendulum) -> Controller:
    """The controller of a validated [controller] table for the scene's pendulum `p`, with its LQR
    gain or the gain it gives (raises `GainError`).

    In the rig's coordinates (`p.coordinates`) the weights, an equilibrium given as angles, the
    gain and the equilibrium returned are in them; "upright" and "hanging" name the same physical
    state in any convention (its angles there follow the map, docs/model.md). K is in the units
    of u (`p.actuator`: volts for a dc_motor, m/s² or rad/s² for an acceleration input)."""
    import numpy as np

    from ipgen.control.linear import equilibrium_state

    if table.kind == "mpc":
        return _mpc(table, p)
    frame = p.coordinates
    gain = table.gain if table.kind == "gain" else _lqr_gain(table, p)
    x_eq = equilibrium_state(p.links, table.equilibrium)  # angles as written: the rig's
    if isinstance(table.equilibrium, str) and not frame.is_canonical:
        x_eq = frame.to_user(x_eq, p.links)  # a named state, mapped
    return Controller(
        kind=table.kind,
        gain=tuple(float(k) for k in np.ravel(gain)),  # K is 1 x 2(n+1)
        equilibrium=tuple(float(x) for x in x_eq),
        saturation=None if table.saturation is None else float(table.saturation),
        period=None if table.period is None else float(table.period),
        unit=_unit(p),
    )


def _lqr_gain(table: Any, p: Pendulum) -> Any:
    """K by `control.lqr` from the table's weights (default: identity)."""
    from ipgen.control.linear import ControlError, lqr

    weights = table.q if table.q is not None else [1.0] * (2 * p.dof)
    try:
        return lqr(p, weights, float(table.r), equilibrium=table.equilibrium)
    except ControlError as exc:
        raise GainError(f"controller: no LQR gain: {exc}") from None


def _unit(p: Pendulum) -> str:
    """What u is when it is not the force or torque ("" then)."""
    if p.actuator.is_motor:
        return "motor voltage [V]"
    if p.actuator.is_acceleration:
        return "base acceleration [rad/s^2]" if p.is_rotary else "base acceleration [m/s^2]"
    return ""


def _mpc(table: Any, p: Pendulum | FixedPendulum) -> Controller:
    """kind = "mpc": the problem resolved (`MpcDesign`) by `ipgen.mpc` on `p` (its defaults: the
    terminal weight P the discrete LQR's Riccati matrix, the budgets of the mode). A fixed chain's
    table (pipeline/fixed_mpc.py) has the same attributes; its gain and equilibrium are returned
    in ipgen's coordinates (fixed_mpc maps the gain)."""
    import numpy as np

    from ipgen.control import mpc as mpc_module
    from ipgen.control.linear import ControlError
    from ipgen.scene import controller as rules

    nx = 2 * p.dof
    soft = {i: (lo, hi) for i, lo, hi in table.soft_bounds or ()}
    penalty = table.soft_penalty if table.soft_penalty is not None else rules.DEFAULT_SOFT_PENALTY
    stage, terminal, reference = np.eye(nx) if table.q is None else table.q, table.p, table.equilibrium
    fixed = isinstance(p, FixedPendulum)
    frame = p.coordinates
    try:
        if not frame.is_canonical:  # the problem in ipgen's coordinates, which the MPC step takes
            stage, terminal, reference, soft = _mpc_in_ipgen_coordinates(p, stage, terminal, reference, soft)
        design = mpc_module.mpc(
            p, horizon=table.horizon or rules.DEFAULT_HORIZON, period=float(table.period),
            Q=stage, R=float(table.r), P=terminal,
            u_max=float(table.u_max), travel=None if table.travel is None else float(table.travel),
            soft_bounds=soft or None, soft_penalty=tuple(penalty), reference=reference,
            substeps=table.substeps or 1, mode=table.mode or "rti", sqp_iterations=table.iterations,
            qp_iterations=table.qp_iterations, barrier=float(table.barrier or 0.0),
            sensitivities=table.sensitivities or "exact",
        )  # fmt: skip
    except (mpc_module.MpcError, ControlError) as exc:  # ControlError: the weights' checks (lqr's)
        raise GainError(f"controller: no MPC: {exc}") from None
    _, a, b = design.rk4(design.x_ref, 0.0)
    gain = np.linalg.solve(design.R + b.T @ design.P @ b, b.T @ design.P @ a)  # the discrete LQR's K
    x_ref = design.x_ref
    if not (frame.is_canonical or fixed):  # the gain and equilibrium the scene states: the rig's
        matrix, _ = frame.matrices(p.links)
        gain, x_ref = gain @ np.linalg.inv(matrix), frame.to_user(x_ref, p.links)

    def flat(matrix: Any) -> tuple[float, ...]:
        return tuple(float(v) for v in np.ravel(matrix))

    resolved = MpcDesign(
        horizon=design.N, substeps=design.substeps, Q=flat(design.Q), R=float(design.R[0, 0]),
        P=flat(design.P),
        reference=flat(design.x_ref), u_min=design.u_min, u_max=design.u_max, bounds=tuple(design.hard),
        soft_bounds=tuple(design.soft), soft_penalty=design.soft_penalty, mode=design.mode,
        sqp_iterations=design.sqp_iterations, cold_iterations=design.cold_iterations,
        qp_iterations=design.qp_iterations, sqp_tolerance=float(design.sqp_tolerance),
        qp_tolerance=float(design.qp_tolerance),
        params=_model_params(p),
        input_gain=1.0 if fixed else float(p.gain), barrier=design.barrier,
        sensitivities=design.sensitivities,
    )  # fmt: skip
    return Controller(
        kind="mpc", gain=flat(gain), equilibrium=flat(x_ref), saturation=design.u_max,
        period=float(table.period), unit="" if fixed else _unit(p), mpc=resolved,
    )  # fmt: skip


def _model_params(p: Pendulum | FixedPendulum) -> tuple[tuple[str, tuple[float, ...] | float], ...]:
    """The parameters the MPC predicts with, by the names of the C header's structs: a cart's or
    an arm's with a motor folded in (`Pendulum.folded().params()`), a fixed chain's m, l, delta,
    g, Ir, gr (one per input), com and J (the rods' where not given)."""
    if isinstance(p, FixedPendulum):
        groups: dict[str, object] = {"m": p.m, "l": p.l, "delta": p.delta, "g": p.g}
        groups |= {name: p.motor(name) for name in ("Ir", "gr")}
        groups |= {name: p.resolved(name) for name in ("com", "J")}
    else:
        groups = dict(p.folded().params())
    return tuple(
        (name, tuple(float(v) for v in value) if isinstance(value, tuple | list) else float(value))  # type: ignore[arg-type]
        for name, value in groups.items()
    )


def _mpc_in_ipgen_coordinates(
    p: Pendulum | FixedPendulum,
    stage: Any,
    terminal: Any,
    reference: Any,
    soft: dict[int, tuple[float, float]],
) -> tuple[Any, Any, Any, dict[int, tuple[float, float]]]:
    """The MPC's weights, reference and soft bounds given in the rig's coordinates (x_user = P x + c,
    `Coordinates.matrices`) in ipgen's, where its step works: Q and a terminal P as Pᵀ Q P, an
    equilibrium given as angles mapped ("upright", "hanging": the same physical state), a bound
    on one coordinate mapped when that coordinate is one of ipgen's times ±1 plus a constant (the
    base, or a link in absolute angles); a bound on a relative angle is refused (it bounds a
    difference of two of ipgen's coordinates, not one)."""
    import numpy as np

    from ipgen.control.linear import checked_vector, weights

    dof = p.dof
    if isinstance(p, FixedPendulum):
        from ipgen.model.fixed_equations import state_map

        matrix, offset = state_map(p.coordinates, p.links)
    else:
        matrix, offset = p.coordinates.matrices(p.links)
    q, _ = weights(stage, 1.0, 2 * dof)
    stage = matrix.T @ q @ matrix
    if terminal is not None:  # 2 dof weights or a matrix, as Q
        terminal = matrix.T @ weights(terminal, 1.0, 2 * dof)[0] @ matrix
    if reference is not None and not isinstance(reference, str):
        angles = checked_vector(
            "equilibrium", reference, dof, "the angles (θ0 and one per link; fixed: one per link)"
        )
        reference = np.linalg.solve(matrix, np.concatenate([angles, np.zeros(dof)]) - offset)
    mapped = {}
    for index, (low, high) in soft.items():
        row = matrix[index]
        if np.count_nonzero(row) != 1:
            raise GainError(
                f"controller: soft_bounds on coordinate {index} bound a relative angle or its rate (angles = "
                '"relative"): the MPC bounds single coordinates of ipgen\'s; bound link 1 or the base, '
                "or use absolute angles"
            )
        sign = float(row[index])  # user = sign · x + offset
        ends = sorted(((low - offset[index]) / sign, (high - offset[index]) / sign))
        mapped[index] = (ends[0], ends[1])
    return stage, terminal, reference, mapped
