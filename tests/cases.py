"""The small systems the symbolic and the independent checks both cover: (type, links, inertia)."""

from __future__ import annotations

CASES = [
    ("classical", 1, "pivot"),
    ("classical", 2, "pivot"),
    ("classical", 3, "pivot"),
    ("rotary", 1, "pivot"),
    ("rotary", 1, "full"),
    ("rotary", 2, "pivot"),
    ("rotary", 2, "full"),
]


def case_id(case: tuple[str, int, str]) -> str:
    """A test id such as classical2 or rotary1-full (the inertia only matters for rotary)."""
    kind, links, inertia = case
    return f"{kind}{links}" + (f"-{inertia}" if kind == "rotary" else "")
