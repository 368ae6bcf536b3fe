"""An independent derivation with sympy.physics.mechanics (Kane's method) against ipgen.

tests/independent_model.py builds the pendulums from first principles, sharing nothing with
generator/model.py; Kane's equations give M(θ) θ̈ = forcing(θ, θ̇, u). With the generalized
speeds θ̇i, ipgen must have M equal and bias = B u − forcing, compared numerically at random
states and positive parameters to 1e-12 relative.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import cache

import numpy as np
import pytest
import sympy as sp
from cases import CASES, case_id
from independent_model import reference
from numeric import assert_close

from ipgen.model.derivation import Equations, derive
from ipgen.model.system import System

RELATIVE = 1e-12
STATES = 5
SIDES = ("ipgen", "mechanics")  # how a failure names the two values


@dataclass(frozen=True)
class Ipgen:
    """ipgen's equations as numerical functions with the same argument layout."""

    mass_matrix: Callable[..., np.ndarray]
    bias: Callable[..., np.ndarray]
    kinetic: Callable[..., float]
    potential: Callable[..., float]


@cache
def ipgen(kind: str, links: int, inertia: str) -> Ipgen:
    eqs: Equations = derive(System(kind, links, inertia))  # type: ignore[arg-type]
    sym = eqs.symbols
    arguments = (sym.q, sym.qd, sym.u, (sym.m, sym.l, sym.delta, sym.g))

    def numeric(expr: sp.Expr | sp.Matrix) -> Callable[..., np.ndarray]:
        return sp.lambdify(arguments, expr, "numpy")

    return Ipgen(
        numeric(eqs.mass_matrix),
        numeric(eqs.bias),
        numeric(eqs.kinetic_energy),
        numeric(eqs.potential_energy),
    )


def random_case(rng: np.random.Generator, size: int) -> tuple:
    angles = tuple(rng.uniform(-np.pi, np.pi, size))
    rates = tuple(rng.uniform(-3.0, 3.0, size))
    torque = float(rng.uniform(-2.0, 2.0))
    params = (
        tuple(rng.uniform(0.1, 2.0, size)),
        tuple(rng.uniform(0.2, 1.5, size)),
        tuple(rng.uniform(0.0, 0.5, size)),
        float(rng.uniform(1.0, 20.0)),
    )
    return angles, rates, torque, params


@pytest.mark.parametrize("case", CASES, ids=case_id)
def test_matches_kanes_method(case: tuple[str, int, str]) -> None:
    kind, links, inertia = case
    size = links + 1
    ref = reference(kind, links, inertia)
    ours = ipgen(kind, links, inertia)
    rng = np.random.default_rng(20130 + 10 * links + (kind == "rotary") + 2 * (inertia == "full"))
    input_map = np.zeros(size)
    input_map[0] = 1.0
    for k in range(STATES):
        args = random_case(rng, size)
        torque = args[2]
        where = f"{case_id(case)}, state {k}: θ={np.round(args[0], 4)}, θ̇={np.round(args[1], 4)}"
        mass = ours.mass_matrix(*args)
        assert_close(mass, ref.mass_matrix(*args), RELATIVE, f"{where}: M", SIDES)
        bias = np.ravel(ours.bias(*args))
        expected_bias = torque * input_map - np.ravel(ref.forcing(*args))
        assert_close(bias, expected_bias, RELATIVE, f"{where}: bias (= B u − Kane's forcing)", SIDES)
        assert_close(ours.kinetic(*args), ref.kinetic(*args), RELATIVE, f"{where}: T", SIDES)
        assert_close(ours.potential(*args), ref.potential(*args), RELATIVE, f"{where}: V", SIDES)
