"""A system's model library (ipgen_model.h) compiled and loaded for ctypes: what `ipgen.mpc` calls.

The library is `--emit library`'s (the model's C header and its adapter, codegen/model_library.py),
general in the parameters (they are passed at run time), compiled by the C compiler of `ipgen
run`'s model libraries into the same cache entry `<cache>/models/<key>/libipgen_<name>.so`
(pipeline/simulator.py's key and command), and loaded with ctypes; `ipgen_model_get` returns the
address of its `ipgen_model` description.
"""

from __future__ import annotations

import ctypes
import tempfile
from pathlib import Path

from ipgen.codegen.fixed_header import fixed_library_sources
from ipgen.common.build_cache import Recipe, cache_root, cached_build, last_error_line
from ipgen.model.fixed import FixedPendulum
from ipgen.model.system import System
from ipgen.pipeline.generate import generate
from ipgen.pipeline.simulator import BuildError, c_compiler, compile_command, compiler_version, library_key


def compiled_model_library(system: System | FixedPendulum) -> ctypes.CDLL:
    """The model library of `system` loaded with ctypes (`ipgen_model_get` returns a void pointer).

    Parameters
    ----------
    system : System or FixedPendulum
        The type, links and inertia (a fixed chain: its links and driven joints, the library of
        `ipgen run`'s fixed scenes, in ipgen's coordinates); the library is general in every parameter.

    Returns
    -------
    ctypes.CDLL
        The library, generated and compiled into the cache if it is not there yet.

    Raises
    ------
    BuildError
        No C compiler, or the compilation failed (one line).
    """
    if isinstance(system, FixedPendulum):
        name, texts = fixed_library_sources(system.links, tuple(system.joints))
    else:
        name = f"mpc_{system.type}{system.links}_{system.inertia}"
        with tempfile.TemporaryDirectory() as scratch:
            generate(system, name, Path(scratch), force=True, emit=("library",))
            texts = {
                f"{name}{suffix}": (Path(scratch) / f"{name}{suffix}").read_text()
                for suffix in (".h", "_model.c")
            }
    cc = c_compiler()
    recipe = Recipe(
        sources=texts,
        command=lambda entry, output: compile_command(cc, entry, name, output),
        error=BuildError,
        failed=lambda output: f"compiling the model library failed: {last_error_line(output)}",
        what=f"the model library of {name}",
        noun="model library",
    )
    key = library_key(cc, texts, compiler_version(cc))
    built = cached_build(cache_root() / "models", key, f"libipgen_{name}.so", recipe)
    try:
        lib = ctypes.CDLL(str(built.path))
    except OSError as e:
        raise BuildError(f"cannot load the model library {built.path}: {e}") from None
    lib.ipgen_model_get.restype = ctypes.c_void_p
    return lib
