"""A drive lag known to the loop ([estimator] compensate_lag, ipgen_loop_lag_* in
cpp/include/ipgen_loop.h): the C functions against the lag's ODE integrated here by scipy, the
inverse's round trip and its bound, the C header's firmware loop against the simulator's, in the
simulator the QUBE preset that a 30 ms lag defeats without the key and not with it, and one-line
errors and the .cfg key only when asked (the simulator's refusal: tests/test_sensors_sim.py)."""

from __future__ import annotations

import ctypes
import io
import math
import re
import subprocess
from contextlib import redirect_stderr, redirect_stdout
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from test_firmware_c import REPLAY
from test_gain_learning import STEP
from test_sensors import config, refused, scene, text

ROOT = Path(__file__).resolve().parents[1]

lags = st.floats(1e-4, 1.0)
periods = st.floats(1e-4, 0.05)
inputs = st.floats(-20.0, 20.0)


def _lib():
    from ipgen.common.loop_runtime import library

    return library()


def _ode(command: float, start: float, lag: float, period: float) -> tuple[float, float]:
    """The drive's input at the period's end and its mean over the period: τ a' = u − a, and its
    integral as a second state, by scipy (RK45, tight tolerances)."""
    from scipy.integrate import solve_ivp

    def rates(_t: float, y: np.ndarray) -> list[float]:
        return [(command - y[0]) / lag, y[0]]

    done = solve_ivp(rates, (0.0, period), [start, 0.0], rtol=1e-12, atol=1e-14)
    assert done.success
    return float(done.y[0, -1]), float(done.y[1, -1] / period)


@settings(max_examples=40, deadline=None)
@given(lag=lags, period=periods, command=inputs, start=inputs)
def test_the_lags_mean_and_end_value_are_the_odes(
    lag: float, period: float, command: float, start: float
) -> None:
    lib = _lib()
    model = lib.ipgen_loop_lag_of(lag, period, math.inf)
    applied = ctypes.c_double(start)
    mean = lib.ipgen_loop_lag_mean(ctypes.byref(model), command, ctypes.addressof(applied))
    end, ode_mean = _ode(command, start, lag, period)
    scale = max(1.0, abs(command), abs(start))
    assert applied.value == pytest.approx(end, abs=1e-9 * scale)
    assert mean == pytest.approx(ode_mean, abs=1e-9 * scale)


@settings(max_examples=40, deadline=None)
@given(lag=lags, period=periods, wanted=inputs, start=inputs, limit=st.floats(0.5, 30.0))
def test_the_command_gives_the_wanted_mean_or_its_bound(
    lag: float, period: float, wanted: float, start: float, limit: float
) -> None:
    """Within the bound the command's mean over its period is the wanted one (the ODE's); at the
    bound the mean is the closest the bound allows (the bound on the wanted side)."""
    lib = _lib()
    model = lib.ipgen_loop_lag_of(lag, period, limit)
    command = lib.ipgen_loop_lag_command(ctypes.byref(model), wanted, start)
    assert abs(command) <= limit
    _, mean = _ode(command, start, lag, period)
    if abs(command) < limit:
        assert mean == pytest.approx(
            wanted, abs=1e-7 * max(1.0, abs(wanted), abs(start)) * (1 + lag / period)
        )
    else:
        _, best = _ode(math.copysign(limit, wanted - start * model.weight), start, lag, period)
        assert command == math.copysign(limit, wanted - start * model.weight)
        assert abs(best - wanted) <= abs(mean - wanted) + 1e-12 and (wanted - mean) * command >= 0


@settings(max_examples=20, deadline=None)
@given(commands=st.lists(inputs, min_size=1, max_size=6), start=inputs, lag=lags, period=periods)
def test_the_inputs_over_a_delay_follow_the_ode(
    commands: list[float], start: float, lag: float, period: float
) -> None:
    lib = _lib()
    model = lib.ipgen_loop_lag_of(lag, period, math.inf)
    pending = np.array([0.5, *commands])  # pending[0]: the command that acted, left as it is
    means = np.zeros_like(pending)
    then = lib.ipgen_loop_lag_ahead(
        ctypes.byref(model), start, len(commands), pending.ctypes.data, means.ctypes.data
    )
    assert means[0] == 0.5
    value = start
    for j, command in enumerate(commands, start=1):
        value, mean = _ode(command, value, lag, period)
        assert means[j] == pytest.approx(mean, abs=1e-8 * 20)
    assert then == pytest.approx(value, abs=1e-8 * 20)


def test_without_a_lag_nothing_changes() -> None:
    lib = _lib()
    for lag in (0.0, -1.0):
        model = lib.ipgen_loop_lag_of(lag, 0.001, 2.0)
        applied = ctypes.c_double(3.0)
        assert (model.decay, model.weight) == (0.0, 0.0)
        assert lib.ipgen_loop_lag_mean(ctypes.byref(model), 7.5, ctypes.addressof(applied)) == 7.5
        assert applied.value == 7.5
        assert lib.ipgen_loop_lag_command(ctypes.byref(model), 9.0, 3.0) == 9.0  # the law's own bound


# ---- the C header and the simulator ---------------------------------------------------------------


def test_the_headers_loop_compensates_the_lag_as_the_simulator_does(tmp_path: Path) -> None:
    """qube_servo2_swingup with an EKF, a delay of 2 periods predicted over and a 5 ms drive lag
    the loop is built for: the C header's firmware step, fed the encoder counts of the simulator's
    run, returns the command the simulator applies 2 samples later (1e-9 of 10 V); the header
    compiles under -Werror in double and in float; the commands differ from the law's (the lag's
    inverse is in use) and reach the bound."""
    from c_models import CC, WARNINGS, require_cc
    from cxx import require_toolchain
    from run_csv import read_run_csv

    from ipgen.command.cli import run

    require_toolchain()
    require_cc()
    name = "qube_servo2_swingup"
    source = (ROOT / "scenes" / "rigs" / f"{name}.toml").read_text()
    source = source.replace(f'name = "{name}"', f'name = "{name}"\nemit = ["c"]')
    source = source.replace('kind = "filter"', 'kind = "ekf"\npredict = true\ncompensate_lag = true', 1)
    source = source.replace("resolution = 2048 ", "delay = 0.002\nresolution = 2048 ", 1)
    source = source.replace('kind = "dc_motor"', 'kind = "dc_motor"\nlag = 0.005', 1)
    assert "\ncompensate_lag = true" in source and "\nlag = 0.005" in source
    path = tmp_path / "scene.toml"
    path.write_text(source)
    for argv in (
        ["--scene", str(path), "-o", str(tmp_path)],
        ["run", str(path), "-o", str(tmp_path / "run"), "--no-plot"],
    ):
        with redirect_stdout(io.StringIO()), redirect_stderr(io.StringIO()) as err:
            assert run(argv) == 0, err.getvalue()
    header = (tmp_path / f"{name}.h").read_text()
    assert "ipgen_loop_lag_command(" in header and f"IPGEN_{name.upper()}_LAG 0.005" in header
    run_ = read_run_csv(tmp_path / "run" / "scene.csv", phase=True).columns()
    zero = np.array([0.0, -math.pi])
    counts = np.rint((np.column_stack([run_["y_theta0"], run_["y_theta1"]]) - zero) / STEP).astype(int)
    (tmp_path / "replay.c").write_text(REPLAY.replace("NAME", name).replace("P_", f"ipgen_{name}_"))
    program = tmp_path / "replay"
    flags = [CC, "-std=c99", "-O1", *WARNINGS, f"-I{tmp_path}"]
    done = subprocess.run(
        [*flags, str(tmp_path / "replay.c"), "-o", str(program), "-lm"], capture_output=True, text=True
    )
    assert done.returncode == 0, done.stderr[:3000]
    in_float = [*flags, "-DIPGEN_SCALAR=float", "-c", str(tmp_path / "replay.c"), "-o", str(tmp_path / "f.o")]
    single = subprocess.run(in_float, capture_output=True, text=True)
    assert single.returncode == 0, single.stderr[:3000]
    lines = "\n".join(f"{a} {b}" for a, b in counts.tolist()) + "\n"
    out = subprocess.run([str(program)], input=lines, capture_output=True, text=True, check=True).stdout
    values = np.array([[float(v) for v in line.split()] for line in out.splitlines()])
    samples, delay = len(values) - 1, 2  # the simulator's u at row k is the command of row k − 2
    assert np.all(run_["u"][:delay] == 0.0)
    assert np.max(np.abs(values[: samples - delay, 0] - run_["u"][delay:samples])) <= 1e-9 * 10.0
    assert np.max(np.abs(run_["u"])) == pytest.approx(10.0)  # the bound: the inverse asks for more


@pytest.mark.parametrize(
    ("preset", "step"), [("qube_servo2_sensors", "loop_step"), ("qube_servo2_mpc", "mpc_loop_step")]
)
def test_the_controllers_loop_steps_compensate_a_lag_and_compile(
    tmp_path: Path, preset: str, step: str
) -> None:
    """An LQR's and an MPC's loop step (no swing-up) with a known lag: the step sends the lag's
    inverse and the header compiles under -Werror in double and float (C99)."""
    from c_models import CC, WARNINGS, require_cc

    from ipgen.command.cli import run

    require_cc()
    source = (ROOT / "scenes" / "rigs" / f"{preset}.toml").read_text()
    source = re.sub(r"^emit = .*\n", "", source, flags=re.M)
    source = re.sub(r"^(name = .*)$", r'\1\nemit = ["c"]', source, count=1, flags=re.M)
    source = source.replace("[estimator]", "[estimator]\ncompensate_lag = true", 1)
    source = source.replace('kind = "dc_motor"', 'kind = "dc_motor"\nlag = 0.01', 1)
    assert "\nlag = 0.01" in source and "compensate_lag = true" in source and 'emit = ["c"]' in source
    path = tmp_path / "scene.toml"
    path.write_text(source)
    with redirect_stdout(io.StringIO()), redirect_stderr(io.StringIO()) as err:
        assert run(["--scene", str(path), "-o", str(tmp_path / "out")]) == 0, err.getvalue()
    (header,) = (tmp_path / "out").glob("*.h")
    text = header.read_text()
    body = text[text.index(f"_{step}(") :]
    body = body[: body.index("\n}\n")]
    assert "ipgen_loop_lag_command(" in body and "s->acted" in body
    unit = tmp_path / "unit.c"
    unit.write_text(f'#include "{header.name}"\n')
    for scalar in ("double", "float"):
        flags = [CC, "-std=c99", *WARNINGS, f"-DIPGEN_SCALAR={scalar}", f"-I{header.parent}", "-c"]
        done = subprocess.run(
            [*flags, str(unit), "-o", str(tmp_path / "unit.o")], capture_output=True, text=True
        )
        assert done.returncode == 0, done.stderr[:3000]


def test_a_known_lag_keeps_the_qube_upright_where_the_nominal_loop_loses_it() -> None:
    """qube_servo2_mpc_swingup_m4f on a drive with a 30 ms lag (the scorecard's lag level 12), its
    loop nominal as a sweep keeps it: without compensate_lag the swing-up is not held; with it, it is."""
    from cxx import require_toolchain

    from ipgen.sweeps import execute
    from ipgen.sweeps.success import Success

    require_toolchain()
    source = (ROOT / "scenes" / "rigs" / "qube_servo2_mpc_swingup_m4f.toml").read_text()
    assert "\ncompensate_lag = true" in source
    plain = "\n".join(line for line in source.splitlines() if not line.startswith("compensate_lag"))
    results = {}
    for name, body in (("known", source), ("plain", plain)):
        task = execute.Task(0, "lag", 0, 0, 0, (("actuator.lag", 0.03),))
        results[name] = execute.run_one(execute.SceneSource(f"qube_{name}", body), task, Success())
    assert results["plain"].outcome == "fail", results
    assert results["known"].outcome == "pass", results["known"]


# ---- the scene key -----------------------------------------------------------------------------


@settings(max_examples=12, deadline=None)
@given(value=st.one_of(st.integers(-2, 2), st.floats(allow_nan=False, allow_infinity=False),
                       st.sampled_from(['"true"', '"yes"', "[true]", "{}"])))  # fmt: skip
def test_compensate_lag_takes_only_true_or_false(value: object) -> None:
    shown = repr(value) if isinstance(value, float) else value
    assert "estimator.compensate_lag" in refused(text(f"[sensors]\n[estimator]\ncompensate_lag = {shown}\n"))


def test_compensate_lag_with_an_acceleration_base_is_refused() -> None:
    message = refused(
        text("[sensors]\n[estimator]\ncompensate_lag = true\n", actuator='[actuator]\nkind = "acceleration"')
    )
    assert "estimator.compensate_lag" in message and "acceleration" in message


def test_compensate_lag_is_written_only_when_asked(tmp_path: Path) -> None:
    asked = config(
        scene(tmp_path, "[sensors]\n[estimator]\ncompensate_lag = true\n", actuator="[actuator]\nlag = 0.01")
    )
    assert asked["estimator.compensate_lag"] == "1" and asked["actuator.lag"] == "0.01"
    plain = config(scene(tmp_path, "[sensors]\n", actuator="[actuator]\nlag = 0.01"))
    assert "estimator.compensate_lag" not in plain
