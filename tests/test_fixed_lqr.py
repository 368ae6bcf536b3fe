"""`ipgen run` of fixed-pivot scenes with [controller] kind = "lqr": K m × 2n, every input its row.

DFKI's design C.1 (model_1.0 masses and inertias, their viscous damping; no rotors, and no Coulomb
friction: its atan law, 12-16 N m s/rad of slope at rest, defeats the frictionless LQR of the
underactuated chains from this tilt, in ipsim and in an independent integration alike) in DFKI's
coordinates (q1 from hanging, q2 relative, counterclockwise torques) as the
pendubot ([1]), the acrobot ([2]) and fully actuated ([1, 2]): from a small tilt the upright is
held within 6 N m, and the gain the resolved config carries equals an independent Riccati solve
(python-control's `lqr` on A, B from central differences of FixedModel's forward dynamics).
Bad [controller] tables are refused in one line.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from test_fixed_run import refusal

from ipgen.errors import Error
from ipgen.model.fixed import FixedPendulum
from ipgen.model.fixed_numeric import FixedModel
from ipgen.pipeline.run import run_scene

CHAIN = """
[system]
type = "fixed"
links = 2
angles = "relative"
zero = "hanging"
positive = "counterclockwise"

[parameters]
m = [0.5234602302310271, 0.6255677234174437]
l = [0.2, 0.3]
com = [0.2, 0.25569305436052964]
J = [0.010948790382272026, 0.009970894693799519]
delta = [0.001, 0.001]
g = 9.81

[actuator]
joints = {joints}

[initial]
theta = [{tilt}, 0.1]

[simulation]
t_end = 2.0
sample = 0.01
"""
CONTROLLER = """
[controller]
kind = "lqr"
q = [10.0, 10.0, 1.0, 1.0]
r = 1.0
saturation = 6.0
{period}
"""


def _scene(path: Path, joints: list[int], period: float | None, tilt: float = math.pi - 0.08) -> Path:
    text = CHAIN.format(joints=joints, tilt=tilt)
    text += CONTROLLER.format(period="" if period is None else f"period = {period}")
    path.write_text(text)
    return path


def _independent_gain(chain: FixedPendulum) -> np.ndarray:
    """K of python-control's lqr on A, B by central differences of the forward dynamics at upright."""
    import control

    model, n, m = FixedModel(chain), chain.links, chain.inputs
    x0, u0 = np.array([math.pi, 0.0, 0.0, 0.0]), np.zeros(m)

    def f(x: np.ndarray, u: np.ndarray) -> np.ndarray:
        return np.concatenate([x[n:], model.forward_dynamics(x[:n], x[n:], u, coulomb=False)])

    h = 1e-6
    a = np.column_stack([(f(x0 + h * e, u0) - f(x0 - h * e, u0)) / (2 * h) for e in np.eye(2 * n)])
    b = np.column_stack([(f(x0, u0 + h * e) - f(x0, u0 - h * e)) / (2 * h) for e in np.eye(m)])
    gain, _, _ = control.lqr(a, b, np.diag([10.0, 10.0, 1.0, 1.0]), np.eye(m))
    return np.asarray(gain)


@pytest.mark.parametrize(
    ("joints", "period"),
    [([1], 0.002), ([2], 0.002), ([1, 2], None)],
    ids=["pendubot", "acrobot", "both-continuous"],
)
def test_lqr_holds_the_upright_with_the_riccati_gain(
    tmp_path: Path, joints: list[int], period: float | None
) -> None:
    scene = _scene(tmp_path / "hold.toml", joints, period)
    outcome = run_scene(scene, tmp_path / "out", plot=False)
    assert outcome.status == 0, outcome.messages
    cfg = (tmp_path / "out" / "hold.cfg").read_text()
    written = re.search(r"^controller\.gain = (.*)$", cfg, re.MULTILINE)
    assert written is not None
    gain = np.array([float(v) for v in written.group(1).split()]).reshape(len(joints), 4)
    chain = FixedPendulum.from_scene(scene)
    assert np.allclose(gain, _independent_gain(chain), rtol=1e-5, atol=1e-6)
    data = np.genfromtxt(tmp_path / "out" / "hold.csv", delimiter=",", names=True)
    final = np.array([data[name][-1] for name in ("theta0", "theta1", "dtheta0", "dtheta1")])
    assert np.max(np.abs(final - [math.pi, 0.0, 0.0, 0.0])) < 0.03  # held (the acrobot still settling at 2 s)
    torques = [name for name in data.dtype.names if re.fullmatch(r"u\d?", name)]
    assert len(torques) == len(joints)
    for name in torques:
        assert np.max(np.abs(data[name])) <= 6.0 + 1e-12
    assert "K row 1 (u1)" in outcome.summary


BASE = CHAIN.format(joints=[1, 2], tilt=3.0)


@pytest.mark.parametrize(
    ("table", "says"),
    [
        ('kind = "pid"', "controller.kind"),
        ('kind = "lqr"\nr = [1.0, 2.0, 3.0]', "controller.r"),
        ('kind = "lqr"\nr = -1.0', "R must be symmetric positive definite"),
        ('kind = "lqr"\nsaturation = [6.0, 0.0]', "controller.saturation"),
        ('kind = "lqr"\nperiod = 0.003', "controller.period"),
        ('kind = "lqr"\nq = [1, 1]', "controller.q"),
        ('kind = "lqr"\nq = [[1, 0], [0, 1]]', "controller.q"),  # 4 numbers, but not 4 × 4
        ('kind = "lqr"\nequilibrium = [1.0, 0.0]', "not an equilibrium"),
        ('kind = "gain"', "missing required key 'controller.gain'"),
        ('kind = "lqr"\ncolour = 1', "unknown key 'controller.colour'"),
    ],
    ids=[
        "kind",
        "r-size",
        "r-negative",
        "saturation",
        "period",
        "q-size",
        "q-shape",
        "equilibrium",
        "gain",
        "unknown",
    ],
)
def test_bad_controller_tables_are_refused_in_one_line(tmp_path: Path, table: str, says: str) -> None:
    assert says in refusal(tmp_path, BASE + "\n[controller]\n" + table + "\n")


@settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(
    key=st.sampled_from(["q", "r", "saturation", "period", "gain", "equilibrium", "kind"]),
    value=st.one_of(
        st.floats(allow_nan=False, allow_infinity=False),
        st.lists(st.floats(allow_nan=False, allow_infinity=False, width=32), max_size=5),
        st.text(max_size=5),
        st.booleans(),
    ),
)
def test_any_controller_value_is_checked_in_one_line(tmp_path: Path, key: str, value: object) -> None:
    from ipgen.pipeline.fixed_run import fixed_plan
    from ipgen.scene.load import parse_document

    if isinstance(value, str):
        shown = '"' + "".join(c for c in value if c.isalnum()) + '"'
    else:
        shown = str(value).lower()
    table = 'kind = "gain"\n' if key == "gain" else ('kind = "lqr"\n' if key != "kind" else "")
    scene = tmp_path / "any.toml"
    scene.write_text(BASE + "\n[controller]\n" + table + f"{key} = {shown}\n")
    try:
        reader, document = parse_document(scene)
        fixed_plan(scene, document, reader)
    except Error as exc:
        assert "\n" not in str(exc) and str(exc).startswith(str(scene))
