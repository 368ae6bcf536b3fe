"""Where ipgen's non-Python parts are: the CMake package (`ipgen --cmake-dir`)."""

from __future__ import annotations

import importlib.util
from pathlib import Path

from ipgen.errors import Error


def cmake_dir() -> Path:
    """The folder holding ipgenConfig.cmake (installed with the package; a checkout's cmake/)."""
    spec = importlib.util.find_spec("ipgen.cmake")
    locations = list(spec.submodule_search_locations or []) if spec is not None else []
    for location in locations:
        if (Path(location) / "ipgenConfig.cmake").is_file():
            return Path(location).resolve()
    checkout = Path(__file__).resolve().parents[2] / "cmake"  # an uninstalled checkout
    if (checkout / "ipgenConfig.cmake").is_file():
        return checkout
    raise Error(
        "ipgen's CMake package is missing from this installation: reinstall it with "
        "pip install ipgen-pendulum (PyPI's `ipgen` is another project)"
    )


def presets_dir() -> Path:
    """The folder of the rig presets (`ipgen.Pendulum.preset`): a checkout's scenes/rigs/.

    Returns
    -------
    Path
        The folder holding one scene file per rig (qube_servo2.toml, ...).

    Raises
    ------
    Error
        The presets are not part of this installation.
    """
    checkout = Path(__file__).resolve().parents[2] / "scenes" / "rigs"
    if checkout.is_dir():
        return checkout
    raise Error(
        "ipgen's rig presets are missing from this installation: use a checkout of the repository, "
        "or pass the scene file to Pendulum.from_scene"
    )
