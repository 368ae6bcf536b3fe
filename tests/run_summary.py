"""What `ipgen run`'s summary (OUT/<stem>.txt) says about the simulator it ran.

The tests share one simulator cache (tests/conftest.py), which holds binaries of earlier runs and
other models too: a test finds the binary its run used by the path the summary names, never by
searching the cache.
"""

from __future__ import annotations

import re
from pathlib import Path

_SIMULATOR = re.compile(r"Simulator (.+?) \((built in [0-9.]+ s|taken from the cache, not compiled)\)\.")


def simulator_of(summary: str) -> Path:
    """The simulator binary the run used, as the summary names it."""
    found = _SIMULATOR.search(summary)
    assert found is not None, f"the summary names no simulator: {summary[:300]!r}"
    binary = Path(found.group(1))
    assert binary.is_file(), binary
    return binary


def was_built(summary: str) -> bool:
    """Whether the run compiled its simulator (False: taken from the cache)."""
    found = _SIMULATOR.search(summary)
    assert found is not None, f"the summary names no simulator: {summary[:300]!r}"
    return found.group(2).startswith("built")
