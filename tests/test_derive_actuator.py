"""`ipgen.derive(..., actuator=)`: the sympy views with a DC motor folded in, and the link rows
that are the equations of motion of an acceleration-driven base.

References: the manufacturers' motor formula written out by hand (τ = η_g K_g η_m k_t (V −
K_g k_m θ̇0)/R_m, /r on a cart, reflected inertia η_g K_g² J_m (/r²)), and Lagrange's equations
taken by sympy from the views' own T, V and D (a second derivation of M θ̈ + bias).
"""

from __future__ import annotations

import pytest
import sympy as sp

import ipgen

MOTOR = {"kind": "dc_motor", "Rm": 2.6, "kt": 0.0077, "km": 0.0075, "Kg": 3.71, "eta_g": 0.9, "Jm": 3.9e-7}


def _rational(value: float) -> sp.Rational:
    return sp.Rational(repr(value))


@pytest.mark.parametrize("kind", ["classical", "rotary"])
def test_motor_folded_views_match_the_manufacturers_formula(kind: str) -> None:
    motor = dict(MOTOR, **({"r": 6.35e-3} if kind == "classical" else {}))
    direct = ipgen.derive(kind, 2)
    driven = ipgen.derive(kind, 2, actuator=motor)
    s = driven.symbols
    rm, kt, km, kg, eta_g, jm = (_rational(motor[k]) for k in ("Rm", "kt", "km", "Kg", "eta_g", "Jm"))
    r = _rational(motor["r"]) if kind == "classical" else sp.Integer(1)
    voltage = sp.Symbol("V")
    # By hand: the motor's generalised force on θ0 and the rotor's inertia reflected to θ0.
    torque = eta_g * kg * kt * (voltage - kg * km * s.qd[0] / r) / (rm * r)
    reflected = eta_g * kg**2 * jm / r**2
    difference = driven.mass_matrix - direct.mass_matrix
    assert sp.simplify(difference[0, 0] - reflected) == 0
    assert all(difference[i, j] == 0 for i in range(3) for j in range(3) if (i, j) != (0, 0))
    # M θ̈ + bias_driven = B V  ⇔  M θ̈ + bias_direct = B V − (bias_driven − bias_direct) = torque e0.
    force = driven.input_matrix * voltage - (driven.bias - direct.bias)
    assert sp.expand(force[0] - torque) == 0
    assert force[1] == 0 and force[2] == 0


@pytest.mark.parametrize("kind", ["classical", "rotary"])
def test_driven_views_are_lagranges_equations_of_their_energies(kind: str) -> None:
    """d/dt ∂L/∂θ̇ − ∂L/∂θ + ∂D/∂θ̇ from the driven views' T, V, D equals M θ̈ + bias."""
    motor = dict(MOTOR, **({"r": 6.35e-3} if kind == "classical" else {}))
    eq = ipgen.derive(kind, 1, actuator=motor)
    s = eq.symbols
    t = sp.Symbol("t")
    paths = [sp.Function(f"x{i}")(t) for i in range(2)]
    to_path = {**{q: x for q, x in zip(s.q, paths, strict=True)}}
    to_path.update({qd: x.diff(t) for qd, x in zip(s.qd, paths, strict=True)})
    lagrangian = (eq.kinetic_energy - eq.potential_energy).subs(to_path, simultaneous=True)
    dissipation = eq.dissipation.subs(to_path, simultaneous=True)
    qdd = sp.symbols("a0 a1")
    back = {x.diff(t, 2): a for x, a in zip(paths, qdd, strict=True)}
    back.update({x.diff(t): qd for x, qd in zip(paths, s.qd, strict=True)})
    back.update({x: q for x, q in zip(paths, s.q, strict=True)})
    for i, x in enumerate(paths):
        lhs = (lagrangian.diff(x.diff(t)).diff(t) - lagrangian.diff(x) + dissipation.diff(x.diff(t))).subs(
            back
        )
        views = (eq.mass_matrix * sp.Matrix(qdd) + eq.bias)[i]
        assert sp.simplify(lhs - views) == 0


def test_direct_and_none_are_the_paper_model() -> None:
    plain = ipgen.derive("rotary", 1)
    direct = ipgen.derive("rotary", 1, actuator={"kind": "direct"})
    assert plain.mass_matrix == direct.mass_matrix and plain.bias == direct.bias
    assert list(direct.input_matrix) == [1, 0]


def test_acceleration_link_equations() -> None:
    """Cart and one rod: the link row is (m l²/3) θ̈1 + (m l/2) cos θ1 u + δ1 θ̇1 − (m g l/2) sin θ1 = 0."""
    eq = ipgen.derive("classical", 1, actuator={"kind": "acceleration"})
    s = eq.symbols
    m_ll, m_l0, bias_l = eq.link_equations
    u = sp.Symbol("u")
    m, l, d, g = s.m[1], s.l[1], s.delta[1], s.g  # noqa: E741
    hand = (
        m * l**2 / 3 * sp.Symbol("a")
        + m * l / 2 * sp.cos(s.q[1]) * u
        + d * s.qd[1]
        - m * g * l / 2 * sp.sin(s.q[1])
    )
    ours = (m_ll * sp.Matrix([sp.Symbol("a")]) + m_l0 * u + bias_l)[0]
    assert sp.simplify(ours - hand) == 0


@pytest.mark.parametrize(
    ("actuator", "message"),
    [
        ({"kind": "dc_motor", "Rm": 2.0, "kt": 0.01}, "needs km"),
        ({"kind": "dc_motor", "Rm": 2.0, "kt": 0.01, "km": 0.01}, "needs r"),
        ({"kind": "acceleration", "Rm": 2.0}, "applies to kind 'dc_motor' only"),
        ({"kind": "servo"}, "or 'acceleration'"),
        ("dc_motor", "must be an ipgen Actuator, a dict or None"),
    ],
)
def test_bad_actuator_is_a_one_line_error(actuator: object, message: str) -> None:
    with pytest.raises(ipgen.Error, match=message) as caught:
        ipgen.derive("classical", 1, actuator=actuator)  # type: ignore[arg-type]
    assert "\n" not in str(caught.value)
