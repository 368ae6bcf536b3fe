"""The links as built: their parameters' defaults (the paper's rods) and what values are allowed.

Parameters (docs/model.md, "Links as built"), arrays indexed 0 (the base) to n:
- com[i] (i >= 1): pivot-to-CoG distance of link i [m], default l_i/2. Any finite value is
  allowed: a negative com puts the CoG on the other side of the pivot (a counterweight), one
  beyond l_i past the far end; the model is the same rigid body either way.
- J[i] (i >= 1): inertia about the CoG across the link [kg m²] >= 0, default m_i l_i²/12;
  J[0]: the rotary arm's about the vertical >= 0, default m0 l0²/3 (a cart: unused, 0).
- J_axial[i] (i >= 1): inertia about the link's own axis [kg m²], 0 <= J_axial <= 2 J (an
  axisymmetric body: J_axial = ∫(x² + y²) dm = 2∫x² dm <= 2 J), default 0. Read by the rotary
  "full" inertia only.
- tip[i] (i >= 1): point mass at the far end of link i [kg] >= 0, default 0.
And every link must have some inertia about its pivot (J_i + m_i com_i² + (mass beyond) l_i² > 0),
or the mass matrix is singular.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from ipgen.errors import Error
from ipgen.model.system import LINK_GROUPS, System

# Relative slack of the J_axial <= 2 J test: values computed in floating point (2 J of a disc)
AXIAL_SLACK = 1e-12


class LinkError(Error, ValueError):
    """A link parameter that no real body has; the message names it and the fix."""


@dataclass(frozen=True)
class LinkValues:
    """com, J, J_axial, tip: one float per index 0..n each (index 0 of com, J_axial, tip unused)."""

    com: tuple[float, ...]
    J: tuple[float, ...]
    J_axial: tuple[float, ...]
    tip: tuple[float, ...]

    def flat(self) -> list[float]:
        """com, J, J_axial, tip concatenated: the order `Symbols.link_parameters` uses."""
        return [*self.com, *self.J, *self.J_axial, *self.tip]


def rod_value(system: System, group: str, i: int, m: Sequence[float], l: Sequence[float]) -> float:  # noqa: E741
    """The paper's rod value of parameter `group`[i] for masses m and lengths l."""
    if group == "com":
        return l[i] / 2 if i else 0.0
    if group == "J":
        if i == 0:
            return m[0] * l[0] * l[0] / 3 if system.is_rotary else 0.0
        return m[i] * l[i] * l[i] / 12  # products, not **: a huge length gives inf, not OverflowError
    return 0.0


def resolve_links(
    system: System,
    m: Sequence[float],
    l: Sequence[float],  # noqa: E741
    given: dict[str, Sequence[float] | None],
) -> LinkValues:
    """The links' values: each group of `given` (com, J, J_axial, tip; None: the rods) with dof
    entries, checked (`link_problem`); LinkError with a one-line message if one is not allowed."""
    dof = system.dof
    values: dict[str, tuple[float, ...]] = {}
    for group in LINK_GROUPS:
        entries = given.get(group)
        if entries is None:
            values[group] = tuple(rod_value(system, group, i, m, l) for i in range(dof))
            continue
        try:
            numbers = tuple(float(v) for v in entries)
        except (TypeError, ValueError):
            raise LinkError(f"{group} must be a list of {dof} numbers (base, link 1, ...)") from None
        if len(numbers) != dof:
            raise LinkError(f"{group} has {len(numbers)} entries, expected {dof} (links + 1 = base + links)")
        values[group] = numbers
    links = LinkValues(values["com"], values["J"], values["J_axial"], values["tip"])
    problem = link_problem(system, m, l, links)
    if problem:
        raise LinkError(problem)
    return links


def value_problem(system: System, name: str, group: str, value: float) -> str | None:
    """Why `name` (of `group`) = value is not allowed on its own, or None."""
    if not math.isfinite(value):
        return f"{name} = {value}: must be a finite number"
    if group in ("J", "J_axial", "tip") and value < 0:
        what = "a mass" if group == "tip" else "an inertia"
        return f"{name} = {value:g}: {what} cannot be negative (use 0 for none)"
    return None


def link_problem(system: System, m: Sequence[float], l: Sequence[float], links: LinkValues) -> str | None:  # noqa: E741
    """Why these links cannot be built, or None (the rules of the module docstring)."""
    n = system.links
    for group in LINK_GROUPS:
        for i, value in enumerate(getattr(links, group)):  # index 0's too: unused, but not nonsense
            problem = value_problem(system, f"{group}[{i}]", group, value)
            if problem:
                return problem
    for i in range(1, n + 1):
        axial, across = links.J_axial[i], links.J[i]
        if axial > 2 * across * (1 + AXIAL_SLACK):
            return (
                f"J_axial[{i}] = {axial:g} > 2 J[{i}] = {2 * across:g}: no axisymmetric body has that; "
                "check the two inertias (J is about an axis across the link, J_axial about the link)"
            )
    beyond = 0.0
    for i in range(n, 0, -1):
        beyond += links.tip[i]
        pivot = links.J[i] + m[i] * links.com[i] * links.com[i] + beyond * l[i] * l[i]
        if not pivot > 0:
            return (
                f"link {i} has no inertia about its pivot (J[{i}] = 0, com[{i}] = 0 and nothing beyond "
                "it): give it a J, a com or a tip mass"
            )
        beyond += m[i]
    return None
