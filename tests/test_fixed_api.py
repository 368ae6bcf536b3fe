"""The fixed-pivot chain through the public API: `ipgen.FixedPendulum`, `ipgen.derive`,
`ipgen.linearize` (B 2n × m) and `ipgen.lqr` (K m × 2n), and its bad input refused in one line."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import ipgen
from ipgen.model.dfki import dfki_pendulum, read_model_parameters
from ipgen.model.fixed import FixedPendulumError
from ipgen.model.fixed_numeric import FixedModel

DATA = Path(__file__).parent / "data" / "dfki"
C1 = read_model_parameters(DATA / "design_C.1_model_1.0.yml")


def _central_differences(p: ipgen.FixedPendulum, q, qd, u, step: float = 1e-6):
    model = FixedModel(p)
    n, x = p.links, np.concatenate([q, qd])

    def f(state, torque):
        return np.concatenate(
            [state[n:], model.forward_dynamics(state[:n], state[n:], torque, coulomb=False)]
        )

    a = np.column_stack([(f(x + step * e, u) - f(x - step * e, u)) / (2 * step) for e in np.eye(2 * n)])
    b = np.column_stack([(f(x, u + step * e) - f(x, u - step * e)) / (2 * step) for e in np.eye(len(u))])
    return a, b


@pytest.mark.parametrize("joints", [(1,), (2,), (1, 2)])
def test_linearize_matches_central_differences(joints: tuple[int, ...]) -> None:
    values = read_model_parameters(DATA / "design_C.0_model_3.0.yml")
    p = dfki_pendulum(values | ({} if len(joints) == 2 else {"Ir": 0.0}), joints=joints)
    q, qd, u = np.array([0.4, -0.9]), np.array([1.3, -0.6]), np.linspace(0.2, -0.3, len(joints))
    a, b = ipgen.linearize(p, q, qd, u)
    a_ref, b_ref = _central_differences(p, q, qd, u)
    assert a.shape == (4, 4) and b.shape == (4, len(joints))
    np.testing.assert_allclose(a, a_ref, rtol=1e-6, atol=1e-6)
    np.testing.assert_allclose(b, b_ref, rtol=1e-6, atol=1e-6)


def test_linearization_in_rig_coordinates_is_the_canonical_one_mapped() -> None:
    p = dfki_pendulum(C1 | {"Ir": 0.0}, joints=(2,))
    canonical = p.canonical()
    a, b = ipgen.linearize(canonical)  # upright at rest in ipgen's coordinates
    # DFKI's q of the same state: q1 = π (upright, from hanging), q2 = 0; the map's matrix T:
    t = np.kron(np.eye(2), np.array([[-1.0, 0.0], [1.0, -1.0]]))
    a_rig, b_rig = ipgen.linearize(p, [np.pi, 0.0], [0.0, 0.0])
    np.testing.assert_allclose(a_rig, t @ a @ np.linalg.inv(t), atol=1e-9)
    # u is the torque in the rig's positive sense: counterclockwise here, clockwise in ipgen's
    np.testing.assert_allclose(b_rig, -t @ b, atol=1e-12)


@pytest.mark.parametrize("joints", [(1,), (2,), (1, 2)])
def test_lqr_stabilises_upright_with_m_inputs(joints: tuple[int, ...]) -> None:
    p = dfki_pendulum(C1 | {"Ir": 0.0, "cf1": 0.0, "cf2": 0.0}, joints=joints)
    k = ipgen.lqr(p, Q=[10, 10, 1, 1], R=1.0, equilibrium="upright")
    assert k.shape == (len(joints), 4)
    a, b = ipgen.linearize(p, [np.pi, 0.0])
    assert np.max(np.linalg.eigvals(a - b @ k).real) < 0
    from scipy.linalg import solve_continuous_are

    riccati = solve_continuous_are(a, b, np.diag([10.0, 10, 1, 1]), np.eye(len(joints)))
    np.testing.assert_allclose(k, b.T @ riccati, rtol=1e-8)


def test_derive_gives_b_n_by_m() -> None:
    p = ipgen.FixedPendulum(3, m=[1, 1, 1], l=[1, 1, 1], delta=[0, 0, 0], joints=[3, 1])
    assert ipgen.derive(p).input_matrix.tolist() == [[0, 1], [-1, 0], [1, 0]]


GOOD = {"m": [1.0, 1.0], "l": [0.5, 0.5], "delta": [0.0, 0.0]}


def _refused(**fields) -> str:
    with pytest.raises(ipgen.Error) as caught:
        ipgen.FixedPendulum(2, **(GOOD | fields))
    message = str(caught.value)
    assert "\n" not in message and len(message) < 200
    return message


@settings(max_examples=40, deadline=None)
@given(st.lists(st.integers(-5, 9), min_size=1, max_size=3))
def test_joint_out_of_range_refused(joints: list[int]) -> None:
    if all(1 <= j <= 2 for j in joints) and len(set(joints)) == len(joints):
        assert ipgen.FixedPendulum(2, **GOOD, joints=joints).inputs == len(joints)
        return
    message = _refused(joints=joints)
    assert "joint" in message


@settings(max_examples=30, deadline=None)
@given(st.sampled_from(["m", "l", "delta", "com", "J", "coulomb"]), st.floats(0.1, 2.0))
def test_base_entry_refused(group: str, extra: float) -> None:
    assert "no base entry" in _refused(**{group: [extra, 0.5, 0.5]})


@settings(max_examples=20, deadline=None)
@given(st.lists(st.floats(0, 1e-2), min_size=1, max_size=1))
def test_rotor_without_gear_refused(rotor: list[float]) -> None:
    assert "Ir without gr" in _refused(joints=[1], Ir=rotor)


@pytest.mark.parametrize("joints", [(1,), (2,)])
def test_a_rotor_with_one_driven_joint_is_refused(joints: tuple[int, ...]) -> None:
    """DFKI's closed form keeps both motors' rotors (the passive one stays mounted); a
    FixedPendulum holds a rotor at a driven joint only, so dfki_pendulum with Ir > 0 and one
    driven joint (it dropped the passive rotor: up to 48 % off in θ̈) is one line."""
    values = read_model_parameters(DATA / "design_C.0_model_3.0.yml")
    with pytest.raises(FixedPendulumError) as refused:
        dfki_pendulum(values, joints=joints)
    assert "\n" not in str(refused.value) and "Ir" in str(refused.value) and "passive" in str(refused.value)
    assert dfki_pendulum(values | {"Ir": 0.0}, joints=joints).Ir == (0.0,)


def test_derive_is_typed_as_what_it_returns() -> None:
    """ipgen.derive was annotated `-> Equations` but returns FixedEquations for a FixedPendulum
    (whose views lack rod(), symbols, ...): its overloads say which, as the calls return."""
    import typing

    from ipgen.model.derivation import Equations
    from ipgen.model.fixed_equations import FixedEquations

    overloads = typing.get_overloads(ipgen.derive)
    by_input = {f.__annotations__["type"]: f.__annotations__["return"] for f in overloads}  # as written
    assert by_input == {"FixedPendulum": "FixedEquations", "str | Pendulum": "Equations"}, by_input
    fixed = ipgen.FixedPendulum(2, m=[1.0, 1.0], l=[1.0, 2.0], delta=[0.1, 0.1], joints=[2])
    assert isinstance(ipgen.derive(fixed), FixedEquations)
    assert isinstance(ipgen.derive("rotary", 1), Equations)
