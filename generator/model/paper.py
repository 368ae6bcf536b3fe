"""The paper's rigs (Jadlovská & Sarnovský 2013): the default values where no scene gives any.

A cart of 0.3 kg or an arm of 0.5 kg and 0.6 m, each link 0.275 kg and 0.5 m, the paper's damping
(scenes/cdip_pulse.toml, scenes/rsip_pulse.toml); every link like the first.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from ipgen.model.pendulum import Pendulum

# type -> group -> (base, each link)
PAPER_RIGS: dict[str, dict[str, tuple[float, float]]] = {
    "classical": {"m": (0.3, 0.275), "l": (0.0, 0.5), "delta": (0.3, 0.1)},
    "rotary": {"m": (0.5, 0.275), "l": (0.6, 0.5), "delta": (0.3, 0.011458)},
}


def paper_pendulum(type: str, links: int, inertia: str = "pivot") -> Pendulum:
    """The paper's rig of `type` with `links` equal links, as an `ipgen.Pendulum`."""
    from ipgen.model.pendulum import Pendulum

    values = PAPER_RIGS[type]
    base_and_links = {k: (values[k][0], *[values[k][1]] * links) for k in ("m", "l", "delta")}
    return Pendulum(type, links, inertia=inertia if type == "rotary" else "pivot", **base_and_links)
