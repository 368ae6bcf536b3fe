"""What a scene with `specialise = true` folds into its header (`model.specialise`)."""

from __future__ import annotations

from typing import TYPE_CHECKING

from ipgen.common.safetext import quote_path
from ipgen.model.specialise import ENERGY_FUNCTIONS, FUNCTIONS, SIMULATOR_FUNCTIONS, Specialisation
from ipgen.model.system import unused_parameter

if TYPE_CHECKING:
    from ipgen.scene.reader import Scene


def from_scene(scene: Scene) -> Specialisation:
    """What a scene with `specialise = true` needs: every parameter but its `free` ones folded,
    the simulator's functions (and the energies for an energy ledger), a zero input pruned."""
    fixed = tuple(
        (name, scene.exact(name))
        for name in scene.parameter_names()
        if name not in scene.free and unused_parameter(scene.type, name) is None
    )
    outputs = SIMULATOR_FUNCTIONS + (ENERGY_FUNCTIONS if scene.energy else ())
    return Specialisation(
        fixed=fixed,
        outputs=tuple(f for f in FUNCTIONS if f in outputs),
        zero_input=scene.input.kind == "zero" and scene.controller is None,
        scene=quote_path(scene.path.as_posix()),  # it is quoted in the header's comments
    )
