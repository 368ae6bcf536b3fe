"""The batched step kernel of one model: the generated C99 header plus templates/gym_kernel.c.jinja
(a fixed-pivot chain: its header `codegen.fixed_header` plus templates/gym_fixed_kernel.c.jinja),
compiled once into a shared library and called through ctypes.

Why C and not numpy: an environment step is a handful of RK4 stages of a small dense system;
in numpy each stage costs microseconds of interpreter and array overhead per call, in C it is
tens of nanoseconds, and one call advances N environments without allocating.

Cache: `<cache>/gym/<key>/libipgen_gym_<name>.so`, the key a SHA-256 over the kernel's source
(header included), the C compiler (path and --version) and the flags, next to the simulators'
cache and kept like it (common/build_cache.py: a lock per key, compiled to a temporary name and
renamed, checksummed, a corrupt entry rebuilt).
"""

from __future__ import annotations

import ctypes
from dataclasses import dataclass
from functools import cache, cached_property
from pathlib import Path
from typing import Any

import numpy as np

from ipgen.codegen.c_header import render_c_header
from ipgen.codegen.fixed_header import FixedHeaderRequest, fixed_command, render_fixed
from ipgen.codegen.header import HeaderRequest, environment
from ipgen.common.build_cache import (
    Recipe,
    c_compiler,
    cache_root,
    cached_build,
    compiler_key,
    last_error_line,
)
from ipgen.common.version import __version__
from ipgen.errors import Error
from ipgen.gym.fixed import FixedSystem, fixed_layout
from ipgen.model.derivation import derive
from ipgen.model.system import System

# No -Werror: the kernel is compiled on the user's machine, where a newer compiler may warn where
# ours does not, and that must not stop an environment (tests/test_gym.py compiles the same
# sources with -Werror).
FLAGS = ("-std=c99", "-O3", "-fPIC", "-shared", "-Wall", "-Wextra", "-Wpedantic")
TEMPLATE = "gym_kernel.c.jinja"
FIXED_TEMPLATE = "gym_fixed_kernel.c.jinja"
# The order of the task constants in the kernel's cfg[] (its enum).
CFG_FIELDS = ("dt", "substeps", "u_max", "x_limit", "angle_limit", "task", "integrator")
TASK_CODES = {"balance": 0, "swingup": 1, "cartpole": 2}
INTEGRATOR_CODES = {"rk4": 0, "euler": 1}


class KernelError(Error, RuntimeError):
    """The kernel could not be built; the message names the missing piece."""


def model_name(system: System | FixedSystem) -> str:
    """The header's and kernel's model name: classical2, rotary1_pivot, rotary3_full, fixed2_j2."""
    if isinstance(system, FixedSystem):
        return system.name
    name = f"{system.type}{system.links}"
    return f"{name}_{system.inertia}" if system.is_rotary else name


def parameter_count(dof: int) -> int:
    """Entries of one environment's parameter row (the kernel's PARAMS)."""
    return 7 * dof + 2


def row_size(system: System | FixedSystem) -> int:
    """Entries of one environment's parameter row of `system`."""
    if isinstance(system, FixedSystem):
        return sum(size for _, size in fixed_layout(system))
    return parameter_count(system.dof)


def observation_size(system: System | FixedSystem) -> int:
    """q[0], (sin, cos) of each link angle, every rate (a fixed chain: no q[0])."""
    if isinstance(system, FixedSystem):
        return 3 * system.links
    return 1 + 2 * system.links + system.dof


def fixed_sources(system: FixedSystem) -> tuple[str, str]:
    """(the chain's C header, the kernel's source) of a fixed chain; deterministic."""
    name = system.name
    command = fixed_command(name, system.links, system.joints, ("c",))
    header = render_fixed(FixedHeaderRequest(name, system.links, system.joints, command), "c")[".h"]
    kernel = (
        environment()
        .get_template(FIXED_TEMPLATE)
        .render(
            name=name,
            nameu=name.upper(),
            links=system.links,
            joints=list(system.joints),
            inputs=system.inputs,
            dof=system.dof,
            observation_size=observation_size(system),
            version=__version__,
        )
    )
    return header, kernel


def sources(system: System | FixedSystem) -> tuple[str, str]:
    """(the C header, the kernel's source) of `system`; deterministic."""
    if isinstance(system, FixedSystem):
        return fixed_sources(system)
    name = model_name(system)
    header = render_c_header(
        derive(system),
        HeaderRequest(name, f"ipgen --type {system.type} --links {system.links} --emit c -o <dir>"),
    )
    kernel = (
        environment()
        .get_template(TEMPLATE)
        .render(
            name=name,
            nameu=name.upper(),
            type=system.type,
            links=system.links,
            dof=system.dof,
            observation_size=observation_size(system),
            version=__version__,
        )
    )
    return header, kernel


def cache_folder() -> Path:
    """`<cache>/gym`, next to the simulators (the same rules as `ipgen run`'s cache)."""
    return cache_root() / "gym"


def build(system: System | FixedSystem) -> Path:
    """The compiled kernel of `system`: from the cache, or compiled into it."""
    header, kernel = sources(system)
    name = model_name(system)
    cc = c_compiler(KernelError)
    recipe = Recipe(
        sources={f"{name}.h": header, f"gym_{name}.c": kernel},
        command=lambda entry, library: [cc, *FLAGS, f"-I{entry}", str(entry / f"gym_{name}.c"), "-o",
                                        str(library), "-lm"],
        error=KernelError,
        failed=lambda output: f"compiling the gym kernel of {name} failed: {last_error_line(output)}",
        what=f"the gym kernel of {name}",
        noun="gym kernel",
    )  # fmt: skip
    key = compiler_key(cc, " ".join(FLAGS), header, kernel)
    return cached_build(cache_folder(), key, f"libipgen_gym_{name}.so", recipe).path


_DOUBLES = np.ctypeslib.ndpointer(dtype=np.float64, flags="C_CONTIGUOUS")
_FLOATS = np.ctypeslib.ndpointer(dtype=np.float32, flags="C_CONTIGUOUS")
_BYTES = np.ctypeslib.ndpointer(dtype=np.uint8, flags="C_CONTIGUOUS")


@dataclass(frozen=True)
class Kernel:
    """The loaded kernel of one model: `step` and `observe` over N environments at once."""

    system: System | FixedSystem
    library: ctypes.CDLL

    def _step_function(self) -> Any:
        """A fresh handle on the C step function (its argtypes are the caller's to set)."""
        return self.library[f"ipgen_gym_{model_name(self.system)}_step"]

    def bound_step(
        self, params: np.ndarray, state: np.ndarray, action: Any, cfg: np.ndarray, obs: np.ndarray,
        reward: Any, terminated: Any,
    ) -> Any:  # fmt: skip
        """`step` over fixed buffers as a call without arguments: numpy arrays (written in place
        only, never replaced) or ctypes scalars, converted once. numpy's per-call argument checks
        cost more than a small environment's whole step."""
        function = self._step_function()
        function.restype = ctypes.c_long
        function.argtypes = None  # the arguments below are ctypes objects already

        def pointer(buffer: Any) -> Any:  # an array's data, or a ctypes scalar by reference
            if isinstance(buffer, np.ndarray):
                return ctypes.c_void_p(buffer.ctypes.data)
            return ctypes.byref(buffer)

        arguments = (
            ctypes.c_long(len(state)), *map(pointer, (params, state, action, cfg, obs)),
            ctypes.c_long(obs.shape[1]), *map(pointer, (reward, terminated)),
        )  # fmt: skip
        return lambda: function(*arguments)

    @cached_property
    def _step(self) -> Any:
        function = self._step_function()
        function.restype = ctypes.c_long
        function.argtypes = [ctypes.c_long, _DOUBLES, _DOUBLES, _DOUBLES, _DOUBLES, _FLOATS, ctypes.c_long,
                             _DOUBLES, _BYTES]  # fmt: skip
        return function

    @cached_property
    def _observe(self) -> Any:
        function = self.library[f"ipgen_gym_{model_name(self.system)}_observe"]
        function.restype = None
        function.argtypes = [ctypes.c_long, _DOUBLES, _DOUBLES, _FLOATS, ctypes.c_long]
        return function

    def step(
        self,
        params: np.ndarray,
        state: np.ndarray,
        action: np.ndarray,
        cfg: np.ndarray,
        obs: np.ndarray,
        reward: np.ndarray,
        terminated: np.ndarray,
    ) -> int:
        """Advance every row of `state` (N × 2 dof, in place) by cfg's dt; returns the failures.
        `params` N rows, `action` N entries (a fixed chain: N × m), `reward`, `terminated` (uint8)
        N entries, `obs` N rows (float32)."""
        return int(self._step(len(state), params, state, action, cfg, obs, obs.shape[1], reward, terminated))

    def observe(self, state: np.ndarray, cfg: np.ndarray, obs: np.ndarray) -> None:
        """The observations of every row of `state` (after a reset)."""
        self._observe(len(state), state, cfg, obs, obs.shape[1])


@cache
def load(system: System | FixedSystem) -> Kernel:
    """The kernel of `system`, built if needed and loaded once per process."""
    return Kernel(system, ctypes.CDLL(str(build(system))))
