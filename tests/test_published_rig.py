"""A published rig the links as built represent exactly: the Quanser QUBE-Servo 2 rotary pendulum.

Source: Quanser's QUBE-Servo 2 rotary pendulum model. Parameters from its setup file
`qube2_rotpen_param.m` (read through the copy github.com/weilunwc/rotary_pendulum,
qube2_rotpen_param.m): arm Mr = 0.095 kg, Lr = 0.085 m, Jr = Mr Lr²/12 (the arm pivots at its
centre), Dr = 0.0015 N m s/rad; pendulum Mp = 0.024 kg, Lp = 0.129 m, Jp = Mp Lp²/12 about its
CoG at Lp/2, Dp = 0.0005 N m s/rad; g = 9.81. Linear model about the upright, state
(θ, α, θ̇, α̇), input the arm torque τ (Quanser's state-space script before "Add actuator
dynamics", read through the copy github.com/shaobow/CMU_MLC_24773, HW8/plant.m, which says it is
based on Quanser's QUBE-Servo scripts):

    Jt = Jr Jp + Mp (Lp/2)² Jr + Jp Mp Lr²
    A = [0 0 1 0; 0 0 0 1;
         0  Mp² (Lp/2)² Lr g / Jt        −Dr (Jp + Mp (Lp/2)²) / Jt   −Mp (Lp/2) Lr Dp / Jt;
         0  Mp g (Lp/2) (Jr + Mp Lr²)/Jt  −Mp (Lp/2) Lr Dr / Jt        −Dp (Jr + Mp Lr²) / Jt]
    B = [0; 0; (Jp + Mp (Lp/2)²) / Jt; Mp (Lp/2) Lr / Jt]

This is the torque-input (mechanical) part; the motor's voltage input and back-EMF are issue 22.
ipgen represents the rig exactly with J[0] = Jr (the arm's inertia about the vertical, which no
rod of the arm's mass and length has: a rod about one end would be Mr Lr²/3) and the pendulum's
defaults (com = Lp/2, J = Mp Lp²/12), inertia "pivot" (Quanser's model counts the pendulum's
inertia about its pivot axis only). Quanser's α is positive the other way round (its M01 is
−½ Mp Lp Lr): the published A, B are S A S and S B with S = diag(1, −1, 1, −1).
"""

from __future__ import annotations

import numpy as np

import ipgen

MR, LR, DR = 0.095, 0.085, 0.0015
MP, LP, DP = 0.024, 0.129, 0.0005
G = 9.81
JR, JP = MR * LR**2 / 12, MP * LP**2 / 12


def published() -> tuple[np.ndarray, np.ndarray]:
    jt = JR * JP + MP * (LP / 2) ** 2 * JR + JP * MP * LR**2
    a = np.array(
        [
            [0, 0, 1, 0],
            [0, 0, 0, 1],
            [
                0,
                MP**2 * (LP / 2) ** 2 * LR * G / jt,
                -DR * (JP + MP * (LP / 2) ** 2) / jt,
                -MP * (LP / 2) * LR * DP / jt,
            ],
            [
                0,
                MP * G * (LP / 2) * (JR + MP * LR**2) / jt,
                -MP * (LP / 2) * LR * DR / jt,
                -DP * (JR + MP * LR**2) / jt,
            ],
        ]
    )
    b = np.array([[0], [0], [(JP + MP * (LP / 2) ** 2) / jt], [MP * (LP / 2) * LR / jt]])
    return a, b


def test_qube_servo_2_linear_model() -> None:
    a, b = ipgen.linearize("rotary", 1, m=[MR, MP], l=[LR, LP], delta=[DR, DP], g=G, J=[JR, JP])
    s = np.diag([1.0, -1.0, 1.0, -1.0])
    a_pub, b_pub = published()
    assert np.allclose(s @ a @ s, a_pub, rtol=1e-12, atol=1e-12), (s @ a @ s, a_pub)
    assert np.allclose(s @ b, b_pub, rtol=1e-12, atol=1e-12)


def test_the_rod_arm_would_not_match() -> None:
    """Without J[0] (the default: a rod of the arm's mass and length about one end) the model
    is another rig: the published matrices are not reproduced."""
    a, _ = ipgen.linearize("rotary", 1, m=[MR, MP], l=[LR, LP], delta=[DR, DP], g=G)
    s = np.diag([1.0, -1.0, 1.0, -1.0])
    assert not np.allclose(s @ a @ s, published()[0], rtol=1e-3)
