"""Scene files: one experiment per small TOML file, checked and resolved for the simulator.

The format (tables, keys, types, bounds, defaults) is declared once in `schema.py`; the
reference for users is docs/scenes.md. Reading is three steps, one module each: `load`
(the file to a validated document, every problem one line naming the file and the dotted
key), `resolve` (the `Scene`, with the controller's gain and the swing-up's plan computed) and
`config` (`resolved_config`: the flat `key = value` text the C++ simulator reads).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from ipgen.scene.config import resolved_config
from ipgen.scene.fields import Reader
from ipgen.scene.load import load_document, parse_document, validate_document
from ipgen.scene.resolve import InputSpec, Scene, build_scene

__all__ = ["InputSpec", "Scene", "load_scene", "read_document", "resolved_config", "scene_from_document"]


def load_scene(path: str | Path) -> Scene:
    """Read, validate and complete a scene file; raises `SceneError` on any problem."""
    reader, document = load_document(Path(path))
    return build_scene(reader, document)


def read_document(path: str | Path) -> dict[str, Any]:
    """The scene file's TOML document (numbers as exact `Decimal`s), not yet validated: what
    `scene_from_document` reads after a sweep changed some values."""
    return parse_document(Path(path))[1]


def scene_from_document(
    path: str | Path, document: dict[str, Any], *, designed: Scene | None = None
) -> Scene:
    """The scene of a TOML `document` (as `read_document` gives it, possibly changed), its
    messages naming `path`. With `designed`, the controller and swing-up law are that scene's
    instead of designed anew on this document's parameters (`ipgen sweep`)."""
    reader = Reader(Path(path))
    return build_scene(reader, validate_document(reader, document), designed)
