"""The resolved config: the flat `key = value` text the C++ simulator reads (cpp/src/simulate.cpp,
parsed by cpp/include/ipsim/scene.hpp), written from a `Scene`.

`CFG_KEYS` is the one list of its keys: the writer writes no other (`_Lines.put` refuses one
not in it), the simulator's key table and value rules are generated from it and the scene schema
(`ipgen.pipeline.cfg_rules` -> cpp/include/ipsim/cfg_rules.hpp), and tests/test_scene_config.py
checks that simulate.cpp's help names no other. Numbers are written so that they read back
exactly (`format_number`), lists space-separated, one key a line, deterministic.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from ipgen.common.presets import scene_source
from ipgen.common.version import __version__
from ipgen.model.links import rod_value
from ipgen.scene.fields import format_number

if TYPE_CHECKING:
    from ipgen.control.controller import Controller, MpcDesign
    from ipgen.control.swingup import SwingUpLaw
    from ipgen.experiment.loop import Loop
    from ipgen.experiment.scene import Scene
    from ipgen.model.coordinates import Coordinates

# Every key of a resolved config, in the order written, and what it holds (lists: per coordinate,
# base first; a state x = θ0..θn then θ̇0..θ̇n).
CFG_KEYS: dict[str, str] = {
    "name": "the scene file's stem",
    "model": "the model (header) name the simulator must be built for",
    "type": "classical | rotary | fixed",
    "links": "the number of links",
    "inertia": "pivot | full",
    "joints": "fixed: the driven joints, one input each (1 = the shoulder)",
    "Ir": "fixed: each input's rotor inertia [kg m^2]",
    "gr": "fixed: each input's gear ratio",
    "angles": "absolute | relative: the rig's link angles (absent: ipgen's)",
    "zero": "upright | hanging: where a link angle is 0",
    "positive": "clockwise | counterclockwise",
    "m": "masses [kg] (with a dc_motor: the motor-folded ones)",
    "l": "lengths [m]",
    "delta": "viscous damping [kg/s or N m s]",
    "g": "gravity [m/s^2]",
    "com": "pivot-to-CoG distances [m]",
    "J": "inertias about the CoG [kg m^2]",
    "J_axial": "inertias about the link axis [kg m^2]",
    "tip": "tip masses [kg]",
    "actuator": "dc_motor | acceleration (absent: direct)",
    "actuator.gain": "dc_motor: force or torque per volt [N/V or N m/V]",
    "coulomb": "Coulomb friction [N or N m]",
    "coulomb_speed": "the tanh law's rate [m/s or rad/s]",
    "coulomb_law": "fixed: tanh | atan (DFKI's c atan(k w); absent: tanh)",
    "coulomb_gain": "fixed: the atan law's k [s/rad]",
    "theta": "initial angles [rad] (the base: [m] or [rad])",
    "dtheta": "initial rates",
    "input": "zero | constant | pulse | step | sine | chirp | multisine",
    **{
        f"input.{key}": "the [input] key of that kind"
        for key in "amplitude start duration time frequency phase f0 f1 sweep f_min f_max period".split()
    },
    "input.frequencies": "multisine: the lines [Hz]",
    "input.phases": "multisine: their phases [rad]",
    "input.scale": "multisine: u = amplitude scale sum cos(2 pi f t + phase)",
    "limits.travel": "|θ0| limit [m or rad]: the run stops beyond it (exit status 4)",
    "t_end": "simulated time [s]",
    "sample": "output interval [s]",
    "method": "integration method",
    "jacobian": "exact | dq (bdf, adams)",
    "step": "fixed step [s] (rk4)",
    "rtol": "relative tolerance",
    "atol": "absolute tolerance",
    "max_steps": "step limit between two samples",
    "energy": "true: the energy ledger columns",
    "controller": "lqr | gain | mpc",
    "controller.gain": "K of u = -K (x - x_eq)",
    "controller.equilibrium": "x_eq",
    "controller.saturation": "the largest |u|",
    "controller.period": "sampling period [s] (absent: continuous)",
    **{
        f"controller.{key}": f"mpc: {what}"
        for key, what in (
            ("horizon", "N, the samples predicted"),
            ("substeps", "RK4 steps a sample"),
            ("q", "the stage weight Q, row-major (ipgen's coordinates)"),
            ("r", "the weight R of u^2"),
            ("p", "the terminal weight P, row-major"),
            ("reference", "x_ref"),
            ("u_min", "the lower bound on u"),
            ("u_max", "the upper bound on u"),
            ("bounds", "hard state bounds: index min max, ..."),
            ("soft_bounds", "soft state bounds: index min max, ..."),
            ("soft_penalty", "rho1 rho2 of a soft bound's violation s: rho1 s + rho2 s^2"),
            ("mode", "rti | converged"),
            ("iterations", "SQP iterations a step at most"),
            ("cold_iterations", "SQP iterations at most on a cold start"),
            ("qp_iterations", "interior-point iterations a QP at most"),
            ("sqp_tolerance", "the SQP's stopping test (0: run the budget)"),
            ("qp_tolerance", "the QP's stopping test"),
            ("barrier", "> 0: the QP's fixed log-barrier weight (absent: the interior point)"),
            ("sensitivities", "exact | frozen | shifted (absent: exact)"),
        )
    },
    **{
        f"controller.model.{key}": f"mpc: the model it predicts with, {key} (absent: the scene's; "
        "a sweep's run keeps the nominal model, sweeps/design_model.py)"
        for key in ("m", "l", "delta", "g", "com", "J", "J_axial", "tip", "gain", "Ir", "gr")
    },
    "swingup": "energy | trajectory",
    **{
        f"swingup.{key}": "the swing-up law (control/swingup.py)"
        for key in (
            "u_max period hold hold_gain target gain_energy gain_position gain_velocity accel_max "
            "catch_angle catch_rate energy_target energy_inertia energy_weight release_angle energy_step "
            "catch_deficit catch_base "
            "steps inputs states gains tracking"
        ).split()
    },
    "actuator.noise": "σ of the noise on the applied input, held per sample interval (the drive)",
    "actuator.lag": "the drive's first-order time constant [s]",
    "actuator.pulses": "disturbance pulses on the base: start duration amplitude, ...",
    "sensors.measured": "the measured coordinates (indices of θ)",
    "sensors.resolution": "encoder counts per revolution or metre, per measured coordinate (0: exact)",
    "sensors.noise": "σ of the measurement noise per measured coordinate",
    "sensors.zero": "where the encoders read 0, per measured coordinate (default: the rig at rest)",
    "sensors.delay": "s from sampling to applying the output (k periods)",
    "sensors.seed": "the seed of the run's random streams",
    "estimator": "exact | difference | filter | kalman | ekf",
    "estimator.cutoff": "filter: ω_c [rad/s]",
    "estimator.equilibrium": "kalman, ekf: x_eq",
    "estimator.A": "kalman: A_d, row-major",
    "estimator.B": "kalman: B_d",
    "estimator.gain": "kalman: the current-form gain M, row-major",
    "estimator.input": "kalman: u_eq",
    "estimator.process_noise": "ekf: Qn, row-major",
    "estimator.measurement_noise": "ekf: Rn, row-major",
    "estimator.delay": "s: the delay the loop is built for (estimator, prediction); absent: sensors.delay",
    "estimator.predict": "1: the law sees the estimate carried over the delay (ipgen_loop_predict)",
    "estimator.compensate_lag": "1: the loop is built for actuator.lag (lagged inputs, the lag's inverse)",
    "estimator.lag": "s: with compensate_lag, the lag the loop is built for; absent: actuator.lag",
    "estimator.gain_spread": "ekf: > 0, the input gain is learnt (rho's prior σ; the swing-up's u ÷ rho)",
    "estimator.gain_drift": "ekf with gain_spread: rho's random walk, σ's growth per √s",
    "estimator.noise_memory": "ekf: > 0, each measured coordinate's noise variance learnt over it [s]",
    "estimator.noise_margin": "ekf with noise_memory: the multiple of the learnt variance the filter uses",
    "estimator.noise_floor": "ekf with noise_memory: the lowest variance used, per measured",
    "estimator.noise_ceiling": "ekf with noise_memory: the highest variance used, per measured",
}


class _Lines(list[str]):
    """The config's lines; `put` writes one key (of `CFG_KEYS`) with its value."""

    def put(self, key: str, value: object) -> None:
        if key not in CFG_KEYS:
            raise KeyError(f"{key!r} is not a key of the resolved config (CFG_KEYS)")
        self.append(f"{key} = {_text(value)}")


def _text(value: object) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return format_number(value)
    if isinstance(value, tuple | list):
        return " ".join(format_number(item) for item in value)
    return str(value)


def resolved_config(scene: Scene, model: str | None = None) -> str:
    """The flat `key = value` text the C++ simulator reads (deterministic, numbers exact); `model`:
    the model (header) name the simulator is built for, default the scene's name."""
    lines = _Lines(
        [f"# Generated by ipgen {__version__} from {scene_source(scene.path)}; do not edit"]
    )
    for key, value in (
        ("name", scene.stem),
        ("model", scene.name if model is None else model),
        ("type", scene.type),
        ("links", scene.links),
        ("inertia", scene.inertia),
    ):
        lines.put(key, value)
    _coordinates(lines, scene.coordinates)
    _parameters(lines, scene)
    lines.put("theta", scene.theta)
    lines.put("dtheta", scene.dtheta)
    lines.put("input", scene.input.kind)
    for key, value in scene.input.fields():
        lines.put(f"input.{key}", value)
    if scene.input.kind == "multisine":  # the lines the simulator sums (control/signals.py)
        lines.put("input.frequencies", scene.input.lines.frequencies)
        lines.put("input.phases", scene.input.lines.phases)
        lines.put("input.scale", scene.input.lines.scale)
    if scene.travel is not None:
        lines.put("limits.travel", scene.travel)
    lines.put("t_end", scene.t_end)
    lines.put("sample", scene.sample)
    lines.put("method", scene.method)
    if scene.jacobian is not None:
        lines.put("jacobian", scene.jacobian)
    if scene.step is not None:
        lines.put("step", scene.step)
    lines.put("rtol", scene.rtol)
    lines.put("atol", scene.atol)
    lines.put("max_steps", scene.max_steps)
    if scene.energy:
        lines.put("energy", True)
    _controller(lines, scene.controller)
    _swingup(lines, scene.swingup)
    _loop(lines, scene.loop)
    return "\n".join(lines) + "\n"


def _coordinates(lines: _Lines, coordinates: Coordinates) -> None:
    """The rig's convention, when it is not ipgen's (nothing otherwise: the file is as before)."""
    if coordinates.is_canonical:
        return
    lines += [
        "# the rig's coordinates (docs/model.md): theta, dtheta, controller.* and the CSV's columns are in",
        "# them; the simulator integrates in ipgen's and maps at the edges (swingup.* are ipgen's)",
    ]
    lines.put("angles", coordinates.angles)
    lines.put("zero", coordinates.zero)
    lines.put("positive", coordinates.positive)


def _parameters(lines: _Lines, scene: Scene) -> None:
    """m, l, delta, g and the links as built; with a dc_motor the equivalent direct model's
    (`actuator.fold`: δ0 + back-EMF damping, m0 or J0 + the rotor's reflected inertia) and
    `actuator.gain`, the force or torque per volt the simulator multiplies u by."""
    m, delta, built, gain = motor_folded_parameters(scene)
    lines.put("m", m)
    lines.put("l", scene.l)
    lines.put("delta", delta)
    lines.put("g", scene.g)
    for group in ("com", "J", "J_axial", "tip"):
        if group in built:
            lines.put(group, built[group])
    motor = scene.actuator
    if motor.is_motor:
        lines += [
            "# [actuator] dc_motor, folded into the direct model (docs/model.md): u is the voltage [V],",
            f"# Rm {motor.Rm!r}, kt {motor.kt!r}, km {motor.km!r}, Kg {motor.Kg!r}, eta_g {motor.eta_g!r}, "
            f"eta_m {motor.eta_m!r}, Jm {motor.Jm!r}, r {motor.r!r}",
        ]
        lines.put("actuator", "dc_motor")
        lines.put("actuator.gain", gain)
    if motor.is_acceleration:
        lines.append(
            "# [actuator] acceleration (docs/model.md): u is the base's acceleration; the links follow"
        )
        lines.put("actuator", "acceleration")
    if scene.coulomb is not None:
        lines.put("coulomb", scene.coulomb)
        lines.put("coulomb_speed", scene.coulomb_speed)


def _swingup(lines: _Lines, law: SwingUpLaw | None) -> None:
    """The swing-up for the simulator: method, limits, hold LQR, and the energy law's constants
    or the plan's inputs, states and gain schedule (one long line each)."""
    if law is None:
        return
    lines.put("swingup", law.method)
    for key in ("u_max", "period", "hold", "hold_gain", "target"):
        lines.put(f"swingup.{key}", getattr(law, key))
    for name, value in law.energy:
        lines.put(f"swingup.{name}", value)
    if law.release_angle > 0:  # absent: the hold is for good (the .cfg of a scene without it unchanged)
        lines.put("swingup.release_angle", law.release_angle)
    if law.method == "trajectory":
        for key in ("steps", "inputs", "states", "gains"):
            lines.put(f"swingup.{key}", getattr(law, key))
        if law.tracking != "lqr":  # absent: the gains track (the .cfg of a scene without it unchanged)
            lines.put("swingup.tracking", law.tracking)


def _controller(lines: _Lines, controller: Controller | None) -> None:
    """u = −K (x − x_eq) for the simulator: kind, gain, equilibrium, and saturation and period if set."""
    if controller is None:
        return
    lines.put("controller", controller.kind)
    if controller.mpc is not None:
        _mpc(lines, controller)
        return
    lines.put("controller.gain", controller.gain)
    lines.put("controller.equilibrium", controller.equilibrium)
    if controller.saturation is not None:
        lines.put("controller.saturation", controller.saturation)
    if controller.period is not None:
        lines.put("controller.period", controller.period)


def _mpc(lines: _Lines, controller: Controller) -> None:
    """kind = "mpc": the problem, resolved (`MpcDesign`), in ipgen's coordinates and the unit of u."""
    assert controller.mpc is not None and controller.period is not None
    for key, value in mpc_entries(controller.period, controller.mpc):
        lines.put(key, value)


def mpc_entries(period: float, design: MpcDesign) -> list[tuple[str, Any]]:
    """The .cfg's controller.* keys of an MPC (after `controller = mpc`), in their order: what
    ipsim's MpcProblem reads (cpp/include/ipsim/scene.hpp, load_mpc)."""
    entries: list[tuple[str, Any]] = [("controller.period", period)]
    entries += [
        ("controller.horizon", design.horizon), ("controller.substeps", design.substeps),
        ("controller.q", design.Q), ("controller.r", design.R), ("controller.p", design.P),
        ("controller.reference", design.reference), ("controller.u_min", design.u_min),
        ("controller.u_max", design.u_max),
    ]  # fmt: skip
    for key, bounds in (("bounds", design.bounds), ("soft_bounds", design.soft_bounds)):
        if bounds:
            entries.append((f"controller.{key}", [float(v) for bound in bounds for v in bound]))
    if design.soft_bounds:
        entries.append(("controller.soft_penalty", design.soft_penalty))
    entries += [
        ("controller.mode", design.mode), ("controller.iterations", design.sqp_iterations),
        ("controller.cold_iterations", design.cold_iterations),
        ("controller.qp_iterations", design.qp_iterations),
        ("controller.sqp_tolerance", design.sqp_tolerance), ("controller.qp_tolerance", design.qp_tolerance),
    ]  # fmt: skip
    # the method, written only when not the default: every existing scene's config stays as it was
    if design.barrier > 0:
        entries.append(("controller.barrier", design.barrier))
    if design.sensitivities != "exact":
        entries.append(("controller.sensitivities", design.sensitivities))
    return entries


def _loop(lines: _Lines, loop_: Loop | None) -> None:
    """The measured loop's keys for the simulator (none without one: the config is as before)."""
    from ipgen.estimation.measurement import grid_zero

    if loop_ is None:
        return

    def numbers(values: Any) -> str:
        return " ".join(format_number(float(v)) for v in values)

    def matrix(rows: Any) -> str:
        return " ".join(numbers(row) for row in rows)

    if loop_.drive_noise > 0:
        lines.put("actuator.noise", loop_.drive_noise)
    if loop_.lag > 0:
        lines.put("actuator.lag", loop_.lag)
    if loop_.pulses:
        lines.put("actuator.pulses", matrix(loop_.pulses))
    sensors, estimator = loop_.sensors, loop_.estimator
    if sensors is None:
        return
    lines.put("sensors.measured", " ".join(str(i) for i in sensors.measured))
    lines.put("sensors.resolution", numbers(sensors.resolution))
    lines.put("sensors.noise", numbers(sensors.noise))
    offsets = [grid_zero(z, step) for z, step in zip(sensors.zero, sensors.steps(), strict=True)]
    if any(offsets):  # a zero pose off the grid counted from 0 (else the same numbers without it)
        lines.put("sensors.zero", numbers(offsets))
    lines.put("sensors.delay", loop_.delay)
    lines.put("sensors.seed", loop_.seed)
    lines.put("estimator", estimator.kind)
    if estimator.cutoff is not None:
        lines.put("estimator.cutoff", estimator.cutoff)
    if estimator.kind in ("kalman", "ekf"):
        lines.put("estimator.equilibrium", numbers(estimator.equilibrium))
    if estimator.kind == "kalman":
        lines.put("estimator.A", matrix(estimator.A))
        lines.put("estimator.B", numbers(estimator.B))
        lines.put("estimator.gain", matrix(estimator.gain))
        lines.put("estimator.input", estimator.input_equilibrium)
    if estimator.kind == "ekf":
        lines.put("estimator.process_noise", matrix(estimator.process_noise))
        lines.put("estimator.measurement_noise", matrix(estimator.measurement_noise))
    if loop_.assumed_delay is not None:
        lines.put("estimator.delay", loop_.assumed_delay)
    if estimator.predict:
        lines.put("estimator.predict", 1)
    if estimator.compensate_lag:  # absent otherwise: the .cfg of a scene without it unchanged
        lines.put("estimator.compensate_lag", 1)
    if estimator.compensate_lag and estimator.lag is not None:
        lines.put("estimator.lag", estimator.lag)
    if estimator.gain_spread > 0:  # absent otherwise: the .cfg of a scene without it unchanged
        lines.put("estimator.gain_spread", estimator.gain_spread)
        lines.put("estimator.gain_drift", estimator.gain_drift)
    if estimator.noise_memory > 0:  # absent otherwise: the .cfg of a scene without it unchanged
        lines.put("estimator.noise_memory", estimator.noise_memory)
        lines.put("estimator.noise_margin", estimator.noise_margin)
        lines.put("estimator.noise_floor", numbers(estimator.noise_floor))
        lines.put("estimator.noise_ceiling", numbers(estimator.noise_ceiling))


def motor_folded_parameters(
    scene: Scene,
) -> tuple[tuple[float, ...], tuple[float, ...], dict[str, tuple[float, ...]], float]:
    """(m, delta, links as built, b) the simulator integrates: the scene's own, or with a
    dc_motor the equivalent direct model's (`actuator.fold`: δ0 + back-EMF damping, m0 or J0 +
    the rotor's reflected inertia, rounded once from `Scene.motor_folded`) and its force or
    torque per volt b."""
    m, delta, built = scene.m, scene.delta, dict(scene.links_as_built)
    if not scene.actuator.is_motor:
        return m, delta, built, 1.0
    folded = scene.pendulum.folded()  # the floats; the base's entries rounded once from exact
    m_, delta_, gain = list(folded.m), list(folded.delta), scene.actuator.gain()
    exact = scene.motor_folded()  # the same values, rounded once (a specialised header folds them)
    delta_[0] = float(exact["delta0"])
    j_ = None if folded.J is None else list(folded.J)
    if j_ is not None and "J" not in dict(scene.links_as_built):  # the rods' J1..Jn, as a specialised
        j_[1:] = [_rod_inertia(scene, i) for i in range(1, len(j_))]  # header folds them
    if j_ is not None and scene.system.is_rotary:
        j_[0] = float(exact["J0"])
    if not scene.system.is_rotary:
        m_[0] = float(exact["m0"])
    if j_ is not None:
        built["J"] = tuple(j_)
    return tuple(m_), tuple(delta_), built, gain


def _rod_inertia(scene: Scene, i: int) -> float:
    """The rod's J[i] from the decimals written, rounded once: what a specialised header folds
    (`specialisation._rod_links`), so that the simulator's check of it agrees to the last bit
    (float products differ in the last bit, e.g. J1 of scenes/rsip_pulse.toml)."""
    exact = [scene.exact(f"{group}{i}") for group in ("m", "l")]
    m, l = [0.0] * i + [exact[0]], [0.0] * i + [exact[1]]  # noqa: E741
    try:
        return float(rod_value(scene.system, "J", i, m, l))
    except OverflowError:  # beyond the doubles: what the float products give (inf)
        return rod_value(scene.system, "J", i, scene.m, scene.l)
