"""Where runs execute: a local process pool (all cores by default) or a Dask cluster, both through
`concurrent.futures`. Tasks go in batches (one submission runs many runs in one process), results
come back as batches finish; the order of the table does not depend on the engine.
"""

from __future__ import annotations

import contextlib
import math
import os
from collections.abc import Callable, Iterator
from concurrent.futures import Executor, ProcessPoolExecutor, as_completed

from ipgen.common.install import install_hint
from ipgen.common.safetext import abbreviate
from ipgen.sweeps.execute import Result, SceneSource, Task, run_batch
from ipgen.sweeps.spec import SweepError
from ipgen.sweeps.success import Success

DASK_INSTALL = install_hint("dask")
CONNECT_TIMEOUT = "5s"
CONNECT_SECONDS = 5.0  # the whole of reaching the scheduler: connection, handshake, first answer
# Schemes of a scheduler another process can reach (inproc:// is within one process only).
SCHEMES: tuple[str, ...] = ("tcp", "tls", "ws", "wss", "ucx")


def default_jobs() -> int:
    """All cores this process may use."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def check_address(address: str) -> str:
    """`address` as a Dask scheduler address SCHEME://HOST:PORT (tcp:// when no scheme is
    written), or the one-line SweepError saying what to write; checked before anything runs."""
    text = address.strip()
    if text and "://" not in text:
        text = f"tcp://{text}"
    scheme, host, port = _parts(text)
    number = int(port) if port.isascii() and port.isdigit() else 0
    if scheme not in SCHEMES or not host or not 0 < number < 65536:
        raise SweepError(
            f"--dask {abbreviate(address)!r} is not a scheduler address: write SCHEME://HOST:PORT with "
            f"SCHEME one of {', '.join(SCHEMES)}, e.g. tcp://10.0.0.5:8786 (docs/sweep.md)"
        )
    return text


def _parts(address: str) -> tuple[str, str, str]:
    """SCHEME://HOST:PORT as (scheme, host without IPv6 brackets, port text); "" where absent."""
    scheme, _, location = address.partition("://")
    host, colon, port = location.rpartition(":")
    return scheme, host.strip("[]") if colon else "", port if colon else ""


def _unreachable(address: str, why: str) -> SweepError:
    return SweepError(
        f"--dask {abbreviate(address)}: cannot reach a Dask scheduler there "
        f"({abbreviate(' '.join(why.split()), 120)}); start one with `dask scheduler` (docs/sweep.md)"
    )


def probe(address: str, seconds: float = CONNECT_SECONDS) -> None:
    """A SweepError unless a Dask scheduler answers at `address` within `seconds` in all
    (connection, handshake and its identity): a listener that accepts and never answers, or no
    listener, is found here, before a `Client` (and its background loop) exists."""
    import asyncio

    from distributed.core import rpc
    from distributed.security import Security

    scheme, host, port = _parts(address)

    async def identity() -> None:
        # A plain connection first: nothing listening is refused at once (Dask's own connect
        # retries a refused connection until its timeout); the same deadline covers both.
        if scheme in ("tcp", "tls", "ws", "wss"):
            _, writer = await asyncio.open_connection(host, int(port))
            writer.close()
            await writer.wait_closed()
        args = Security().get_connection_args("client")
        async with rpc(address, connection_args=args, timeout=seconds) as scheduler:
            await scheduler.identity()

    def answered() -> None:  # in a thread of its own: the caller may be inside an event loop (Jupyter)
        asyncio.run(asyncio.wait_for(identity(), seconds))

    from concurrent.futures import ThreadPoolExecutor

    try:
        with ThreadPoolExecutor(max_workers=1) as thread:
            thread.submit(answered).result()
    except TimeoutError:
        raise _unreachable(address, f"no answer within {seconds:g} s") from None
    except ConnectionRefusedError:
        raise _unreachable(address, "connection refused: nothing listens at that port") from None
    except (OSError, ValueError, RuntimeError, TypeError) as error:  # unknown host, bad TLS
        raise _unreachable(address, str(error) or type(error).__name__) from None


def _worker_signals() -> None:
    """A pool worker's signals: the default SIGTERM (the command's handler, inherited through fork,
    would raise in the worker and print its traceback when the pool ends it) and no SIGINT (a
    Ctrl-C reaches the whole process group; the command ends the workers itself)."""
    import signal

    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    signal.signal(signal.SIGINT, signal.SIG_IGN)


@contextlib.contextmanager
def _local(workers: int) -> Iterator[Executor]:
    """A process pool of `workers`; interrupted (or failed), its queued batches are cancelled and
    its workers ended at once (a batch in progress is not waited for: its runs are in no table)."""
    pool = ProcessPoolExecutor(max_workers=workers, initializer=_worker_signals)
    try:
        yield pool
    except BaseException:
        processes = list((getattr(pool, "_processes", None) or {}).values())
        manager = getattr(pool, "_executor_manager_thread", None)  # shutdown forgets it
        pool.shutdown(wait=False, cancel_futures=True)
        for process in processes:
            with contextlib.suppress(OSError, ValueError, AttributeError):
                process.terminate()
        for process in processes:
            with contextlib.suppress(OSError, ValueError, AttributeError, AssertionError):
                process.join(timeout=5)
        # The pool's manager thread closes its wake-up pipe as it ends. Python 3.11's exit hook
        # (concurrent.futures.process._python_exit) writes to that pipe without a lock; while the
        # thread is still ending, the write can meet the closed pipe and print a traceback
        # (OSError: Bad file descriptor) after the one-line message. Ended first, it is quiet.
        if manager is not None:
            manager.join(timeout=5)
        raise
    pool.shutdown(wait=True)


@contextlib.contextmanager
def executor(dask: str | None = None, jobs: int | None = None) -> Iterator[tuple[Executor, int]]:
    """(executor, its number of workers): Dask's for a scheduler address, else a process pool."""
    if jobs is not None and jobs < 1:
        raise SweepError(f"--jobs {jobs}: give a number of worker processes >= 1")
    if dask is None:
        workers = jobs or default_jobs()
        with _local(workers) as pool:
            yield pool, workers
        return
    address = check_address(dask)
    try:
        from distributed import Client
    except ImportError:
        raise SweepError(f"--dask needs Dask's distributed scheduler: {DASK_INSTALL}") from None
    probe(address)
    try:
        client = Client(address, timeout=CONNECT_TIMEOUT, set_as_default=False)
    except (OSError, TimeoutError, ValueError) as error:
        raise _unreachable(dask, str(error)) from None
    try:
        workers = sum(client.nthreads().values())
        if workers == 0:
            raise SweepError(
                f"--dask {abbreviate(dask)}: the scheduler has no workers; start `dask worker ADDRESS`"
            )
        with client.get_executor(pure=False) as pool:
            yield pool, workers
    finally:
        client.close()


def batches(tasks: list[Task], workers: int) -> list[list[Task]]:
    """Tasks in batches: about eight per worker (an even load, a moving progress bar), at most 32 runs."""
    size = max(1, min(32, math.ceil(len(tasks) / (8 * workers))))
    return [tasks[i : i + size] for i in range(0, len(tasks), size)]


def execute(
    pool: Executor,
    workers: int,
    source: SceneSource,
    tasks: list[Task],
    test: Success,
    done: Callable[[list[Result]], None] = lambda results: None,
) -> None:
    """Run `tasks` on `pool` (from `executor`), calling `done` with each finished batch's results."""
    futures = [pool.submit(run_batch, source, batch, test) for batch in batches(tasks, workers)]
    try:
        for future in as_completed(futures):
            done(future.result())
    except BaseException:
        for future in futures:
            future.cancel()
        raise
