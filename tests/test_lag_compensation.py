"""A drive lag known to the loop ([estimator] compensate_lag, ipgen_loop_lag_* in
cpp/include/ipgen_loop.h): the C functions against the lag's ODE integrated here by scipy, the
inverse's round trip and its bound, the C header's firmware loops (a swing-up's and an MPC's)
against the simulator's, a failed EKF sample's law acting on the kept estimate, in the simulator the QUBE
preset that a 30 ms lag defeats without the key and not with it, and one-line
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
from test_mpc_c_header import FIRMWARE
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
@given(lag=lags, period=periods, fraction=st.floats(-0.999, 0.999), start=inputs, limit=st.floats(0.5, 30.0))
def test_the_command_of_a_mean_is_the_command_that_gave_it(
    lag: float, period: float, fraction: float, start: float, limit: float
) -> None:
    """The round trip: a command c within the bound gives the mean m over its period (the ODE's);
    the command the loop sends for the wanted mean m from the same start is c."""
    lib = _lib()
    model = lib.ipgen_loop_lag_of(lag, period, limit)
    command = fraction * limit
    _, mean = _ode(command, start, lag, period)
    back = lib.ipgen_loop_lag_command(ctypes.byref(model), mean, start)
    assert back == pytest.approx(command, abs=1e-8 * max(1.0, limit, abs(start)) * (1 + lag / period))


@settings(max_examples=40, deadline=None)
@given(lag=lags, period=periods, start=inputs, limit=st.floats(0.5, 30.0), beyond=st.floats(1e-3, 10.0),
       sign=st.sampled_from([-1.0, 1.0]))  # fmt: skip
def test_a_mean_out_of_reach_gets_the_bound_on_its_side(
    lag: float, period: float, start: float, limit: float, beyond: float, sign: float
) -> None:
    """A wanted mean beyond what the bound gives (the ODE's mean of ±limit, plus a margin on that
    side) is sent the bound on that side: the mean grows with the command, so it is the closest."""
    lib = _lib()
    model = lib.ipgen_loop_lag_of(lag, period, limit)
    _, reach = _ode(sign * limit, start, lag, period)
    assert lib.ipgen_loop_lag_command(ctypes.byref(model), reach + sign * beyond, start) == sign * limit


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
    """No lag (0 or below): each period's input is its command exactly, whatever the drive's
    modelled input held (even a NaN or an infinity), and the inverse is the identity."""
    lib = _lib()
    for lag in (0.0, -1.0):
        model = lib.ipgen_loop_lag_of(lag, 0.001, 2.0)
        assert (model.decay, model.weight, model.boost) == (0.0, 0.0, 1.0)
        for start in (3.0, math.nan, math.inf):
            applied = ctypes.c_double(start)
            assert lib.ipgen_loop_lag_mean(ctypes.byref(model), 7.5, ctypes.addressof(applied)) == 7.5
            assert applied.value == 7.5
        applied = ctypes.c_double(3.0)
        negative_zero = lib.ipgen_loop_lag_mean(ctypes.byref(model), -0.0, ctypes.addressof(applied))
        assert math.copysign(1.0, negative_zero) == -1.0
        assert lib.ipgen_loop_lag_command(ctypes.byref(model), 9.0, 3.0) == 9.0  # the law's own bound


# ---- the C header and the simulator ---------------------------------------------------------------


def test_the_headers_loop_compensates_the_lag_as_the_simulator_does(tmp_path: Path) -> None:
    """qube_servo2_swingup with an EKF, a delay of 2 periods predicted over and a 5 ms drive lag
    the loop is built for: the C header's firmware step, fed the encoder counts of the simulator's
    run, returns the command the simulator applies 2 samples later (1e-9 of 10 V); the header
    compiles under -Werror in double and in float; the step sends the lag's inverse (its body
    calls ipgen_loop_lag_command) and the commands reach the bound."""
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
    step = header[header.index(f"ipgen_{name}_swingup_loop_step(") :]
    assert "ipgen_loop_lag_command(" in step[: step.index("\n}\n")]  # the step sends the inverse
    assert f"IPGEN_{name.upper()}_LAG 0.005" in header
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
    assert np.max(np.abs(run_["u"])) == pytest.approx(10.0)  # the bound


@pytest.mark.parametrize(
    ("preset", "step", "bound"),
    [
        ("qube_servo2_sensors", "loop_step", "10.0"),
        ("qube_servo2_sensors", "loop_step", ""),  # no saturation: the inverse unbounded (HUGE_VAL)
        ("qube_servo2_mpc", "mpc_loop_step", "10.0"),
    ],
)
def test_the_controllers_loop_steps_compensate_a_lag_and_compile(
    tmp_path: Path, preset: str, step: str, bound: str
) -> None:
    """An LQR's (with and without a saturation) and an MPC's loop step (no swing-up) with a known
    lag: the step sends the lag's inverse, bounded by the law's bound, and the header compiles
    under -Werror in double and float (C99)."""
    from c_models import CC, WARNINGS, require_cc

    from ipgen.command.cli import run

    require_cc()
    source = (ROOT / "scenes" / "rigs" / f"{preset}.toml").read_text()
    if not bound:
        source = re.sub(r"^saturation = .*\n", "", source, count=1, flags=re.M)
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
    assert f", {bound or 'HUGE_VAL'});" in text[text.index("= ipgen_loop_lag_of(") :].split("\n")[0]
    unit = tmp_path / "unit.c"
    unit.write_text(f'#include "{header.name}"\n')
    for scalar in ("double", "float"):
        flags = [CC, "-std=c99", *WARNINGS, f"-DIPGEN_SCALAR={scalar}", f"-I{header.parent}", "-c"]
        done = subprocess.run(
            [*flags, str(unit), "-o", str(tmp_path / "unit.o")], capture_output=True, text=True
        )
        assert done.returncode == 0, done.stderr[:3000]


MPC_REPLAY = FIRMWARE.replace('"qube_servo2.h"', '"qube_servo2_mpc.h"')  # counts in, commands out

# After the samples of counts, the EKF is made to fail (P negative: the innovation covariance is
# not positive definite) and the MPC's loop steps once more. A copy of the loop taken before that
# sample computes what the law gives on the kept estimate: the MPC's step on it, and the lag's
# inverse of that from the drive's input when it acts. Prints the queue, the lag's state, the
# sample count and the estimate before and after, the command and that law's.
FAILED_EKF = """\
#include <stdio.h>
#include "qube_servo2_mpc.h"
static P_loop_state s, copy;
static void show(const char *label) {
  int i;
  printf("%s", label);
  for (i = 0; i <= IPGEN_QUBE_SERVO2_MPC_DELAY; ++i) printf(" %.17g", s.estimator.pending[i]);
  printf(" %.17g %.17g %ld", s.estimator.applied, s.estimator.acted, s.estimator.k);
  for (i = 0; i < 4; ++i) printf(" %.17g", s.estimator.x[i]);
  printf("\\n");
}
int main(void) {
  long counts[2];
  int i;
  double u, x[4], means[IPGEN_QUBE_SERVO2_MPC_DELAY + 1], applied, law;
  P_loop_init(&s);
  while (scanf("%ld %ld", &counts[0], &counts[1]) == 2) (void)P_step(&s, counts);
  for (i = 0; i < 16; ++i) s.estimator.P[i] = i % 5 == 0 ? -1e6 : 0.0;
  copy = s;
  show("before");
  u = P_mpc_loop_step(&s.estimator, &s.mpc, s.estimator.x);
  show("after");
  for (i = 0; i < 4; ++i) x[i] = copy.estimator.x[i]; /* the scene's coordinates are ipgen's */
  applied = ipgen_loop_lag_ahead(&copy.estimator.lag, copy.estimator.applied, IPGEN_QUBE_SERVO2_MPC_DELAY,
                                 copy.estimator.pending, means);
  law = ipgen_loop_lag_command(&copy.estimator.lag, P_mpc_step(&copy.mpc, x), applied);
  printf("u %.17g %.17g\\n", u, law);
  return 0;
}
"""


@pytest.fixture(scope="module")
def lagged_mpc(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, dict]:
    """qube_servo2_mpc with an EKF, a delay of 1 period predicted over and a 10 ms drive lag the
    loop is built for, pushed from near upright: its C header (emit c) and the simulator's run."""
    from cxx import require_toolchain
    from run_csv import read_run_csv

    from ipgen.command.cli import run

    require_toolchain()
    folder = tmp_path_factory.mktemp("lagged_mpc")
    source = (ROOT / "scenes" / "rigs" / "qube_servo2_mpc.toml").read_text()
    source = re.sub(r"^(name = .*)$", r'\1\nemit = ["c"]', source, count=1, flags=re.M)
    estimator = 'kind = "ekf"\npredict = true\ncompensate_lag = true'
    source = re.sub(r'^kind = "kalman".*$', estimator, source, flags=re.M)
    source = source.replace("resolution = 2048 ", "delay = 0.01\nresolution = 2048 ", 1)
    source = source.replace('kind = "dc_motor"', 'kind = "dc_motor"\nlag = 0.01', 1)
    source = re.sub(r"^t_end = .*$", "t_end = 1.5", source, count=1, flags=re.M)
    keys = ('emit = ["c"]', "compensate_lag", "delay = 0.01", "lag = 0.01", "t_end = 1.5")
    assert all(key in source for key in keys)
    path = folder / "qube_servo2_mpc.toml"
    path.write_text(source)
    unpredicted = folder / "unpredicted"  # the same loop without predict: its law sees the estimate
    unpredicted.mkdir()
    (unpredicted / "qube_servo2_mpc.toml").write_text(source.replace("\npredict = true", "", 1))
    for argv in (
        ["--scene", str(path), "-o", str(folder)],
        ["run", str(path), "-o", str(folder / "run"), "--no-plot"],
        ["--scene", str(unpredicted / "qube_servo2_mpc.toml"), "-o", str(unpredicted)],
    ):
        with redirect_stdout(io.StringIO()), redirect_stderr(io.StringIO()) as err:
            assert run(argv) == 0, err.getvalue()
    assert "(void)ipgen_loop_predict(" in (folder / "qube_servo2_mpc.h").read_text()
    assert "(void)ipgen_loop_predict(" not in (unpredicted / "qube_servo2_mpc.h").read_text()
    return folder, read_run_csv(folder / "run" / "qube_servo2_mpc.csv", phase=False).columns(slice(-1))


def _compiled(folder: Path, name: str, source: str) -> Path:
    from c_models import CC, WARNINGS, require_cc

    require_cc()
    (folder / f"{name}.c").write_text(source.replace("P_", "ipgen_qube_servo2_mpc_"))
    command = [CC, "-std=c99", "-O1", *WARNINGS, f"-I{folder}", str(folder / f"{name}.c")]
    done = subprocess.run([*command, "-o", str(folder / name), "-lm"], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr[:3000]
    return folder / name


def _counts(columns: dict) -> str:
    """The encoders' counts the simulator's measured y are, a line per sample (asserts whole counts)."""
    y = np.column_stack([columns["y_theta0"], columns["y_theta1"]]) - np.array([0.0, math.pi])
    counts = np.rint(y / STEP).astype(int)
    assert np.allclose(counts * STEP, y, atol=1e-12), "the simulator's y are whole counts"
    return "\n".join(f"{a} {b}" for a, b in counts.tolist()) + "\n"


def test_the_mpcs_loop_step_compensates_the_lag_as_the_simulator_does(lagged_mpc: tuple[Path, dict]) -> None:
    """The MPC's firmware entry (EKF, prediction over 1 period, a known 10 ms lag), fed the
    encoder counts of the simulator's run, returns the command the simulator applies 1 sample
    later (double, 1e-9 of 10 V); the lag's inverse is at work (commands unlike a plain MPC's
    reach the bound) and the link is held."""
    folder, columns = lagged_mpc
    program = _compiled(folder, "replay", MPC_REPLAY)
    out = subprocess.run([str(program)], input=_counts(columns), capture_output=True, text=True, check=True)
    commands = np.array([float(v) for v in out.stdout.split()])
    samples, delay = len(commands), 1
    assert np.all(columns["u"][:delay] == 0.0)
    assert np.max(np.abs(commands[: samples - delay] - columns["u"][delay:samples])) <= 1e-9 * 10.0
    # the lag's inverse clips at the bound exactly; the MPC's interior point stays inside it
    assert np.count_nonzero(np.abs(columns["u"]) == 10.0) >= 2
    assert abs(columns["theta1"][-1]) < 0.05  # held upright


def test_a_failed_ekf_keeps_the_estimate_and_the_law_acts_on_it(lagged_mpc: tuple[Path, dict]) -> None:
    """A sample whose EKF fails (the MPC's loop, a known 10 ms lag, a delay of 1 period, no
    prediction) does what the simulator's loop does: the estimate and its sample count stay, the
    law acts on that estimate (the command is the lag's inverse of the MPC's step on it, computed
    from a copy of the loop), and the queue and the lag's model move on by the command as the
    rig's drive takes it: τ a' = u − a over the period with the command sent a period before
    (a = u + (a0 − u) e^(−T/τ), its mean u + (a0 − u) (τ/T)(1 − e^(−T/τ)))."""
    folder, columns = lagged_mpc
    program = _compiled(folder / "unpredicted", "failed", FAILED_EKF)
    counts = "".join(_counts(columns).splitlines(keepends=True)[:40])
    out = subprocess.run([str(program)], input=counts, capture_output=True, text=True, check=True).stdout
    rows = {line.split()[0]: [float(v) for v in line.split()[1:]] for line in out.splitlines()}
    before, after, (u, law) = rows["before"], rows["after"], rows["u"]
    pending, applied = before[:2], before[2]
    assert after[4:] == before[4:] and before[4] == 40  # the sample count and the estimate kept
    assert u == law and u != pending[-1]  # the law acted on the kept estimate
    assert after[:2] == [pending[1], u]
    period, lag = 0.01, 0.01
    assert after[2] == pytest.approx(pending[1] + (applied - pending[1]) * math.exp(-period / lag), rel=1e-12)
    weight = (lag / period) * -math.expm1(-period / lag)
    assert after[3] == pytest.approx(pending[1] + (applied - pending[1]) * weight, rel=1e-12)


def _lqr_run(tmp_path: Path, lag: str, key: bool, pinned: str = "") -> tuple[dict, str]:
    """qube_servo2's LQR sampled every 2 ms, the exact state through [sensors], a drive `lag`, the
    key or not (and `pinned`: [estimator] lag): the run's CSV columns and its resolved config."""
    from run_csv import read_run_csv

    from ipgen.command.cli import run

    source = (ROOT / "scenes" / "rigs" / "qube_servo2.toml").read_text()
    source = source.replace("saturation = 10 ", "period = 0.002\nsaturation = 10 ", 1)
    source = source.replace("t_end = 5.0 ", "sample = 0.002\nt_end = 2.0 ", 1)
    source += "\n[sensors]\n" + ("[estimator]\ncompensate_lag = true\n" if key else "")
    source += f"lag = {pinned}\n" if pinned else ""
    source = source.replace('kind = "dc_motor"', f'kind = "dc_motor"\nlag = {lag}', 1)
    assert "\nperiod = 0.002" in source and "\nsample = 0.002" in source and f"\nlag = {lag}" in source
    folder = tmp_path / f"lag{lag}_{key}_{pinned}"
    folder.mkdir()
    (folder / "scene.toml").write_text(source)
    with redirect_stdout(io.StringIO()), redirect_stderr(io.StringIO()) as err:
        assert run(["run", str(folder / "scene.toml"), "-o", str(folder / "out"), "--no-plot"]) == 0, (
            err.getvalue()
        )
    return read_run_csv(folder / "out" / "scene.csv", phase=False).columns(), (
        folder / "out" / "scene.cfg"
    ).read_text()


def test_the_simulators_drive_gets_the_laws_input_on_average(tmp_path: Path) -> None:
    """The LQR on the exact state with a 20 ms drive lag the loop knows: the drive's input, the lag's
    ODE driven by the commands the CSV records (integrated here by scipy from 0), has over each
    period the mean the law asks, −K (x_k − x_eq) from the CSV's state, wherever the command is
    within ±10 V (and the commands are not the law's)."""
    from cxx import require_toolchain

    require_toolchain()
    columns, cfg = _lqr_run(tmp_path, "0.02", key=True)
    lines = dict(line.split(" = ", 1) for line in cfg.splitlines() if " = " in line)
    gain = np.array([float(v) for v in lines["controller.gain"].split()])
    target = np.array([float(v) for v in lines["controller.equilibrium"].split()])
    states = np.column_stack([columns[f"{kind}theta{i}"] for kind in ("", "d") for i in (0, 1)])
    law = np.clip(-(states - target) @ gain, -10.0, 10.0)
    commands, applied, means = columns["u"], 0.0, []
    for command in commands[:-1]:
        applied, mean = _ode(float(command), applied, 0.02, 0.002)
        means.append(mean)
    inside = np.abs(commands[:-1]) < 10.0 - 1e-9
    assert inside.sum() > 100 and np.max(np.abs(commands)) == pytest.approx(10.0)
    assert np.max(np.abs(np.array(means)[inside] - law[:-1][inside])) < 1e-6
    assert np.max(np.abs(commands[:-1] - law[:-1])) > 1.0  # the inverse, not the law, is sent


def test_without_a_lag_the_key_changes_no_number(tmp_path: Path) -> None:
    """With [actuator] lag = 0 the run with compensate_lag writes the same CSV as the run without."""
    from cxx import require_toolchain

    require_toolchain()
    with_key, _ = _lqr_run(tmp_path, "0", key=True)
    without, _ = _lqr_run(tmp_path, "0", key=False)
    assert with_key.keys() == without.keys()
    assert all(np.array_equal(with_key[name], without[name]) for name in with_key)


def test_a_pinned_lag_is_what_the_loop_is_built_for(tmp_path: Path) -> None:
    """[estimator] lag pins the loop's lag: pinned at 0 on a rig with 20 ms the commands are the
    law's (nothing inverted, the same CSV as without the key); pinned at 20 ms on a rig without
    a lag they are not; the header's IPGEN_NAME_LAG is the pinned value."""
    from cxx import require_toolchain

    from ipgen.command.cli import run

    require_toolchain()
    plain, _ = _lqr_run(tmp_path, "0.02", key=False)
    zero, cfg = _lqr_run(tmp_path, "0.02", key=True, pinned="0")
    assert "estimator.lag = 0" in cfg and all(np.array_equal(zero[k], plain[k]) for k in plain)
    told, cfg = _lqr_run(tmp_path, "0", key=True, pinned="0.02")
    untold, _ = _lqr_run(tmp_path, "0", key=False)
    assert "estimator.lag = 0.02" in cfg and np.max(np.abs(told["u"] - untold["u"])) > 1.0
    source = (ROOT / "scenes" / "rigs" / "qube_servo2_mpc.toml").read_text()
    source = source.replace('name = "qube_servo2_mpc"', 'name = "qube_servo2_mpc"\nemit = ["c"]', 1)
    source = source.replace("[estimator]", "[estimator]\ncompensate_lag = true\nlag = 0.01", 1)
    source = source.replace('kind = "dc_motor"', 'kind = "dc_motor"\nlag = 0.02', 1)
    (tmp_path / "pinned.toml").write_text(source)
    with redirect_stdout(io.StringIO()), redirect_stderr(io.StringIO()) as err:
        assert run(["--scene", str(tmp_path / "pinned.toml"), "-o", str(tmp_path / "header")]) == 0, (
            err.getvalue()
        )
    assert (
        "#define IPGEN_QUBE_SERVO2_MPC_LAG 0.01 " in (tmp_path / "header" / "qube_servo2_mpc.h").read_text()
    )


def test_a_known_lag_keeps_the_qube_upright_where_the_nominal_loop_loses_it() -> None:
    """qube_servo2_mpc_swingup_m4f on a drive with a 20 ms lag (the scorecard's lag level 8, well
    inside what the key passes, 0–32.5 ms; without it the preset passes to 7.5 ms), its loop
    nominal as a sweep keeps it: without compensate_lag the swing-up is not held; with it, it is."""
    from cxx import require_toolchain
    from preset_runs import with_and_without

    require_toolchain()
    results = with_and_without("compensate_lag", "lag", (("actuator.lag", 0.02),), rn="preset")
    assert results["without"].outcome == "fail", results
    assert results["with"].outcome == "pass", results["with"]


# ---- the scene key -----------------------------------------------------------------------------


@settings(max_examples=12, deadline=None)
@given(value=st.one_of(st.integers(-2, 2), st.floats(allow_nan=False, allow_infinity=False),
                       st.sampled_from(['"true"', '"yes"', "[true]", "{}"])))  # fmt: skip
def test_compensate_lag_takes_only_true_or_false(value: object) -> None:
    shown = repr(value) if isinstance(value, float) else value
    assert "estimator.compensate_lag" in refused(text(f"[sensors]\n[estimator]\ncompensate_lag = {shown}\n"))


@settings(max_examples=10, deadline=None)
@given(value=st.one_of(st.floats(max_value=-1e-9), st.just(math.nan), st.sampled_from(['"fast"', "[0.1]"])))
def test_a_bad_or_lone_pinned_lag_is_refused(value: object) -> None:
    shown = ("nan" if math.isnan(value) else repr(value)) if isinstance(value, float) else value
    message = refused(text(f"[sensors]\n[estimator]\ncompensate_lag = true\nlag = {shown}\n"))
    assert "estimator.lag" in message
    assert "compensate_lag" in refused(text("[sensors]\n[estimator]\nlag = 0.01\n"))


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
