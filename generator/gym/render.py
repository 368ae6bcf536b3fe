"""`render_mode="rgb_array"`: a drawing of one environment's state to scale (matplotlib, Agg).

A cart is drawn from the front (the rail horizontal, the links in the picture's plane), a chain on
a fixed pivot likewise from its pivot; a Furuta arm in a cabinet projection (the arm turning in
the horizontal plane, drawn foreshortened, the links swinging across it).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from ipgen.gym.spec import EnvSpec

SIZE = (480, 360)  # pixels


def points(spec: EnvSpec, state: np.ndarray, row: np.ndarray) -> np.ndarray:
    """The drawing's 2-D points: the base's point, then each link's far end."""
    dof = spec.system.dof
    lengths = spec.group(row, "l")
    q = state[:dof]
    if spec.system.type == "fixed":  # from the pivot at the origin, link 1 first
        xs, ys = [0.0], [0.0]
        for i in range(dof):
            xs.append(xs[-1] + lengths[i] * math.sin(q[i]))
            ys.append(ys[-1] + lengths[i] * math.cos(q[i]))
        return np.column_stack([xs, ys])
    if spec.system.type == "classical":
        xs, ys = [q[0]], [0.0]
        for i in range(1, dof):
            xs.append(xs[-1] + lengths[i] * math.sin(q[i]))
            ys.append(ys[-1] + lengths[i] * math.cos(q[i]))
        return np.column_stack([xs, ys])
    arm = lengths[0]
    tip = np.array([arm * math.cos(q[0]), arm * math.sin(q[0]), 0.0])
    tangent = np.array([-math.sin(q[0]), math.cos(q[0]), 0.0])
    chain = [np.zeros(3), tip]
    for i in range(1, dof):
        across = np.array([0.0, 0.0, math.cos(q[i])]) + math.sin(q[i]) * tangent
        chain.append(chain[-1] + lengths[i] * across)
    return np.array([[p[0] + 0.5 * p[1], p[2] + 0.35 * p[1]] for p in chain])


def draw(spec: EnvSpec, state: np.ndarray, row: np.ndarray) -> np.ndarray:
    """An RGB image (height × width × 3, uint8) of the state."""
    import matplotlib.patches
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    figure = Figure(figsize=(SIZE[0] / 100, SIZE[1] / 100), dpi=100)
    canvas = FigureCanvasAgg(figure)
    axes = figure.add_axes((0, 0, 1, 1))
    reach = float(np.sum(spec.group(row, "l"))) * 1.15 or 1.0
    chain = points(spec, state, row)
    if spec.system.type == "classical":
        centre = chain[0, 0]
        axes.plot([centre - 2 * reach, centre + 2 * reach], [0, 0], color="0.6", lw=1)
        axes.add_patch(matplotlib.patches.Rectangle((chain[0, 0] - 0.15 * reach, -0.08 * reach),
                                                    0.3 * reach, 0.16 * reach, color="0.3"))  # fmt: skip
        axes.set_xlim(centre - reach * 4 / 3, centre + reach * 4 / 3)
    elif spec.system.type == "fixed":
        axes.plot([-0.2 * reach, 0.2 * reach], [0, 0], color="0.3", lw=4)  # the pivot's mount
        axes.set_xlim(-reach * 4 / 3, reach * 4 / 3)
    else:
        axes.plot(chain[:2, 0], chain[:2, 1], color="0.3", lw=4)
        axes.set_xlim(-reach * 4 / 3, reach * 4 / 3)
    axes.plot(chain[1:, 0] if spec.system.type == "rotary" else chain[:, 0],
              chain[1:, 1] if spec.system.type == "rotary" else chain[:, 1],
              color="tab:blue", lw=3, marker="o")  # fmt: skip
    axes.set_ylim(-reach, reach)
    axes.set_aspect("equal", adjustable="box")
    axes.axis("off")
    canvas.draw()
    return np.asarray(canvas.buffer_rgba())[..., :3].copy()
