"""The shipped scenes (scenes/ and scenes/rigs/), each loaded once per test process.

test_scene, test_scene_config, test_sensors and test_specialise each load every shipped scene;
loading is deterministic and a Scene is frozen, so they share one load per process and path
(about 1.9 s of CPU time for all of them, most of it designing the swing-up plans of the cdip
swing-up and MPC scenes). For the shipped files only, read as they are: a test that loads a scene
under a changed environment, directory or file calls `load_scene` itself.
"""

from __future__ import annotations

from functools import cache
from pathlib import Path

from ipgen.experiment.scene import Scene, load_scene


@cache
def shipped_scene(path: Path) -> Scene:
    """`load_scene(path)`, once per process and path."""
    return load_scene(path)
