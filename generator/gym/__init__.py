"""ipgen.gym: exact n-link cart and Furuta pendulums as gymnasium environments (extra `gym`).

    import ipgen.gym
    env = ipgen.gym.make("qube_servo2", task="swingup")       # a preset, a scene file or a Pendulum
    env = gymnasium.make("ipgen/RotaryDouble-SwingUp-v0")      # registered on import of ipgen.gym
    envs = gymnasium.make_vec("ipgen/CartSingle-Balance-v0", num_envs=1024,
                              vectorization_mode="vector_entry_point")

Every step runs the generated C99 equations in a compiled kernel (RK4 with substeps, batched
over environments and parameter sets); docs/gym.md states the observations, rewards,
terminations and what one step is accurate to.
"""

from __future__ import annotations

from ipgen.common.install import install_hint

try:
    import gymnasium  # noqa: F401
except ModuleNotFoundError as missing:  # one line that says what to install, not a bare import error
    if missing.name != "gymnasium":
        raise
    message = f"ipgen.gym needs gymnasium >= 1.0: {install_hint('gymnasium')}"
    raise ModuleNotFoundError(message, name="gymnasium") from None

from ipgen.gym.registry import make, make_vec, register_all

__all__ = ["make", "make_vec", "register_all"]

register_all()
