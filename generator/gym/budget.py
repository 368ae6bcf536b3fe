"""How many environments fit: the memory a vector environment needs before it allocates it.

`PendulumVectorEnv(spec, num_envs)` holds per environment its parameter row, state, observation,
action, reward, flags and step count, and a numpy Generator (about 1 KB measured with
tracemalloc; counted as `GENERATOR_BYTES`). `check_num_envs` refuses a batch whose need exceeds
half of the memory this process may use (the physical memory, or RLIMIT_AS when lower), so that
`make_vec(..., 10**9)` is a one-line error, not a MemoryError or the kernel's OOM killer.
"""

from __future__ import annotations

import os
import resource

from ipgen.gym.checks import GymError

GENERATOR_BYTES = 2048  # a numpy Generator with its PCG64 state, with margin
SHARE = 0.5  # of the memory this process may use


def env_bytes(dof: int, observation: int) -> int:
    """Bytes one environment of `dof` coordinates and an `observation` of that size needs."""
    params = (7 * dof + 2) * 8
    arrays = 2 * dof * 8 + observation * 4 + 8 + 8 + 1 + 8 + 1 + 1  # state obs action reward flags
    return params + arrays + GENERATOR_BYTES


def usable_bytes() -> int:
    """The memory this process may use: the physical memory, or RLIMIT_AS when that is lower."""
    try:
        physical = os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):  # not POSIX: no bound known
        physical = 1 << 62
    soft, _ = resource.getrlimit(resource.RLIMIT_AS)
    return physical if soft == resource.RLIM_INFINITY else min(physical, soft)


def check_num_envs(num_envs: object, dof: int, observation: int) -> int:
    """`num_envs` if it is an integer >= 1 whose environments fit in `SHARE` of `usable_bytes`;
    else the GymError saying what to pass."""
    if isinstance(num_envs, bool) or not isinstance(num_envs, int) or num_envs < 1:
        raise GymError(f"num_envs = {num_envs!r:.40} must be an integer >= 1")
    need, usable = num_envs * env_bytes(dof, observation), usable_bytes()
    if need > SHARE * usable:
        fits = max(1, int(SHARE * usable // env_bytes(dof, observation)))
        raise GymError(
            f"num_envs = {num_envs:,} needs about {need / 1e9:.3g} GB, more than half of the "
            f"{usable / 1e9:.3g} GB this process may use: pass at most {fits:,}"
        )
    return num_envs
