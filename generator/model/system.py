"""Which system: its type, number of links, inertia variant and parameter names.

This module says *what* the system is; `bodies.py` gives its kinematics and `derivation.py` turns
those into equations of motion without knowing whether the base is a cart or an arm.

Coordinates: θ0 is the cart position [m] or the arm angle [rad]; θ1..θn are absolute link
angles [rad] from the upright vertical, clockwise positive (docs/model.md).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

from ipgen.common.safetext import abbreviate
from ipgen.errors import Error

SystemType = Literal["classical", "rotary"]
Inertia = Literal["pivot", "full"]
SYSTEM_TYPES: tuple[str, ...] = ("classical", "rotary")
INERTIA_VARIANTS: tuple[str, ...] = ("pivot", "full")


class SystemChoiceError(Error, ValueError):
    """A system type, link count or inertia variant ipgen does not have. `field` says which
    ("type", "links" or "inertia"; "rotary-only" for an inertia given to a cart), so that the
    command can say it with its option names."""

    def __init__(self, message: str, field: str) -> None:
        super().__init__(message)
        self.field = field


def system_problem(system_type: object, links: object, inertia: object = None) -> SystemChoiceError | None:
    """What is wrong with (type, links, inertia), or None: the one check of these three values
    (`System`, `check_system`, `model.pendulum.Pendulum`, the command's options).

    Parameters
    ----------
    system_type : object
        Expected "classical" or "rotary".
    links : object
        Expected an int >= 1 (not a bool).
    inertia : object
        "pivot" or "full"; None means not given (a cart then has "pivot"); given to a cart it
        must be "pivot".

    Returns
    -------
    SystemChoiceError or None
        The error to raise (one line in the library's words; `field` names the value), or None.

    Examples
    --------
    >>> str(system_problem("rotary", 0))
    'links must be an integer >= 1 (got 0): it counts the rods in the chain'
    >>> system_problem("rotary", 2, "full") is None
    True
    """
    if not isinstance(system_type, str) or system_type not in SYSTEM_TYPES:
        return SystemChoiceError(
            f"type must be one of {', '.join(SYSTEM_TYPES)} (got {abbreviate(repr(system_type))})", "type"
        )
    if isinstance(links, bool) or not isinstance(links, int):
        return SystemChoiceError(
            f"links must be an integer >= 1 (got {abbreviate(repr(links))}): it counts the rods in the chain",
            "links",
        )
    if links < 1:
        return SystemChoiceError(
            f"links must be an integer >= 1 (got {links}): it counts the rods in the chain", "links"
        )
    if inertia is not None and (not isinstance(inertia, str) or inertia not in INERTIA_VARIANTS):
        return SystemChoiceError(
            f"inertia must be one of {', '.join(INERTIA_VARIANTS)} (got {abbreviate(repr(inertia))})",
            "inertia",
        )
    if inertia not in (None, "pivot") and system_type != "rotary":
        return SystemChoiceError(
            f"inertia {abbreviate(repr(inertia))} applies to rotary systems only: "
            "use 'pivot' or type 'rotary'",
            "rotary-only",
        )
    return None


def check_system(system_type: object, links: object, inertia: object = None) -> System:
    """The `System` (type, links, inertia) name, or the `SystemChoiceError` of `system_problem`.

    Parameters
    ----------
    system_type : str
        "classical" (a cart) or "rotary" (a Furuta arm).
    links : int
        The number of rods in the chain, >= 1.
    inertia : str or None
        "pivot" or "full" (rotary only); None: not given ("pivot").

    Returns
    -------
    System

    Raises
    ------
    SystemChoiceError
        One line naming the wrong value and what is expected.

    Examples
    --------
    >>> check_system("rotary", 2, "full").dof
    3
    """
    problem = system_problem(system_type, links, inertia)
    if problem is not None:
        raise problem
    return System(system_type, links, inertia or "pivot")  # type: ignore[arg-type]


@dataclass(frozen=True)
class System:
    """A classical (cart) or rotary (Furuta arm) base carrying a chain of `links` rods."""

    type: SystemType
    links: int
    inertia: Inertia = "pivot"  # rotary only: "pivot" (published model) or "full" thin rod

    def __post_init__(self) -> None:
        # A cart keeps whichever variant it is given (it has no arm for it to change).
        problem = system_problem(self.type, self.links, self.inertia if self.type == "rotary" else None)
        if problem is None and self.inertia not in INERTIA_VARIANTS:
            problem = system_problem(self.type, self.links, self.inertia)
        if problem is not None:
            raise problem

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
# The links as they are built (docs/model.md, "Links as built"): optional arrays whose defaults
# are the paper's homogeneous rods. com[i]: pivot-to-CoG distance (l_i/2); J[i]: inertia about the
# CoG (m_i l_i²/12), J[0] the rotary arm's about the vertical (m0 l0²/3); J_axial[i]: inertia about
# the link's own axis (0; rotary "full" only); tip[i]: a point mass at the far end of link i (0).
LINK_GROUPS: tuple[str, ...] = ("com", "J", "J_axial", "tip")
# Rod defaults of the link groups that have no default of zero, for messages and documents.
ROD_DEFAULTS: dict[str, str] = {"com": "l/2", "J": "m l²/12 (J0: m0 l0²/3)", "J_axial": "0", "tip": "0"}


def group_indices(group: str, links: int) -> range:
    """The indices a parameter group has: 0..n, except com, J_axial and tip (links only, 1..n)."""
    return range(1, links + 1) if group in ("com", "J_axial", "tip") else range(links + 1)


def parameter_names(links: int) -> tuple[str, ...]:
    """m0..mn, l0..ln, delta0..deltan, g (n = `links`), in this order: the paper's parameters."""
    indices = range(links + 1)
    return (*(f"{group}{i}" for group in PARAMETER_GROUPS for i in indices), "g")


def link_parameter_names(links: int) -> tuple[str, ...]:
    """com1..comn, J0..Jn, J_axial1..J_axialn, tip1..tipn: the links as built, in this order."""
    return tuple(f"{group}{i}" for group in LINK_GROUPS for i in group_indices(group, links))


def all_parameter_names(links: int) -> tuple[str, ...]:
    """`parameter_names` then `link_parameter_names`: every parameter of the general model."""
    return (*parameter_names(links), *link_parameter_names(links))


def parameter_range(links: int) -> str:
    """The names `parameter_names(links)` as messages show them: "m0..m2, ..., delta0..delta2 or g"."""
    return f"m0..m{links}, l0..l{links}, delta0..delta{links} or g"


def all_parameter_range(links: int) -> str:
    """The names `all_parameter_names(links)` as messages show them."""
    return (
        f"m0..m{links}, l0..l{links}, delta0..delta{links}, g, com1..com{links}, J0..J{links}, "
        f"J_axial1..J_axial{links} or tip1..tip{links}"
    )


class UnknownParameter(Error, KeyError):
    """A parameter name the model does not have (a KeyError, as a mapping's; one line)."""

    def __str__(self) -> str:
        return str(self.args[0]) if self.args else ""


def split_parameter(name: str) -> tuple[str, int | None]:
    """ "delta2" -> ("delta", 2), "J_axial1" -> ("J_axial", 1), "g" -> ("g", None);
    `UnknownParameter` (a KeyError) if `name` is no parameter name."""
    if not isinstance(name, str):
        raise UnknownParameter(f"parameter name {name!r}: expected text such as 'm1' or 'g'")
    if name == "g":
        return "g", None
    group = name.rstrip("0123456789")
    if group not in PARAMETER_GROUPS + LINK_GROUPS or group == name:
        raise UnknownParameter(f"unknown parameter {name!r}")
    return group, int(name[len(group) :])


def unused_parameter(system_type: str, name: str, inertia: str = "pivot") -> str | None:
    """Why the model of a `system_type` system (with `inertia`) has no parameter `name` (one of
    its `all_parameter_names`), or None if it has: a cart has no length l0 and no inertia J0;
    J_axial counts only for a rotary system with inertia "full"."""
    if system_type == "classical" and name == "l0":
        return "a cart has no length l0"
    if system_type == "classical" and name == "J0":
        return "a cart has no inertia J0 (its mass m0 is all that matters)"
    if name.startswith("J_axial") and (system_type != "rotary" or inertia != "full"):
        return f"{name} counts only for a rotary system with inertia full"
    return None
