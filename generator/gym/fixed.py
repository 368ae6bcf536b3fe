"""Fixed-pivot chains in ipgen.gym: the acrobot, the pendubot and any `FixedPendulum`.

A chain of n links on a fixed pivot, driven by torques at its `joints` (m inputs), has no base:
its state is (θ1..θn, θ̇1..θ̇n) in ipgen's coordinates (absolute angles from upright, clockwise
positive), whatever coordinates its scene is written in. Its kernel runs the chain's own C99
header (`codegen.fixed_header`, the forward dynamics with the rotors and B u for m inputs). The
parameter row is m, l, delta, com, J (n entries each), g, then Ir and gr (m entries each).
Coulomb friction is not in the header (the simulator adds it): a chain with friction is refused.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from decimal import Decimal
from pathlib import Path
from typing import Any

import numpy as np

from ipgen.common.safetext import abbreviate
from ipgen.errors import Error
from ipgen.gym.checks import GymError
from ipgen.model.fixed import FixedPendulum

# The per-link groups of a fixed chain's row, then g, then the per-input groups.
LINK_GROUPS = ("m", "l", "delta", "com", "J")
INPUT_GROUPS = ("Ir", "gr")
# Short names of the RealAIGym leaderboard's rigs (presets acrobot_swingup, pendubot_swingup).
ALIASES = {"acrobot": "acrobot_swingup", "pendubot": "pendubot_swingup"}
LEADERBOARD_TORQUE = 6.0  # N m: the RealAIGym leaderboard's limit on the driven joint


@dataclass(frozen=True)
class FixedSystem:
    """What a fixed chain's kernel is compiled for: its links and driven joints.

    Attributes
    ----------
    links : int
        The number of links n (its degrees of freedom).
    joints : tuple of int
        The driven joints, one input each in this order (1 = the shoulder).
    """

    links: int
    joints: tuple[int, ...]

    @property
    def type(self) -> str:
        """ "fixed"."""
        return "fixed"

    @property
    def dof(self) -> int:
        """The coordinates: one per link (no base)."""
        return self.links

    @property
    def inputs(self) -> int:
        """m: the number of driven joints."""
        return len(self.joints)

    @property
    def name(self) -> str:
        """The model's name, as `ipgen run` names its library: fixed2_j2, fixed2_j1_2."""
        return f"fixed{self.links}_j{'_'.join(map(str, self.joints))}"


def fixed_layout(system: FixedSystem) -> tuple[tuple[str, int], ...]:
    """The parameter row's groups and sizes, in the kernel's order."""
    n, m = system.links, system.inputs
    return (*((name, n) for name in LINK_GROUPS), ("g", 1), *((name, m) for name in INPUT_GROUPS))


def fixed_row(chain: FixedPendulum) -> np.ndarray:
    """The kernel's parameter row of `chain` (`fixed_layout`): com and J resolved, Ir 0 and gr 1
    where not given. A chain with Coulomb friction is a GymError (the kernel has none)."""
    if any(chain.coulomb or ()):
        raise GymError(
            "ipgen.gym does not model Coulomb friction of a fixed-pivot chain yet: give the chain "
            "without it (chain.replace(coulomb=None)) or simulate it with ipgen run"
        )
    values = [*chain.m, *chain.l, *chain.delta, *chain.resolved("com"), *chain.resolved("J"), chain.g]
    values += [*chain.motor("Ir"), *chain.motor("gr")]
    return np.array(values, dtype=np.float64)


def fixed_document(source: Any) -> tuple[FixedPendulum, dict[str, Any]] | None:
    """(the chain, its scene document) if `source` is a fixed chain, a fixed scene file or the
    name of a fixed preset (or "acrobot", "pendubot"); None otherwise."""
    if isinstance(source, FixedPendulum):
        return source, {}
    from ipgen.common.presets import preset_path
    from ipgen.scene.fixed import fixed_pendulum_of, is_fixed_document
    from ipgen.scene.load import parse_document

    if isinstance(source, Path) or (isinstance(source, str) and source.endswith(".toml")):
        path = Path(source)
    elif isinstance(source, str):
        try:
            path = Path(preset_path(ALIASES.get(source, source)))
        except Error:  # not a preset: the cart and arm path says so in its own words
            return None
    else:
        return None
    if not path.is_file():
        return None
    reader, document = parse_document(path)
    if not is_fixed_document(document):
        return None
    tables = {key: value for key, value in document.items() if key in ("system", "parameters", "actuator")}
    return fixed_pendulum_of(reader, tables), document


def scene_torque(document: dict[str, Any]) -> float:
    """The torque limit [N m] a fixed scene states: its swing-up's u_max, else its controller's
    (largest) saturation, else the RealAIGym leaderboard's 6 N m. A limit that is not a finite
    number > 0 is a GymError naming the scene's key."""
    swingup, controller = document.get("swingup"), document.get("controller")
    if isinstance(swingup, dict) and "u_max" in swingup:
        key, given = "swingup.u_max", swingup["u_max"]
    elif isinstance(controller, dict) and "saturation" in controller:
        key, given = "controller.saturation", controller["saturation"]
    else:
        return LEADERBOARD_TORQUE
    values = [_torque(v) for v in (given if isinstance(given, list) else [given])]
    if not values or None in values:
        shown = f"[{', '.join(map(_shown, given))}]" if isinstance(given, list) else _shown(given)
        raise GymError(
            f"the scene's {key} = {abbreviate(shown)}: expected finite numbers > 0 [N m] "
            "(the actions' bound; or pass u_max=...)"
        )
    return max(value for value in values if value is not None)


def _torque(value: object) -> float | None:
    """A scene's torque limit (the reader's Decimal, an int or a float) as a float, if finite and
    > 0; else None."""
    if isinstance(value, bool) or not isinstance(value, int | float | Decimal):
        return None
    number = float(value)
    return number if math.isfinite(number) and number > 0 else None


def _shown(value: object) -> str:
    """A scene's value as its TOML would write it (numbers plain, others quoted)."""
    return (
        str(value)
        if isinstance(value, int | float | Decimal) and not isinstance(value, bool)
        else repr(value)
    )
