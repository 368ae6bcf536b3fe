"""[sensors], [estimator] and the drive keys of [actuator] on the Python side (issue 32): what a
scene with them writes into the resolved config, that a scene without them writes what it
wrote before, and that bad tables are one-line errors with nothing written (hypothesis).

The simulator's side (measurement, delay, estimators, reproducibility) is test_sensors_sim.py.
"""

from __future__ import annotations

import contextlib
import io
import math
import tempfile
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from scipy.linalg import expm, solve_discrete_are
from shipped_scenes import shipped_scene

from ipgen.command.cli import MESSAGE_CHARS, run
from ipgen.control.linear import linearize
from ipgen.errors import SceneError
from ipgen.experiment.config import resolved_config
from ipgen.experiment.scene import Scene, load_scene

ROOT = Path(__file__).resolve().parent.parent
LOOP_KEYS = ("sensors.", "estimator", "actuator.noise", "actuator.lag", "actuator.pulses")

# The paper's rotary single pendulum, a sampled LQR at 1 kHz.
BASE = """\
[system]
type = "{type}"
links = 1
[parameters]
m = [0.5, 0.275]
l = [0.6, 0.5]
delta = [0.3, 0.011458]
[initial]
theta = [0, 0.05]
{actuator}
[controller]
kind = "lqr"
saturation = 5
{period}
[simulation]
t_end = 0.5
sample = 0.001
"""


def scene(tmp_path: Path, extra: str = "", *, period: str = "period = 0.001", actuator: str = "",
          kind: str = "rotary") -> Path:  # fmt: skip
    path = tmp_path / "loop.toml"
    path.write_text(BASE.format(type=kind, period=period, actuator=actuator) + extra)
    return path


def config(path: Path, load: Callable[[Path], Scene] = load_scene) -> dict[str, str]:
    text = resolved_config(load(path))
    return dict(line.split(" = ", 1) for line in text.splitlines() if line and not line.startswith("#"))


def test_shipped_scenes_write_no_loop_keys() -> None:
    """No shipped scene has the new tables: their configs carry none of the new keys (so the
    simulator runs today's loop: test_sensors_sim.py checks that path byte for byte)."""
    for path in sorted((ROOT / "scenes").rglob("*.toml")):
        if path.stem.startswith(("qube_servo2_sensors", "qube_servo2_swingup", "qube_servo2_mpc")):
            continue  # measured loops
        if 'type = "fixed"' in path.read_text(encoding="utf-8"):  # no simulator config yet
            continue
        keys = config(path, shipped_scene)
        assert not [key for key in keys if key.startswith(LOOP_KEYS)], path


def test_sensor_keys_are_written_per_measured_coordinate(tmp_path: Path) -> None:
    table = "[sensors]\nmeasured = [0]\nresolution = 4096\nnoise = [0.001]\ndelay = 0.002\nseed = 7\n"
    keys = config(scene(tmp_path, table + '[estimator]\nkind = "kalman"\n'))
    assert keys["sensors.measured"] == "0"
    assert keys["sensors.resolution"] == "4096"
    assert keys["sensors.noise"] == "0.001"
    assert keys["sensors.delay"] == "0.002"
    assert keys["sensors.seed"] == "7"
    assert keys["estimator"] == "kalman"


def test_defaults_measure_every_coordinate_exactly(tmp_path: Path) -> None:
    keys = config(scene(tmp_path, "[sensors]\n"))
    assert keys["sensors.measured"] == "0 1"
    assert keys["sensors.resolution"] == "0 0" and keys["sensors.noise"] == "0 0"
    assert keys["sensors.delay"] == "0" and keys["sensors.seed"] == "0" and keys["estimator"] == "exact"
    keys = config(scene(tmp_path, '[estimator]\nkind = "filter"\n'))  # [estimator] alone: default sensors
    assert keys["sensors.measured"] == "0 1" and keys["estimator.cutoff"] == "50"


def test_drive_keys(tmp_path: Path) -> None:
    keys = config(
        scene(
            tmp_path,
            actuator="[actuator]\nnoise = 0.01\nlag = 0.005\npulses = [[0.1, 0.02, 0.3], [0.3, 0.01, -1]]",
        )
    )
    assert keys["actuator.noise"] == "0.01" and keys["actuator.lag"] == "0.005"
    assert keys["actuator.pulses"] == "0.1 0.02 0.3 0.3 0.01 -1"
    assert not any(key.startswith("sensors.") for key in keys)  # no sensors: no y_*, hat_* columns


def test_kalman_numbers_are_the_zoh_model_and_the_dlqe_gain(tmp_path: Path) -> None:
    """A_d, B_d against expm of the linearisation (ipgen.linearize), M against scipy's discrete
    Riccati solution with Rn = Δ²/12 (the default: quantisation only)."""
    period, counts = 0.001, 2048
    keys = config(
        scene(
            tmp_path, f'[sensors]\nmeasured = [0, 1]\nresolution = {counts}\n[estimator]\nkind = "kalman"\n'
        )
    )
    a, b = linearize("rotary", 1, [0.5, 0.275], [0.6, 0.5], [0.3, 0.011458])
    block = np.zeros((5, 5))
    block[:4, :4], block[:4, 4] = a, b[:, 0]
    e = expm(block * period)
    a_d = np.array(keys["estimator.A"].split(), dtype=float).reshape(4, 4)
    b_d = np.array(keys["estimator.B"].split(), dtype=float)
    np.testing.assert_allclose(a_d, e[:4, :4], rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(b_d, e[:4, 4], rtol=1e-12, atol=1e-15)
    c = np.eye(2, 4)
    rn = np.eye(2) * (2 * math.pi / counts) ** 2 / 12
    qn = np.outer(b_d, b_d) * (0.01 * 5) ** 2 + period * np.diag([0, 0, 1, 1])
    p = solve_discrete_are(a_d.T, c.T, qn, rn)
    m = p @ c.T @ np.linalg.inv(c @ p @ c.T + rn)
    gain = np.array(keys["estimator.gain"].split(), dtype=float).reshape(4, 2)
    np.testing.assert_allclose(gain, m, rtol=1e-8)
    # The filter's error covariance is smaller than the prediction's (it uses y_k).
    assert np.trace((np.eye(4) - m @ c) @ p) < np.trace(p)


# ---------------------------------------------------------------- bad tables: one line, nothing written

_CHECKS = [HealthCheck.too_slow, HealthCheck.function_scoped_fixture]


def refused(text: str) -> str:
    """Runs `ipgen --scene` on `text`: asserts exit 2, one line `ipgen: error: ...` naming the
    file, nothing written; returns the message."""
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "bad.toml"
        path.write_text(text)
        out = Path(tmp) / "out"
        err = io.StringIO()
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
            status = run(["--scene", str(path), "-o", str(out)])
        message = err.getvalue()
        assert status == 2, message
        assert message.startswith("ipgen: error: ") and message.count("\n") == 1, message
        assert len(message) <= MESSAGE_CHARS + 80 and "Traceback" not in message
        assert not out.exists() and sorted(p.name for p in Path(tmp).iterdir()) == ["bad.toml"]
        return message


def text(extra: str = "", *, period: str = "period = 0.001", actuator: str = "") -> str:
    return BASE.format(type="rotary", period=period, actuator=actuator) + extra


def number(x: float) -> str:
    return "nan" if math.isnan(x) else ("inf" if x > 0 else "-inf") if math.isinf(x) else repr(x)


bad_numbers = st.one_of(
    st.floats(max_value=-1e-300), st.just(math.nan), st.just(math.inf), st.just(-math.inf)
)


@settings(max_examples=10, deadline=None, suppress_health_check=_CHECKS)
@given(key=st.sampled_from(["resolution", "noise", "delay"]), value=bad_numbers)
def test_negative_or_non_finite_sensor_values_are_refused(key: str, value: float) -> None:
    message = refused(text(f"[sensors]\n{key} = {number(value)}\n"))
    assert f"sensors.{key}" in message


@settings(max_examples=10, deadline=None, suppress_health_check=_CHECKS)
@given(k=st.integers(0, 50), fraction=st.floats(0.01, 0.99), table=st.sampled_from(["sensors", "estimator"]))
def test_a_delay_between_periods_is_refused(k: int, fraction: float, table: str) -> None:
    message = refused(text(f"[{table}]\ndelay = {(k + fraction) * 0.001!r}\n"))
    assert "whole multiple of the period" in message and f"{table}.delay" in message


@settings(max_examples=8, deadline=None, suppress_health_check=_CHECKS)
@given(value=bad_numbers)
def test_a_negative_or_non_finite_assumed_delay_is_refused(value: float) -> None:
    assert "estimator.delay" in refused(text(f"[sensors]\n[estimator]\ndelay = {number(value)}\n"))


@settings(max_examples=8, deadline=None, suppress_health_check=_CHECKS)
@given(
    table=st.sampled_from(
        ["[sensors]\n", '[estimator]\nkind = "kalman"\n', '[estimator]\nkind = "ekf"\n', "noise"]
    ),
    period=st.sampled_from(["", "# continuous"]),
)
def test_a_loop_without_a_sampled_controller_is_refused(table: str, period: str) -> None:
    if table == "noise":
        message = refused(text(period=period, actuator="[actuator]\nnoise = 0.1"))
    else:
        message = refused(text(table, period=period))
    assert "need a sampled loop" in message and "period" in message


@settings(max_examples=8, deadline=None, suppress_health_check=_CHECKS)
@given(count=st.integers(0, 6).filter(lambda n: n != 2), key=st.sampled_from(["resolution", "noise"]))
def test_per_coordinate_lists_of_the_wrong_length_are_refused(count: int, key: str) -> None:
    message = refused(text(f"[sensors]\n{key} = {[0.001] * count}\n"))
    assert f"sensors.{key}" in message


@settings(max_examples=8, deadline=None, suppress_health_check=_CHECKS)
@given(measured=st.lists(st.integers(-3, 5), min_size=0, max_size=4).filter(
    lambda m: not (m and all(0 <= i <= 1 for i in m) and m == sorted(set(m)))))  # fmt: skip
def test_bad_measured_coordinates_are_refused(measured: list[int]) -> None:
    assert "sensors.measured" in refused(text(f"[sensors]\nmeasured = {measured}\n"))


@pytest.mark.parametrize("kind", ["difference", "filter"])
def test_unmeasured_angles_need_a_model_based_estimator(kind: str) -> None:
    message = refused(text(f'[sensors]\nmeasured = [1]\n[estimator]\nkind = "{kind}"\n'))
    assert "needs every coordinate measured" in message and "kalman" in message


@settings(max_examples=8, deadline=None, suppress_health_check=_CHECKS)
@given(
    key=st.sampled_from(["process_noise", "measurement_noise"]),
    value=st.one_of(st.lists(st.floats(0.1, 1), min_size=3, max_size=3), st.just([[1.0, 2.0], [0.0, 1.0]]),
                    st.just(-1.0), st.just([[1.0, 0.0], [0.0, -1.0]])),
)  # fmt: skip
def test_bad_covariances_are_refused(key: str, value: object) -> None:
    message = refused(text(f'[sensors]\n[estimator]\nkind = "kalman"\n{key} = {value}\n'))
    assert f"estimator.{key}" in message


@settings(max_examples=8, deadline=None, suppress_health_check=_CHECKS)
@given(pulse=st.one_of(
    st.lists(st.floats(0, 1), min_size=0, max_size=5).filter(lambda p: len(p) != 3),
    st.tuples(st.floats(max_value=-1e-3), st.floats(0.01, 1), st.floats(-1, 1)).map(list),
    st.tuples(st.floats(0, 1), st.floats(max_value=0), st.floats(-1, 1)).map(list),
    st.tuples(st.floats(0, 1), st.floats(0.01, 1), st.just(math.nan)).map(list),
))  # fmt: skip
def test_bad_pulses_and_drive_values_are_refused(pulse: list[float]) -> None:
    values = ", ".join(number(x) for x in pulse)
    assert "actuator.pulses" in refused(text(actuator=f"[actuator]\npulses = [[{values}]]"))


@pytest.mark.parametrize("key", ["noise", "lag"])
def test_negative_drive_values_are_refused(key: str) -> None:
    assert f"actuator.{key}" in refused(text(actuator=f"[actuator]\n{key} = -0.1"))


def test_misplaced_estimator_keys_are_refused() -> None:
    assert "estimator.cutoff" in refused(text('[estimator]\nkind = "kalman"\ncutoff = 10\n'))
    assert "estimator.process_noise" in refused(text('[estimator]\nkind = "filter"\nprocess_noise = 1\n'))
    assert "estimator.kind" in refused(text('[estimator]\nkind = "luenberger"\n'))


@settings(max_examples=12, deadline=None, suppress_health_check=_CHECKS)
@given(value=st.one_of(st.integers(-2, 2), st.floats(allow_nan=False, allow_infinity=False),
                       st.sampled_from(['"true"', '"yes"', "[true]", "{}"])))  # fmt: skip
def test_predict_takes_only_true_or_false(value: object) -> None:
    shown = number(value) if isinstance(value, float) else value  # a TOML float, or the value's own text
    message = refused(text(f'[sensors]\ndelay = 0.002\n[estimator]\nkind = "ekf"\npredict = {shown}\n'))
    assert "estimator.predict" in message


@pytest.mark.parametrize("kind", ["difference", "filter", "kalman"])
def test_predict_needs_an_estimator_that_runs_the_model(kind: str) -> None:
    message = refused(text(f'[sensors]\ndelay = 0.002\n[estimator]\nkind = "{kind}"\npredict = true\n'))
    assert "estimator.predict" in message and '"ekf"' in message and kind in message


def test_predict_with_a_trajectory_swingup_or_an_acceleration_base_is_refused() -> None:
    swing = BASE.split("[initial]")[0].format(type="rotary") + (
        '[simulation]\nt_end = 3.0\nsample = 0.001\n[swingup]\nmethod = "trajectory"\nduration = 1.5\n'
        'u_max = 5.0\nperiod = 0.001\n'
    )
    message = refused(swing + '[sensors]\ndelay = 0.002\n[estimator]\npredict = true\n')
    assert "estimator.predict" in message and "trajectory" in message
    message = refused(text('[sensors]\ndelay = 0.002\n[estimator]\npredict = true\n',
                           actuator='[actuator]\nkind = "acceleration"'))  # fmt: skip
    assert "estimator.predict" in message and "acceleration" in message


def test_predict_is_written_only_when_asked(tmp_path: Path) -> None:
    asked = config(scene(tmp_path, '[sensors]\ndelay = 0.002\n[estimator]\nkind = "exact"\npredict = true\n'))
    assert asked["estimator.predict"] == "1" and asked["sensors.delay"] == "0.002"
    plain = config(scene(tmp_path, "[sensors]\ndelay = 0.002\n"))
    assert "estimator.predict" not in plain and "estimator.delay" not in plain  # the rig's delay, known
    told = config(scene(tmp_path, '[sensors]\ndelay = 0.002\n[estimator]\ndelay = 0.004\npredict = true\n'))
    assert told["estimator.delay"] == "0.004" and told["sensors.delay"] == "0.002"


def test_load_scene_raises_scene_error(tmp_path: Path) -> None:
    with pytest.raises(SceneError, match=r"sensors\.seed"):
        load_scene(scene(tmp_path, "[sensors]\nseed = -1\n"))


# ---------------------------------------------------------------- the EKF that learns the input gain

# The paper's rotary single pendulum swung up by the energy law (no [controller]).
SWING = BASE.split("[initial]")[0].format(type="rotary") + (
    "[initial]\ntheta = [0, 3.14]\n[simulation]\nt_end = 1.0\nsample = 0.001\n"
    '[swingup]\nmethod = "energy"\nu_max = 5.0\nperiod = 0.001\n'
)


@settings(max_examples=10, deadline=None, suppress_health_check=_CHECKS)
@given(key=st.sampled_from(["gain_spread", "gain_drift"]), value=bad_numbers)
def test_a_negative_or_non_finite_gain_setting_is_refused(key: str, value: float) -> None:
    spread = "" if key == "gain_spread" else "gain_spread = 0.2\n"
    message = refused(SWING + f'[sensors]\n[estimator]\nkind = "ekf"\n{spread}{key} = {number(value)}\n')
    assert f"estimator.{key}" in message


def test_gain_learning_needs_an_ekf_a_swingup_and_a_spread() -> None:
    """gain_spread on a kalman filter, without a [swingup], and gain_drift alone: one line each."""
    message = refused(SWING + '[sensors]\n[estimator]\nkind = "kalman"\ngain_spread = 0.2\n')
    assert "estimator.gain_spread" in message and '"ekf"' in message
    message = refused(text('[sensors]\n[estimator]\nkind = "ekf"\ngain_spread = 0.2\n'))
    assert "estimator.gain_spread" in message and "[swingup]" in message
    message = refused(SWING + '[sensors]\n[estimator]\nkind = "ekf"\ngain_drift = 0.01\n')
    assert "estimator.gain_drift" in message and "gain_spread" in message


@settings(max_examples=15, deadline=None, suppress_health_check=_CHECKS)
@given(value=st.one_of(bad_numbers, st.just(0.0), st.floats(60.001, 1e300)))
def test_a_bad_noise_memory_is_refused(value: float) -> None:
    """[estimator] noise_memory zero, negative, above 60 s or not finite: one line naming it."""
    message = refused(SWING + f'[sensors]\n[estimator]\nkind = "ekf"\nnoise_memory = {number(value)}\n')
    assert "estimator.noise_memory" in message


def test_noise_learning_needs_an_ekf() -> None:
    for kind in ("kalman", "difference", "exact"):
        message = refused(SWING + f'[sensors]\n[estimator]\nkind = "{kind}"\nnoise_memory = 1\n')
        assert "estimator.noise_memory" in message and '"ekf"' in message


def test_gain_learning_is_written_only_when_asked(tmp_path: Path) -> None:
    """gain_spread > 0 writes it and the drift (its default unless given); 0 or absent writes
    neither (the config of a scene without them unchanged)."""
    from ipgen.scene.sensors import DEFAULT_GAIN_DRIFT

    path = tmp_path / "swing.toml"
    for extra, expected in (
        ("gain_spread = 0.2\n", ("0.2", repr(DEFAULT_GAIN_DRIFT))),
        ("gain_spread = 0.1\ngain_drift = 0.02\n", ("0.1", "0.02")),
        ("gain_spread = 0\n", None),
        ("", None),
    ):
        path.write_text(SWING + '[sensors]\n[estimator]\nkind = "ekf"\n' + extra)
        keys = config(path)
        if expected is None:
            assert "estimator.gain_spread" not in keys and "estimator.gain_drift" not in keys
        else:
            assert (keys["estimator.gain_spread"], keys["estimator.gain_drift"]) == expected


@pytest.mark.parametrize(("zero", "link"), [("upright", 0.0), ("hanging", math.pi)])
def test_a_swing_ups_estimator_is_built_at_its_upright_in_the_scenes_coordinates(
    tmp_path: Path, zero: str, link: float
) -> None:
    """A swing-up without a [controller] (its LQR hold) with an EKF: the filter's equilibrium
    (where its unmeasured coordinates start, the default Qn's linearisation) is the upright the
    hold aims at, written in the scene's coordinates: the link at 0 when they count from
    upright, half a turn from their zero when they count from hanging (Quanser's QUBE: α
    counter-clockwise)."""
    source = (ROOT / "scenes" / "rigs" / "qube_servo2_swingup.toml").read_text()
    sense = 'positive = "counterclockwise"'
    source = source.replace(sense, f'{sense}\nzero = "{zero}"', 1)
    source = source.replace('kind = "filter"', 'kind = "ekf"', 1)
    assert f'zero = "{zero}"' in source and 'kind = "ekf"' in source and "[controller]" not in source
    path = tmp_path / "swing.toml"
    path.write_text(source)
    equilibrium = [float(v) for v in config(path)["estimator.equilibrium"].split()]
    assert equilibrium[0] == 0.0 and equilibrium[2:] == [0.0, 0.0]
    assert math.remainder(equilibrium[1] - link, 2 * math.pi) == pytest.approx(0.0, abs=1e-12)


@pytest.mark.parametrize(
    ("line", "runs"),
    [
        ("seed = 9223372036854774784", True),  # 2^63 - 1024, the largest double below 2^63
        ("seed = 9223372036854775807", False),  # ipgen took it, the simulator refused it
        ("max_steps = 9223372036854774784", True),
        ("max_steps = 9223372036854775807", False),
        ("max_steps = 100000000000000000000", False),  # ipgen took it, the simulator refused it
    ],
)
def test_the_largest_seed_and_step_limit_ipgen_takes_the_simulator_takes(
    tmp_path: Path, line: str, runs: bool
) -> None:
    """At the top of [sensors] seed and [simulation] max_steps, ipgen and the simulator agree: a
    value ipgen takes runs, one past it is one line from ipgen (exit 2) naming the key."""
    from cxx import require_toolchain

    require_toolchain()
    shipped = Path(__file__).resolve().parents[1] / "scenes" / "rigs" / "qube_servo2_sensors.toml"
    text = shipped.read_text(encoding="utf-8")
    text = text.replace("t_end = 5.0 ", "t_end = 0.02 ").replace("[sensors]\n", "[sensors]\n" + line + "\n")
    if line.startswith("max_steps"):
        text = text.replace(line + "\n", "").replace("[simulation]\n", "[simulation]\n" + line + "\n")
    assert line in text and "t_end = 0.02 " in text
    scene = tmp_path / "s.toml"
    scene.write_text(text, encoding="utf-8")
    error = io.StringIO()
    with contextlib.redirect_stderr(error):
        status = run(["run", str(scene), "-o", str(tmp_path / "out"), "--no-plot"])
    if runs:
        assert status == 0, error.getvalue()
    else:
        key = line.split(" = ")[0]
        assert status == 2 and error.getvalue().count("\n") == 1 and key in error.getvalue(), error.getvalue()
        assert "ipgen: error:" in error.getvalue() and "simulate:" not in error.getvalue()
