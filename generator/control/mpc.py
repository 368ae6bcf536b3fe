"""Constrained nonlinear MPC on the exact model: the design (`Mpc`, `mpc`) and its C step via ctypes.

cpp/include/ipgen_mpc.h holds the controller once, in C99 (docs/mpc.md): the RK4 discretisation
with its exact sensitivities, Gauss–Newton SQP in multiple shooting, each QP solved by a primal-dual
interior-point method on a Riccati recursion; real-time iteration (one SQP iteration per sample
on the shifted solution) or converged mode. Python keeps the design (weights, the terminal cost,
bounds, budgets) and calls the C step through ctypes, as `ipgen.common.loop_runtime` does for the
loop: the header and cpp/src/ipgen_mpc_model.c (the model callback on a compiled model library,
ipgen_model.h) compiled once into `<cache>/mpc/<key>/libipgen_mpc[_float].so` (double, or
float with -DIPGEN_MPC_REAL=float). The model is the pendulum's model library (`--emit library`),
compiled into `<cache>/models/<key>/` like `ipgen run`'s; a DC motor is folded in
(`Pendulum.folded`: u is then the voltage, the back-EMF in the base's damping).

States are in ipgen's coordinates (docs/model.md): x = [θ; θ̇], θ0 the cart position [m] or the
arm angle [rad], θ1..θn the absolute link angles from upright, clockwise positive. A chain on a
fixed pivot (`FixedPendulum`, one driven joint: the acrobot, the pendubot) has no θ0: x = [θ1..θn;
θ̇1..θ̇n] in the same convention, u the joint's torque [N m], clockwise positive (its model library
is `ipgen run`'s for fixed scenes; its Coulomb friction is not in the prediction, as for LQR).
"""

from __future__ import annotations

import ctypes
import numbers
import os
import threading
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ipgen.common.arrays import float_array
from ipgen.common.build_cache import runtime_library
from ipgen.common.install import REINSTALL
from ipgen.common.limits import (
    MAX_MPC_BARRIER,
    MAX_MPC_HORIZON,
    MAX_MPC_ITERATIONS,
    MAX_MPC_SPAN,
    MAX_SOFT_PENALTY,
    MIN_MPC_PERIOD,
)
from ipgen.common.locations import cmake_dir
from ipgen.common.safetext import shown_path
from ipgen.control.casadi_model import rk4_unstable_mode
from ipgen.control.linear import ControlError, equilibrium_state, weights
from ipgen.errors import Error
from ipgen.model.coordinates import rests
from ipgen.model.fixed import FixedPendulum
from ipgen.model.pendulum import Pendulum

__all__ = ["MODES", "Mpc", "MpcError", "StepInfo", "mpc"]

HEADER = "ipgen_mpc.h"
MODEL_HEADER = "ipgen_model.h"
GLUE = "ipgen_mpc_model.c"
FLAGS = ("-std=c99", "-O2", "-shared", "-fPIC", "-DIPGEN_MPC_EXPORT", "-Wall", "-Wextra", "-Wpedantic")
PRECISIONS = {
    "double": (ctypes.c_double, np.float64, ()),
    "float": (ctypes.c_float, np.float32, ("-DIPGEN_MPC_REAL=float",)),
}
MODES = ("rti", "converged")
HESSIANS = ("gauss-newton", "exact")
SENSITIVITIES = ("exact", "frozen", "shifted")  # IPGEN_MPC_EXACT, IPGEN_MPC_FROZEN, IPGEN_MPC_SHIFTED
MAX_DOF = 41  # IPGEN_MAX_DOF
MAX_INPUTS = MAX_DOF  # IPGEN_MAX_INPUTS
LAYOUT_ENTRIES = 42  # IPGEN_MPC_MODEL_LAYOUT
STATUS = {
    0: "ok",
    1: "model failed",
    2: "QP budget reached",
    3: "SQP budget reached",
    4: "breakdown",
    5: "bad settings",
    6: "QP infeasible",
}


class MpcError(ControlError):
    """An MPC that cannot be built or run (bad weights or bounds, no compiler, a failed build)."""


def _check_rest(x_ref: np.ndarray, dof: int, first_link: int) -> None:
    """A constant reference is a rest of the model with u_ref = 0 (the terminal LQR's point): rates
    0, each link upright (0) or hanging (π) in ipgen's absolute angles, a base anywhere."""
    moving = [i for i in range(dof, 2 * dof) if x_ref[i] != 0.0]
    if moving:
        raise MpcError(
            f"reference: rate x_ref[{moving[0]}] = {x_ref[moving[0]]:g} is not 0; a constant reference is a "
            "rest (a moving one: step(x, reference=(states, inputs)) per stage)"
        )
    for i in range(first_link, dof):
        if not rests(x_ref[i]):
            raise MpcError(
                f"reference: link angle x_ref[{i}] = {x_ref[i]:g} rad is not a rest with u = 0: links rest "
                "upright (0) or hanging (π)"
            )


# ---- the header's types, mirrored (checked against the compiled layout when loaded) ----------


def _settings_type(real: type) -> type[ctypes.Structure]:
    p = ctypes.c_void_p
    fields = [
        ("nx", ctypes.c_int), ("nu", ctypes.c_int), ("N", ctypes.c_int), ("period", real),
        ("substeps", ctypes.c_int), ("dynamics", p), ("context", p),
        ("Q", p), ("R", p), ("P", p), ("x_ref", p), ("u_ref", p), ("u_min", p), ("u_max", p),
        ("hard_count", ctypes.c_int), ("hard_index", p), ("hard_min", p), ("hard_max", p),
        ("soft_count", ctypes.c_int), ("soft_index", p), ("soft_min", p), ("soft_max", p),
        ("soft_linear", p), ("soft_quadratic", p),
        ("sqp_iterations", ctypes.c_int), ("sqp_tolerance", real),
        ("qp_iterations", ctypes.c_int), ("qp_tolerance", real), ("shift", ctypes.c_int),
        ("line_search", ctypes.c_int), ("cold_iterations", ctypes.c_int), ("exact_hessian", ctypes.c_int),
    ]  # fmt: skip
    return type(f"Settings_{real.__name__}", (ctypes.Structure,), {"_fields_": fields})


def _method_type(real: type) -> type[ctypes.Structure]:
    fields = [("barrier", real), ("sensitivities", ctypes.c_int)]
    return type(f"Method_{real.__name__}", (ctypes.Structure,), {"_fields_": fields})


def _info_type(real: type) -> type[ctypes.Structure]:
    fields = [
        ("status", ctypes.c_int), ("sqp_iterations", ctypes.c_int), ("qp_iterations", ctypes.c_int),
        ("step", real), ("defect", real), ("qp_residual", real),
    ]  # fmt: skip
    return type(f"Info_{real.__name__}", (ctypes.Structure,), {"_fields_": fields})


class Parameters(ctypes.Structure):
    """ipgen_parameters (ipgen_model.h): IPGEN_MAX_DOF doubles a field, g; a fixed chain's Ir and
    gr (IPGEN_MAX_INPUTS each, unused here: 0)."""

    _fields_ = [
        *((name, ctypes.c_double * MAX_DOF) for name in ("m", "l", "delta")), ("g", ctypes.c_double),
        *((name, ctypes.c_double * MAX_DOF) for name in ("com", "J", "J_axial", "tip")),
        *((name, ctypes.c_double * MAX_INPUTS) for name in ("Ir", "gr")),
    ]  # fmt: skip


MODEL_ABI = 4  # cpp/include/ipgen_model.h's IPGEN_MODEL_ABI: the layout ModelHead reads


class ModelHead(ctypes.Structure):
    """The first fields of ipgen_model, up to the function pointers the MPC's callback calls."""

    _fields_ = [
        ("abi", ctypes.c_int), *((name, ctypes.c_char_p) for name in ("name", "type", "inertia")),
        *((name, ctypes.c_int) for name in ("links", "dof", "inputs", "links_as_built")),
        ("forward_dynamics", ctypes.c_void_p),
    ]  # fmt: skip


class ModelContext(ctypes.Structure):
    """ipgen_mpc_model_context: the model library's description, the parameters, the input gain."""

    _fields_ = [("model", ctypes.c_void_p), ("parameters", ctypes.c_void_p), ("gain", ctypes.c_double)]


def _layout(real: type) -> list[int]:
    """What ipgen_mpc_model_layout writes, from the ctypes mirrors (the order of the C file)."""
    settings, info = _settings_type(real), _info_type(real)

    def at(struct: type[ctypes.Structure], name: str) -> int:
        return int(getattr(struct, name).offset)

    names = ("period", "substeps", "dynamics", "context", "Q", "u_ref", "u_max", "hard_count", "hard_index",
             "hard_max", "soft_count", "soft_index", "soft_quadratic", "sqp_iterations", "sqp_tolerance",
             "qp_iterations", "qp_tolerance", "shift", "line_search",
             "cold_iterations", "exact_hessian")  # fmt: skip
    method = _method_type(real)
    return [
        ctypes.sizeof(real), ctypes.sizeof(settings), *(at(settings, n) for n in names),
        ctypes.sizeof(method), at(method, "sensitivities"), ctypes.sizeof(info),
        *(at(info, n) for n in ("sqp_iterations", "qp_iterations", "step", "defect", "qp_residual")),
        ctypes.sizeof(ModelContext), at(ModelContext, "parameters"), at(ModelContext, "gain"),
        ctypes.sizeof(Parameters), at(Parameters, "g"), at(Parameters, "tip"),
        at(ModelHead, "dof"), at(ModelHead, "inputs"), at(ModelHead, "forward_dynamics"),
        -1, LAYOUT_ENTRIES,  # sizeof(ipgen_mpc_layout): not mirrored
    ]  # fmt: skip


# ---- building and loading ----------------------------------------------------------------------


def sources() -> dict[str, str]:
    """ipgen_mpc.h, ipgen_model.h and ipgen_mpc_model.c of this installation (package or checkout)."""
    root = cmake_dir().parent
    paths = {HEADER: root / "cpp" / "include" / HEADER, MODEL_HEADER: root / "cpp" / "include" / MODEL_HEADER,
             GLUE: root / "cpp" / "src" / GLUE}  # fmt: skip
    if not all(path.is_file() for path in paths.values()):
        raise MpcError(f"the MPC library's sources are missing from {shown_path(root)}: {REINSTALL}")
    return {name: path.read_text() for name, path in paths.items()}


def build(precision: str = "double") -> Path:
    """The compiled MPC library in `precision` ("double" or "float"): from the cache, or compiled
    into it (module docstring)."""
    target = "libipgen_mpc.so" if precision == "double" else "libipgen_mpc_float.so"
    return runtime_library(
        "mpc", sources(), GLUE, (*FLAGS, *PRECISIONS[precision][2]), target, MpcError,
        "the MPC library (ipgen_mpc.h)", "MPC library",
    )  # fmt: skip


_lock = threading.Lock()  # guards the two dicts below and _building, never held while building
_building: dict[Any, threading.Lock] = {}  # one lock per library being built
_loaded: dict[str, ctypes.CDLL] = {}
_models: dict[Any, ctypes.CDLL] = {}


def _once(store: dict[Any, ctypes.CDLL], key: Any, make: Callable[[], ctypes.CDLL]) -> ctypes.CDLL:
    """store[key], made by `make` once per process: a thread asking for a library another is
    building waits for it, one asking for any other does not (the module lock was held through
    a whole compile: a loaded model's lookup waited 0.33 s on another model's build)."""
    with _lock:
        if key in store:
            return store[key]
        building = _building.setdefault(key, threading.Lock())
    with building:
        with _lock:
            if key in store:
                return store[key]
        made = make()
        with _lock:
            store[key] = made
        return made


def _after_fork() -> None:
    """A child forked while a thread held a lock would wait on it for good: new locks."""
    global _lock
    _lock = threading.Lock()
    _building.clear()


os.register_at_fork(after_in_child=_after_fork)


def library(precision: str = "double") -> ctypes.CDLL:
    """The MPC library in `precision`, its functions declared and its structs' layout checked:
    built if needed, loaded once per process."""
    if precision not in PRECISIONS:
        raise MpcError(f"precision {precision!r}: expected 'double' or 'float'")
    return _once(_loaded, precision, lambda: _load(precision))


def _load(precision: str) -> ctypes.CDLL:
    """The MPC library in `precision`, built if needed, loaded and checked (`library`)."""
    path = build(precision)
    try:
        lib = ctypes.CDLL(str(path))
    except OSError as e:
        raise MpcError(f"cannot load the MPC library {shown_path(path)}: {e}") from None
    real = PRECISIONS[precision][0]
    P, I, L = ctypes.c_void_p, ctypes.c_int, ctypes.c_long  # noqa: E741
    for name, restype, argtypes in (
        ("ipgen_mpc_work_size", L, (P,)),
        ("ipgen_mpc_carve", L, (P, P, P)),
        ("ipgen_mpc_rk4", I, (P, P, P, P, P, P, P)),
        ("ipgen_mpc_rk4_method", I, (P, P, P, P, P, P, P, P)),
        ("ipgen_mpc_reset", None, (P,)),
        ("ipgen_mpc_cost", real, (P, P)),
        ("ipgen_mpc_check", I, (P,)),
        ("ipgen_mpc_step", I, (P, P, P, P, P)),
        ("ipgen_mpc_track", I, (P, P, P, P, P, P, P)),
        ("ipgen_mpc_track_method", I, (P, P, P, P, P, P, P, P)),
        ("ipgen_mpc_cost_tracking", real, (P, P, P, P)),
        ("ipgen_mpc_model_dynamics", I, (P, P, P, P, P, P)),
        ("ipgen_mpc_model_layout", L, (P,)),
    ):
        function = getattr(lib, name)
        function.restype, function.argtypes = restype, list(argtypes)
    written = (ctypes.c_long * LAYOUT_ENTRIES)()
    count = lib.ipgen_mpc_model_layout(ctypes.addressof(written))
    got, expected = list(written), _layout(real)
    got[-2] = -1
    if count != LAYOUT_ENTRIES or got != expected:
        raise MpcError(
            f"the MPC library's structs do not match ipgen.control.mpc's mirrors (C {got}, Python "
            f"{expected}): update the mirrors with ipgen_mpc.h"
        )
    return lib


def model_library(pendulum: Pendulum | FixedPendulum) -> ctypes.CDLL:
    """The compiled model library (ipgen_model.h) of `pendulum`'s system, loaded once per process
    and system (`ipgen.pipeline.model_library`: generated and compiled into the cache as `ipgen
    run` does; imported here, on request, from the later stage that builds it)."""
    from ipgen.pipeline.model_library import compiled_model_library

    fixed = isinstance(pendulum, FixedPendulum)
    system = pendulum.canonical() if fixed else pendulum.system
    key = ("fixed", pendulum.links, tuple(pendulum.joints)) if fixed else system

    def make() -> ctypes.CDLL:
        try:
            return compiled_model_library(system)
        except Error as e:
            raise MpcError(str(e)) from None

    return _once(_models, key, make)


# ---- the design --------------------------------------------------------------------------------


@dataclass(frozen=True)
class StepInfo:
    """What one `Mpc.step` did (ipgen_mpc_info): the status ("ok", "QP budget reached", ...), the
    SQP and interior-point iterations, the last SQP step's and the dynamics' largest entries and
    the last QP's largest residual."""

    status: str
    sqp_iterations: int
    qp_iterations: int
    step: float
    defect: float
    qp_residual: float


def _shown(value: Any) -> str:
    """`value` for a one-line message (at most 60 characters)."""
    text = repr(value).replace("\n", " ")
    return text if len(text) <= 60 else text[:57] + "..."


def _real(name: str, value: Any) -> float:
    """A finite real number (not a bool), else one line naming `name`."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real) or not np.isfinite(float(value)):
        raise MpcError(f"{name} = {_shown(value)}: expected a finite number")
    return float(value)


def _whole(name: str, value: Any, low: int, high: int) -> int:
    """An integer (not a bool) in [low, high], else one line naming `name`."""
    if isinstance(value, bool) or not isinstance(value, numbers.Integral) or not low <= value <= high:
        raise MpcError(f"{name} = {_shown(value)}: expected an integer from {low} to {high}")
    return int(value)


def _choice(name: str, value: Any, choices: Sequence[str]) -> str:
    """One of `choices` (text), else one line naming `name`."""
    if not (isinstance(value, str) and value in choices):
        raise MpcError(f"{name} {_shown(value)}: expected one of {', '.join(choices)}")
    return value


def _bounds(
    name: str, given: Mapping[int, Sequence[float]] | None, states: int
) -> list[tuple[int, float, float]]:
    """{state index: (min, max)} as a sorted list, checked."""
    if given is not None and not isinstance(given, Mapping):
        raise MpcError(f"{name} = {_shown(given)}: expected {{state index: (min, max)}}, as {{0: (-1, 1)}}")
    out: list[tuple[int, float, float]] = []
    for index, pair in (given or {}).items():
        if isinstance(index, bool) or not (isinstance(index, numbers.Integral) and 0 <= index < states):
            raise MpcError(f"{name}: state index {_shown(index)} is not one of 0..{states - 1}")
        if not (isinstance(pair, Sequence | np.ndarray) and not isinstance(pair, str) and len(pair) == 2):
            raise MpcError(f"{name}[{index}] = {_shown(pair)}: expected (min, max)")
        lo, hi = (_real(f"{name}[{index}]", v) for v in pair)
        if not lo < hi:
            raise MpcError(f"{name}[{index}] = ({lo:g}, {hi:g}): expected finite min < max")
        out.append((int(index), lo, hi))
    return sorted(out)


def _check_reachable(
    x_ref: np.ndarray, hard: list[tuple[int, float, float]], u_min: float, u_max: float
) -> None:
    """MpcError unless the reference rests inside the hard bounds: its state within each, and u = 0
    (what holds a rest) within [u_min, u_max]; otherwise every QP is infeasible near it."""
    for index, lo, hi in hard:
        if not lo <= x_ref[index] <= hi:
            raise MpcError(
                f"reference: state {index} = {x_ref[index]:g} is outside its hard bound [{lo:g}, {hi:g}] "
                "(travel or bounds): the MPC could never reach it; move the reference inside or widen "
                "the bound"
            )
    if not u_min <= 0.0 <= u_max:
        raise MpcError(
            f"u bounds [{u_min:g}, {u_max:g}] exclude 0, the input that holds the reference at rest: "
            "give u_min <= 0 <= u_max"
        )


def _state(name: str, x: Any, size: int) -> np.ndarray:
    """A state of `size` finite entries, else one line."""
    try:
        state = np.asarray(x, dtype=float)
    except (TypeError, ValueError):
        raise MpcError(f"{name} = {_shown(x)}: expected {size} numbers") from None
    if state.shape != (size,) or not np.all(np.isfinite(state)):
        raise MpcError(f"{name} = {_shown(x)}: expected {size} finite numbers")
    return state


def _weights(Q: Any, R: Any, size: int, name: str = "Q") -> tuple[np.ndarray, np.ndarray]:
    """`linear.weights`, its messages naming `name` (Q or P) and every bad value in one line."""
    try:
        return weights(Q, R, size, name)
    except ControlError as error:
        raise MpcError(str(error)) from None
    except (TypeError, ValueError):
        raise MpcError(
            f"{name} = {_shown(Q)}, R = {_shown(R)}: expected numbers ({size} weights or a matrix; R > 0)"
        ) from None


def _parameters(plant: Pendulum | FixedPendulum) -> Parameters:
    """ipgen_parameters of `plant`: a cart's or arm's with its DC motor folded in (`Pendulum.folded`),
    or a fixed chain's links (com and J resolved) and its motors' Ir, gr."""
    params = Parameters()
    dof = plant.dof
    if isinstance(plant, FixedPendulum):
        for field in ("m", "l", "delta"):
            getattr(params, field)[:dof] = [float(v) for v in getattr(plant, field)]
        params.g = float(plant.g)
        params.com[:dof], params.J[:dof] = plant.resolved("com"), plant.resolved("J")
        params.Ir[: plant.inputs], params.gr[: plant.inputs] = plant.motor("Ir"), plant.motor("gr")
        return params
    values = plant.folded().flat()
    for k, field in enumerate(("m", "l", "delta")):
        getattr(params, field)[:dof] = values[k * dof : (k + 1) * dof]
    params.g = values[3 * dof]
    for k, field in enumerate(("com", "J", "J_axial", "tip")):
        start = 3 * dof + 1 + k * dof
        getattr(params, field)[:dof] = values[start : start + dof]
    return params


class Mpc:
    """A constrained nonlinear MPC of one pendulum (docs/mpc.md), run by the C step of ipgen_mpc.h.

    Built by `ipgen.mpc`; see its parameters. `step(x)` returns u for the state estimate x (the
    real-time iteration, or the converged solution in mode "converged") and keeps the warm start;
    `solve(x)` solves from a cold start to convergence; `reset()` forgets the warm start.

    Attributes
    ----------
    Q, R, P : numpy.ndarray
        The stage weights and the terminal weight (the discrete LQR's Riccati matrix by default).
    x_ref, u_ref : numpy.ndarray
        The reference state and input.
    info : StepInfo or None
        What the last step did.
    """

    def __init__(
        self,
        pendulum: Pendulum | FixedPendulum,
        *,
        horizon: int,
        period: float,
        Q: Any,
        R: Any,
        P: Any,
        u_max: float,
        u_min: float | None,
        travel: float | None,
        bounds: Mapping[int, Sequence[float]] | None,
        soft_bounds: Mapping[int, Sequence[float]] | None,
        soft_penalty: tuple[float, float],
        reference: Sequence[float] | str,
        substeps: int,
        mode: str,
        sqp_iterations: int | None,
        cold_iterations: int,
        hessian: str | None,
        qp_iterations: int | None,
        sqp_tolerance: float | None,
        qp_tolerance: float | None,
        precision: str,
        barrier: float = 0.0,
        sensitivities: str = "exact",
    ) -> None:
        fixed = isinstance(pendulum, FixedPendulum)
        if not (fixed or isinstance(pendulum, Pendulum)):
            raise MpcError(
                f"ipgen.mpc needs an ipgen.Pendulum or FixedPendulum, got {type(pendulum).__name__}"
            )
        if fixed and pendulum.inputs != 1:
            raise MpcError(
                f"ipgen.mpc: this chain drives {pendulum.inputs} joints {tuple(pendulum.joints)}; the MPC "
                "takes one input (drive one joint: joints = [1] or [2])"
            )
        if not fixed and pendulum.actuator.is_acceleration:
            raise MpcError(
                "ipgen.mpc: an acceleration-driven base is not supported (u must be a force, torque or volts)"
            )
        mode = _choice("mode", mode, tuple(MODES))
        precision = _choice("precision", precision, tuple(PRECISIONS))
        horizon = _whole("horizon", horizon, 1, MAX_MPC_HORIZON)
        substeps = _whole("substeps", substeps, 1, 100)
        if not _real("period", period) >= MIN_MPC_PERIOD:
            raise MpcError(f"period {period!r}: expected a number of seconds >= {MIN_MPC_PERIOD:g}")
        if horizon * period > MAX_MPC_SPAN:
            raise MpcError(
                f"horizon · period = {horizon} · {period:g} s: the prediction reaches beyond "
                f"{MAX_MPC_SPAN:g} s; give a shorter horizon or period"
            )
        self.pendulum = pendulum
        self.precision = precision
        self.mode = mode
        dof = pendulum.dof
        nx = 2 * dof
        self.nx, self.nu, self.N = nx, 1, horizon
        q, r = _weights(np.eye(nx) if Q is None else Q, 1.0 if R is None else R, nx)
        self.Q, self.R = q, r
        if isinstance(reference, str):
            try:
                self.x_ref = equilibrium_state(pendulum.links, reference)
            except ControlError:
                raise MpcError(
                    f"reference {reference!r}: expected 'upright', 'hanging', {dof} angles or a state "
                    f"of {nx} entries"
                ) from None
            if fixed:  # no base: the links' angles and rates only
                self.x_ref = np.delete(self.x_ref, [0, dof + 1])
        else:
            try:
                self.x_ref = np.asarray(reference, dtype=float).reshape(-1)
            except (TypeError, ValueError):
                self.x_ref = np.full(1, np.nan)  # refused below
            if self.x_ref.size == dof:
                self.x_ref = np.concatenate([self.x_ref, np.zeros(dof)])
            if self.x_ref.size != nx or not np.all(np.isfinite(self.x_ref)):
                raise MpcError(
                    f"reference: expected 'upright', 'hanging', {dof} angles or a state of {nx} entries"
                )
            _check_rest(self.x_ref, dof, first_link=0 if fixed else 1)
        self.u_ref = np.zeros(1)
        hi = _real("u_max", u_max)
        lo = -hi if u_min is None else _real("u_min", u_min)
        if not (np.isfinite(lo) and np.isfinite(hi) and lo < hi):
            raise MpcError(f"u bounds ({lo:g}, {hi:g}): expected finite u_min < u_max")
        self.u_min, self.u_max = lo, hi
        hard = {i: (lo, hi) for i, lo, hi in _bounds("bounds", bounds, nx)}  # checked before travel joins
        if travel is not None:
            if fixed:
                raise MpcError(
                    "travel: a chain on a fixed pivot has no base to bound (use bounds on its states)"
                )
            if not _real("travel", travel) > 0:
                raise MpcError(f"travel {travel!r}: expected a positive bound on the base (m or rad)")
            if 0 in hard:
                raise MpcError("travel and bounds[0] both bound the base: give one of them")
            hard[0] = (-float(travel), float(travel))
        self.hard = _bounds("bounds", hard, nx)
        _check_reachable(self.x_ref, self.hard, lo, hi)
        self.soft = _bounds("soft_bounds", soft_bounds, nx)
        pair = isinstance(soft_penalty, Sequence | np.ndarray) and not isinstance(soft_penalty, str)
        if not (pair and len(soft_penalty) == 2):
            raise MpcError(f"soft_penalty = {_shown(soft_penalty)}: expected (ρ1, ρ2): s costs ρ1 s + ρ2 s²")
        linear, quadratic = (_real("soft_penalty", v) for v in soft_penalty)
        if not (0 <= linear <= MAX_SOFT_PENALTY and 0 < quadratic <= MAX_SOFT_PENALTY):
            raise MpcError(
                f"soft_penalty ({linear:g}, {quadratic:g}): expected 0 <= ρ1 <= {MAX_SOFT_PENALTY:g} "
                f"and 0 < ρ2 <= {MAX_SOFT_PENALTY:g}"
            )
        self.soft_penalty = (linear, quadratic)
        self.period, self.substeps = float(period), substeps
        converged = mode == "converged"
        double = precision == "double"
        budget = MAX_MPC_ITERATIONS if not converged else 100 * MAX_MPC_ITERATIONS
        self.sqp_iterations = (500 if converged else 1) if sqp_iterations is None else sqp_iterations
        self.sqp_iterations = _whole("sqp_iterations", self.sqp_iterations, 1, budget)
        self.qp_iterations = (50 if converged else 20) if qp_iterations is None else qp_iterations
        self.qp_iterations = _whole("qp_iterations", self.qp_iterations, 1, budget)
        for name, given in (("sqp_tolerance", sqp_tolerance), ("qp_tolerance", qp_tolerance)):
            if given is not None and not _real(name, given) >= 0:
                raise MpcError(f"{name} = {_shown(given)}: expected a number >= 0")
        sqp_eps = (1e-10 if double else 1e-4) if converged else 0.0
        self.sqp_tolerance = sqp_tolerance if sqp_tolerance is not None else sqp_eps
        # float: 1e-4 in the real-time iteration (one interior-point iteration fewer a step on the
        # QUBE than 1e-5: docs/mpc.md), 1e-5 converged (below its SQP tolerance)
        qp_eps = (1e-10 if converged else 1e-9) if double else (1e-5 if converged else 1e-4)
        self.qp_tolerance = qp_tolerance if qp_tolerance is not None else qp_eps
        self.cold_iterations = _whole("cold_iterations", cold_iterations, 1, MAX_MPC_ITERATIONS)
        if isinstance(barrier, bool) or not (
            isinstance(barrier, numbers.Real) and np.isfinite(barrier) and 0 <= barrier <= MAX_MPC_BARRIER
        ):
            raise MpcError(
                f"barrier {barrier!r}: expected a weight >= 0 and <= {MAX_MPC_BARRIER:g} "
                "(0: the interior point)"
            )
        if barrier > 0 and converged:
            raise MpcError(
                "barrier: a fixed barrier weight is for the real-time iteration, not mode 'converged'"
            )
        self.barrier = float(barrier)
        sensitivities = _choice("sensitivities", sensitivities, tuple(SENSITIVITIES))
        if sensitivities != "exact" and converged:
            raise MpcError(
                f"sensitivities {sensitivities!r}: for the real-time iteration, not mode 'converged'"
            )
        self.sensitivities = sensitivities
        if hessian is None:
            hessian = "exact" if converged and double else "gauss-newton"
        hessian = _choice("hessian", hessian, tuple(HESSIANS))
        if hessian == "exact" and sensitivities != "exact":
            raise MpcError(
                f"sensitivities {sensitivities!r} with hessian 'exact': the Lagrangian's Hessian needs the "
                "exact sensitivities (hessian 'gauss-newton', or sensitivities 'exact')"
            )
        self.hessian = hessian
        self._setup()
        _check_rk4_stable(self.pendulum, self.x_ref, float(self.u_ref[0]), self.period, self.substeps)
        self.P = self.lqr_terminal() if P is None else _weights(P, 1.0, nx, "P")[0]
        self._arrays["P"][:] = self.P.reshape(-1)
        self.info: StepInfo | None = None

    # -- the C structures ---------------------------------------------------------------------

    def _setup(self) -> None:
        real, dtype, _ = PRECISIONS[self.precision]
        self._lib = library(self.precision)
        self._model_lib = model_library(self.pendulum)
        dof = self.pendulum.dof
        self._params = params = _parameters(self.pendulum)
        gain = 1.0 if isinstance(self.pendulum, FixedPendulum) else float(self.pendulum.gain)
        self._context = ModelContext(self._model_lib.ipgen_model_get(), ctypes.addressof(params), gain)
        head = ModelHead.from_address(self._context.model)
        if head.abi != MODEL_ABI:  # the fields after abi mean something else in another ABI
            raise MpcError(
                f"the model library is built for model ABI {head.abi}, this ipgen reads {MODEL_ABI}: "
                "delete it from the cache (ipgen builds it again)"
            )
        if head.dof != dof or head.inputs != 1:
            raise MpcError(
                f"the model library has dof {head.dof} and {head.inputs} inputs, expected {dof} and 1"
            )

        def arr(values: Any, kind: Any = dtype) -> np.ndarray:
            return np.ascontiguousarray(np.asarray(values, dtype=kind).reshape(-1))

        linear, quadratic = self.soft_penalty
        ns = len(self.soft)
        self._arrays = {
            "Q": arr(self.Q), "R": arr(self.R), "P": arr(np.zeros((self.nx, self.nx))),
            "x_ref": arr(self.x_ref), "u_ref": arr(self.u_ref),
            "u_min": arr([self.u_min]), "u_max": arr([self.u_max]),
            "hard_index": arr([b[0] for b in self.hard] or [0], np.int32),
            "hard_min": arr([b[1] for b in self.hard] or [0]),
            "hard_max": arr([b[2] for b in self.hard] or [0]),
            "soft_index": arr([b[0] for b in self.soft] or [0], np.int32),
            "soft_min": arr([b[1] for b in self.soft] or [0]),
            "soft_max": arr([b[2] for b in self.soft] or [0]),
            "soft_linear": arr([linear] * ns or [0]), "soft_quadratic": arr([quadratic] * ns or [1]),
        }  # fmt: skip
        settings = _settings_type(real)()
        settings.nx, settings.nu, settings.N = self.nx, self.nu, self.N
        settings.period, settings.substeps = self.period, self.substeps
        settings.dynamics = ctypes.cast(self._lib.ipgen_mpc_model_dynamics, ctypes.c_void_p).value
        settings.context = ctypes.addressof(self._context)
        for name, array in self._arrays.items():
            setattr(settings, name, array.ctypes.data)
        settings.hard_count, settings.soft_count = len(self.hard), ns
        settings.sqp_iterations, settings.sqp_tolerance = self.sqp_iterations, self.sqp_tolerance
        settings.qp_iterations, settings.qp_tolerance = self.qp_iterations, self.qp_tolerance
        settings.shift = 1
        settings.line_search = int(self.mode == "converged")
        settings.cold_iterations = self.cold_iterations
        settings.exact_hessian = int(self.hessian == "exact")
        self._settings = settings
        self._method = _method_type(real)(self.barrier, SENSITIVITIES.index(self.sensitivities))
        self._dtype = dtype
        self._info = _info_type(real)()
        self.work = np.zeros(int(self._lib.ipgen_mpc_work_size(ctypes.byref(settings))), dtype=dtype)
        if self._lib.ipgen_mpc_check(ctypes.byref(settings)) != 0:
            raise MpcError(
                "the MPC's settings describe no problem (sizes, bounds or soft weights): check them"
            )

    def _vector(self, values: Any, size: int, name: str) -> np.ndarray:
        """`values` flattened into `size` finite reals of the MPC's precision, else one line."""
        try:
            array = np.ascontiguousarray(np.asarray(values, dtype=float).reshape(-1), dtype=self._dtype)
        except (TypeError, ValueError):
            raise MpcError(f"{name} = {_shown(values)}: expected {size} numbers") from None
        if array.size != size:
            raise MpcError(f"{name} has {array.size} entries, expected {size}")
        if not np.all(np.isfinite(array)):
            raise MpcError(f"{name} = {_shown(values)}: expected finite numbers")
        return array

    # -- the controller -----------------------------------------------------------------------

    @property
    def work_bytes(self) -> int:
        """The workspace's size in bytes (IPGEN_MPC_WORK reals)."""
        return int(self.work.nbytes)

    def reset(self) -> None:
        """Forget the warm start: the next step starts cold."""
        self._lib.ipgen_mpc_reset(self.work.ctypes.data)

    def _reference(self, reference: Any) -> tuple[Any, Any, tuple[np.ndarray, ...]]:
        """(x_refs pointer, u_refs pointer, the arrays kept alive) of a per-stage reference, or
        null pointers for the constant x_ref, u_ref. States: (N+1) × nx (or flat, row by row);
        inputs: N (or N × 1)."""
        if reference is None:
            return None, None, ()
        N, nx, nu = self.N, self.nx, self.nu
        usage = f"reference: expected (states, inputs), a plan's {N + 1} × {nx} states, {N} inputs from now"
        try:
            states, inputs = reference
            xs = float_array(states)
            us = float_array(inputs)
        except (TypeError, ValueError):
            raise MpcError(usage) from None
        if xs.ndim == 0 or us.ndim == 0:  # None, or one number: not a plan
            raise MpcError(f"{usage}; got {_shown(states)} and {_shown(inputs)}")
        if xs.shape not in ((N + 1, nx), ((N + 1) * nx,)) or us.shape not in ((N,), (N, nu)):
            raise MpcError(f"{usage}; got {xs.shape} and {us.shape} (a transposed plan reads wrong)")
        if not (np.all(np.isfinite(xs)) and np.all(np.isfinite(us))):
            raise MpcError("reference: every entry must be finite")
        xs = np.ascontiguousarray(xs.reshape(-1), dtype=self._dtype)
        us = np.ascontiguousarray(us.reshape(-1), dtype=self._dtype)
        return xs.ctypes.data, us.ctypes.data, (xs, us)

    def step(self, x: Sequence[float] | np.ndarray, reference: Any = None) -> float:
        """The input u for the state estimate x (2·dof entries, ipgen's coordinates): one real-time
        iteration on the shifted warm start (mode "rti") or the problem solved to convergence
        (mode "converged"); `info` says what was done.

        Parameters
        ----------
        x : array_like
            The current state [θ; θ̇].
        reference : (array_like, array_like), optional
            A reference per stage instead of the constant x_ref, u_ref (a plan to track): the states
            x_ref_0..x_ref_N ((N+1) × nx) and inputs u_ref_0..u_ref_{N-1} (N × nu) from this
            sample on, one row a sample; a cold start starts from them (ipgen_mpc_track).

        Returns
        -------
        float
            u within [u_min, u_max] (volts for a DC motor, else N or N m).
        """
        state = np.ascontiguousarray(_state("x", x, self.nx), dtype=self._dtype)
        x_refs, u_refs, _alive = self._reference(reference)
        u = np.zeros(1, dtype=self._dtype)
        self._lib.ipgen_mpc_track_method(
            ctypes.byref(self._settings),
            ctypes.byref(self._method),
            x_refs,
            u_refs,
            state.ctypes.data,
            u.ctypes.data,
            self.work.ctypes.data,
            ctypes.byref(self._info),
        )
        i = self._info
        self.info = StepInfo(
            STATUS.get(i.status, str(i.status)), i.sqp_iterations, i.qp_iterations, float(i.step),
            float(i.defect), float(i.qp_residual),
        )  # fmt: skip
        return float(u[0])

    def solve(self, x: Sequence[float] | np.ndarray, reference: Any = None) -> float:
        """The first input of the problem solved from a cold start to convergence, whatever the
        mode: up to `sqp_iterations` SQP iterations in the converged mode (500 from a real-time
        design), tolerances at least as tight as the converged mode's, the line search on and
        the design's Hessian; the warm start then holds that solution, unshifted. A barrier
        weight stays (the solution is its barrier problem's, the point its steps track); frozen or
        shifted sensitivities are exact here (the problem's solution, which theirs approximates).

        Parameters
        ----------
        x : array_like
            The current state [θ; θ̇].
        reference : (array_like, array_like), optional
            A reference per stage, as for `step`.

        Returns
        -------
        float
            u_0 of the solution.
        """
        s = self._settings
        saved = (s.sqp_iterations, s.sqp_tolerance, s.qp_iterations, s.qp_tolerance, s.shift, s.line_search)
        sqp_eps, qp_eps = (1e-10, 1e-10) if self.precision == "double" else (1e-4, 1e-5)
        s.sqp_iterations = saved[0] if self.mode == "converged" else max(saved[0], 500)
        s.sqp_tolerance = sqp_eps if saved[1] <= 0 else min(saved[1], sqp_eps)
        s.qp_iterations = max(saved[2], 50)
        s.qp_tolerance = min(saved[3], qp_eps)
        s.shift, s.line_search = 0, 1
        method, self._method.sensitivities = self._method.sensitivities, SENSITIVITIES.index("exact")
        try:
            self.reset()
            return self.step(x, reference)
        finally:
            s.sqp_iterations, s.sqp_tolerance, s.qp_iterations, s.qp_tolerance, s.shift, s.line_search = saved
            self._method.sensitivities = method

    def trajectory(self) -> tuple[np.ndarray, np.ndarray]:
        """(states (N+1) × nx, inputs N × nu) held in the workspace: the last step's solution
        (shifted by one sample at the start of the next step)."""
        z = self.work[1 : 1 + (self.N + 1) * self.nx + self.N * self.nu].astype(float)
        states = z[: (self.N + 1) * self.nx].reshape(self.N + 1, self.nx)
        return states, z[(self.N + 1) * self.nx :].reshape(self.N, self.nu)

    def cost(self, reference: Any = None) -> float:
        """The problem's cost of the trajectory held (`trajectory`), about the constant x_ref, u_ref
        or a reference per stage (as for `step`)."""
        if reference is None:
            return float(self._lib.ipgen_mpc_cost(ctypes.byref(self._settings), self.work.ctypes.data))
        x_refs, u_refs, _alive = self._reference(reference)
        settings, work = ctypes.byref(self._settings), self.work.ctypes.data
        return float(self._lib.ipgen_mpc_cost_tracking(settings, x_refs, u_refs, work))

    def rk4(self, x: Sequence[float] | np.ndarray, u: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(F(x, u), ∂F/∂x, ∂F/∂u): one sample of the discretised model the MPC predicts with
        (`substeps` RK4 steps over `period`) and its exact sensitivities, from the C code."""
        return self._sample(x, u, None)

    def linearisation(
        self, x: Sequence[float] | np.ndarray, u: float
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(F(x, u), A, B) as a step linearises a stage: `rk4`'s, or with ``sensitivities="frozen"``
        (and a stage that ``"shifted"`` computes) A, B from the model's Jacobians at (x, u)
        discretised as RK4 discretises a linear model."""
        return self._sample(x, u, self._method)

    def _sample(self, x: Any, u: float, method: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        state = np.ascontiguousarray(_state("x", x, self.nx), dtype=self._dtype)
        inputs = self._vector([u], 1, "u")
        xn = np.zeros(self.nx, dtype=self._dtype)
        a = np.zeros((self.nx, self.nx), dtype=self._dtype)
        b = np.zeros((self.nx, 1), dtype=self._dtype)
        scratch = np.zeros_like(self.work)
        failed = self._lib.ipgen_mpc_rk4_method(
            ctypes.byref(self._settings), None if method is None else ctypes.byref(method), state.ctypes.data,
            inputs.ctypes.data, xn.ctypes.data, a.ctypes.data, b.ctypes.data, scratch.ctypes.data,
        )  # fmt: skip
        if failed:
            raise MpcError("the model failed at this state (its mass matrix is not positive definite)")
        return xn.astype(float), a.astype(float), b.astype(float)

    def lqr_terminal(self) -> np.ndarray:
        """The discrete LQR's Riccati matrix of (∂F/∂x, ∂F/∂u) at (x_ref, u_ref) with Q, R: the
        default terminal weight P (the infinite-horizon cost-to-go of the linear model)."""
        import scipy.linalg

        _, a, b = self.rk4(self.x_ref, float(self.u_ref[0]))
        try:
            p = scipy.linalg.solve_discrete_are(a, b, self.Q, self.R)
        except (np.linalg.LinAlgError, ValueError) as e:
            raise MpcError(
                f"no terminal weight: the discrete Riccati equation at the reference has no solution ({e})"
            ) from None
        return (p + p.T) / 2


# RK4's growth factor over one step of a linear mode ẋ = λ x, z = h λ: the Taylor polynomial of e^z.
def _check_rk4_stable(
    pendulum: Pendulum | FixedPendulum, x_ref: np.ndarray, u_ref: float, period: float, substeps: int
) -> None:
    """An MpcError unless RK4 with `substeps` steps a sample keeps every mode of the model at the
    reference that does not grow (Re λ <= 0) from growing in the prediction (|R(h λ)| <= 1, h the
    step): a stiff mode (heavy damping on a light body: λ = −976 s⁻¹ at 10 ms, h λ = −9.8) made
    every QP break down and the loop diverge with advice that did not name the cause."""

    from ipgen.control import fixed_linear, linear

    dof = pendulum.dof if isinstance(pendulum, Pendulum) else pendulum.links
    q, qd = x_ref[:dof], x_ref[dof:]
    try:  # the reference was checked to be a rest already: no warning wanted
        if isinstance(pendulum, FixedPendulum):
            a, _ = fixed_linear.linearize_fixed(pendulum.canonical(), q, qd, [u_ref])
        else:
            a, _ = linear.linear_model_at(pendulum.canonical(), q, qd, u_ref)
        worst = rk4_unstable_mode(a, period / substeps)
        if worst is None:
            return
        enough = next((n for n in range(substeps + 1, 101) if rk4_unstable_mode(a, period / n) is None), None)
    except (Error, np.linalg.LinAlgError, ValueError):
        return  # the model's own checks (the terminal weight's Riccati equation) say what is wrong
    fix = "even 100 substeps are not enough: a shorter period"
    if enough:
        fix = f"give substeps = {enough}, or a shorter period"
    raise MpcError(
        f"substeps {substeps}: the prediction's RK4 step of {period / substeps:g} s is unstable for the "
        f"model's mode at s = {complex(worst):.4g} 1/s at the reference (a stiff one: RK4 needs |h s| below "
        f"about 2.8): {fix}"
    )


def mpc(
    pendulum: Pendulum | FixedPendulum,
    *,
    horizon: int = 30,
    period: float = 0.01,
    Q: Any = None,
    R: Any = None,
    P: Any = None,
    u_max: float,
    u_min: float | None = None,
    travel: float | None = None,
    bounds: Mapping[int, Sequence[float]] | None = None,
    soft_bounds: Mapping[int, Sequence[float]] | None = None,
    soft_penalty: tuple[float, float] = (0.0, 1e3),
    reference: Sequence[float] | str = "upright",
    substeps: int = 1,
    mode: str = "rti",
    sqp_iterations: int | None = None,
    cold_iterations: int = 10,
    hessian: str | None = None,
    qp_iterations: int | None = None,
    sqp_tolerance: float | None = None,
    qp_tolerance: float | None = None,
    precision: str = "double",
    barrier: float = 0.0,
    sensitivities: str = "exact",
) -> Mpc:
    """A constrained nonlinear MPC of `pendulum` on its exact model (docs/mpc.md).

    The problem over `horizon` samples of `period` seconds: minimise
    Σ (x_k − x_ref)ᵀ Q (x_k − x_ref) + (u_k − u_ref)ᵀ R (u_k − u_ref) + (x_N − x_ref)ᵀ P (x_N − x_ref)
    (+ the soft bounds' penalty) subject to x_{k+1} = F(x_k, u_k) (RK4, u held), the bounds on u
    and on the states. Solved by Gauss–Newton SQP with an interior-point QP on a Riccati
    recursion, in C (cpp/include/ipgen_mpc.h).

    Parameters
    ----------
    pendulum : Pendulum or FixedPendulum
        The system; a DC motor is folded in (u in volts). A fixed chain drives one joint (u its
        torque [N m], clockwise positive; states without a base: docs/mpc.md).
    horizon : int, default 30
        N, samples predicted.
    period : float, default 0.01
        T [s], the sample period (u held over it).
    Q, R : array_like, optional
        Stage weights: 2·dof diagonal entries or a symmetric PSD matrix (default identity), and
        the weight of u² (> 0, default 1).
    P : array_like, optional
        Terminal weight; default the discrete LQR's Riccati matrix at the reference (`Mpc.lqr_terminal`).
    u_max, u_min : float
        Hard bounds on u (u_min default −u_max); volts for a DC motor, else N or N m.
    travel : float, optional
        Hard bound |θ0| <= travel on the base (rail [m] or arm angle [rad]), predicted states x_1..x_N.
    bounds : dict, optional
        More hard state bounds {state index: (min, max)}.
    soft_bounds : dict, optional
        Soft state bounds {state index: (min, max)}, a violation s costing ρ1 s + ρ2 s².
    soft_penalty : (float, float), default (0, 1000)
        (ρ1, ρ2) of the soft bounds.
    reference : str or array_like, default "upright"
        x_ref: "upright", "hanging", dof angles or a full state (ipgen's coordinates); u_ref = 0.
        A rest: each link at a multiple of π, rates 0, the base anywhere (else `MpcError`; a
        moving reference goes per stage: ``step(x, reference=(states, inputs))``).
    substeps : int, default 1
        RK4 steps per sample.
    mode : str, default "rti"
        "rti": one SQP iteration per step on the shifted warm start (real-time iteration);
        "converged": iterate to `sqp_tolerance` (validation).
    sqp_iterations, qp_iterations : int, optional
        Budgets: SQP iterations per step (rti 1, converged 500) and interior-point iterations per
        QP (rti 20, converged 50).
    cold_iterations : int, default 10
        SQP iterations at most on a cold start (the first step, or after `reset`), if more than
        `sqp_iterations`: the real-time iteration starts from a solved problem.
    hessian : str, optional
        The QPs' Hessian: "gauss-newton" (the cost's: no second derivatives of the model) or
        "exact" (the Lagrangian's, by central differences of the exact sensitivities, from the
        second SQP iteration on; more workspace). Default: "exact" in the converged mode in
        double, else "gauss-newton".
    sqp_tolerance, qp_tolerance : float, optional
        Stop when the SQP step and defects (rti: 0, run the budget; converged 1e-10, float 1e-4)
        and the QP's largest residual (rti 1e-9, converged 1e-10; float 1e-5) are below.
    precision : str, default "double"
        "double" or "float" (the C step compiled with IPGEN_MPC_REAL=float; the model in double).
    barrier : float, default 0
        0: each QP solved by the interior point to `qp_tolerance`. > 0 (rti only): each QP is
        `qp_iterations` Newton steps on its log-barrier problem at this fixed weight, continued
        from the previous sample's slacks and multipliers, shifted (one Riccati factorisation an
        iteration): with ``qp_iterations=1`` the microcontroller's fixed-time step (docs/mpc.md).
    sensitivities : str, default "exact"
        The linearisation of each stage: "exact" (dF/dx, dF/du of the RK4 map) or "frozen" (rti
        only; from the second stage on: the model's Jacobians at the stage's start, discretised as
        RK4 discretises a linear model; one Jacobian a stage instead of four, an inexact Newton
        step with exact defects) or "shifted" (rti only; as "frozen", but a warm step keeps the
        last sample's A, B of stages 2 .. N-1 for its stages 1 .. N-2, the trajectory having moved
        by one sample: the model's Jacobians at the first and the last stage only; the defects
        stay exact).

    Returns
    -------
    Mpc
        `step(x)` → u, `solve(x)`, `reset()`, `trajectory()`, `info`, `P`.

    Raises
    ------
    MpcError
        Bad weights, bounds or sizes; no C compiler; a failed build.

    Examples
    --------
    The QUBE-Servo 2 (u in volts, |u| <= 10 V, the arm within ±1 rad), link tilted by 0.05 rad:

    >>> import ipgen
    >>> controller = ipgen.mpc(ipgen.Pendulum.preset("qube_servo2"), u_max=10.0, travel=1.0)
    >>> u = controller.step([0.0, 0.05, 0.0, 0.0])  # cold: cold_iterations SQP iterations
    >>> controller.info.sqp_iterations
    10
    >>> u = controller.step([0.0, 0.04, 0.0, 0.0])  # then one a sample
    >>> bool(-10.0 <= u <= 10.0), controller.info.status, controller.info.sqp_iterations
    (True, 'ok', 1)
    """
    return Mpc(
        pendulum, horizon=horizon, period=period, Q=Q, R=R, P=P, u_max=u_max, u_min=u_min, travel=travel,
        bounds=bounds, soft_bounds=soft_bounds, soft_penalty=soft_penalty, reference=reference,
        substeps=substeps,
        mode=mode, sqp_iterations=sqp_iterations, cold_iterations=cold_iterations, hessian=hessian,
        qp_iterations=qp_iterations, sqp_tolerance=sqp_tolerance,
        qp_tolerance=qp_tolerance, precision=precision, barrier=barrier, sensitivities=sensitivities,
    )  # fmt: skip
