"""The sympy symbols of one system: the names of the expression views (`ipgen.derive`)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import sympy as sp


@dataclass(frozen=True)
class Symbols:
    """The sympy symbols of one system, index 0 the base, 1..n the links (sympy views only)."""

    q: tuple[sp.Symbol, ...]  # θ_i
    qd: tuple[sp.Symbol, ...]  # θ̇_i
    qdd: tuple[sp.Symbol, ...]  # θ̈_i (for derivatives of M θ̈ at a known θ̈)
    m: tuple[sp.Symbol, ...]
    l: tuple[sp.Symbol, ...]  # noqa: E741 (the paper's name)
    delta: tuple[sp.Symbol, ...]
    g: sp.Symbol
    # The links as built (docs/model.md); index 0 of com, J_axial and tip is never used.
    com: tuple[sp.Symbol, ...]  # pivot-to-CoG distance of link i [m]
    J: tuple[sp.Symbol, ...]  # inertia about link i's CoG; J[0]: the arm's about the vertical
    J_axial: tuple[sp.Symbol, ...]  # inertia about link i's own axis (rotary "full" only)
    tip: tuple[sp.Symbol, ...]  # point mass at the far end of link i [kg]
    u: sp.Symbol  # force on the cart [N] or torque on the arm [N m]

    @classmethod
    def for_dof(cls, dof: int) -> Symbols:
        import sympy as sp

        idx = range(dof)
        return cls(
            q=tuple(sp.Symbol(f"theta{i}", real=True) for i in idx),
            qd=tuple(sp.Symbol(f"dtheta{i}", real=True) for i in idx),
            qdd=tuple(sp.Symbol(f"ddtheta{i}", real=True) for i in idx),
            m=tuple(sp.Symbol(f"m{i}", positive=True) for i in idx),
            l=tuple(sp.Symbol(f"l{i}", positive=True) for i in idx),
            delta=tuple(sp.Symbol(f"delta{i}", nonnegative=True) for i in idx),
            g=sp.Symbol("g", positive=True),
            com=tuple(sp.Symbol(f"com{i}", real=True) for i in idx),
            J=tuple(sp.Symbol(f"J{i}", nonnegative=True) for i in idx),
            J_axial=tuple(sp.Symbol(f"J_axial{i}", nonnegative=True) for i in idx),
            tip=tuple(sp.Symbol(f"tip{i}", nonnegative=True) for i in idx),
            u=sp.Symbol("u", real=True),
        )

    @property
    def parameters(self) -> tuple[sp.Symbol, ...]:
        """m, l, delta and g: what the default (rod) views are written in."""
        return (*self.m, *self.l, *self.delta, self.g)

    @property
    def link_parameters(self) -> tuple[sp.Symbol, ...]:
        """com, J, J_axial and tip (every index): what general views add to `parameters`."""
        return (*self.com, *self.J, *self.J_axial, *self.tip)
