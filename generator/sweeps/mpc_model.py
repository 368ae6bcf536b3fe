"""The model an MPC predicts with in a sweep's run: the nominal scene's.

A sweep changes the plant and keeps the controller designed for the nominal scene (its gains, its
plan, its estimator). An MPC's design includes the model it predicts with, which the simulator
otherwise takes from the run's own (changed) parameters: a run with the masses × 1.25 would give
the MPC the true masses. `model_lines` reads the nominal resolved config's plant parameters and
states them as `controller.model.*` (cpp/include/ipsim/scene.hpp, load_mpc), which the run's config
then carries after its own.
"""

from __future__ import annotations

# Plant keys of a resolved config -> the MPC's model keys (a dc_motor's folded parameters and gain;
# a fixed chain's rotors).
PLANT_KEYS: dict[str, str] = {
    **{
        key: f"controller.model.{key}"
        for key in ("m", "l", "delta", "g", "com", "J", "J_axial", "tip", "Ir", "gr")
    },
    "actuator.gain": "controller.model.gain",
}


def is_mpc(cfg: str) -> bool:
    """Whether a resolved config's controller is an MPC (`controller = mpc`)."""
    return any(line.replace(" ", "") == "controller=mpc" for line in cfg.splitlines())


def model_lines(nominal_cfg: str) -> list[str]:
    """`controller.model.* = ...` lines holding the plant parameters of the nominal resolved config
    `nominal_cfg`, as written there (the same text: the nominal run predicts with bit-identical
    numbers; com and J where it writes them, else the simulator's rods of these m and l, as for
    the plant); none when its controller is not an MPC or the config states its model already."""
    if not is_mpc(nominal_cfg) or "\ncontroller.model." in f"\n{nominal_cfg}":  # none, or stated already
        return []
    lines = []
    for line in nominal_cfg.splitlines():
        key, equals, value = line.partition("=")
        if equals and key.strip() in PLANT_KEYS:
            lines.append(f"{PLANT_KEYS[key.strip()]} = {value.strip()}")
    return lines
