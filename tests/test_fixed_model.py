"""The fixed-pivot chain (`ipgen.FixedPendulum`): its equations against an independent
derivation with sympy.physics.mechanics (n = 1–4, motors at one or two joints, rotors, damping,
Coulomb friction, several rig coordinates) and against DFKI's own closed form with DFKI's
parameter files (tests/data/dfki, BSD-3-Clause)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from fixed_reference import dfki_closed_form, mechanics_model

from ipgen.model.coordinates import Coordinates
from ipgen.model.dfki import dfki_pendulum, read_model_parameters
from ipgen.model.fixed import FixedPendulum
from ipgen.model.fixed_equations import angle_map
from ipgen.model.fixed_numeric import FixedModel

DATA = Path(__file__).parent / "data" / "dfki"
CASES = [
    (1, (1,), Coordinates("relative", "hanging", "counterclockwise")),
    (2, (1,), Coordinates()),
    (2, (2,), Coordinates("relative", "hanging", "counterclockwise")),
    (2, (1, 2), Coordinates("relative", "hanging", "counterclockwise")),
    (3, (2, 3), Coordinates("absolute", "hanging", "counterclockwise")),
    (3, (3, 1), Coordinates("relative", "upright", "clockwise")),
    (4, (1, 4), Coordinates("relative", "hanging", "counterclockwise")),
]


def _random_pendulum(links: int, joints: tuple[int, ...], coordinates: Coordinates, rng) -> FixedPendulum:
    return FixedPendulum(
        links,
        m=rng.uniform(0.2, 2, links),
        l=rng.uniform(0.2, 1, links),
        delta=rng.uniform(0, 0.3, links),
        g=9.81,
        com=rng.uniform(-0.2, 0.8, links),
        J=rng.uniform(0.01, 0.1, links),
        coulomb=rng.uniform(0, 0.2, links),
        coulomb_law="atan",
        coulomb_gain=float(rng.uniform(5, 50)),
        joints=joints,
        Ir=rng.uniform(1e-4, 1e-2, len(joints)),
        gr=rng.uniform(-8, 8, len(joints)),
        angles=coordinates.angles,
        zero=coordinates.zero,
        positive=coordinates.positive,
    )


@pytest.mark.parametrize(("links", "joints", "coordinates"), CASES)
def test_fixed_chain_equals_sympy_mechanics(
    links: int, joints: tuple[int, ...], coordinates: Coordinates
) -> None:
    rng = np.random.default_rng(links * 10 + len(joints))
    pendulum = _random_pendulum(links, joints, coordinates, rng)
    model = FixedModel(pendulum)
    matrix, zero = angle_map(coordinates, links)
    mass_ref, forcing_ref = mechanics_model(links, joints, matrix, zero, coordinates.positive == "clockwise")
    values = pendulum.numbers()
    for _ in range(5):
        q, qd = rng.uniform(-3, 3, links), rng.uniform(-4, 4, links)
        u = rng.uniform(-2, 2, len(joints))
        mass = model.mass_matrix(q)
        np.testing.assert_allclose(mass, mass_ref(q, values), rtol=1e-11, atol=1e-13)
        forcing = model.B @ u - model.bias(q, qd) - model.friction(q, qd)
        np.testing.assert_allclose(forcing, forcing_ref(q, qd, u, values), rtol=1e-10, atol=1e-12)


@pytest.mark.parametrize("name", ["design_C.0_model_3.0", "design_C.1_model_1.0"])
def test_dfki_parameters_give_dfki_closed_form(name: str) -> None:
    values = read_model_parameters(DATA / f"{name}.yml")
    model = FixedModel(dfki_pendulum(values))
    rng = np.random.default_rng(7)
    for _ in range(20):
        q, qd = rng.uniform(-np.pi, np.pi, 2), rng.uniform(-8, 8, 2)
        mass, bias = dfki_closed_form(values, q, qd)
        assert np.max(np.abs(model.mass_matrix(q) - mass)) <= 1e-12 * np.max(np.abs(mass))
        ours = model.bias(q, qd) + model.friction(q, qd)
        assert np.max(np.abs(ours - bias)) <= 1e-12 * max(1.0, np.max(np.abs(bias)))
    np.testing.assert_array_equal(model.B, np.eye(2))


@pytest.mark.parametrize(("joints", "expected"), [((1,), [[1], [0]]), ((2,), [[0], [1]])])
def test_pendubot_and_acrobot_select_dfki_columns(joints: tuple[int, ...], expected: list[list[int]]) -> None:
    values = read_model_parameters(DATA / "design_C.1_model_1.0.yml") | {"Ir": 0.0}
    model = FixedModel(dfki_pendulum(values, joints=joints))
    np.testing.assert_array_equal(model.B, np.array(expected, dtype=float))
    q, qd = np.array([0.3, -1.1]), np.array([0.7, 2.0])
    mass, bias = dfki_closed_form(values, q, qd)
    np.testing.assert_allclose(model.mass_matrix(q), mass, rtol=1e-12)
    np.testing.assert_allclose(model.bias(q, qd) + model.friction(q, qd), bias, rtol=1e-12)
