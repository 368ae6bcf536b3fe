"""The model a loop is designed with in a sweep's run: the nominal scene's.

A sweep changes the plant and keeps the controller designed for the nominal scene (its gains, its
plan, its estimator). Where the loop runs a model, the model is part of its design: an MPC's
predictions, the energy swing-up's mass matrix and bias, an EKF's dynamics, the prediction over a
delay. The simulator otherwise takes it from the run's own (changed) parameters: a run with the
masses × 1.25 would give them the true masses, a run with Rm × 1.2 the true motor. `model_lines`
reads the nominal resolved config's plant parameters and states them as `controller.model.*`
(cpp/include/ipsim/scene.hpp, Scene::design), which the run's config then carries after its own.
"""

from __future__ import annotations

# Plant keys of a resolved config -> the design model's keys (a dc_motor's folded parameters and
# gain; a fixed chain's rotors).
PLANT_KEYS: dict[str, str] = {
    **{
        key: f"controller.model.{key}"
        for key in ("m", "l", "delta", "g", "com", "J", "J_axial", "tip", "Ir", "gr")
    },
    "actuator.gain": "controller.model.gain",
}


# Resolved-config lines (spaces removed) of a loop that runs a model at run time: an MPC, the energy
# swing-up, an EKF, the prediction over a delay (the others run numbers designed before the run:
# gains, plans, a Kalman gain).
MODEL_USERS = ("controller=mpc", "swingup=energy", "estimator=ekf", "estimator.predict=1")


def runs_a_model(cfg: str) -> bool:
    """Whether a resolved config's loop runs a model (MODEL_USERS)."""
    lines = {line.replace(" ", "") for line in cfg.splitlines()}
    return any(line in lines for line in MODEL_USERS)


def model_lines(nominal_cfg: str) -> list[str]:
    """`controller.model.* = ...` lines holding the plant parameters of the nominal resolved config
    `nominal_cfg`, as written there (the same text: the nominal run predicts with bit-identical
    numbers; com and J where it writes them, else the simulator's rods of these m and l, as for
    the plant); none when its loop runs no model or the config states its model already."""
    if not runs_a_model(nominal_cfg) or "\ncontroller.model." in f"\n{nominal_cfg}":  # none, or stated
        return []
    lines = []
    for line in nominal_cfg.splitlines():
        key, equals, value = line.partition("=")
        if equals and key.strip() in PLANT_KEYS:
            lines.append(f"{PLANT_KEYS[key.strip()]} = {value.strip()}")
    return lines
