"""`ipgen run` of fixed-pivot scenes: the simulator with m inputs against an independent integration.

The pendubot (joint 1 driven), the acrobot (joint 2) and the fully actuated double pendulum (both)
with geared rotors and damping, driven by pulses and steps, run by `ipgen run` (ipsim, CVODE BDF,
rtol 1e-10) equal tests/test_fixed_energy.py's `integrate` (scipy DOP853 on the sympy FixedModel,
integrated here segment by segment between the inputs' jumps) to 1e-6 rad and rad/s; the summary's
energy balance (every input's work) closes within 1e-6 J; a free chain keeps its energy. Bad input
tables are refused in one line before anything is built.
"""

from __future__ import annotations

import itertools
import re
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from scipy.integrate import solve_ivp

from ipgen.errors import Error
from ipgen.model.fixed import FixedPendulum
from ipgen.model.fixed_numeric import FixedModel
from ipgen.pipeline.run import run_scene

TOLERANCE = 1e-6  # rad, rad/s: the simulator (rtol 1e-10, atol 1e-12) against DOP853 (rtol 1e-11)
BALANCE = 1e-6  # J

CHAIN = """
[system]
type = "fixed"
links = 2

[parameters]
m = [0.6, 0.4]
l = [0.3, 0.25]
delta = {delta}
com = [0.15, 0.1]
J = [0.004, 0.002]

[actuator]
joints = {joints}
{rotors}

[initial]
theta = [0.3, -0.2]
dtheta = [0.0, 0.5]

[simulation]
t_end = {t_end}
sample = 0.01

[outputs]
energy = true
"""
PULSE = {"kind": "pulse", "amplitude": 0.8, "start": 0.2, "duration": 0.5}
STEP = {"kind": "step", "amplitude": -0.5, "time": 0.4}


def _toml_input(table: dict[str, object], many: bool) -> str:
    header = "[[input]]" if many else "[input]"
    lines = [f"{key} = {value!r}".replace("'", '"') for key, value in table.items()]
    return "\n" + header + "\n" + "\n".join(lines) + "\n"


def _scene(
    path: Path,
    joints: tuple[int, ...],
    inputs: list[dict[str, object]],
    free: bool = False,
    t_end: float = 1.0,
) -> Path:
    rotors = "" if free else f"Ir = {[2e-4] * len(joints)}\ngr = {[6.0] * len(joints)}"
    text = CHAIN.format(
        delta="[0.0, 0.0]" if free else "[0.02, 0.01]", joints=list(joints), rotors=rotors, t_end=t_end
    )
    text += "".join(_toml_input(table, len(joints) > 1) for table in inputs)
    path.write_text(text)
    return path


def _value(table: dict[str, object], t: float) -> float:
    if table["kind"] == "pulse":
        on = table["start"] <= t < table["start"] + table["duration"]  # type: ignore[operator]
        return float(table["amplitude"]) if on else 0.0  # type: ignore[arg-type]
    if table["kind"] == "step":
        return float(table["amplitude"]) if t >= table["time"] else 0.0  # type: ignore[arg-type,operator]
    return 0.0


def _reference(
    chain: FixedPendulum,
    inputs: list[dict[str, object]],
    times: np.ndarray,
    start: tuple[float, ...] = (0.3, -0.2, 0.0, 0.5),
) -> np.ndarray:
    """[q, q̇] at `times` by DOP853 on FixedModel (in the chain's coordinates), restarted at every
    jump of an input (the right-hand side of tests/test_fixed_energy.py's `integrate`)."""
    model = FixedModel(chain)
    n = chain.links
    jumps = sorted(
        {float(t) for table in inputs for t in (table.get("start"), table.get("time")) if t is not None}
        | {float(table["start"]) + float(table["duration"]) for table in inputs if table["kind"] == "pulse"}  # type: ignore[arg-type]
    )
    edges = [0.0, *[t for t in jumps if 0.0 < t < times[-1]], float(times[-1])]
    x = np.array(start)
    rows = np.empty((len(times), 2 * n))
    for a, b in itertools.pairwise(edges):
        u = np.array([_value(table, 0.5 * (a + b)) for table in inputs])

        def f(t: float, y: np.ndarray, u: np.ndarray = u) -> np.ndarray:
            return np.concatenate([y[n:], model.forward_dynamics(y[:n], y[n:], u)])

        inside = (times >= a - 1e-12) & (times <= b + 1e-12)
        solution = solve_ivp(f, (a, b), x, method="DOP853", t_eval=times[inside], rtol=1e-11, atol=1e-12)
        assert solution.success, solution.message
        rows[inside] = solution.y.T
        x = (
            solution.y[:, -1]
            if solution.t[-1] == b
            else solve_ivp(f, (a, b), x, method="DOP853", rtol=1e-11, atol=1e-12).y[:, -1]
        )
    return rows


def _balance(summary: str) -> float:
    found = re.search(r"balance error (\S+) J", summary)
    assert found, summary
    return float(found.group(1))


@pytest.mark.parametrize(
    ("joints", "inputs"),
    [((1,), [PULSE]), ((2,), [STEP]), ((1, 2), [PULSE, STEP])],
    ids=["pendubot", "acrobot", "both"],
)
def test_run_equals_the_independent_integration(
    tmp_path: Path, joints: tuple[int, ...], inputs: list[dict[str, object]]
) -> None:
    scene = _scene(tmp_path / "chain.toml", joints, inputs)
    outcome = run_scene(scene, tmp_path / "out", plot=len(joints) > 1)  # one plot: it does not crash
    assert outcome.status == 0, outcome.messages
    data = np.genfromtxt(tmp_path / "out" / "chain.csv", delimiter=",", names=True)
    names = data.dtype.names
    assert names[:5] == ("t", "theta0", "theta1", "dtheta0", "dtheta1")
    assert names[-len(joints) :] == (("u1", "u2") if len(joints) > 1 else ("dissipated",))
    times = data["t"]
    simulated = np.column_stack([data[name] for name in ("theta0", "theta1", "dtheta0", "dtheta1")])
    chain = FixedPendulum.from_scene(_scene(tmp_path / "chain_only.toml", joints, []))
    expected = _reference(chain, inputs, times)
    assert np.max(np.abs(simulated - expected)) < TOLERANCE
    assert abs(_balance(outcome.summary)) < BALANCE
    assert float(re.search(r"input work (\S+) J", outcome.summary).group(1)) != 0.0  # type: ignore[union-attr]
    if len(joints) > 1:  # the inputs' columns: each joint's torque as its table says
        for k, table in enumerate(inputs, start=1):
            assert np.array_equal(data[f"u{k}"], [_value(table, t) for t in times])
        assert (tmp_path / "out" / "chain.png").is_file()


def test_a_free_chain_keeps_its_energy(tmp_path: Path) -> None:
    scene = _scene(tmp_path / "free.toml", (1,), [], free=True, t_end=2.0)
    outcome = run_scene(scene, tmp_path / "out", plot=False)
    assert outcome.status == 0, outcome.messages
    data = np.genfromtxt(tmp_path / "out" / "free.csv", delimiter=",", names=True)
    energy = data["kinetic"] + data["potential"]
    assert np.max(np.abs(energy - energy[0])) < BALANCE
    assert np.all(data["input_work"] == 0.0) and np.all(data["dissipated"] == 0.0)


def refusal(tmp_path: Path, text: str) -> str:
    """The one-line error `ipgen run` gives for the scene `text` (tests/test_fixed_lqr.py too)."""
    scene = tmp_path / "bad.toml"
    scene.write_text(text)
    with pytest.raises(Error) as caught:
        run_scene(scene, tmp_path / "out", plot=False)
    message = str(caught.value)
    assert "\n" not in message
    return message


BOTH = CHAIN.format(delta="[0.0, 0.0]", joints=[1, 2], rotors="", t_end=1.0)


@pytest.mark.parametrize(
    ("extra", "says"),
    [
        (_toml_input(PULSE, False), "[input] is one table, this chain has 2 driven joints"),
        (_toml_input(PULSE, True), "[[input]] has 1 tables, this chain has 2 driven joints"),
        (_toml_input(PULSE, True) + _toml_input({"kind": "pulse", "amplitude": 1.0}, True),
         "[[input]] 2 (joint 2): missing required key 'input.duration'"),
        (_toml_input(PULSE, True) + _toml_input(STEP | {"f0": 1}, True),
         "[[input]] 2 (joint 2): input.f0 is not used by a 'step' input"),
        (_toml_input(STEP, True) + _toml_input({"kind": "wobble"}, True),
         "[[input]] 2 (joint 2): input.kind = \"wobble\": expected"),
        ("\n[swingup]\nmethod = \"trajectory\"\n", "[swingup] drives one joint; this chain drives 2"),
        ("\n[sensors]\nnoise = 0.1\n", "[sensors] on a fixed-pivot chain: ipgen run simulates"),
    ],
    ids=["one-table", "too-few", "missing-key", "other-kind", "bad-kind", "swingup", "sensors"],
)  # fmt: skip
def test_bad_input_tables_are_refused_in_one_line(tmp_path: Path, extra: str, says: str) -> None:
    assert says in refusal(tmp_path, BOTH + extra)


def test_a_dfki_preset_runs_in_its_coordinates(tmp_path: Path) -> None:
    """DFKI's design C.0 (model_3.0: a negative J, atan Coulomb friction, rotors geared −6, both
    joints driven) in DFKI's coordinates (q1 from hanging, q2 relative, counterclockwise; the
    inputs counterclockwise torques): the CSV equals DOP853 on FixedModel in those coordinates."""
    from ipgen.common.presets import preset_path

    start = (0.4, -0.3, 0.0, 1.0)
    inputs = [PULSE, STEP]
    text = preset_path("dfki_c0").read_text()
    text = text[: text.index("[initial]")]  # the chain; its run's tables here
    text += f"\n[initial]\ntheta = {list(start[:2])}\ndtheta = {list(start[2:])}\n"
    text += "\n[simulation]\nt_end = 0.6\nsample = 0.01\n\n[outputs]\nenergy = true\n"
    text += "".join(_toml_input(table, True) for table in inputs)
    scene = tmp_path / "dfki.toml"
    scene.write_text(text)
    outcome = run_scene(scene, tmp_path / "out", plot=False)
    assert outcome.status == 0, outcome.messages
    data = np.genfromtxt(tmp_path / "out" / "dfki.csv", delimiter=",", names=True)
    names = ("theta0", "theta1", "dtheta0", "dtheta1")
    simulated = np.column_stack([data[name] for name in names])
    chain = FixedPendulum.preset("dfki_c0")
    assert chain.resolved("J")[1] < 0 and chain.coulomb_law == "atan"
    assert np.max(np.abs(simulated - _reference(chain, inputs, data["t"], start))) < TOLERANCE
    assert abs(_balance(outcome.summary)) < BALANCE  # the friction's dissipated energy included
    assert np.array_equal(data["u1"], [_value(PULSE, t) for t in data["t"]])  # the rig's sense, as given


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(
    count=st.integers(min_value=0, max_value=4),
    amplitude=st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.text(max_size=5), st.booleans()),
    key=st.sampled_from(["amplitude", "start", "duration", "time", "frequency", "color"]),
)
def test_any_input_tables_are_checked_in_one_line(
    tmp_path: Path, count: int, amplitude: object, key: str
) -> None:
    tables = "".join(
        _toml_input({"kind": "pulse", "amplitude": 0.5, "start": 0.0, "duration": 0.1}, True)
        for _ in range(count)
    )
    if count:
        value = amplitude if not isinstance(amplitude, float) or np.isfinite(amplitude) else "nan"
        shown = f'"{value}"' if isinstance(value, str) and value != "nan" else str(value).lower()
        tables += f"{key} = {shown}\n"
    try:
        from ipgen.pipeline.fixed_run import fixed_plan
        from ipgen.scene.load import parse_document

        scene = tmp_path / "any.toml"
        scene.write_text(BOTH + tables)
        reader, document = parse_document(scene)
        plan = fixed_plan(scene, document, reader)
    except Error as exc:
        assert "\n" not in str(exc) and str(exc).startswith(str(scene))
    else:
        assert count in (0, 2) and plan.cfg.count("input") >= 1


def test_plot_and_animate_draw_a_fixed_chain_from_its_csv(tmp_path: Path) -> None:
    """`ipgen plot` and `ipgen animate` read a fixed chain's CSV as one (its .cfg says type =
    fixed: no base column), and the animation's points are the chain's joints: for DFKI's
    coordinates (q1 from hanging, q2 relative, counter-clockwise) link i's absolute angle from
    upright, clockwise, is φ1 = π − q1, φ2 = π − q1 − q2, its tip Σ l (sin φ, cos φ)."""
    from PIL import Image

    from ipgen.command.cli import run as cli
    from ipgen.model.coordinates import Coordinates
    from ipgen.plots.animation import _on_a_still_base, canonical_angles, geometry, read_run

    t = np.linspace(0.0, 1.0, 11)
    q1, q2 = 0.3 * np.sin(3 * t), -0.2 + 0.5 * t
    rows = np.column_stack([t, q1, q2, 0.9 * np.cos(3 * t), np.full_like(t, 0.5), 0.1 * t])
    csv = tmp_path / "chain.csv"
    header = "t,theta0,theta1,dtheta0,dtheta1,u"
    np.savetxt(csv, rows, delimiter=",", header=header, comments="", fmt="%.17g")
    cfg = "type = fixed\nlinks = 2\nl = 0.2 0.3\nangles = relative\nzero = hanging\n"
    cfg += "positive = counterclockwise\n"
    csv.with_suffix(".cfg").write_text(cfg)

    assert cli(["plot", str(csv)]) == 0 and csv.with_suffix(".png").is_file()
    assert cli(["animate", str(csv), "--fps", "5"]) == 0
    with Image.open(csv.with_suffix(".gif")) as gif:
        assert gif.n_frames == 6  # 1 s at 5 frames per second, both ends

    rig = Coordinates("relative", "hanging", "counterclockwise")
    angles = canonical_angles(_on_a_still_base(read_run(csv)), rig)
    side = geometry("classical", [0.0, 0.2, 0.3], angles)["side"]
    phi1, phi2 = np.pi - q1, np.pi - q1 - q2
    elbow = np.column_stack([0.2 * np.sin(phi1), 0.2 * np.cos(phi1)])
    tip = elbow + np.column_stack([0.3 * np.sin(phi2), 0.3 * np.cos(phi2)])
    np.testing.assert_allclose(side[:, 0], 0.0, atol=1e-15)  # the pivot stays put
    np.testing.assert_allclose(side[:, 1], elbow, atol=1e-12)
    np.testing.assert_allclose(side[:, 2], tip, atol=1e-12)
