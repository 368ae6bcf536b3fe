"""[controller] kind = "mpc" in scenes and the simulator (issue 47): the keys and their one-line
errors, the resolved config, and the simulator's closed loop against `ipgen.mpc`'s step fed the
states the simulator's controller saw (read back from its CSV): the same C step (ipgen_mpc.h), so
the inputs agree to 1e-9; the bound on u and the base's bound hold at every sample.
"""

from __future__ import annotations

import io
import math
import re
import subprocess
from contextlib import redirect_stderr, redirect_stdout
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from run_csv import read_run_csv
from test_scene import ROTARY, expect_error, make

import ipgen
from ipgen.command.cli import run
from ipgen.errors import SceneError
from ipgen.experiment.scene import load_scene

# The QUBE-Servo 2 in volts (Quanser's parameters), ipgen's coordinates, the arm pushed toward its
# travel: u reaches its bound and the arm nears its travel.
QUBE = """\
[system]
type = "rotary"
links = 1
name = "qube_servo2"

[parameters]
m = [0.095, 0.024]
l = [0.085, 0.129]
J = [5.7197916666666667e-05, 3.3282e-05]
delta = [0.0015, 0.0005]

[actuator]
kind = "dc_motor"
Rm = 8.4
kt = 0.042
km = 0.042

[initial]
{initial}

[controller]
kind = "mpc"
q = [1, 10, 0.1, 0.1]
r = 0.1
u_max = 10
travel = 1.0
period = 0.01
{controller}
[simulation]
t_end = {t_end}
{extra}
"""
MEASURED = """
[sensors]
measured = [0, 1]
resolution = 2048

[estimator]
kind = "kalman"
"""
U_MAX, TRAVEL = 10.0, 1.0


PUSHED = "theta = [0.3, 0.15]\ndtheta = [1.0, 0]"
# the microcontroller's method (docs/mpc.md): one Newton step a sample on the barrier, frozen sensitivities
FAST = 'barrier = 0.001\nqp_iterations = 1\nsensitivities = "frozen"\n'


def simulate(
    tmp_path: Path, controller: str = "", extra: str = "", t_end: float = 1.0, initial: str = PUSHED
) -> tuple[dict, object]:
    """Runs the scene; (the CSV's columns by name, the scene)."""
    path = tmp_path / "qube_mpc.toml"
    path.write_text(QUBE.format(controller=controller, extra=extra, t_end=t_end, initial=initial))
    out = tmp_path / "out"
    assert run(["run", str(path), "-o", str(out), "--no-plot"]) == 0
    return read_run_csv(out / "qube_mpc.csv", phase=False).columns(), load_scene(path)


def replay(scene: object, states: np.ndarray) -> np.ndarray:
    """`ipgen.mpc`'s step, built from the scene's resolved design, at each of `states` in turn."""
    design = scene.controller.mpc  # type: ignore[attr-defined]
    nx = len(design.reference)
    controller = ipgen.mpc(
        scene.pendulum,  # type: ignore[attr-defined]
        horizon=design.horizon, period=scene.controller.period, Q=np.reshape(design.Q, (nx, nx)),  # type: ignore[attr-defined]
        R=design.R, P=np.reshape(design.P, (nx, nx)), u_max=design.u_max, u_min=design.u_min,
        bounds={i: (lo, hi) for i, lo, hi in design.bounds},
        soft_bounds={i: (lo, hi) for i, lo, hi in design.soft_bounds} or None,
        soft_penalty=design.soft_penalty, reference=design.reference, substeps=design.substeps,
        mode=design.mode, sqp_iterations=design.sqp_iterations, cold_iterations=design.cold_iterations,
        qp_iterations=design.qp_iterations, sqp_tolerance=design.sqp_tolerance,
        qp_tolerance=design.qp_tolerance,
    )  # fmt: skip
    return np.array([controller.step(x) for x in states])


def test_the_measured_loop_runs_ipgen_mpc_step(tmp_path: Path) -> None:
    """Encoders + Kalman filter, real-time iteration: the simulator's u at each sample is
    ipgen.mpc's step at the estimate the simulator's controller saw (the hat_* columns)."""
    columns, scene = simulate(tmp_path, extra=MEASURED)
    estimate = np.column_stack(
        [columns[f"hat_{name}"] for name in ("theta0", "theta1", "dtheta0", "dtheta1")]
    )
    u = columns["u"][:-1]  # the rows are the sampling instants (sample = period), the last t_end
    expected = replay(scene, estimate[:-1])
    assert np.max(np.abs(u - expected)) <= 1e-9
    assert np.max(np.abs(columns["u"])) <= U_MAX and np.max(np.abs(columns["u"])) > 6  # near its bound
    assert np.max(np.abs(columns["theta0"])) <= TRAVEL and np.max(np.abs(columns["theta0"])) > 0.8
    assert abs(columns["theta1"][-1]) < 0.05  # held near upright


def test_soft_bounds_in_the_converged_mode(tmp_path: Path) -> None:
    """The exact state, a soft bound on the arm's rate (reached) and the converged mode (the line
    search and the exact Hessian): the same steps as ipgen.mpc's; the hard bounds hold. (Where the
    converged mode ends at its SQP budget, far from upright with the arm on its travel, the two
    differ by what the parameters' last bits move in an unconverged iterate: not tested there.)"""
    controller = (
        'mode = "converged"\nsoft_bounds = [[2, -0.5, 0.5]]\nsoft_penalty = [1000, 1000]\nhorizon = 20\n'
    )
    columns, scene = simulate(tmp_path, controller=controller, t_end=0.3, initial="theta = [0, 0.1]")
    states = np.column_stack([columns[name] for name in ("theta0", "theta1", "dtheta0", "dtheta1")])
    expected = replay(scene, states[:-1])
    assert np.max(np.abs(columns["u"][:-1] - expected)) <= 1e-9
    assert np.max(np.abs(columns["u"])) <= U_MAX
    assert np.max(np.abs(columns["theta0"])) <= TRAVEL
    assert np.max(np.abs(columns["dtheta0"])) > 0.5  # the soft bound acted: violated, by little


def test_the_resolved_config_holds_the_whole_problem(tmp_path: Path) -> None:
    from ipgen.experiment.config import resolved_config

    path = tmp_path / "qube_mpc.toml"
    path.write_text(
        QUBE.format(controller="soft_bounds = [[1, -0.5, 0.5]]\n", extra="", t_end=1.0, initial="")
    )
    keys = dict(
        line.split(" = ", 1) for line in resolved_config(load_scene(path)).splitlines() if " = " in line
    )
    assert keys["controller"] == "mpc" and keys["controller.horizon"] == "30"
    assert keys["controller.bounds"] == "0 -1 1" and keys["controller.soft_bounds"] == "1 -0.5 0.5"
    assert keys["controller.u_min"] == "-10" and keys["controller.u_max"] == "10"
    assert len(keys["controller.p"].split()) == 16 and keys["controller.mode"] == "rti"
    assert "controller.gain" not in keys and "controller.saturation" not in keys
    # the method's keys only when set: the interior point's configs are as before them
    assert "controller.barrier" not in keys and "controller.sensitivities" not in keys
    path.write_text(QUBE.format(controller=FAST, extra="", t_end=1.0, initial=""))
    fast = dict(
        line.split(" = ", 1) for line in resolved_config(load_scene(path)).splitlines() if " = " in line
    )
    assert fast["controller.barrier"] == "0.001" and fast["controller.sensitivities"] == "frozen"
    assert fast["controller.qp_iterations"] == "1"


@pytest.mark.parametrize(
    ("lines", "message"),
    [
        ("controller.sensitivities = sideways\ncontroller.mode = rti", "`exact`, `frozen` or `shifted`"),
        ("controller.sensitivities = shifted\ncontroller.mode = converged", "are for mode rti"),
        ("controller.sensitivities = frozen\ncontroller.mode = converged", "are for mode rti"),
    ],
)
def test_the_simulator_refuses_a_bad_method_line(tmp_path: Path, lines: str, message: str) -> None:
    """A .cfg not written by ipgen (the FAST scene's, its method lines replaced): one line
    `simulate: error: ...` naming the key, exit 2, no CSV; the shifted method's own line runs."""
    simulate(tmp_path, controller=FAST.replace('"frozen"', '"shifted"'), t_end=0.05)
    out = tmp_path / "out"
    cfg = (out / "qube_mpc.cfg").read_text()
    assert "controller.sensitivities = shifted" in cfg
    found = re.search(r"Simulator (\S+)", (out / "qube_mpc.txt").read_text())
    assert found is not None
    method = ("controller.sensitivities", "controller.mode")
    kept = [line for line in cfg.splitlines() if not line.startswith(method)]
    bad = tmp_path / "bad.cfg"
    bad.write_text("\n".join([*kept, *lines.split("\n")]) + "\n")
    command = [found.group(1), str(bad), "--csv", str(tmp_path / "bad.csv")]
    done = subprocess.run(command, capture_output=True, text=True, check=False)
    assert done.returncode == 2 and not (tmp_path / "bad.csv").exists()
    assert len(done.stderr.strip().splitlines()) == 1 and message in done.stderr, done.stderr


# ---- the keys' errors: one line each --------------------------------------------------------

MPC = {
    **ROTARY,
    "input.kind": None,
    "input.amplitude": None,
    "input.duration": None,
    "initial.theta": "[0, 0.05]",
    "controller.kind": '"mpc"',
    "controller.u_max": "5",
    "controller.period": "0.01",
}

BAD = [
    ({"controller.u_max": None}, 'controller.kind = "mpc"', "needs u_max"),
    ({"controller.period": None}, 'controller.kind = "mpc"', "add period"),
    ({"controller.saturation": "3"}, "controller.saturation = 3", "u_max"),
    ({"controller.u_max": "0"}, "controller.u_max = 0", "> 0"),
    ({"controller.horizon": "0"}, "controller.horizon", "1 .. 1000"),
    ({"controller.horizon": "2.5"}, "controller.horizon", ""),
    ({"controller.travel": "-1"}, "controller.travel = -1", "> 0"),
    ({"controller.mode": '"fast"'}, "controller.mode", "rti"),
    ({"controller.soft_bounds": "[[9, 0, 1]]"}, "controller.soft_bounds[0]", "0 .. 3"),
    ({"controller.soft_bounds": "[[1, 1, 0]]"}, "controller.soft_bounds[0]", "min < max"),
    ({"controller.soft_bounds": "[[1, 0]]"}, "controller.soft_bounds[0] has 2 entries", "3"),
    ({"controller.soft_bounds": "[[1, -1, 1], [1, -2, 2]]"}, "controller.soft_bounds", "once"),
    ({"controller.soft_penalty": "[1, 0]"}, "controller.soft_penalty", "0 < ρ2"),
    ({"controller.soft_penalty": "[1, 1]"}, "controller.soft_penalty", "soft_bounds"),  # no soft bounds
    ({"controller.p": "[[1, 2, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]"}, "p[1][0]", "P must"),
    ({"controller.p": "[[1, 0, 0, 0], [0, -1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]"}, "p", "P must be"),
    ({"controller.soft_penalty": "[1e300, 1000]"}, "controller.soft_penalty", "ρ1 <= 1e+06"),
    ({"controller.gain": "[1, 2, 3, 4]"}, "controller.gain", 'is for kind = "gain"'),
    ({"controller.kind": '"lqr"', "controller.u_max": "5"}, "controller.u_max = 5", 'is for kind = "mpc"'),
    ({"controller.barrier": "-1"}, "controller.barrier = -1", ">= 0"),
    ({"controller.barrier": '"x"'}, "controller.barrier", "a number"),
    ({"controller.barrier": "1e7"}, "controller.barrier", "<= 1e+06"),
    ({"controller.sensitivities": '"exakt"'}, "controller.sensitivities", "frozen"),
    ({"controller.barrier": "0.001", "controller.mode": '"converged"'}, "controller", "real-time iteration"),
    ({"controller.sensitivities": '"frozen"', "controller.mode": '"converged"'}, "controller", "real-time"),
    ({"controller.q": "[0, 1, 1, 1]", "controller.r": "1e-30"}, "controller", ""),
]


@pytest.mark.parametrize(("changes", "key", "expected"), BAD, ids=[f"{c}" for c, _, _ in BAD])
def test_bad_mpc_key_is_one_line(tmp_path: Path, changes: dict, key: str, expected: str) -> None:
    try:
        load_scene(make(tmp_path, {**MPC, **changes}))
    except SceneError:
        expect_error(make(tmp_path, {**MPC, **changes}), key, expected)
        return
    assert not expected, "loaded"  # the last case may design (a weak weight is not an error)


METHODS = ('"frozen"', '"shifted"')
VALUES = st.one_of(
    st.integers(-2, 40).map(str),
    st.sampled_from(
        ['"rti"', '"converged"', '"x"', "0.5", "-1", "nan", "inf", "true", "1e400", *METHODS, "1e-3"]
    ),
    st.lists(st.sampled_from(["0", "1", "-1", "2.5", '"x"']), max_size=4).map(
        lambda v: "[" + ", ".join(v) + "]"
    ),
    st.sampled_from(
        ["[[0, -1, 1]]", "[[3, -5, 5], [1, -1, 1]]", "[[4, 0, 1]]", "[[0, 1, -1]]", "[[0.5, 0, 1]]"]
    ),
)
KEYS = st.sampled_from(
    [
        "horizon",
        "u_max",
        "travel",
        "soft_bounds",
        "soft_penalty",
        "mode",
        "iterations",
        "qp_iterations",
        "substeps",
        "barrier",
        "sensitivities",
    ]
)


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.dictionaries(KEYS, VALUES, max_size=3))
def test_any_mpc_table_loads_or_fails_in_one_line(tmp_path: Path, table: dict[str, str]) -> None:
    """Whatever the new keys hold: a scene whose resolved MPC is within its keys' rules, or one
    SceneError line naming [controller]."""
    path = make(tmp_path, {**MPC, **{f"controller.{key}": value for key, value in table.items()}})
    try:
        scene = load_scene(path)
    except SceneError as exc:
        message = str(exc)
        assert "\n" not in message and message.startswith(f"{path.as_posix()}: "), message
        assert "controller" in message, message
        return
    design = scene.controller.mpc
    assert design is not None and 1 <= design.horizon <= 1000 and 1 <= design.substeps <= 100
    assert design.u_max > 0 and design.u_min == -design.u_max and design.mode in ("rti", "converged")
    assert all(math.isfinite(v) for v in (*design.Q, *design.P, design.R))
    assert all(0 <= i < 4 and lo < hi for i, lo, hi in (*design.bounds, *design.soft_bounds))
    assert design.barrier >= 0 and design.sensitivities in ("exact", "frozen", "shifted")
    assert design.mode == "rti" or (design.barrier == 0 and design.sensitivities == "exact")


def test_the_rigs_coordinates_give_the_same_physical_run(tmp_path: Path) -> None:
    """The QUBE in Quanser's convention (positive = counterclockwise, zero = hanging: α = π − θ1
    wherever θ1 is ipgen's) with the same physical start, weights, a soft bound on the pendulum
    written in the rig's angles and encoders + Kalman filter: the MPC works in ipgen's coordinates
    (the weights Pᵀ Q P, the bound mapped), so the run is the canonical scene's, its link angle
    read through the map, its volts the same (1e-9: the Kalman filter is designed in the rig's
    coordinates, P A P⁻¹)."""
    soft = "soft_bounds = [[1, {lo}, {hi}]]\n"  # the link within ±1 rad of upright, in each convention
    (tmp_path / "ipgen").mkdir()
    canonical, _ = simulate(tmp_path / "ipgen", controller=soft.format(lo=-1.0, hi=1.0), extra=MEASURED)
    quanser = 'name = "qube_servo2"\npositive = "counterclockwise"\nzero = "hanging"'
    rig_text = QUBE.format(
        controller=soft.format(lo=math.pi - 1.0, hi=math.pi + 1.0), extra=MEASURED, t_end=1.0,
        initial=f"theta = [0.3, {math.pi - 0.15!r}]\ndtheta = [1.0, 0]",
    ).replace('name = "qube_servo2"', quanser)  # fmt: skip
    (tmp_path / "rig").mkdir()
    path = tmp_path / "rig" / "qube_mpc.toml"
    path.write_text(rig_text)
    assert run(["run", str(path), "-o", str(tmp_path / "rig" / "out"), "--no-plot"]) == 0
    rig = read_run_csv(tmp_path / "rig" / "out" / "qube_mpc.csv", phase=False).columns()
    assert np.max(np.abs(rig["u"] - canonical["u"])) <= 1e-9 and np.max(np.abs(canonical["u"])) > 5
    assert np.allclose(rig["theta0"], canonical["theta0"], atol=1e-9)
    assert np.allclose(rig["theta1"], math.pi - canonical["theta1"], atol=1e-9)


def test_a_terminal_weight_in_the_rigs_coordinates_is_mapped_as_the_stage_weights(tmp_path: Path) -> None:
    """p given as 2 dof weights or as a matrix in Quanser's convention: the resolved terminal
    weight in ipgen's coordinates is Pᵀ p P (a sign flip keeps a diagonal; the off-diagonal
    entries of a matrix change sign with it)."""
    quanser = 'name = "qube_servo2"\npositive = "counterclockwise"'
    for stated, expected in (
        ("p = [2, 3, 4, 5]", np.diag([2.0, 3.0, 4.0, 5.0])),
        ("p = [[2, 1, 0, 0], [1, 3, 0, 0], [0, 0, 4, 0], [0, 0, 0, 5]]",
         np.array([[2.0, -1, 0, 0], [-1, 3, 0, 0], [0, 0, 4, 0], [0, 0, 0, 5]])),
    ):  # fmt: skip
        path = tmp_path / "qube_mpc.toml"
        path.write_text(
            QUBE.format(controller=stated + "\n", extra="", t_end=1.0, initial=PUSHED).replace(
                'name = "qube_servo2"', quanser
            )
        )
        design = load_scene(path).controller.mpc
        assert np.allclose(np.array(design.P).reshape(4, 4), expected, rtol=0, atol=0)


def test_a_bound_on_a_relative_angle_is_refused_in_one_line(tmp_path: Path) -> None:
    """angles = "relative": a soft bound on link 2's angle bounds θ2 − θ1, not one of ipgen's
    coordinates: refused, naming the coordinate and what to bound instead."""
    text = QUBE.format(controller="soft_bounds = [[2, -1, 1]]\n", extra="", t_end=1.0, initial=PUSHED)
    for old, new in (
        ("links = 1", 'links = 2\nangles = "relative"'),
        ("theta = [0.3, 0.15]\ndtheta = [1.0, 0]", "theta = [0.3, 0.15, 0]\ndtheta = [1.0, 0, 0]"),
        ("m = [0.095, 0.024]", "m = [0.095, 0.024, 0.024]"),
        ("l = [0.085, 0.129]", "l = [0.085, 0.129, 0.129]"),
        ("J = [5.7197916666666667e-05, 3.3282e-05]\n", ""),
        ("delta = [0.0015, 0.0005]", "delta = [0.0015, 0.0005, 0.0005]"),
        ("q = [1, 10, 0.1, 0.1]", "q = [1, 10, 10, 0.1, 0.1, 0.1]"),
    ):
        text = text.replace(old, new)
    path = tmp_path / "relative.toml"
    path.write_text(text)
    err = io.StringIO()
    with redirect_stdout(io.StringIO()), redirect_stderr(err):
        assert run(["run", str(path), "-o", str(tmp_path / "out"), "--no-plot"]) == 2
    message = err.getvalue().strip()
    assert message.count("\n") == 0 and "soft_bounds on coordinate 2 bound a relative angle" in message, (
        message
    )
