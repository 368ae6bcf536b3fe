"""Where ipgen's non-Python parts are: the CMake package (`ipgen --cmake-dir`), the preset
scenes (`ipgen presets`) and the loop runtime printed into C headers (cpp/include/ipgen_loop.h)."""

from __future__ import annotations

import importlib.util
from pathlib import Path

from ipgen.common.install import REINSTALL
from ipgen.errors import Error


def cmake_dir() -> Path:
    """The folder holding ipgenConfig.cmake, for CMake's ``-Dipgen_DIR=`` (`ipgen --cmake-dir`).

    Returns
    -------
    Path
        The CMake package installed with ipgen, or a checkout's cmake/ folder.

    Raises
    ------
    Error
        The package is missing from this installation (reinstall it from the checkout: pip install ./).

    Examples
    --------
    >>> import ipgen
    >>> (ipgen.cmake_dir() / "ipgenConfig.cmake").is_file()
    True
    """
    spec = importlib.util.find_spec("ipgen.cmake")
    locations = list(spec.submodule_search_locations or []) if spec is not None else []
    for location in locations:
        if (Path(location) / "ipgenConfig.cmake").is_file():
            return Path(location).resolve()
    checkout = Path(__file__).resolve().parents[2] / "cmake"  # an uninstalled checkout
    if (checkout / "ipgenConfig.cmake").is_file():
        return checkout
    raise Error(f"ipgen's CMake package is missing from this installation: {REINSTALL}")


def presets_dir() -> Path:
    """The folder of the preset scenes (`ipgen presets`, `ipgen run --preset NAME`,
    `ipgen.Pendulum.preset`): the installed package's `presets/` (the checkout's scenes/ with
    scenes/rigs/, shipped in the wheel as package data), else an uninstalled checkout's scenes/.

    Returns
    -------
    Path
        The folder holding the paper's scenes (cdip_pulse.toml, ...) and, in rigs/, one scene
        file per rig (qube_servo2.toml, ...).

    Raises
    ------
    Error
        The presets are not part of this installation.
    """
    spec = importlib.util.find_spec("ipgen.presets")
    locations = list(spec.submodule_search_locations or []) if spec is not None else []
    for location in locations:
        if any(Path(location).glob("*.toml")):
            return Path(location).resolve()
    checkout = Path(__file__).resolve().parents[2] / "scenes"  # an uninstalled checkout
    if any(checkout.glob("*.toml")):
        return checkout
    raise Error(f"ipgen's preset scenes are missing from this installation: {REINSTALL}")


LOOP_RUNTIME = "ipgen_loop.h"  # the sampled loop's algorithms in C99, in cpp/include/


def loop_runtime() -> Path:
    """cpp/include/ipgen_loop.h of this installation (package data `ipgen.cpp.include`, or an
    uninstalled checkout's): the sampled loop's algorithms that a C header with an estimator or a
    swing-up carries whole (`--emit c`).

    Returns
    -------
    Path
        The file ipgen_loop.h.

    Raises
    ------
    Error
        The file is missing from this installation.
    """
    path = cmake_dir().parent / "cpp" / "include" / LOOP_RUNTIME  # the package's ipgen/, or the checkout
    if path.is_file():
        return path
    raise Error(
        f"ipgen's loop runtime cpp/include/{LOOP_RUNTIME} is missing from this installation: {REINSTALL}"
    )


MPC_RUNTIME = "ipgen_mpc.h"  # the MPC step in C99, in cpp/include/


def mpc_runtime() -> Path:
    """cpp/include/ipgen_mpc.h of this installation (as `loop_runtime`): the MPC step that a C
    header with a [controller] kind = "mpc" carries whole (`--emit c`).

    Returns
    -------
    Path
        The file ipgen_mpc.h.

    Raises
    ------
    Error
        The file is missing from this installation.
    """
    path = cmake_dir().parent / "cpp" / "include" / MPC_RUNTIME
    if path.is_file():
        return path
    raise Error(f"ipgen's MPC step cpp/include/{MPC_RUNTIME} is missing from this installation: {REINSTALL}")
