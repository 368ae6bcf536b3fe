"""Renders the C99 header of one model (`--emit c`, templates/model.h.jinja).

The same equations, specialisation and common-subexpression elimination as the C++ header
(`header.py`), printed in C (`functions.C_SYNTAX`): `static inline` functions over plain arrays
(matrices row-major), the scalar type the macro `IPGEN_SCALAR` (double unless defined as float
before the include), constants cast to it and sin/cos chosen by its size (sinf/cosf for float;
<math.h> only, as newlib's <tgmath.h> does not work in C99), so that float mode computes in
float only. Optionally the controller u = −K (x − x_eq) of a scene, or its swing-up (energy law,
or the plan and gain schedule as const tables), and its estimator and measured loop; the
algorithms of the swing-up, the estimators and the loop are cpp/include/ipgen_loop.h's (the loop
runtime, shared with the simulator and Python), printed whole into the header, which wraps them
with its constants.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from ipgen.codegen.functions import C_SYNTAX, FunctionBody
from ipgen.codegen.header import (
    HeaderRequest,
    environment,
    folded_entries,
    function_bodies,
    header_context,
    poly_keys,
)
from ipgen.codegen.motor import motor_functions
from ipgen.common.locations import loop_runtime, mpc_runtime
from ipgen.common.safetext import comment_safe
from ipgen.control.controller import Controller, MpcDesign
from ipgen.errors import Error
from ipgen.estimation.covariance import NOISE_CEILING
from ipgen.estimation.printed import PrintedEstimator
from ipgen.model.derivation import Equations
from ipgen.model.specialise import specialise

if TYPE_CHECKING:
    from ipgen.control.swingup import SwingUpLaw

TEMPLATE = "model.h.jinja"
# Functions whose outputs use θ̈, and the C array holding it once solved for.
_LATE = {"forward_dynamics_derivatives": "qdd"}


class ControllerError(Error, ValueError):
    """A controller that cannot be printed into the C header; the message names the entry."""


def c_number(value: float) -> str:
    """A finite double as a C constant of type IPGEN_SCALAR (exact in double: repr round-trips)."""
    return f"(IPGEN_SCALAR){float(value)!r}"


@dataclass(frozen=True)
class ControlTerm:
    """One term of u: `u -= gain*variable` (`operator` "-=") or `u += |gain|*variable`."""

    operator: str
    gain: str
    variable: str


def control_context(controller: Controller, dof: int) -> dict[str, object]:
    """The folded control law for the template: u = offset − Σ K_i x_i, offset = K x_eq."""
    size = 2 * dof
    for label, values in (("gain K", controller.gain), ("equilibrium x_eq", controller.equilibrium)):
        if len(values) != size:
            raise ControllerError(
                f"controller {label} has {len(values)} entries, expected {size} (2 x {dof} coordinates)"
            )
        for i, v in enumerate(values):
            if not isinstance(v, int | float) or not math.isfinite(v):
                raise ControllerError(f"controller {label}[{i}] = {v!r} is not a finite number")
    saturation = controller.saturation
    if saturation is not None and not (isinstance(saturation, int | float) and 0 < saturation < math.inf):
        raise ControllerError(
            f"controller saturation {saturation!r} must be a positive finite number or none"
        )
    period = controller.period
    if period is not None and not (isinstance(period, int | float) and 0 < period < math.inf):
        raise ControllerError(f"controller period {period!r} must be positive and finite, or none")
    terms = []
    for i, k in enumerate(controller.gain):
        if k == 0:
            continue
        variable = f"q[{i}]" if i < dof else f"qd[{i - dof}]"
        terms.append(ControlTerm("-=" if k > 0 else "+=", c_number(abs(k)), variable))
    try:
        offset = math.fsum(k * x for k, x in zip(controller.gain, controller.equilibrium, strict=True))
    except (OverflowError, ValueError):  # intermediate overflow, or inf − inf
        offset = math.inf
    if not math.isfinite(offset):
        raise ControllerError("controller K x_eq overflows a double: scale the gain or the equilibrium")
    return {
        "kind": comment_safe(controller.kind),
        "unit": comment_safe(controller.unit),
        "terms": terms,
        "unused": [a for a in ("q", "qd") if not any(t.variable.startswith(a + "[") for t in terms)],
        "offset": c_number(offset) if offset != 0 else "",
        "saturation": c_number(saturation) if saturation is not None else "",
        "saturation_value": repr(float(saturation)) if saturation is not None else "",
        "period": repr(float(period)) if period is not None else "",
        "gain": ", ".join(repr(float(k)) for k in controller.gain),
        "equilibrium": ", ".join(repr(float(x)) for x in controller.equilibrium),
    }


# The fields of a header's params and links structs in their order: the MPC's model printed as
# their initialisers (a cart's or an arm's model.h; a fixed chain's fixed.h).
Structs = tuple[tuple[str, ...], tuple[str, ...]]
CART_STRUCTS: Structs = (("m", "l", "delta", "g"), ("com", "J", "J_axial", "tip"))
FIXED_STRUCTS: Structs = (("m", "l", "delta", "g", "Ir", "gr"), ("com", "J"))


def mpc_context(
    design: MpcDesign,
    period: float,
    dof: int,
    functions: tuple[str, ...],
    structs: Structs = CART_STRUCTS,
    u_what: str | None = None,
) -> dict[str, object]:
    """The MPC of a scene (kind "mpc") for the template (mpc_step.h.jinja): its problem as
    constants and the model it predicts with (the design's parameters, a motor folded in, as
    the initialisers of the header's `structs`); the step is cpp/include/ipgen_mpc.h's, printed
    whole (`mpc_runtime`). `u_what` names u in the comments (default: a cart's or an arm's)."""
    missing = [f for f in ("forward_dynamics", "forward_dynamics_derivatives") if f not in functions]
    if missing:
        raise ControllerError(
            f"the MPC needs the header's {' and '.join(missing)}: add them to the scene's outputs"
        )
    if not design.params:
        raise ControllerError("this MPC design states no model parameters to print")
    size = 2 * dof
    params = dict(design.params)

    def initialiser(names: tuple[str, ...]) -> str:
        """A struct's initialiser: {array}, ... or a number, field by field."""
        return ", ".join(
            c_number(float(value)) if isinstance(value := params[n], float | int)
            else "{" + _c_list(tuple(value), f"MPC {n}") + "}"
            for n in names
        )  # fmt: skip

    def indices(bounds: tuple[tuple[int, float, float], ...]) -> str:
        return ", ".join(str(int(i)) for i, _, _ in bounds)

    hard, soft = design.bounds, design.soft_bounds
    motor = design.input_gain != 1.0
    return {
        "horizon": design.horizon,
        "substeps": design.substeps,
        "size": size,
        "period": c_number(period),
        "period_value": repr(float(period)),
        "Q": _c_list(design.Q, "MPC Q"),
        "R": _c_list((design.R,), "MPC R"),
        "P": _c_list(design.P, "MPC P"),
        "reference": _c_list(design.reference, "MPC reference"),
        "u_min": c_number(design.u_min),
        "u_max": c_number(design.u_max),
        "u_min_value": repr(design.u_min),
        "u_max_value": repr(design.u_max),
        "hard": len(hard),
        "hard_index": indices(hard),
        "hard_min": _c_list(tuple(b[1] for b in hard), "MPC bounds"),
        "hard_max": _c_list(tuple(b[2] for b in hard), "MPC bounds"),
        "soft": len(soft),
        "soft_index": indices(soft),
        "soft_min": _c_list(tuple(b[1] for b in soft), "MPC soft bounds"),
        "soft_max": _c_list(tuple(b[2] for b in soft), "MPC soft bounds"),
        "soft_linear": _c_list((design.soft_penalty[0],) * len(soft), "MPC soft penalty"),
        "soft_quadratic": _c_list((design.soft_penalty[1],) * len(soft), "MPC soft penalty"),
        "converged": design.mode == "converged",
        "sqp_iterations": design.sqp_iterations,
        "cold_iterations": design.cold_iterations,
        "qp_iterations": design.qp_iterations,
        "sqp_tolerance": c_number(design.sqp_tolerance),
        "qp_tolerance": c_number(design.qp_tolerance),
        # the method (ipgen_mpc_method), printed only when not the default: headers stay as before
        "method": design.barrier > 0 or design.sensitivities != "exact",
        "barrier": c_number(design.barrier),
        "barrier_set": design.barrier > 0,
        "barrier_value": f"{design.barrier:g}",
        "sensitivities": design.sensitivities,  # exact, frozen or shifted: IPGEN_MPC_EXACT, ...
        # float: the tolerances ipgen.mpc takes in float (qp 1e-4 in RTI, 1e-5 converged; converged sqp 1e-4)
        "sqp_tolerance_float": c_number(1e-4 if design.mode == "converged" else 0.0),
        "qp_tolerance_float": c_number(1e-5 if design.mode == "converged" else 1e-4),
        "input_gain": c_number(design.input_gain),
        "motor": motor,
        "u_what": u_what or ("the motor voltage [V]" if motor else "force [N] or torque [N m]"),
        "params": initialiser(structs[0]),
        "links": initialiser(structs[1]),
    }


def printed(runtime: Path) -> str:
    """A runtime (cpp/include/ipgen_mpc.h, ipgen_loop.h) as a C header prints it whole."""
    return runtime.read_text(encoding="utf-8").rstrip("\n")


def runtime_name_clash(name: str, header: str, runtimes: tuple[str, ...]) -> None:
    """Refuses (`ControllerError`, one line) a model name for which the header defines an
    identifier that a runtime printed whole into it defines too: name = "loop" makes
    ipgen_loop_swingup, ipgen_loop.h's struct, with a swing-up."""
    printed = [text for text in runtimes if text]
    if not printed:
        return
    own = header
    for text in printed:
        own = own.replace(text, "")
    ident = rf"(ipgen_{re.escape(name)}_\w+)"
    defined = set()
    for form in (
        rf"\bstatic inline [^;{{(]*?\b{ident}\s*\(",  # a function
        rf"\bstatic const [^;{{=]*?\b{ident}\s*[\[=]",  # a constant
        rf"}}\s*{ident}\s*;",  # a typedef'd struct
        rf"\btypedef [^;{{]*?\b{ident}\s*;",  # a typedef
    ):
        defined |= set(re.findall(form, own))
    theirs = set(re.findall(r"\bipgen_\w+", "\n".join(printed)))
    clash = sorted(defined & theirs)
    if clash:
        raise ControllerError(
            f"the model name {name!r} makes {clash[0]}, which the runtime printed into the C header "
            "defines too: choose another name"
        )


def _c_list(values: tuple[float, ...] | list[float], what: str) -> str:
    for i, v in enumerate(values):
        if not math.isfinite(v):
            raise ControllerError(f"swing-up {what}[{i}] = {v!r} is not a finite number")
    return ", ".join(c_number(v) for v in values)


# The numbers of ipgen_loop_energy_law (cpp/include/ipgen_loop.h) in its order, SwingUpLaw.energy's names.
ENERGY_FIELDS = (
    "gain_energy",
    "gain_position",
    "gain_velocity",
    "accel_max",
    "catch_angle",
    "catch_rate",
    "energy_target",
    "energy_inertia",
    "energy_weight",
)
# ipgen_loop_energy_law's optional numbers after input_gain, in its order: (name, unit, what a
# value > 0 does, what 0 means), printed with their comment in the header's initialiser.
ENERGY_OPTIONS = (
    ("energy_step", " [J]", "the law learns its target", "the target is fixed"),
    ("catch_deficit", " [J]", "a catch needs E >= -catch_deficit", "any E"),
    ("catch_base", "", "a catch needs |q0| <= catch_base", "the base anywhere"),
)


def swingup_context(law: SwingUpLaw, dof: int, catch_every: int | None = None) -> dict[str, object]:
    """The swing-up for the template: limits, hold LQR, the energy law's constants or the plan's
    tables (ū_k, x̄_k, K_k as const arrays: `table_bytes` of flash in double); `catch_every`: the
    samples between two steps of an MPC that catches (None: the hold LQR)."""
    size = 2 * dof
    if len(law.hold_gain) != size or len(law.target) != size:
        raise ControllerError(f"swing-up hold gain and target need {size} entries each")
    energy = dict(law.energy)  # the optional constants are absent when 0
    context: dict[str, object] = {
        "method": law.method,
        "u_max": c_number(law.u_max),
        "u_max_value": repr(float(law.u_max)),
        "period": repr(float(law.period)),
        "hold_gain": _c_list(law.hold_gain, "hold gain"),
        "target": _c_list(law.target, "target"),
        "energy": {name: c_number(value) for name, value in energy.items()},
        "steps": law.steps,
        # a dc_motor: u in volts, the energy law's force divided by b (None: u is the force)
        "input_gain": c_number(law.input_gain) if law.input_gain != 1.0 else None,
        "base_acceleration": law.base_acceleration,  # u is the base's acceleration: the law's a
        "input_gain_c": c_number(law.input_gain),  # ipgen_loop_energy_law's input_gain (1: none)
        # ipgen_loop_energy_law's numbers in its order (all 0 for a plan, which never swings)
        "energy_fields": [(name, c_number(energy.get(name, 0.0))) for name in ENERGY_FIELDS],
        # the optional numbers: (C value, comment), each set (> 0) or not
        "energy_options": [
            (c_number(energy.get(name, 0.0)), f"{name}{unit}: {on if energy.get(name, 0.0) > 0 else off}")
            for name, unit, on, off in ENERGY_OPTIONS
        ],
        "energy_learns": energy.get("energy_step", 0.0) > 0,  # else the target is fixed
        "catch_conditions": energy.get("catch_deficit", 0.0) > 0 or energy.get("catch_base", 0.0) > 0,
        "catch_every": catch_every,
        "release_angle": c_number(law.release_angle) if law.release_angle > 0 else None,
        "tracking": law.tracking,  # "mpc": the MPC tracks the plan (its reference per stage)
    }
    if law.method == "trajectory":
        rows = [law.states[k * size : (k + 1) * size] for k in range(law.steps + 1)]
        gains = [law.gains[k * size : (k + 1) * size] for k in range(law.steps)]
        context["inputs"] = _c_list(law.inputs, "inputs")
        context["states"] = [_c_list(row, "states") for row in rows]
        gain_rows = 0 if law.tracking == "mpc" else law.steps  # the MPC tracks: no gain schedule flashed
        context["gains"] = [_c_list(row, "gains") for row in gains[:gain_rows]]
        context["table_bytes"] = 8 * (law.steps + (law.steps + 1 + gain_rows) * size)
    return context


def c_bodies(eqs: Equations, wanted: tuple[str, ...]) -> dict[str, FunctionBody]:
    """The C99 body of every function in `wanted` (same expressions as the C++ header's)."""
    return function_bodies(eqs, wanted, syntax=C_SYNTAX, late=_LATE)


def render_c_header(eqs: Equations, request: HeaderRequest) -> str:
    """The complete C99 header text; deterministic for the same equations and request."""
    spec = request.specialisation
    context = header_context(eqs, request, TEMPLATE)
    eqs = specialise(eqs, spec, poly_keys(spec.outputs))
    context["nameu"] = request.name.upper()
    context["fn"] = c_bodies(eqs, spec.outputs)
    context["folded"] = folded_entries(eqs.system, spec, C_SYNTAX, lambda v: c_number(float(v)))
    # the dc_motor functions (actuator.motor_terms), prefixed as the template's P
    context["motor"] = motor_functions(eqs.system, "c", f"ipgen_{request.name}")
    dof = eqs.system.dof
    mpc = request.controller.mpc if request.controller is not None else None
    context["controller"] = (
        control_context(request.controller, dof) if request.controller and not mpc else None
    )
    context["mpc"] = mpc_context(mpc, request.controller.period, dof, spec.outputs) if mpc else None  # type: ignore[union-attr]
    context["mpc_runtime"] = printed(mpc_runtime()) if mpc else ""
    # with an MPC that catches: its step every catch_every swing-up samples (the scene checked the ratio)
    catch_every = None
    if mpc and request.swingup:
        catch_every = round(request.controller.period / request.swingup.period)  # type: ignore[union-attr]
    context["swingup"] = swingup_context(request.swingup, dof, catch_every) if request.swingup else None
    context["estimator"] = (
        estimator_context(request.estimator, dof, spec.outputs) if request.estimator is not None else None
    )
    # ipgen_loop.h printed whole when the header runs a loop (an estimator, a swing-up)
    needs_loop = request.estimator is not None or request.swingup is not None
    context["loop_runtime"] = printed(loop_runtime()) if needs_loop else ""
    header = environment().get_template(TEMPLATE).render(context)
    runtime_name_clash(request.name, header, (context["mpc_runtime"], context["loop_runtime"]))
    return header


def _c_rows(rows: tuple[tuple[float, ...], ...] | tuple[float, ...], what: str) -> str:
    """Row-major C initialiser of a matrix (or a vector) of finite numbers."""
    flat = [float(v) for row in rows for v in (row if isinstance(row, tuple) else (row,))]
    for i, v in enumerate(flat):
        if not math.isfinite(v):
            raise ControllerError(f"estimator {what}[{i}] = {v!r} is not a finite number")
    return ", ".join(c_number(v) for v in flat)


def estimator_context(estimator: PrintedEstimator, dof: int, functions: tuple[str, ...]) -> dict[str, object]:
    """The estimator of a scene's sampled loop for the template (estimation/printed.py)."""
    size = 2 * dof
    numbers, measured = estimator.numbers, estimator.sensors.measured
    count = len(measured)
    if numbers.kind not in ("difference", "filter", "kalman", "ekf"):
        raise ControllerError(f"estimator kind {numbers.kind!r} has no C implementation")
    if numbers.kind in ("difference", "filter") and measured != tuple(range(dof)):
        raise ControllerError(f'estimator "{numbers.kind}" needs every coordinate measured')
    if numbers.kind == "ekf":
        missing = [f for f in ("forward_dynamics", "forward_dynamics_derivatives") if f not in functions]
        if missing:
            raise ControllerError(
                f"estimator \"ekf\" needs the header's {' and '.join(missing)}: "
                "add them to the scene's outputs"
            )
    context: dict[str, object] = {
        "kind": numbers.kind,
        "period": c_number(estimator.period),
        "period_value": repr(float(estimator.period)),
        "measured": ", ".join(str(i) for i in measured),
        "measured_list": list(measured),
        "count": count,
        "size": size,
        "delay": estimator.delay,
        "predict": numbers.predict,  # the law sees the estimate carried over the delay (ekf's model)
        # ekf: the input gain learnt (x gets rho after the 2 dof states; the swing-up divides u by it)
        "learns": numbers.kind == "ekf" and numbers.gain_spread > 0,
        "gain_spread": c_number(numbers.gain_spread),
        "gain_drift": c_number(numbers.gain_drift),
        # compensate_lag with a lag: the loop models the drive's lag (ipgen_loop_lag_*)
        "lag": repr(float(estimator.lag)) if estimator.lag > 0 else None,
        "lag_limit": repr(float(estimator.lag_limit)) if math.isfinite(estimator.lag_limit) else "HUGE_VAL",
        # ekf with noise_memory: Rn's diagonal learnt (ipgen_loop_ekf's noise_*)
        "learns_noise": numbers.kind == "ekf" and numbers.noise_memory > 0,
    }
    if context["learns_noise"]:
        context["noise_memory"] = repr(float(numbers.noise_memory))
        context["noise_weight"] = c_number(estimator.period / numbers.noise_memory)
        context["noise_margin"] = c_number(numbers.noise_margin)
        context["noise_margin_value"] = f"{numbers.noise_margin:g}"
        context["noise_floor"] = _c_rows(numbers.noise_floor, "noise_floor")
        context["noise_ceiling"] = _c_rows(numbers.noise_ceiling, "noise_ceiling")
        context["noise_ceiling_factor"] = f"{NOISE_CEILING:g}"

    if numbers.kind == "filter":
        cutoff = float(numbers.cutoff or 0.0)
        context["cutoff"] = c_number(cutoff)
        context["cutoff_value"] = repr(cutoff)
        context["pole"] = c_number(math.exp(-cutoff * estimator.period))
    if numbers.kind in ("kalman", "ekf"):
        if len(numbers.equilibrium) != size:
            raise ControllerError(
                f"estimator equilibrium has {len(numbers.equilibrium)} entries, expected {size}"
            )
        context["equilibrium"] = _c_rows(numbers.equilibrium, "equilibrium")
    if numbers.kind == "kalman":
        shapes = (
            (numbers.A, size * size, "A"),
            (numbers.B, size, "B"),
            (numbers.gain, size * count, "M"),
        )
        for rows, expected, what in shapes:
            if sum(len(r) if isinstance(r, tuple) else 1 for r in rows) != expected:
                raise ControllerError(f"estimator {what} has the wrong size (expected {expected} numbers)")
        context["A"] = _c_rows(numbers.A, "A")
        context["B"] = _c_rows(numbers.B, "B")
        context["M"] = _c_rows(numbers.gain, "M")
        context["u_eq"] = c_number(numbers.input_equilibrium)
    context["firmware"] = _firmware_context(estimator) if estimator.firmware else None
    if numbers.kind == "ekf":
        context["Qn"] = _c_rows(numbers.process_noise, "process_noise")
        context["Rn"] = _c_rows(numbers.measurement_noise, "measurement_noise")
        context["input_gain"] = c_number(estimator.input_gain)
        context["input_gain_value"] = repr(float(estimator.input_gain))
    return context


def _firmware_context(estimator: PrintedEstimator) -> dict[str, object]:
    """The firmware entry's constants: Δ per measured coordinate (2π / counts per revolution, or
    1 / counts per metre for a cart's position), the values where the counts are zero, and the
    parameters the loop was designed with (`params`, the motor folded in)."""
    sensors = estimator.sensors
    steps = sensors.steps()
    if len(sensors.zero) != len(sensors.measured):
        raise ControllerError("estimator counts_zero needs one value per measured coordinate")
    context: dict[str, object] = {
        "steps": _c_rows(tuple(steps), "count steps"),
        "resolution": ", ".join(f"{counts:g}" for counts in sensors.resolution),
        "zero": _c_rows(sensors.zero, "counts zero"),
        "params": None,
        "motor": estimator.input_gain != 1.0,
    }
    if estimator.params is not None:
        params = estimator.params

        def group(*names: str) -> str:
            return ", ".join("{" + _c_rows(tuple(params[n]), n) + "}" for n in names)  # type: ignore[arg-type]

        context["params"] = {
            "params": group("m", "l", "delta") + ", " + c_number(float(params["g"])),  # type: ignore[arg-type]
            "links": group("com", "J", "J_axial", "tip"),
        }
    return context
