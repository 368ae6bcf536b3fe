"""The EKF that learns the plant's input gain ([estimator] gain_spread, ipgen_loop_ekf's gain
state in cpp/include/ipgen_loop.h): the C filter against tests/loop_reference.py's numpy one,
the gain it finds on a simulated QUBE whose torque per volt is more or less than its model's (the
truth integrated here by scipy), one-line errors for bad values, the swing-up's u divided by the
learnt gain, the C header's loop against the simulator's, and in the simulator a sweep draw with
a motor 10 % stronger than the loop's model that the learnt gain swings up and holds."""

from __future__ import annotations

import ctypes
import math
from pathlib import Path

import loop_reference as reference
import numpy as np
import pytest
from estimation_cases import EKF_SAMPLES, QUBE, RSIP
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st
from test_catch_conditions import DRAW  # sweep run 76 of the m4f preset: its motor 10 % stronger
from test_firmware_c import REPLAY as FIRMWARE_REPLAY

from ipgen.estimation import EstimationError
from ipgen.estimation.estimators import ExtendedKalman

ROOT = Path(__file__).resolve().parents[1]
STEP = 2 * math.pi / 2048  # rad: the QUBE's encoder count


@settings(max_examples=15, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    samples=EKF_SAMPLES,
    case=st.sampled_from(["rsip", "qube"]),
    spread=st.floats(0.05, 0.5),
    drift=st.sampled_from([0.0, 0.003, 0.1]),
)
def test_the_learning_ekf_equals_the_reference(samples, case: str, spread: float, drift: float) -> None:
    """x̂, ρ and P of the C EKF with the gain state (its ∂f/∂ρ a difference of f, Cholesky) and the
    numpy one (∂f/∂ρ = u B from the model's Jacobian, LU) agree."""
    pendulum = {"rsip": RSIP, "qube": QUBE}[case]
    noise = {"gain_spread": spread, "gain_drift": drift}
    ekf = ExtendedKalman(pendulum, 0.002, np.eye(4) * 1e-3, np.eye(2) * 1e-6, **noise)
    ref = reference.ExtendedKalman(ekf)
    for y, u in samples:
        x, x_ref = ekf.step(y, u), ref.step(y, u)
        assert np.allclose(x, x_ref, rtol=1e-9, atol=1e-10)
        assert ekf.gain == pytest.approx(ref.gain, rel=1e-9, abs=1e-12)
        assert np.allclose(ekf.covariance, ref._p, rtol=1e-8, atol=1e-12)


def _true_run(ratio: float, seconds: float, seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The QUBE hanging, driven by two sines of volts through a motor `ratio` times the model's,
    integrated by scipy (RK45, tight tolerances) with the input held over each 2 ms; the true
    states, the encoder readings (2048 counts) and the inputs at each sample."""
    from scipy.integrate import solve_ivp

    from ipgen.estimation import as_model

    model = as_model(QUBE)
    rng = np.random.default_rng(seed)
    phase = rng.uniform(0, 2 * math.pi, 2)
    period = 0.002
    x = np.array([0.0, math.pi, 0.0, 0.0])
    states, readings, inputs = [], [], []
    for k in range(round(seconds / period)):
        t = k * period
        states.append(x)
        readings.append(np.round(x[:2] / STEP) * STEP)
        u = 3.0 * math.sin(2 * math.pi * 1.3 * t + phase[0])
        u += 2.0 * math.sin(2 * math.pi * 3.7 * t + phase[1])
        inputs.append(u)
        torque = ratio * u
        done = solve_ivp(lambda _, s, v=torque: model.f(s, v), (0.0, period), x, rtol=1e-10, atol=1e-12)
        x = done.y[:, -1]
    return np.array(states), np.array(readings), np.array(inputs)


@pytest.mark.parametrize(("ratio", "seed"), [(1.25, 0), (0.8, 1)])
def test_the_ekf_finds_a_motor_stronger_or_weaker_than_its_model(ratio: float, seed: int) -> None:
    """A QUBE whose motor gives 1.25 or 0.8 times the model's torque per volt (its back-EMF
    damping the model's), hanging and driven for 4 s: the learnt ρ is within 3 % of the ratio;
    without the gain state the filter's arm-rate error is larger than with it."""
    states, readings, inputs = _true_run(ratio, 4.0, seed)
    rn = np.eye(2) * STEP**2 / 12
    learning = ExtendedKalman(QUBE, 0.002, np.eye(4) * 1e-6, rn, equilibrium="hanging", gain_spread=0.2)
    fixed = ExtendedKalman(QUBE, 0.002, np.eye(4) * 1e-6, rn, equilibrium="hanging")
    u_before, errors = 0.0, []
    for x, y, u in zip(states, readings, inputs, strict=True):
        errors.append((learning.step(y, u_before)[2] - x[2], fixed.step(y, u_before)[2] - x[2]))
        u_before = u
    assert learning.gain == pytest.approx(ratio, rel=0.03)
    late = np.array(errors[len(errors) // 2 :])  # the last 2 s: RMS arm-rate errors
    rms_learning, rms_fixed = np.sqrt(np.mean(late**2, axis=0))
    assert rms_learning < rms_fixed


def test_the_learnt_gain_stops_at_twice_the_models() -> None:
    """A motor 3 times the model's: ρ climbs to its bound 2 and stays there (ipgen_loop_ekf's
    clamp), in C and in the reference alike."""
    _, readings, inputs = _true_run(3.0, 1.0, 2)
    rn = np.eye(2) * STEP**2 / 12
    ekf = ExtendedKalman(QUBE, 0.002, np.eye(4) * 1e-6, rn, equilibrium="hanging", gain_spread=0.5)
    ref = reference.ExtendedKalman(ekf)
    u_before, gains = 0.0, []
    for y, u in zip(readings, inputs, strict=True):
        ekf.step(y, u_before)
        ref.step(y, u_before)
        gains.append((ekf.gain, ref.gain))
        u_before = u
    assert gains[-1] == (2.0, 2.0)
    assert max(g for g, _ in gains) == 2.0


@given(
    name=st.sampled_from(["gain_spread", "gain_drift"]),
    value=st.one_of(
        st.floats(allow_nan=True, allow_infinity=True),
        st.floats(-10, 0),
        st.floats(1, 10),
        st.text(max_size=3),
        st.booleans(),
    ),
)
def test_a_bad_gain_setting_is_one_line(name: str, value: object) -> None:
    assume(isinstance(value, bool) or not (isinstance(value, float) and 0 <= value <= 1))
    with pytest.raises(EstimationError, match=name) as error:
        ExtendedKalman(QUBE, 0.002, np.eye(4) * 1e-6, np.eye(2) * 1e-6, **{name: value})
    assert "\n" not in str(error.value)


@given(drift=st.floats(1e-9, 1.0))
def test_a_drift_without_a_learnt_gain_is_one_line(drift: float) -> None:
    """gain_drift is a random walk of the learnt gain: without gain_spread (the gain not learnt)
    it would be ignored; it is refused in one line naming both (as a scene's [estimator] is)."""
    with pytest.raises(EstimationError, match=r"gain_drift .* gain_spread") as error:
        ExtendedKalman(QUBE, 0.002, np.eye(4) * 1e-6, np.eye(2) * 1e-6, gain_drift=drift)
    assert "\n" not in str(error.value)
    ExtendedKalman(QUBE, 0.002, np.eye(4) * 1e-6, np.eye(2) * 1e-6, gain_drift=drift, gain_spread=0.1)


@given(
    rho=st.floats(0.5, 2.0), angle=st.floats(-0.2, 0.2), rate=st.floats(-2, 2),
    u_max=st.sampled_from([0.05, 10.0]),
)  # fmt: skip
@settings(max_examples=25, deadline=None)
def test_the_swing_up_divides_its_input_by_the_learnt_gain(
    rho: float, angle: float, rate: float, u_max: float
) -> None:
    """ipgen_loop_swingup_step with gain_factor → ρ gives the hold's u / ρ, then saturated at u_max
    (10: never, 0.05: mostly); a null gain_factor the u itself."""
    from ipgen.common.loop_runtime import SwingUp, SwingUpState, address, library, swingup_work
    from ipgen.control.casadi_model import plant
    from ipgen.control.energy import energy_swingup

    law = energy_swingup(plant("rotary", 1, [0.095, 0.024], [0.085, 0.129], [0.0005, 0.0]), u_max=u_max)
    x = np.array([0.01, angle, 0.0, rate])  # in the catch window: the hold LQR
    hold, target = np.array(law.hold_gain, dtype=float).reshape(-1), np.zeros(4)
    work = np.zeros(swingup_work(2))
    factor = np.array([rho])
    run = library()
    outputs = []
    for gain_factor in (None, address(factor)):
        c_law = SwingUp(2, law.u_max, address(hold), address(target))
        c_law.gain_factor = gain_factor
        state = SwingUpState()
        state.phase = 2  # IPGEN_LOOP_HOLD
        u = run.ipgen_loop_swingup_step(ctypes.byref(c_law), ctypes.byref(state), address(x), address(work))
        outputs.append(u)
    plain = -float(hold @ x)
    assert u_max == 0.05 or abs(plain / rho) < u_max  # u_max = 10: the division unclipped
    assert outputs[0] == pytest.approx(float(np.clip(plain, -u_max, u_max)), rel=1e-12, abs=1e-15)
    divided = float(np.clip(plain / rho, -u_max, u_max))
    assert outputs[1] == pytest.approx(divided, rel=1e-12, abs=1e-15)


# ---- the C header and the simulator ---------------------------------------------------------------

# test_firmware_c's replay of counts, printing the learnt gain instead of the phase
REPLAY = FIRMWARE_REPLAY.replace('"%.17g %d\\n", u, s.swingup.phase', '"%.17g %.17g\\n", u, s.estimator.x[4]')
assert "s.estimator.x[4]" in REPLAY


def test_the_headers_loop_learns_the_gain_as_the_simulator_does(tmp_path: Path) -> None:
    """qube_servo2_swingup with an EKF that learns the gain, on a rig with a delay of 2 periods that
    the loop predicts over (ρ scales the prediction's input too): the C header's firmware step,
    fed the encoder counts of the simulator's run, returns the command the simulator applies 2
    samples later (1e-9 of 10 V) and its learnt gain (the CSV's hat_gain, 1e-9); it compiles
    under -Werror."""
    import io
    import subprocess
    from contextlib import redirect_stderr, redirect_stdout

    from c_models import CC, WARNINGS, require_cc
    from cxx import require_toolchain
    from run_csv import read_run_csv

    from ipgen.command.cli import run

    require_toolchain()
    require_cc()
    name = "qube_servo2_swingup"
    text = (ROOT / "scenes" / "rigs" / f"{name}.toml").read_text()
    text = text.replace(f'name = "{name}"', f'name = "{name}"\nemit = ["c"]')
    estimator = 'kind = "ekf"\ngain_spread = 0.2\ngain_drift = 0.01\npredict = true'
    text = text.replace('kind = "filter"', estimator, 1)
    text = text.replace("resolution = 2048 ", "delay = 0.002\nresolution = 2048 ", 1)
    assert "\ndelay = 0.002\n" in text and "\npredict = true" in text
    scene = tmp_path / "scene.toml"
    scene.write_text(text)
    generate = ["--scene", str(scene), "-o", str(tmp_path)]
    for argv in (generate, ["run", str(scene), "-o", str(tmp_path / "run"), "--no-plot"]):
        with redirect_stdout(io.StringIO()), redirect_stderr(io.StringIO()) as err:
            assert run(argv) == 0, err.getvalue()
    header = (tmp_path / f"{name}.h").read_text()
    assert "x[4]: rho" in header and "_swingup_scaled(" in header
    run_ = read_run_csv(tmp_path / "run" / "scene.csv", phase=True).columns()
    zero, step = np.array([0.0, -math.pi]), STEP
    counts = np.rint((np.column_stack([run_["y_theta0"], run_["y_theta1"]]) - zero) / step).astype(int)
    (tmp_path / "replay.c").write_text(REPLAY.replace("NAME", name).replace("P_", f"ipgen_{name}_"))
    program = tmp_path / "replay"
    source = str(tmp_path / "replay.c")
    flags = [CC, "-std=c99", "-O1", *WARNINGS, f"-I{tmp_path}"]
    done = subprocess.run([*flags, source, "-o", str(program), "-lm"], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr[:3000]
    lines = "\n".join(f"{a} {b}" for a, b in counts.tolist()) + "\n"
    out = subprocess.run([str(program)], input=lines, capture_output=True, text=True, check=True).stdout
    values = np.array([[float(v) for v in line.split()] for line in out.splitlines()])
    samples = len(values) - 1  # the last row repeats the command held at the end
    delay = 2  # the simulator's u at row k is the command of row k − 2 (zero before)
    assert np.all(run_["u"][:delay] == 0.0)
    assert np.max(np.abs(values[: samples - delay, 0] - run_["u"][delay:samples])) <= 1e-9 * 10.0
    assert np.max(np.abs(values[:samples, 1] - run_["hat_gain"][:samples])) <= 1e-9
    assert np.ptp(run_["hat_gain"]) > 1e-4  # it learnt something: the gain moved




def test_the_learnt_gain_swings_up_a_draw_the_nominal_loop_runs_out_of_its_travel() -> None:
    """qube_servo2_mpc_swingup_m4f on that draw (its loop nominal, as a sweep keeps it): without
    gain_spread its first catch runs the arm out of its travel; with it the swing-up is held."""
    from cxx import require_toolchain
    from preset_runs import with_and_without

    require_toolchain()
    results = with_and_without("gain_spread", "random", DRAW)
    assert (results["without"].outcome, results["without"].reason) == ("fail", "left the travel"), results
    assert results["with"].outcome == "pass", results["with"]
