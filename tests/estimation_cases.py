"""Pendulums the estimation tests share: the QUBE-Servo 2 preset (a DC motor, Quanser's
counter-clockwise α) and the paper's rotary single and double pendulum (scenes/rsip_pulse.toml,
scenes/rdip_lqr.toml), as ipgen's keyword descriptions; and the samples the EKF tests draw."""

from __future__ import annotations

from hypothesis import strategies as st

# (y, u) samples for an EKF measuring two angles: y within ±0.3 rad, u within ±5
EKF_SAMPLES = st.lists(
    st.tuples(st.lists(st.floats(-0.3, 0.3), min_size=2, max_size=2), st.floats(-5, 5)),
    min_size=1,
    max_size=12,
)

QUBE = {
    "type": "rotary",
    "links": 1,
    "m": [0.095, 0.024],
    "l": [0.085, 0.129],
    "J": [5.7197916666666667e-05, 3.3282e-05],
    "delta": [0.0015, 0.0005],
    "actuator": {"kind": "dc_motor", "Rm": 8.4, "kt": 0.042, "km": 0.042},
    "positive": "counterclockwise",
}
QUBE_LQR = {"Q": [5, 1, 1, 1], "R": 1}  # scenes/rigs/qube_servo2.toml
QUBE_SATURATION = 10.0  # V
RSIP = {"type": "rotary", "links": 1, "m": [0.5, 0.275], "l": [0.6, 0.5], "delta": [0.3, 0.011458]}
RDIP = {
    "type": "rotary",
    "links": 2,
    "m": [0.5, 0.275, 0.275],
    "l": [0.6, 0.5, 0.5],
    "delta": [0.3, 0.011458, 0.011458],
}
CDIP = {
    "type": "classical",
    "links": 2,
    "m": [1.0, 0.3, 0.2],
    "l": [0.0, 0.4, 0.3],
    "delta": [0.5, 0.01, 0.01],
}
