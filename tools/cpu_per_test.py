"""A pytest plugin: the CPU time of every test, its own and its subprocesses', one line per test.

Where a test run's time goes (docs/testing.md): the pytest worker's own CPU time (user + sys)
and that of the processes it started and waited for (compilers, `ipgen run`), per test, appended
to the file CPU_LOG (default cpu_per_test.log) as "self children wall start nodeid". A compile
another worker did, which this test waited for, counts there, not here. For make test:

    PYTHONPATH=$PWD/tools CPU_LOG=/tmp/cpu.log PYTEST_ADDOPTS="-p cpu_per_test" make test
    sort -k2 -rn /tmp/cpu.log | head    # the tests whose subprocesses took the most
"""

from __future__ import annotations

import os
import resource
import time
from collections.abc import Generator

import pytest


def _cpu_seconds() -> tuple[float, float]:
    """(this process, its waited-for descendants): user + system CPU time [s]."""
    own = resource.getrusage(resource.RUSAGE_SELF)
    children = resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime, children.ru_utime + children.ru_stime


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_protocol(item: pytest.Item, nextitem: pytest.Item | None) -> Generator[None, None, None]:
    """Time one test with its setup and teardown (a session fixture counts in its first test)."""
    own_before, children_before = _cpu_seconds()
    start = time.time()
    yield
    own_after, children_after = _cpu_seconds()
    line = (
        f"{own_after - own_before:.2f} {children_after - children_before:.2f} "
        f"{time.time() - start:.2f} {start:.1f} {item.nodeid}\n"
    )
    with open(os.environ.get("CPU_LOG", "cpu_per_test.log"), "a", encoding="utf-8") as log:
        log.write(line)
