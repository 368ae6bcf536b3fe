"""Scene-key overrides applied to a scene's TOML document in memory (no file is written).

A value replaces the key (`parameters.m = [...]`) or one entry (`parameters.m[1] = 0.3`); an entry
of an array the scene does not write is taken from the nominal scene's resolved value (the
initial state, the links' rod values com and J, no Coulomb friction). Floats become `Decimal`s
of their shortest repr, as if written in the file, so the scene's own validation (bounds,
relations between keys) judges every level with its usual one-line messages.
"""

from __future__ import annotations

import copy
from collections.abc import Callable
from decimal import Decimal
from typing import TYPE_CHECKING, Any

from ipgen.model.links import rod_value
from ipgen.sweeps.spec import Key, SweepError, parse_key

if TYPE_CHECKING:
    from ipgen.experiment.scene import Scene


def as_toml(value: object) -> object:
    """A Python value as the TOML parser would give it (floats as Decimal, lists recursively)."""
    if isinstance(value, bool):
        return value
    if isinstance(value, int):
        return value
    if isinstance(value, float):
        return Decimal(repr(value))
    if isinstance(value, (list, tuple)):
        return [as_toml(item) for item in value]
    return value


def nominal_array(scene: Scene, key: Key) -> list[float] | None:
    """The resolved value of an array key the scene may not write (None: no default known)."""
    dof = scene.links + 1
    if key.table == "initial" and key.name in ("theta", "dtheta"):
        return list(getattr(scene, key.name))
    if key.table == "parameters":
        if key.name in ("m", "l", "delta"):
            return list(getattr(scene, key.name))
        built = scene.link_values()
        if key.name in built:
            return list(built[key.name])
        if key.name in ("com", "J"):
            return [rod_value(scene.system, key.name, i, scene.m, scene.l) for i in range(dof)]
        if key.name in ("J_axial", "tip"):
            return [0.0] * dof
        if key.name == "coulomb":
            return list(scene.coulomb) if scene.coulomb is not None else [0.0] * dof
    return None


def apply(
    document: dict[str, Any],
    scene: Scene,
    overrides: tuple[tuple[str, object], ...],
    *,
    parse: Callable[[str], Key] = parse_key,
    defaults: Callable[[Key], list[float] | None] | None = None,
) -> dict[str, Any]:
    """A copy of `document` with each (key text, value) of `overrides` set. `parse` checks each
    key (a fixed chain's sweep: its own keys), `defaults` gives an array the document does not
    write (default `nominal_array` of `scene`)."""
    changed = copy.deepcopy(document)
    for text, value in overrides:
        key = parse(text)
        table = changed.setdefault(key.table, {})
        if key.index is None:
            table[key.name] = as_toml(value)
            continue
        current = table.get(key.name)
        if current is None:
            current = nominal_array(scene, key) if defaults is None else defaults(key)
            if current is None:
                raise SweepError(
                    f"{key.text}: the scene has no array {key.table}.{key.name} to index; vary the whole key"
                )
            current = as_toml(current)
        if not isinstance(current, list):
            raise SweepError(f"{key.text}: {key.table}.{key.name} is not an array; drop the index")
        if key.index >= len(current):
            raise SweepError(
                f"{key.text}: {key.table}.{key.name} has {len(current)} entries "
                f"(indices 0..{len(current) - 1})"
            )
        current = list(current)
        current[key.index] = as_toml(value)
        table[key.name] = current
    return changed


def designs(overrides: tuple[tuple[str, object], ...]) -> bool:
    """Whether any override is a controller-design key (the controller is then designed anew)."""
    return any(parse_key(text).designs for text, _ in overrides)
