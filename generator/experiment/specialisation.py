"""What a scene with `specialise = true` folds into its header (`model.specialise`)."""

from __future__ import annotations

from fractions import Fraction
from typing import TYPE_CHECKING

from ipgen.common.safetext import quote_path
from ipgen.model.specialise import ENERGY_FUNCTIONS, FUNCTIONS, SIMULATOR_FUNCTIONS, Specialisation
from ipgen.model.system import link_parameter_names, split_parameter, unused_parameter

if TYPE_CHECKING:
    from ipgen.experiment.scene import Scene


def from_scene(scene: Scene) -> Specialisation:
    """What a scene with `specialise = true` needs: every parameter but its `free` ones folded,
    the simulator's functions (and the energies for an energy ledger), a zero input pruned."""
    motor = scene.motor_folded()  # a dc_motor: delta0 and m0 or J0 folded with it (exactly)
    fixed = tuple(
        (name, motor.get(name, scene.exact(name)))
        for name in scene.parameter_names()
        if name not in scene.free and unused_parameter(scene.type, name) is None
    ) + tuple((name, motor.get(name, value)) for name, value in _rod_links(scene))
    outputs = SIMULATOR_FUNCTIONS + (ENERGY_FUNCTIONS if scene.energy else ())
    if scene.swingup is not None and scene.swingup.method == "energy":
        outputs += ("mass_matrix", "bias")  # the energy law evaluates M and the bias at the state
    return Specialisation(
        fixed=fixed,
        outputs=tuple(f for f in FUNCTIONS if f in outputs),
        zero_input=scene.input.kind == "zero" and scene.controller is None and scene.swingup is None,
        scene=quote_path(scene.path.as_posix()),  # it is quoted in the header's comments
        motor=bool(motor),
    )


def _rod_links(scene: Scene) -> tuple[tuple[str, Fraction], ...]:
    """The links as built, exactly: as the scene gives them, else at the paper's rods' values
    (com = l/2, J = m l²/12, J0 = m0 l0²/3, tip = J_axial = 0) where m and l are folded too (a
    free m or l keeps its rod default computed at run time)."""
    folded = []
    given = scene.link_values()
    for name in link_parameter_names(scene.links):
        if unused_parameter(scene.type, name, scene.inertia):
            continue
        group, index = split_parameter(name)
        assert index is not None
        if group in given:  # written in the scene: its exact decimal
            folded.append((name, scene.exact(name)))
            continue
        if group in ("com", "J") and {f"m{index}", f"l{index}"} & set(scene.free):
            continue
        mass, length = scene.exact(f"m{index}"), scene.exact(f"l{index}")
        if group == "com":
            value = length / 2
        elif group == "J":
            value = mass * length**2 / (3 if index == 0 else 12)
        else:
            value = Fraction(0)
        folded.append((name, value))
    return tuple(folded)
