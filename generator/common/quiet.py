"""Warnings silenced around a call, safely when ipgen runs in several threads.

`warnings.catch_warnings` saves and restores the process-wide filter list: before Python 3.14 it
is not thread-safe, and two threads' save/restore pairs interleaved left a thread's "ignore"
filter in place for the whole process (a thread-safety audit: four threads building MPCs left
`ignore EquilibriumWarning` behind, and the user's own warnings were dropped for good). ipgen's
blocks take one lock, so that they never interleave; a warning another thread raises while one
is open is still silenced for that moment.
"""

from __future__ import annotations

import contextlib
import os
import threading
import warnings
from collections.abc import Iterator

_LOCK = threading.RLock()


def _after_fork() -> None:
    """A child forked while a thread held the lock (inside a silenced call) would wait on it for
    good: a new lock."""
    global _LOCK
    _LOCK = threading.RLock()


os.register_at_fork(after_in_child=_after_fork)


@contextlib.contextmanager
def ignoring(category: type[Warning]) -> Iterator[None]:
    """Warnings of `category` (and its subclasses) silenced inside the block."""
    with _LOCK, warnings.catch_warnings():
        warnings.simplefilter("ignore", category)
        yield
