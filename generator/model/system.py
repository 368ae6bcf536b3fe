"""Which system: its type, number of links, inertia variant and parameter names.

This module says *what* the system is; `bodies.py` gives its kinematics and `derivation.py` turns
those into equations of motion without knowing whether the base is a cart or an arm.

Coordinates: θ0 is the cart position [m] or the arm angle [rad]; θ1..θn are absolute link
angles [rad] from the upright vertical, clockwise positive (docs/model.md).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

SystemType = Literal["classical", "rotary"]
Inertia = Literal["pivot", "full"]
SYSTEM_TYPES: tuple[str, ...] = ("classical", "rotary")
INERTIA_VARIANTS: tuple[str, ...] = ("pivot", "full")


@dataclass(frozen=True)
class System:
    """A classical (cart) or rotary (Furuta arm) base carrying a chain of `links` rods."""

    type: SystemType
    links: int
    inertia: Inertia = "pivot"  # rotary only: "pivot" (published model) or "full" thin rod

    def __post_init__(self) -> None:
        if self.type not in SYSTEM_TYPES:
            raise ValueError(f"unknown system type {self.type!r}")
        if self.links < 1:
            raise ValueError("a system needs at least one link")
        if self.inertia not in INERTIA_VARIANTS:
            raise ValueError(f"unknown inertia variant {self.inertia!r}")

    @property
    def dof(self) -> int:
        return self.links + 1

    @property
    def is_rotary(self) -> bool:
        return self.type == "rotary"

    @property
    def default_name(self) -> str:
        """The model name when none is given: "<type><links>", e.g. rotary3."""
        return f"{self.type}{self.links}"


# Parameters: the arrays m, l, delta (index 0 the base, 1..n the links) and g, named m0, l1,
# delta2, g in scenes, --fix and the generated code (and by `polynomial.Algebra`).
PARAMETER_GROUPS: tuple[str, ...] = ("m", "l", "delta")


def parameter_names(links: int) -> tuple[str, ...]:
    """m0..mn, l0..ln, delta0..deltan, g (n = `links`), in this order."""
    indices = range(links + 1)
    return (*(f"{group}{i}" for group in PARAMETER_GROUPS for i in indices), "g")


def parameter_range(links: int) -> str:
    """The names `parameter_names(links)` as messages show them: "m0..m2, ..., delta0..delta2 or g"."""
    return f"m0..m{links}, l0..l{links}, delta0..delta{links} or g"


def split_parameter(name: str) -> tuple[str, int | None]:
    """ "delta2" -> ("delta", 2), "g" -> ("g", None); KeyError if `name` is no parameter name."""
    if name == "g":
        return "g", None
    group = name.rstrip("0123456789")
    if group not in PARAMETER_GROUPS or group == name:
        raise KeyError(f"unknown parameter {name!r}")
    return group, int(name[len(group) :])


def unused_parameter(system_type: str, name: str) -> str | None:
    """Why the model of a `system_type` system has no parameter `name` (one of its
    `parameter_names`), or None if it has: a cart has no length l0."""
    if system_type == "classical" and name == "l0":
        return "a cart has no length l0"
    return None
