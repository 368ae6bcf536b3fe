"""Scenes of fixed-pivot chains: `[system] type = "fixed"` (docs/scenes.md, "A fixed pivot").

A fixed scene has three tables: [system] (type, links, name, angles, zero, positive; emit: the
targets `ipgen --scene` writes, pipeline/fixed_generate.py),
[parameters] (m, l, delta, g, com, J, coulomb, coulomb_law, coulomb_speed, coulomb_gain; one
entry per link, no base) and [actuator] (joints, Ir, gr); and, for `ipgen run`, the tables of an
open-loop run, [initial], [input] or [[input]], [simulation], [outputs] (RUN_TABLES: checked by
pipeline/fixed_run.py, ignored here). The other commands and tables are not yet there for
fixed-pivot models: a fixed scene given to a command that needs them is refused in one line
(`NOT_YET`), and so is any other table in a fixed scene.
"""

from __future__ import annotations

from decimal import Decimal
from pathlib import Path
from typing import Any

from ipgen.common.safetext import abbreviate
from ipgen.errors import Error, SceneError
from ipgen.model.fixed import FixedPendulum
from ipgen.scene.fields import Reader
from ipgen.scene.load import FIXED_NOT_YET as NOT_YET
from ipgen.scene.load import parse_document

KEYS: dict[str, tuple[str, ...]] = {
    "system": ("type", "links", "name", "angles", "zero", "positive", "emit"),
    "parameters": (
        "m",
        "l",
        "delta",
        "g",
        "com",
        "J",
        "coulomb",
        "coulomb_law",
        "coulomb_speed",
        "coulomb_gain",
    ),
    "actuator": ("joints", "Ir", "gr"),
}
# The tables of a run (`ipgen run`, pipeline/fixed_run.py), which the chain ignores.
RUN_TABLES: tuple[str, ...] = ("initial", "input", "simulation", "outputs", "controller", "swingup")
REQUIRED: dict[str, tuple[str, ...]] = {"system": ("type", "links"), "parameters": ("m", "l", "delta")}


def is_fixed_document(document: dict[str, Any]) -> bool:
    """Whether a parsed scene document declares `[system] type = "fixed"`."""
    system = document.get("system")
    return isinstance(system, dict) and system.get("type") == "fixed"


def _plain(value: Any) -> Any:
    """TOML values with exact Decimals as floats (lists element by element)."""
    if isinstance(value, Decimal):
        return float(value)
    if isinstance(value, list):
        return [_plain(item) for item in value]
    return value


def fixed_pendulum_of(reader: Reader, document: dict[str, Any]) -> FixedPendulum:
    """The `FixedPendulum` of a parsed fixed scene document; `SceneError` (one line) otherwise."""
    for table, value in document.items():
        if table in RUN_TABLES:  # the tables of `ipgen run` (pipeline/fixed_run.py checks them)
            continue
        if table not in KEYS:
            reader.fail(f"[{table}] is {NOT_YET}: a fixed scene has [system], [parameters] and [actuator]")
        if not isinstance(value, dict):
            reader.fail(f"{table} = ...: expected a table: [{table}] on a line of its own")
        for key in value:
            if key not in KEYS[table]:
                reader.fail(
                    f"unknown key '{table}.{key}' in a fixed scene (expected: {', '.join(KEYS[table])})"
                )
    for table, keys in REQUIRED.items():
        for key in keys:
            if key not in document.get(table, {}):
                reader.fail(f"missing required key '{table}.{key}'")
    system = document["system"]
    fields: dict[str, Any] = {
        key: _plain(system[key]) for key in ("angles", "zero", "positive") if key in system
    }
    for table in ("parameters", "actuator"):
        fields |= {key: _plain(value) for key, value in document.get(table, {}).items()}
    law = fields.get("coulomb_law", "tanh")
    for key, used_by in (("coulomb_speed", "tanh"), ("coulomb_gain", "atan")):
        if key in fields and law in ("tanh", "atan") and law != used_by:  # a setting of the other law
            reader.fail(
                f"parameters.{key} is for coulomb_law = '{used_by}', this chain's is '{law}': "
                f"remove it (or set coulomb_law = '{used_by}')"
            )
    links = system["links"]
    if isinstance(links, bool) or not isinstance(links, int):
        reader.bad("system.links", links, "expected an integer >= 1 (the number of links on the pivot)")
    try:
        return FixedPendulum(links, **fields)
    except Error as exc:
        reader.fail(str(exc))
    except TypeError as exc:  # pragma: no cover - every key is a field
        reader.fail(f"cannot build the chain: {exc}")


def load_fixed_scene(path: str | Path) -> FixedPendulum:
    """The `FixedPendulum` a fixed scene file describes; `SceneError` (one line) otherwise.

    Examples
    --------
    >>> from ipgen.common.presets import preset_path
    >>> load_fixed_scene(preset_path("dfki_c0")).joints
    (1, 2)
    """
    if not isinstance(path, str | Path):
        raise SceneError(f"{abbreviate(repr(path))}: expected a scene file's path")
    reader, document = parse_document(Path(path))
    if not is_fixed_document(document):
        reader.fail('expected a fixed-pivot scene ([system] type = "fixed")')
    return fixed_pendulum_of(reader, document)
