"""SIGTERM as an interruption: a command that starts processes or writes scratch files (ipgen
sweep, ipgen run) ends as Ctrl-C ends it, its clean-up run, instead of Python's default for
SIGTERM, which ends the process at once."""

from __future__ import annotations

import contextlib
import signal
from collections.abc import Iterator


class Terminated(KeyboardInterrupt):
    """SIGTERM, raised where the command is: it ends as an interruption does."""


def _terminate(signum: int, frame: object) -> None:
    raise Terminated(signum)


@contextlib.contextmanager
def sigterm_interrupts() -> Iterator[None]:
    """SIGTERM as `Terminated` while the block runs (not the main thread: nothing installed)."""
    try:
        previous = signal.signal(signal.SIGTERM, _terminate)
    except ValueError:
        yield
        return
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


def interrupted_status(interrupt: BaseException) -> int:
    """The exit status of an interrupted command: 128 + SIGTERM for `Terminated` (also as the
    cause of click's Abort, which click raises from an interruption), 130 (SIGINT) else."""
    seen: BaseException | None = interrupt
    while seen is not None:
        if isinstance(seen, Terminated):
            return 128 + int(signal.SIGTERM)
        seen = seen.__cause__ or seen.__context__
    return 130
