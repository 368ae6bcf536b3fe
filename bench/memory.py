"""A resident-memory limit for a benchmark's child process (the machine is shared).

An address-space limit (RLIMIT_AS) does not fit a generator on FLINT: FLINT reserves far more
virtual memory than it touches (classical n = 50: 20 GB of address space for 1.6 GB resident),
and a failed allocation aborts the process. `ResidentLimit` instead watches the child's
resident set (`VmRSS` in /proc) and kills it when it exceeds the limit.
"""

from __future__ import annotations

import subprocess
import threading
from pathlib import Path

POLL_S = 0.2


class ResidentLimit:
    """Kill `process` if its resident memory exceeds `limit_gb` (0: no limit); `tripped` says
    whether it did. Use as a context manager around the wait for the process."""

    def __init__(self, process: subprocess.Popen, limit_gb: float) -> None:
        self.process = process
        self.limit_kb = int(limit_gb * 2**20)
        self.tripped = False
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._watch, daemon=True)

    def __enter__(self) -> ResidentLimit:
        if self.limit_kb:
            self._thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self._stop.set()
        if self._thread.is_alive():
            self._thread.join()

    def _watch(self) -> None:
        status = Path(f"/proc/{self.process.pid}/status")
        while not self._stop.wait(POLL_S):
            try:
                lines = status.read_text().splitlines()
            except OSError:
                return  # the process is gone
            rss = next((int(line.split()[1]) for line in lines if line.startswith("VmRSS:")), 0)
            if rss > self.limit_kb:
                self.tripped = True
                self.process.kill()
                return
