"""The PNG of an identification: measured against simulated angles, and the residuals."""

from __future__ import annotations

import io
from typing import TYPE_CHECKING

from ipgen.common.files import MARKER

if TYPE_CHECKING:
    from ipgen.identification.fit import Fit

__all__ = ["identify_png"]

POINTS = 4000  # samples drawn at most per curve


def identify_png(fit: Fit, system_type: str, title: str) -> bytes:
    """One row per coordinate: measured (dots), simulated at the start (equation error, dashed)
    and at the estimate (solid); below each, the residual measured − simulated."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    t = np.asarray(fit.t)
    stride = max(1, len(t) // POINTS)
    dof = fit.measured.shape[1]
    fig, axes = plt.subplots(2 * dof, 1, figsize=(9, 2.3 * 2 * dof), sharex=True,
                             gridspec_kw={"height_ratios": [3, 1] * dof})  # fmt: skip
    for i in range(dof):
        ax, rax = axes[2 * i], axes[2 * i + 1]
        unit = "m" if i == 0 and system_type == "classical" else "rad"
        name = "θ0 (cart)" if i == 0 and system_type == "classical" else ("θ0 (arm)" if i == 0 else f"θ{i}")
        ax.plot(t[::stride], fit.measured[::stride, i], ".", ms=2, color="0.55", label="measured")
        ax.plot(t[::stride], fit.simulated_start[::stride, i], "--", lw=1, color="tab:orange",
                label="equation-error start")  # fmt: skip
        ax.plot(t[::stride], fit.simulated[::stride, i], "-", lw=1.2, color="tab:blue", label="identified")
        ax.set_ylabel(f"{name} [{unit}]")
        ax.grid(alpha=0.3)
        residual = fit.measured[::stride, i] - fit.simulated[::stride, i]
        rax.plot(t[::stride], residual, lw=0.6, color="tab:blue")
        rax.set_ylabel("residual")
        rax.grid(alpha=0.3)
        if i == 0:
            ax.legend(loc="upper right", fontsize=8)
    axes[-1].set_xlabel("t [s]")
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    buffer = io.BytesIO()
    fig.savefig(buffer, dpi=100, format="png", metadata={"Software": f"{MARKER} (ipgen identify)"})
    plt.close(fig)
    return buffer.getvalue()
