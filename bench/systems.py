"""The systems the benchmarks time, and the ipgen command that generates one.

Shared by bench/generation.py, bench/evaluation.py and tools/time_generation.py. Light on
purpose (no sympy, tqdm or matplotlib): the tool imports it too.
"""

from __future__ import annotations

from ipgen.model.system import SYSTEM_TYPES
from ipgen.pipeline.job import LINKS_WITHOUT_FORCE

TYPES: tuple[str, ...] = SYSTEM_TYPES
LINKS: tuple[int, ...] = (1, 2, 3, 5, 10, 20)


def ipgen_command(python: str, kind: str, links: int, out: str) -> list[str]:
    """`python -m generator --type KIND --links N -o OUT`, with the --force ipgen asks for above
    LINKS_WITHOUT_FORCE links."""
    force = ["--force"] if links > LINKS_WITHOUT_FORCE else []
    return [python, "-m", "ipgen", "--type", kind, "--links", str(links), "-o", out, *force]
