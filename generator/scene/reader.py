"""Scene files: one experiment per small TOML file, checked and resolved for the simulator.

The format (tables, keys, types, bounds, defaults) is declared once in `schema.py`; the
reference for users is docs/scenes.md. Reading is three steps, one module each: `load`
(the file to a validated document, every problem one line naming the file and the dotted
key), `resolve` (the `Scene`, with the controller's gain and the swing-up's plan computed) and
`config` (`resolved_config`: the flat `key = value` text the C++ simulator reads).
"""

from __future__ import annotations

from pathlib import Path

from ipgen.scene.config import resolved_config
from ipgen.scene.load import load_document
from ipgen.scene.resolve import InputSpec, Scene, build_scene

__all__ = ["InputSpec", "Scene", "load_scene", "resolved_config"]


def load_scene(path: str | Path) -> Scene:
    """Read, validate and complete a scene file; raises `SceneError` on any problem."""
    reader, document = load_document(Path(path))
    return build_scene(reader, document)
