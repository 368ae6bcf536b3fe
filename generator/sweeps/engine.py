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


def default_jobs() -> int:
    """All cores this process may use."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


@contextlib.contextmanager
def executor(dask: str | None = None, jobs: int | None = None) -> Iterator[tuple[Executor, int]]:
    """(executor, its number of workers): Dask's for a scheduler address, else a process pool."""
    if jobs is not None and jobs < 1:
        raise SweepError(f"--jobs {jobs}: give a number of worker processes >= 1")
    if dask is None:
        workers = jobs or default_jobs()
        with ProcessPoolExecutor(max_workers=workers) as pool:
            yield pool, workers
        return
    try:
        from distributed import Client
    except ImportError:
        raise SweepError(f"--dask needs Dask's distributed scheduler: {DASK_INSTALL}") from None
    try:
        client = Client(dask, timeout=CONNECT_TIMEOUT, set_as_default=False)
    except (OSError, TimeoutError, ValueError) as error:
        raise SweepError(
            f"--dask {abbreviate(dask)}: cannot reach a Dask scheduler there "
            f"({abbreviate(' '.join(str(error).split()), 120)}); "
            "start one with `dask scheduler` (docs/sweep.md)"
        ) from None
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
