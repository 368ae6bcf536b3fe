"""The rig's own coordinates: how a manufacturer measures the link angles, and the map to ipgen's.

ipgen's (canonical) state is x = [θ0, θ1..θn, θ̇0..θ̇n]: θ0 the cart position or arm angle,
θi the absolute angle of link i from the upright, clockwise positive (docs/model.md). A rig may
measure instead, with s = +1 (positive = "clockwise") or −1 ("counterclockwise") and z = 0
(zero = "upright") or π ("hanging"):

    angles = "absolute":  αi = s (θi − z)                      (i = 1..n)
    angles = "relative":  α1 = s (θ1 − z),  αi = s (θi − θ(i−1))   (i = 2..n: from link i − 1)

and the rates accordingly (θ0 and θ̇0 unchanged). The map is affine, x_user = P x + c, so a
linear model becomes A_u = P A P⁻¹, B_u = P B, and an LQR designed on it gives the gain of
u = −K_u (x_user − x_eq,user) directly.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

from ipgen.common.safetext import abbreviate
from ipgen.errors import Error

if TYPE_CHECKING:
    import numpy as np

ANGLES: tuple[str, ...] = ("absolute", "relative")
ZEROS: tuple[str, ...] = ("upright", "hanging")
POSITIVE: tuple[str, ...] = ("clockwise", "counterclockwise")


def rests(angle: float) -> bool:
    """Whether a link at the absolute angle `angle` (ipgen's, from upright) rests without torque:
    upright or hanging, a multiple of π (to 1e-9 rad)."""
    return abs(math.remainder(float(angle), math.pi)) <= 1e-9


class CoordinateError(Error, ValueError):
    """An unknown convention; the message lists the allowed ones."""


@dataclass(frozen=True)
class Coordinates:
    """A convention for the link angles (module docstring); the default is ipgen's own."""

    angles: str = "absolute"
    zero: str = "upright"
    positive: str = "clockwise"

    def __post_init__(self) -> None:
        for name, value, allowed in (
            ("angles", self.angles, ANGLES),
            ("zero", self.zero, ZEROS),
            ("positive", self.positive, POSITIVE),
        ):
            if not isinstance(value, str) or value not in allowed:
                raise CoordinateError(
                    f"{name} = {abbreviate(repr(value))}: expected {' or '.join(map(repr, allowed))}"
                )

    @property
    def is_canonical(self) -> bool:
        """Whether these are ipgen's own coordinates (absolute, from upright, clockwise)."""
        return self == Coordinates()

    @property
    def sign(self) -> float:
        """1 (clockwise) or −1 (counterclockwise): a torque in this convention's sense is sign
        times ipgen's."""
        return 1.0 if self.positive == "clockwise" else -1.0

    def matrices(self, links: int) -> tuple[np.ndarray, np.ndarray]:
        """(P, c) of x_user = P x + c, for 2 (links + 1) states."""
        import numpy as np

        dof = links + 1
        sign = 1.0 if self.positive == "clockwise" else -1.0
        angle = np.eye(dof)
        for i in range(1, dof):
            angle[i, i] = sign
            if self.angles == "relative" and i >= 2:
                angle[i, i - 1] = -sign
        p = np.zeros((2 * dof, 2 * dof))
        p[:dof, :dof] = angle
        p[dof:, dof:] = angle
        offset = np.zeros(2 * dof)
        z = math.pi if self.zero == "hanging" else 0.0
        last = dof if self.angles == "absolute" else min(dof, 2)
        offset[1:last] = -sign * z
        return p, offset

    def to_user(self, x: np.ndarray, links: int) -> np.ndarray:
        """A state [θ; θ̇] of `links` links in ipgen's coordinates -> in these: P x + c."""
        p, c = self.matrices(links)
        return p @ x + c

    def user_state(self, x: Sequence[float] | np.ndarray, links: int) -> tuple[float, ...]:
        """`to_user` of a state in ipgen's coordinates as plain floats (no -0), as a scene and its
        .cfg and CSV write them."""
        import numpy as np

        return tuple(float(v) + 0.0 for v in self.to_user(np.asarray(x, dtype=float), links))

    def to_canonical(self, x: np.ndarray, links: int) -> np.ndarray:
        """A state in these coordinates -> in ipgen's: P⁻¹ (x − c) (the inverse of `to_user`)."""
        import numpy as np

        p, c = self.matrices(links)
        return np.linalg.solve(p, x - c)
