"""The rig's own coordinates in the Python API (`angles`, `zero`, `positive` on linearize/lqr).

Independent checks: Quanser's published QUBE-Servo 2 model (counter-clockwise pendulum angle)
without any hand-applied sign flip; A and B of a relative-angle, hanging-zero double pendulum
against central differences of the canonical forward dynamics seen through the map; an LQR
about a user-coordinate equilibrium against the canonical gain transformed by hand.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from test_published_rig import DP, DR, JP, JR, LP, LR, MP, MR, G, published

import ipgen
from ipgen.control.linear import ControlError, EquilibriumWarning, dynamics
from ipgen.model.pendulum import Pendulum
from ipgen.model.system import System


def flat_parameters(system, m, l, delta, g, links=None):  # noqa: E741
    """`Dynamics`' flat parameters of these values (the Pendulum's `flat`)."""
    return Pendulum(system.type, system.links, m, l, delta, g, system.inertia, **(links or {})).flat()


def test_qube_in_quanser_s_own_angle() -> None:
    a, b = ipgen.linearize(
        "rotary", 1, m=[MR, MP], l=[LR, LP], delta=[DR, DP], g=G, J=[JR, JP], positive="counterclockwise"
    )
    a_pub, b_pub = published()
    assert np.allclose(a, a_pub, rtol=1e-12, atol=1e-12)
    assert np.allclose(b, b_pub, rtol=1e-12, atol=1e-12)


def test_relative_hanging_counterclockwise_by_differences() -> None:
    m, l, delta = [0.3, 0.2, 0.15], [0.5, 0.4, 0.3], [0.05, 0.002, 0.003]  # noqa: E741
    convention = {"angles": "relative", "zero": "hanging", "positive": "counterclockwise"}
    q_user = [0.1, 0.2, -0.3]
    with pytest.warns(EquilibriumWarning):  # a general state, not an equilibrium: checks more
        a, b = ipgen.linearize("rotary", 2, m, l, delta, q=q_user, qd=[0.0, 0.0, 0.0], **convention)  # type: ignore[arg-type]

    # by hand: α1 = −(θ1 − π), α2 = −(θ2 − θ1)  =>  θ1 = π − α1, θ2 = θ1 − α2
    def canonical(x: np.ndarray) -> np.ndarray:
        t1 = math.pi - x[1]
        t2 = t1 - x[2]
        return np.array([x[0], t1, t2, x[3], -x[4], -x[4] - x[5]])

    def user_rates(xc: np.ndarray, xdot_c: np.ndarray) -> np.ndarray:
        return np.array([xdot_c[0], -xdot_c[1], -(xdot_c[2] - xdot_c[1])])

    system = System("rotary", 2)
    params = flat_parameters(system, m, l, delta, 9.81)
    dyn = dynamics(system)

    def f(x: np.ndarray, u: float) -> np.ndarray:
        xc = canonical(x)
        qdd = dyn.forward_dynamics(xc[:3], xc[3:], u, params)
        return np.concatenate([x[3:], user_rates(xc, qdd)])

    x0 = np.array([*q_user, 0.0, 0.0, 0.0])
    h = 1e-6
    a_fd = np.column_stack([(f(x0 + h * e, 0.0) - f(x0 - h * e, 0.0)) / (2 * h) for e in np.eye(6)])
    b_fd = (f(x0, h) - f(x0, -h)) / (2 * h)
    assert np.allclose(a, a_fd, rtol=1e-6, atol=1e-6)
    assert np.allclose(b.ravel(), b_fd, rtol=1e-6, atol=1e-8)


def test_lqr_about_a_user_equilibrium() -> None:
    m, l, delta = [0.3, 0.2, 0.15], [0.5, 0.4, 0.3], [0.05, 0.002, 0.003]  # noqa: E741
    q = [1.0] * 6
    k_user = ipgen.lqr(
        "rotary", 2, m, l, delta, q, 1.0, zero="hanging", angles="relative", equilibrium=[0, math.pi, 0]
    )
    # user (hanging zero, relative): link 1 at π from hanging = upright, link 2 aligned = upright
    p = np.eye(6)
    p[2, 1] = p[5, 4] = -1.0  # α2 = θ2 − θ1 (the offset c does not enter K)
    a, b = ipgen.linearize("rotary", 2, m, l, delta)
    from scipy.linalg import solve_continuous_are

    a_u, b_u = p @ a @ np.linalg.inv(p), p @ b
    k_hand = b_u.T @ solve_continuous_are(a_u, b_u, np.eye(6), np.eye(1))
    assert np.allclose(k_user, k_hand, rtol=1e-8, atol=1e-10)


@pytest.mark.parametrize(("key", "value"), [("angles", "joint"), ("zero", "down"), ("positive", "cw")])
def test_unknown_conventions_are_one_line(key: str, value: str) -> None:
    with pytest.raises(ControlError, match=f"{key} = '{value}': expected") as caught:
        ipgen.linearize("rotary", 1, [1, 1], [1, 1], [0, 0], **{key: value})  # type: ignore[arg-type]
    assert "\n" not in str(caught.value)
