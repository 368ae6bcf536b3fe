"""Reference derivations with sympy.physics.mechanics, for the generation benchmark.

The frames, bodies and loads are tests/independent_model.py's (the model the test suite checks
ipgen against): rods with the centre of gravity at l/2 and inertia m l²/12, absolute link angles,
viscous damping of the base, of link 1 against the base and of link i against link i − 1, the
input on the base. Rotary links use the "pivot" inertia (the published model, ipgen's default).

Run as `python -m bench.references METHOD TYPE LINKS`: imports first, then times the derivation
alone (frames, bodies, loads, the equations, M and the forcing vector; no code generation) and
prints it as JSON on stdout. A fresh process each time, so no cache is shared between runs.
"""

from __future__ import annotations

import json
import sys
import time

import sympy as sp
from sympy.physics import mechanics as me

from ipgen.model.system import SYSTEM_TYPES
from tests.independent_model import Pendulum, pendulum

METHODS = ("kane", "lagrange")


def derive(method: str, kind: str, links: int) -> tuple[sp.Matrix, sp.Matrix, Pendulum]:
    """M and the forcing vector of the pendulum by Kane's or Lagrange's method."""
    if method not in METHODS:
        raise ValueError(f"unknown method {method!r}: use one of {', '.join(METHODS)}")
    if method == "kane":
        size = links + 1
        w = list(me.dynamicsymbols(f"w0:{size}"))
        system = pendulum(kind, links, "pivot", w)
        kinematics = [qi.diff() - wi for qi, wi in zip(system.q, w, strict=True)]
        kane = me.KanesMethod(system.ground, q_ind=system.q, u_ind=w, kd_eqs=kinematics)
        kane.kanes_equations(system.bodies, system.loads)
        return kane.mass_matrix, kane.forcing, system
    system = pendulum(kind, links, "pivot")
    lagrangian = me.Lagrangian(system.ground, *system.bodies)
    lagrange = me.LagrangesMethod(lagrangian, system.q, forcelist=system.loads, frame=system.ground)
    lagrange.form_lagranges_equations()
    return lagrange.mass_matrix, lagrange.forcing, system


def agrees_with_ipgen(method: str, kind: str, links: int = 2, seed: int = 0) -> float:
    """Largest relative difference from ipgen's M and B u − bias at a random state (~1e-15)."""
    import numpy as np

    from ipgen.model.derivation import derive as ipgen_derive
    from ipgen.model.system import System

    mass, forcing, system = derive(method, kind, links)
    equations = ipgen_derive(System(kind, links, "pivot")).rod()  # type: ignore[arg-type]
    ipgen = equations.symbols
    random = np.random.default_rng(seed)
    size = links + 1
    values = {
        "q": random.uniform(-3, 3, size),
        "qd": random.uniform(-3, 3, size),
        "m": random.uniform(0.1, 2, size),
        "l": random.uniform(0.2, 1.5, size),
        "delta": random.uniform(0, 0.5, size),
        "g": [9.81],
        "u": [0.7],
    }
    theirs = {"q": system.q, "qd": system.speeds, **system.parameters}
    ours = {"q": ipgen.q, "qd": ipgen.qd, "m": ipgen.m, "l": ipgen.l, "delta": ipgen.delta, "g": (ipgen.g,)}

    def at(symbols: dict) -> dict:
        # Rates first: substituting q(t) would otherwise turn q'(t) into a derivative of a number.
        names = ("qd", "q", "m", "l", "delta", "g", "u")
        return {k: v for name in names for k, v in zip(symbols.get(name, ()), values[name], strict=False)}

    def number(matrix: sp.Matrix, symbols: dict) -> np.ndarray:
        return np.array(matrix.subs(list(at(symbols).items())).evalf(), dtype=float)

    wanted_mass = number(equations.mass_matrix, ours)
    wanted_forcing = -number(equations.bias, ours).ravel()
    wanted_forcing[0] += values["u"][0]
    got_mass, got_forcing = number(mass, theirs), number(forcing, theirs).ravel()
    return float(
        max(
            np.abs(got_mass - wanted_mass).max() / np.abs(wanted_mass).max(),
            np.abs(got_forcing - wanted_forcing).max() / np.abs(wanted_forcing).max(),
        )
    )


def main(argv: list[str]) -> None:
    usage = f"usage: python -m bench.references {{{','.join(METHODS)}}} {{{','.join(SYSTEM_TYPES)}}} LINKS"
    if len(argv) != 3 or argv[0] not in METHODS or argv[1] not in SYSTEM_TYPES or not argv[2].isdigit():
        sys.exit(usage)
    method, kind, links = argv[0], argv[1], int(argv[2])
    start, start_cpu = time.perf_counter(), time.process_time()
    derive(method, kind, links)
    wall, cpu = time.perf_counter() - start, time.process_time() - start_cpu
    print(json.dumps({"derive_s": wall, "derive_cpu_s": cpu}))


if __name__ == "__main__":
    main(sys.argv[1:])
