"""ipgen_loop.h for Python: the sampled loop's algorithms, compiled once and called through ctypes.

cpp/include/ipgen_loop.h holds the loop's algorithms once, in C99 (the quantiser, the delay,
saturation, the estimators, the energy swing-up): the firmware header prints it, the simulator
includes it, and Python calls it through this module. The estimators' `step`
(`ipgen.estimation.estimators`), `Sensors.quantise`, ipgen.gym's measured observation and
delayed action (`ipgen.gym.sensing`) and `EnergySwingUp.control` run it; Python keeps the design
(gains, covariances, the energy law's constants).

The library is the header compiled with `-DIPGEN_LOOP_EXPORT` (its functions exported) together
with cpp/src/ipgen_loop_batch.c (the structs' layout, for the check below, and the batched
calls ipgen.gym makes over N environments), by the C compiler of the model libraries ($CC, else
cc, else gcc) with FLAGS (-std=c99: ISO C, so no floating-point contraction into fused
multiply-adds). Cache: `<cache>/loop/<key>/libipgen_loop.so`, the key a SHA-256 over the two
sources, the compiler (path and --version) and the flags, kept like the gym kernels' cache
(common/build_cache.py: a lock per key, compiled to a temporary name and renamed, checksummed).

Nothing is compiled on import: `library()` builds (or finds) and loads the library on its first
call, once per process (thread-safe), and checks that the ctypes structures below have the C
structs' sizes and offsets. Arrays are passed as addresses (`address`): float64 (int32 for
index lists), C-contiguous, kept alive by the caller for as long as C may read them.
"""

from __future__ import annotations

import ctypes
import os
import threading
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ipgen.common.build_cache import runtime_library
from ipgen.common.install import REINSTALL
from ipgen.common.locations import cmake_dir
from ipgen.common.safetext import shown_path
from ipgen.errors import Error

if TYPE_CHECKING:
    import numpy as np

__all__ = [
    "FIELD",
    "FLAGS",
    "MASS_BIAS",
    "PHASES",
    "EkfFilter",
    "EnergyLaw",
    "KalmanFilter",
    "LoopRuntimeError",
    "Measurement",
    "SwingUp",
    "SwingUpState",
    "address",
    "ekf_work",
    "library",
    "swingup_work",
]

# No -Werror here: a user's newer compiler may warn where ours does not, and that must not stop a
# run (tests/test_loop_runtime.py compiles the same sources with -Werror).
FLAGS = ("-std=c99", "-O2", "-shared", "-fPIC", "-DIPGEN_LOOP_EXPORT", "-Wall", "-Wextra", "-Wpedantic")
HEADER = "ipgen_loop.h"
GLUE = "ipgen_loop_batch.c"
TARGET = "libipgen_loop.so"
LAYOUT_ENTRIES = 54  # IPGEN_LOOP_BATCH_LAYOUT
LAYOUT_ROOM = 1024  # entries the check lets C write: a library with more fields fails cleanly
PHASES = ("swing", "track", "hold")  # IPGEN_LOOP_SWING, _TRACK, _HOLD

_real = ctypes.c_double
_real_p = ctypes.POINTER(ctypes.c_double)
_address = ctypes.c_void_p


class LoopRuntimeError(Error, RuntimeError):
    """The loop library could not be built or loaded; the message names the missing piece."""


# ---- the header's types, mirrored (checked against the compiled layout when loaded) ----------

FIELD = ctypes.CFUNCTYPE(ctypes.c_int, ctypes.c_void_p, _real_p, _real, _real_p, _real_p)
"""ipgen_loop_field: (context, x, u, f, A or NULL) -> 0, non-zero if the model fails."""

MASS_BIAS = ctypes.CFUNCTYPE(ctypes.c_int, ctypes.c_void_p, _real_p, _real_p, _real_p, _real_p)
"""ipgen_loop_mass_bias: (context, q, qd, M, b) -> 0, non-zero if the model fails."""


class Measurement(ctypes.Structure):
    """ipgen_loop_measurement: sizes, the measured coordinates (int32 addresses) and x_eq."""

    _fields_ = [("dof", ctypes.c_int), ("count", ctypes.c_int), ("measured", _address), ("x_eq", _address)]


class KalmanFilter(ctypes.Structure):
    """ipgen_loop_kalman: the steady-state Kalman filter's A, B, M (addresses) and u_eq."""

    _fields_ = [
        ("measurement", Measurement), ("A", _address), ("B", _address), ("M", _address), ("u_eq", _real),
    ]  # fmt: skip


class EkfFilter(ctypes.Structure):
    """ipgen_loop_ekf: the extended Kalman filter's period, gain, Qn, Rn and its model `field`; with
    gain_spread > 0 it learns the input gain too (x gets rho)."""

    _fields_ = [
        ("measurement", Measurement), ("period", _real), ("gain", _real), ("Qn", _address), ("Rn", _address),
        ("field", FIELD), ("context", ctypes.c_void_p),
        ("gain_spread", _real), ("gain_drift", _real),  # 0: the gain is not learnt
        ("noise_weight", _real), ("noise_margin", _real),  # 0: Rn is fixed
        ("noise_floor", _address), ("noise_ceiling", _address), ("noise", _address),
    ]  # fmt: skip


class Lag(ctypes.Structure):
    """ipgen_loop_lag: a known drive lag over one period, e^(-T/lag), the start's weight w in the
    period's mean, the inverse's gain 1/(1 - w), and the commands' bound."""

    _fields_ = [("decay", _real), ("weight", _real), ("boost", _real), ("limit", _real)]


class EnergyLaw(ctypes.Structure):
    """ipgen_loop_energy_law: the Åström–Furuta law's constants."""

    _fields_ = [
        *((name, _real) for name in (
            "gain_energy", "gain_position", "gain_velocity", "accel_max", "catch_angle", "catch_rate",
            "energy_target", "energy_inertia", "energy_weight",
        )),
        ("acceleration", ctypes.c_int), ("input_gain", _real),
        ("energy_step", _real),  # 0: the target is fixed
        ("catch_deficit", _real), ("catch_base", _real),  # 0: no such condition on a catch
    ]  # fmt: skip


class SwingUp(ctypes.Structure):
    """ipgen_loop_swingup: the energy law or a tracked plan, then the hold."""

    _fields_ = [
        ("dof", ctypes.c_int), ("u_max", _real), ("hold_gain", _address), ("target", _address),
        ("energy", EnergyLaw), ("steps", ctypes.c_long), ("inputs", _address), ("states", _address),
        ("gains", _address), ("mass_bias", MASS_BIAS), ("context", ctypes.c_void_p),
        ("feedback", ctypes.c_void_p),  # null: ipgen_loop_feedback
        ("catch_law", ctypes.c_void_p), ("catch_context", ctypes.c_void_p),  # null: the hold's LQR
        ("catch_every", ctypes.c_long),
        ("release_angle", _real), ("catch_reset", ctypes.c_void_p),  # 0, null: the hold is for good
        ("track_law", ctypes.c_void_p), ("track_horizon", ctypes.c_int),  # null: the plan's gains track
        ("track_refs", _address),
        ("gain_factor", _address),  # null: u is not divided by a learnt gain
    ]  # fmt: skip


class SwingUpState(ctypes.Structure):
    """ipgen_loop_swingup_state: the phase (an index of PHASES), the samples seen, the upright held,
    a catch law's sample of the catch and last u, and what the energy law learns of its target."""

    _fields_ = [
        ("phase", ctypes.c_int), ("k", ctypes.c_long), ("hold_q1", _real), ("hold_sample", ctypes.c_long),
        ("catch_u", _real),
        ("energy_offset", _real), ("rate_before", _real), ("last_peak", _real),
        ("in_window", ctypes.c_int), ("swinging", ctypes.c_int),
    ]  # fmt: skip


def _layout() -> list[int]:
    """What ipgen_loop_batch_layout writes, from the ctypes mirrors (the order of the C file)."""

    def offset(struct: type[ctypes.Structure], name: str) -> int:
        return int(getattr(struct, name).offset)

    return [
        ctypes.sizeof(_real),
        ctypes.sizeof(Measurement), offset(Measurement, "measured"), offset(Measurement, "x_eq"),
        ctypes.sizeof(KalmanFilter), offset(KalmanFilter, "A"), offset(KalmanFilter, "M"),
        offset(KalmanFilter, "u_eq"),
        ctypes.sizeof(EkfFilter),
        *(offset(EkfFilter, n) for n in ("period", "gain", "Qn", "Rn", "field", "context")),
        offset(EkfFilter, "gain_spread"), offset(EkfFilter, "gain_drift"),
        *(offset(EkfFilter, n) for n in (
            "noise_weight", "noise_margin", "noise_floor", "noise_ceiling", "noise",
        )),
        ctypes.sizeof(EnergyLaw),
        *(offset(EnergyLaw, n) for n in (
            "energy_weight", "acceleration", "input_gain", "energy_step", "catch_deficit", "catch_base",
        )),
        ctypes.sizeof(SwingUp),
        *(offset(SwingUp, n) for n in ("u_max", "target", "energy", "steps", "gains", "mass_bias")),
        offset(SwingUp, "context"), offset(SwingUp, "catch_every"), offset(SwingUp, "release_angle"),
        offset(SwingUp, "catch_reset"), offset(SwingUp, "track_law"), offset(SwingUp, "track_horizon"),
        offset(SwingUp, "track_refs"), offset(SwingUp, "gain_factor"),
        ctypes.sizeof(SwingUpState), offset(SwingUpState, "k"), offset(SwingUpState, "hold_q1"),
        offset(SwingUpState, "catch_u"), offset(SwingUpState, "energy_offset"),
        offset(SwingUpState, "swinging"),
        ctypes.sizeof(Lag), offset(Lag, "boost"), offset(Lag, "limit"),
        ctypes.sizeof(ctypes.c_long),
    ]  # fmt: skip


def ekf_work(states: int, count: int) -> int:
    """IPGEN_LOOP_EKF_WORK(n, c): scratch entries of one EKF sample (n states: 2 dof, one more
    when it learns the gain; c measured)."""
    n, c = states, count
    return 6 * n + 4 * n * n + n * c + 2 * c * c + 2 * c


def swingup_work(dof: int) -> int:
    """IPGEN_LOOP_SWINGUP_WORK(dof): scratch entries of one swing-up sample."""
    return dof * dof + 3 * dof


def address(array: np.ndarray) -> int:
    """The data address of a C-contiguous array (for a c_void_p argument or field); the caller
    keeps `array` alive while C may use it."""
    if not array.flags.c_contiguous:
        raise ValueError("the loop library needs C-contiguous arrays")
    return int(array.ctypes.data)


# ---- building and loading ----------------------------------------------------------------------

# (name, restype, argtypes) of every function the library exports.
_P = ctypes.c_void_p
_I = ctypes.c_int
_L = ctypes.c_long
SIGNATURES: tuple[tuple[str, Any, tuple[Any, ...]], ...] = (
    ("ipgen_loop_quantise", _real, (_real, _real, _real)),
    ("ipgen_loop_saturate", _real, (_real, _real)),
    ("ipgen_loop_delay", _real, (_P, _I, _real)),
    ("ipgen_loop_lag_rate", _real, (_real, _real, _real)),
    ("ipgen_loop_lag_of", Lag, (ctypes.c_double, ctypes.c_double, ctypes.c_double)),
    ("ipgen_loop_lag_mean", _real, (ctypes.POINTER(Lag), _real, _P)),
    ("ipgen_loop_lag_ahead", _real, (ctypes.POINTER(Lag), _real, _I, _P, _P)),
    ("ipgen_loop_lag_command", _real, (ctypes.POINTER(Lag), _real, _real)),
    ("ipgen_loop_difference", None, (_I, _real, _L, _P, _P, _P)),
    ("ipgen_loop_filter", None, (_I, _real, _real, _L, _P, _P, _P)),
    ("ipgen_loop_start_state", None, (ctypes.POINTER(Measurement), _P, _P)),
    ("ipgen_loop_kalman_update", None, (ctypes.POINTER(KalmanFilter), _L, _P, _real, _P, _P)),
    ("ipgen_loop_ekf_update", _I, (ctypes.POINTER(EkfFilter), _L, _P, _real, _P, _P, _P)),
    ("ipgen_loop_rk4", _I, (FIELD, _P, _I, _real, _real, _P, _P, _P, _P)),
    ("ipgen_loop_predict", _I, (FIELD, _P, _I, _real, _real, _I, _P, _P, _P, _P)),
    ("ipgen_loop_upright", _real, (_real,)),
    ("ipgen_loop_energy_caught", _I, (ctypes.POINTER(EnergyLaw), _real, _real)),
    ("ipgen_loop_energy_ready", _I, (ctypes.POINTER(EnergyLaw), _I, _P)),
    ("ipgen_loop_link_energy", _real, (ctypes.POINTER(EnergyLaw), _real, _real)),
    ("ipgen_loop_energy_input", _real, (ctypes.POINTER(EnergyLaw), _I, _P, _P, _P, _P)),
    ("ipgen_loop_feedback", _real, (_I, _real, _P, _P, _P)),
    ("ipgen_loop_swingup_start", None, (ctypes.POINTER(SwingUp), ctypes.POINTER(SwingUpState))),
    ("ipgen_loop_swingup_step", _real, (ctypes.POINTER(SwingUp), ctypes.POINTER(SwingUpState), _P, _P)),
    ("ipgen_loop_plan_reference", None, (ctypes.POINTER(SwingUp), _L, _L, _I, _P, _P)),
    ("ipgen_loop_batch_layout", _L, (_P,)),
    ("ipgen_loop_batch_ekf_work", _L, (_L, _L)),
    ("ipgen_loop_batch_observe", _L,
     (_L, _P, _I, _P, _P, _P, _I, _real, _real, _real, _L, _P, _P, _P, _L, _P)),
    ("ipgen_loop_batch_delay", None, (_L, _P, _I, _P, _P, _P)),
)  # fmt: skip


def sources() -> tuple[str, str]:
    """(ipgen_loop.h, ipgen_loop_batch.c) of this installation (package or checkout)."""
    root = cmake_dir().parent  # the installed package's folder ipgen/, or the checkout
    header, glue = root / "cpp" / "include" / HEADER, root / "cpp" / "src" / GLUE
    if not (header.is_file() and glue.is_file()):
        raise LoopRuntimeError(f"the loop library's sources are missing from {shown_path(root)}: {REINSTALL}")
    return header.read_text(), glue.read_text()


def build() -> Path:
    """The compiled loop library: from the cache, or compiled into it (module docstring)."""
    header, glue = sources()
    return runtime_library(
        "loop", {HEADER: header, GLUE: glue}, GLUE, FLAGS, TARGET, LoopRuntimeError,
        "the loop library (ipgen_loop.h)", "loop library",
    )  # fmt: skip


def declare(loaded: ctypes.CDLL) -> ctypes.CDLL:
    """Set the restype and argtypes of every function of SIGNATURES; check the structs' layout."""
    for name, restype, argtypes in SIGNATURES:
        function = getattr(loaded, name)
        function.restype, function.argtypes = restype, list(argtypes)
    room = (ctypes.c_long * LAYOUT_ROOM)()
    count = loaded.ipgen_loop_batch_layout(ctypes.addressof(room))
    written = list(room)[: max(0, min(count, LAYOUT_ROOM))]
    if count != LAYOUT_ENTRIES or written != _layout():
        raise LoopRuntimeError(
            "the loop library's structs do not match ipgen.common.loop_runtime's mirrors "
            f"(C {written}, Python {_layout()}): update the mirrors with ipgen_loop.h"
        )
    for n, c in ((n, c) for n in range(1, 10) for c in range(1, 5)):  # up to 4 links and rho
        work = loaded.ipgen_loop_batch_ekf_work(n, c)
        if work != ekf_work(n, c):
            raise LoopRuntimeError(
                f"the loop library's IPGEN_LOOP_EKF_WORK({n}, {c}) is {work}, ekf_work's {ekf_work(n, c)}: "
                "update ipgen.common.loop_runtime.ekf_work with ipgen_loop.h"
            )
    return loaded


_lock = threading.Lock()
_loaded: ctypes.CDLL | None = None


def _after_fork() -> None:
    """A child forked while a thread held the lock (compiling the library) would wait on it for
    good: a new lock."""
    global _lock
    _lock = threading.Lock()


os.register_at_fork(after_in_child=_after_fork)


def library() -> ctypes.CDLL:
    """The loop library with its functions declared: built if needed, loaded once per process.

    Returns
    -------
    ctypes.CDLL
        ipgen_loop.h's functions (``ipgen_loop_quantise``, ...) and ipgen_loop_batch.c's, each
        with its restype and argtypes (SIGNATURES).

    Raises
    ------
    LoopRuntimeError
        No C compiler was found (the message names the package to install), the sources are
        missing from the installation, or the compilation failed.
    """
    global _loaded
    loaded = _loaded
    if loaded is not None:
        return loaded
    with _lock:
        if _loaded is None:
            path = build()
            try:
                _loaded = declare(ctypes.CDLL(str(path)))
            except OSError as e:
                raise LoopRuntimeError(f"cannot load the loop library {shown_path(path)}: {e}") from None
        return _loaded
