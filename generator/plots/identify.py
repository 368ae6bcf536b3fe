"""The PNG of an identification: measured against simulated angles, and the residuals."""

from __future__ import annotations

import io
from typing import TYPE_CHECKING

from ipgen.common.files import MARKER

if TYPE_CHECKING:
    from matplotlib.figure import Figure

    from ipgen.identification.fit import Fit
    from ipgen.model.coordinates import Coordinates

__all__ = ["coordinates_note", "identify_figure", "identify_png"]

POINTS = 4000  # samples drawn at most per curve


def coordinates_note(coordinates: Coordinates | None) -> str:
    """The line under the title saying in which coordinates the angles are drawn."""
    if coordinates is None or coordinates.is_canonical:
        return "angles in ipgen's coordinates (absolute, 0 upright, clockwise), as in the CSV"
    sense = "counterclockwise" if coordinates.positive == "counterclockwise" else "clockwise"
    return (
        f"angles in the CSV's coordinates, the scene's [system]: {coordinates.angles}, "
        f"0 {coordinates.zero}, {sense} (the fit runs in ipgen's)"
    )


def identify_figure(fit: Fit, system_type: str, title: str, coordinates: Coordinates | None = None) -> Figure:
    """One row per coordinate: measured (dots), simulated at the start (equation error, dashed)
    and at the estimate (solid); below each, the residual measured − simulated. The fit works in
    ipgen's coordinates; with the scene's `coordinates` (a rig's convention) everything is drawn
    back in them, the CSV's, and the line under the title says so."""
    import numpy as np
    from matplotlib.figure import Figure

    t = np.asarray(fit.t)
    stride = max(1, len(t) // POINTS)
    dof = fit.measured.shape[1]

    def shown(angles: np.ndarray) -> np.ndarray:
        if coordinates is None or coordinates.is_canonical:
            return angles
        p, c = coordinates.matrices(dof - 1)
        return angles @ p[:dof, :dof].T + c[:dof]

    measured, start, simulated = (
        shown(np.asarray(a)) for a in (fit.measured, fit.simulated_start, fit.simulated)
    )
    fig = Figure(figsize=(9, 2.3 * 2 * dof + 0.3))
    axes = fig.subplots(2 * dof, 1, sharex=True, gridspec_kw={"height_ratios": [3, 1] * dof})
    for i in range(dof):
        ax, rax = axes[2 * i], axes[2 * i + 1]
        unit = "m" if i == 0 and system_type == "classical" else "rad"
        name = "θ0 (cart)" if i == 0 and system_type == "classical" else ("θ0 (arm)" if i == 0 else f"θ{i}")
        ax.plot(t[::stride], measured[::stride, i], ".", ms=2, color="0.55", label="measured")
        ax.plot(t[::stride], start[::stride, i], "--", lw=1, color="tab:orange",
                label="equation-error start")  # fmt: skip
        ax.plot(t[::stride], simulated[::stride, i], "-", lw=1.2, color="tab:blue", label="identified")
        ax.set_ylabel(f"{name} [{unit}]")
        ax.grid(alpha=0.3)
        residual = measured[::stride, i] - simulated[::stride, i]
        rax.plot(t[::stride], residual, lw=0.6, color="tab:blue")
        rax.set_ylabel("residual")
        rax.grid(alpha=0.3)
        if i == 0:
            ax.legend(loc="upper right", fontsize=8)
    axes[-1].set_xlabel("t [s]")
    fig.suptitle(f"{title}\n{coordinates_note(coordinates)}", fontsize=10)
    fig.tight_layout()
    return fig


def identify_png(fit: Fit, system_type: str, title: str, coordinates: Coordinates | None = None) -> bytes:
    """The PNG of `identify_figure`."""
    fig = identify_figure(fit, system_type, title, coordinates)
    buffer = io.BytesIO()
    fig.savefig(buffer, dpi=100, format="png", metadata={"Software": f"{MARKER} (ipgen identify)"})
    return buffer.getvalue()
