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
def ipgen(kind: str, links: int, inertia: str, general: bool = False) -> Ipgen:
    """ipgen's equations: the paper's rods in (m, l, delta, g), or with `general` the links as
    built in (m, l, delta, g, com, J, J_axial, tip)."""
    eqs: Equations = derive(System(kind, links, inertia))  # type: ignore[arg-type]
    if not general:
        eqs = eqs.rod()
    sym = eqs.symbols
    parameters: tuple = (sym.m, sym.l, sym.delta, sym.g)
    if general:
        parameters = (*parameters, sym.com, sym.J, sym.J_axial, sym.tip)
    arguments = (sym.q, sym.qd, sym.u, parameters)

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


def random_general_case(rng: np.random.Generator, size: int) -> tuple:
    """A random state and links as built: CoG anywhere on (and a little beyond) the link, CoG
    inertias, axial inertias up to 2 J (axisymmetric bodies), tip masses, an arm inertia J0."""
    angles, rates, torque, (m, lengths, delta, g) = random_case(rng, size)
    com = tuple(rng.uniform(-0.2, 1.2) * length for length in lengths)
    inertia = tuple(rng.uniform(0.001, 0.5, size))
    axial = tuple(rng.uniform(0.0, 2.0) * j for j in inertia)
    tip = tuple(rng.uniform(0.0, 1.0, size))
    return angles, rates, torque, (m, lengths, delta, g, com, inertia, axial, tip)


GENERAL_CASES = [
    (kind, links, inertia)
    for kind in ("classical", "rotary")
    for links in (1, 2, 3, 4)
    for inertia in (("pivot", "full") if kind == "rotary" else ("pivot",))
]


@pytest.mark.parametrize("case", CASES, ids=case_id)
def test_matches_kanes_method(case: tuple[str, int, str]) -> None:
    check_against_kane(case, general=False)


@pytest.mark.parametrize("case", GENERAL_CASES, ids=case_id)
def test_links_as_built_match_kanes_method(case: tuple[str, int, str]) -> None:
    """com, J, J_axial, tip and J0 at random values: ipgen's equations against Kane's method
    on rigid bodies with those centres of gravity and inertias and particles at the tips."""
    check_against_kane(case, general=True)


def check_against_kane(case: tuple[str, int, str], general: bool) -> None:
    kind, links, inertia = case
    size = links + 1
    ref = reference(kind, links, inertia, general)
    ours = ipgen(kind, links, inertia, general)
    seed = 20130 + 10 * links + (kind == "rotary") + 2 * (inertia == "full") + 7 * general
    rng = np.random.default_rng(seed)
    input_map = np.zeros(size)
    input_map[0] = 1.0
    for k in range(STATES):
        args = random_general_case(rng, size) if general else random_case(rng, size)
        torque = args[2]
        where = f"{case_id(case)}, state {k}: θ={np.round(args[0], 4)}, θ̇={np.round(args[1], 4)}"
        mass = ours.mass_matrix(*args)
        assert_close(mass, ref.mass_matrix(*args), RELATIVE, f"{where}: M", SIDES)
        bias = np.ravel(ours.bias(*args))
        expected_bias = torque * input_map - np.ravel(ref.forcing(*args))
        assert_close(bias, expected_bias, RELATIVE, f"{where}: bias (= B u − Kane's forcing)", SIDES)
        assert_close(ours.kinetic(*args), ref.kinetic(*args), RELATIVE, f"{where}: T", SIDES)
        assert_close(ours.potential(*args), ref.potential(*args), RELATIVE, f"{where}: V", SIDES)
