"""The measured loop in the C++ simulator (issue 32): encoders, delay, drive noise, lag, pulses
and the estimators, each against a computation written here from the CSV's own columns.

One simulator (the rotary single pendulum, the paper's parameters) is built for the module and
driven with resolved configs of scene variants; the CSV rows are the sampling instants
(sample = period = 1 ms), so every row is a sample k of the loop.
"""

from __future__ import annotations

import io
import math
import os
import subprocess
import warnings
from contextlib import redirect_stderr, redirect_stdout
from pathlib import Path

import numpy as np
import pytest
import sympy as sp
from cxx import require_toolchain
from run_csv import read_run_csv

import ipgen
from ipgen.command.cli import run
from ipgen.estimation import ExtendedKalman, Sensors, SteadyStateKalman, default_covariances, replay
from ipgen.experiment.config import resolved_config
from ipgen.experiment.scene import load_scene
from ipgen.pipeline.simulator import build, model_sources

PERIOD = 0.001
M, L, DELTA = [0.5, 0.275], [0.6, 0.5], [0.3, 0.011458]
PENDULUM = {"type": "rotary", "links": 1, "m": M, "l": L, "delta": DELTA}
SCENE = """\
[system]
type = "rotary"
links = 1
[parameters]
m = {m}
l = {l}
delta = {delta}
[initial]
theta = [0, {tilt}]
{actuator}
[controller]
kind = "lqr"
saturation = 5
period = 0.001
[simulation]
t_end = {t_end}
sample = 0.001
{extra}
"""


def scene_text(extra: str = "", actuator: str = "", tilt: float = 0.05, t_end: float = 0.5) -> str:
    return SCENE.format(m=M, l=L, delta=DELTA, tilt=tilt, actuator=actuator, t_end=t_end, extra=extra)


@pytest.fixture(scope="module")
def simulator(tmp_path_factory: pytest.TempPathFactory) -> Path:
    require_toolchain()
    folder = tmp_path_factory.mktemp("model")
    (folder / "base.toml").write_text(scene_text())
    with redirect_stdout(io.StringIO()), redirect_stderr(io.StringIO()):
        out = folder / "out"
        assert run(["--scene", str(folder / "base.toml"), "--emit", "library", "-o", str(out)]) == 0
    cache = Path(os.environ.get("IPGEN_CACHE_DIR") or folder / "cache")
    return build(model_sources(folder / "out", "rotary1"), "rotary1", cache).path


class Run:
    """One simulator run: the CSV's columns by name, the summary, the resolved config's keys."""

    def __init__(
        self, simulator: Path, folder: Path, text: str, *options: str, name: str = "loop", cfg_lines: str = ""
    ) -> None:
        path = folder / f"{name}.toml"
        path.write_text(text)
        cfg = folder / f"{name}.cfg"
        cfg.write_text(resolved_config(load_scene(path)) + cfg_lines)  # cfg_lines: e.g. a sweep's design
        self.keys = dict(line.split(" = ", 1) for line in cfg.read_text().splitlines() if " = " in line)
        self.csv = folder / f"{name}.csv"
        result = subprocess.run(
            [str(simulator), str(cfg), "--csv", str(self.csv), "--force", *options],
            capture_output=True,
            text=True,
        )
        assert result.returncode == 0, result.stderr
        self.summary = result.stdout
        run_ = read_run_csv(self.csv, phase=self.csv.read_text().partition("\n")[0].endswith(",phase"))
        self.names, self.data = run_.names, run_.data

    def __getitem__(self, name: str) -> np.ndarray:
        return self.data[:-1, self.names.index(name)]  # the sampling instants (the last row is t_end)

    def matrix(self, key: str, rows: int) -> np.ndarray:
        return np.array(self.keys[key].split(), dtype=float).reshape(rows, -1)


def quantise(theta: np.ndarray, counts: float) -> np.ndarray:
    delta = 2.0 * np.pi / counts
    return delta * np.floor(theta / delta + 0.5)


def test_encoders_quantise_the_true_angles(simulator: Path, tmp_path: Path) -> None:
    r = Run(simulator, tmp_path, scene_text("[sensors]\nresolution = [1000, 2048]\n"))
    assert r.names[-6:] == ["y_theta0", "y_theta1", "hat_theta0", "hat_theta1", "hat_dtheta0", "hat_dtheta1"]
    np.testing.assert_array_equal(r["y_theta0"], quantise(r["theta0"], 1000))
    np.testing.assert_array_equal(r["y_theta1"], quantise(r["theta1"], 2048))
    # By hand at the first sample: θ1 = 0.05 rad is 16.297 counts of 2π/2048 -> 16 counts.
    assert r["y_theta1"][0] == 16 * (2 * math.pi / 2048)
    assert np.max(np.abs(r["y_theta1"] - r["theta1"])) <= math.pi / 2048 * (1 + 1e-12)
    assert "RMS estimation error" in r.summary


@pytest.mark.parametrize(
    ("sensors", "zero"),
    [
        # 2047 counts: the default zero pose, the link hanging (π), is not a whole number of counts
        # from 0, so counting from it is another grid
        ("resolution = [1000, 2047]\n", (0.0, math.pi)),
        ("resolution = [1000, 2048]\nzero = [0.0, 0.001]\n", (0.0, 0.001)),  # reset elsewhere
    ],
)
def test_encoders_count_from_their_zero_pose(
    simulator: Path, tmp_path: Path, sensors: str, zero: tuple[float, float]
) -> None:
    """Issue 49: the simulated encoders count from the pose where they read 0 ([sensors] zero,
    default the rig at rest), as the firmware's q = q_zero + Δ·counts does: every y is a whole
    number of counts from it, the nearest to the true angle."""
    r = Run(simulator, tmp_path, scene_text(f"[sensors]\n{sensors}"))
    counts = [float(v) for v in r.keys["sensors.resolution"].split()]
    assert [float(v) for v in r.keys["sensors.zero"].split()] == pytest.approx([0.0, zero[1]], abs=1e-15)
    for i in (0, 1):
        delta = 2 * math.pi / counts[i]
        whole = (r[f"y_theta{i}"] - zero[i]) / delta
        np.testing.assert_allclose(whole, np.round(whole), atol=1e-6)
        assert np.max(np.abs(r[f"y_theta{i}"] - r[f"theta{i}"])) <= delta / 2 * (1 + 1e-9)
    assert not np.allclose(r["y_theta1"], quantise(r["theta1"], counts[1]))  # not the grid from 0
    python = Sensors.of(2, None, counts, zero=zero)  # the Python loop's sensors count alike
    y = np.array([python.quantise(np.array([a, b])) for a, b in zip(r["theta0"], r["theta1"], strict=True)])
    np.testing.assert_allclose(y[:, 1], r["y_theta1"], rtol=0, atol=1e-12)


def test_the_exact_loop_with_sensors_is_todays_loop_byte_for_byte(simulator: Path, tmp_path: Path) -> None:
    """[sensors] with exact encoders and the exact estimator: the state and u columns are the
    same bytes as without [sensors] (the wrapper does not touch the loop)."""
    plain = Run(simulator, tmp_path, scene_text(), name="plain")
    exact = Run(simulator, tmp_path, scene_text("[sensors]\n"), name="exact")
    width = len(plain.names)
    assert exact.names[:width] == plain.names and len(exact.names) == width + 2 + 4
    lines = plain.csv.read_text().splitlines()
    for mine, theirs in zip(exact.csv.read_text().splitlines(), lines, strict=True):
        assert ",".join(mine.split(",")[:width]) == theirs
    np.testing.assert_array_equal(exact.data[:-1, width + 2 :], exact.data[:-1, 1 : 1 + 4])  # x̂ = x


def test_the_delay_applies_each_command_whole_periods_later(simulator: Path, tmp_path: Path) -> None:
    r = Run(simulator, tmp_path, scene_text("[sensors]\ndelay = 0.003\n", tilt=0.02))
    gain = np.array(r.keys["controller.gain"].split(), dtype=float)
    x = np.column_stack([r["theta0"], r["theta1"], r["dtheta0"], r["dtheta1"]])
    command = np.clip(-(x @ gain), -5, 5)
    np.testing.assert_array_equal(r["u"][:3], 0.0)  # nothing arrived yet
    np.testing.assert_allclose(r["u"][3:], command[:-3], rtol=1e-13, atol=1e-15)
    assert "delay 3 sampling periods" in r.summary


def test_a_predicted_delay_runs_as_the_loop_without_it(simulator: Path, tmp_path: Path) -> None:
    """[estimator] predict over a delay of 20 periods: each command acts on the state it was
    predicted for, so from t = d on the run is the undelayed loop's started at x(d) (u = 0 until
    the first command arrives), to the prediction's RK4 error; without predict it is not."""
    delayed = '[sensors]\ndelay = 0.02\n[estimator]\nkind = "exact"\n'
    states = ("theta0", "theta1", "dtheta0", "dtheta1")
    runs = {
        name: Run(simulator, tmp_path, scene_text(delayed + extra), name=name)
        for name, extra in (("predicted", "predict = true\n"), ("plain", ""))
    }
    x = {name: np.column_stack([r[c] for c in states]) for name, r in runs.items()}
    np.testing.assert_array_equal(x["predicted"][:21], x["plain"][:21])  # u = 0 until t = d, then apart
    start = [float(v) for v in x["predicted"][20]]
    initial = f"theta = [{start[0]!r}, {start[1]!r}]\ndtheta = [{start[2]!r}, {start[3]!r}]"
    free = Run(simulator, tmp_path, scene_text(t_end=0.48).replace("theta = [0, 0.05]", initial), name="free")
    undelayed = np.column_stack([free[c] for c in states])
    gap = {name: np.max(np.abs(value[20 : 20 + len(undelayed)] - undelayed)) for name, value in x.items()}
    assert gap["predicted"] < 1e-7 < 1e-3 < gap["plain"], gap


def test_difference_and_filter_estimates_from_the_measured_angles(simulator: Path, tmp_path: Path) -> None:
    for kind, extra in (("difference", ""), ("filter", "cutoff = 80\n")):
        r = Run(
            simulator,
            tmp_path,
            scene_text(f'[sensors]\nresolution = 2048\n[estimator]\nkind = "{kind}"\n{extra}'),
        )
        y = np.column_stack([r["y_theta0"], r["y_theta1"]])
        step = np.vstack([np.zeros((1, 2)), np.diff(y, axis=0)])
        if kind == "difference":
            rate = step / PERIOD
        else:
            a, rate = math.exp(-80 * PERIOD), np.zeros_like(y)
            for k in range(1, len(y)):
                rate[k] = a * rate[k - 1] + 80 * step[k]
        np.testing.assert_array_equal(r["hat_theta0"], y[:, 0])
        np.testing.assert_allclose(
            np.column_stack([r["hat_dtheta0"], r["hat_dtheta1"]]), rate, rtol=1e-12, atol=1e-9
        )


def kalman_reference(r: Run, measured: list[int], shift: int = 0) -> np.ndarray:
    """The current-form steady-state Kalman filter of SENSORS_SPEC on the CSV's y_* and u (u of
    `shift` samples earlier, 0 before the first: the input a loop told of a longer delay assumes)."""
    u = np.concatenate([np.zeros(shift), r["u"]])
    a, b = r.matrix("estimator.A", 4), r.matrix("estimator.B", 4)[:, 0]
    gain, x_eq = r.matrix("estimator.gain", 4), np.array(r.keys["estimator.equilibrium"].split(), dtype=float)
    c = np.eye(4)[measured]
    y = np.column_stack([r[f"y_theta{i}"] for i in measured])
    predicted = x_eq.copy()
    predicted[measured] = y[0]
    estimates = []
    for k in range(len(y)):
        estimate = predicted + gain @ (y[k] - c @ predicted)
        estimates.append(estimate)
        predicted = x_eq + a @ (estimate - x_eq) + b * u[k]
    return np.array(estimates)


def test_a_loop_built_for_another_delay_predicts_with_the_commands_it_believes(
    simulator: Path, tmp_path: Path
) -> None:
    """[estimator] delay: the rig applies each command at once, the loop believes it 3 periods
    late, so its Kalman filter predicts with the command of 3 samples before (the reference on the
    CSV). Told the rig's own delay, the run is the one without the key, byte for byte."""
    table = "[sensors]\nmeasured = [0, 1]\nresolution = 2048\nnoise = 0.001\nseed = 4\n"
    r = Run(simulator, tmp_path, scene_text(table + '[estimator]\nkind = "kalman"\ndelay = 0.003\n'))
    assert r.keys["estimator.delay"] == "0.003" and "built for a delay of 3 sampling periods" in r.summary
    hat = np.column_stack([r[f"hat_{n}"] for n in ("theta0", "theta1", "dtheta0", "dtheta1")])
    np.testing.assert_allclose(hat, kalman_reference(r, [0, 1], shift=3), rtol=1e-9, atol=1e-9)
    assert np.max(np.abs(hat - kalman_reference(r, [0, 1]))) > 1e-6  # the shift is what it uses
    delayed = table.replace("seed = 4", "seed = 4\ndelay = 0.003")
    told = Run(simulator, tmp_path, scene_text(delayed + '[estimator]\nkind = "kalman"\ndelay = 0.003\n'),
               name="told")  # fmt: skip
    plain = Run(simulator, tmp_path, scene_text(delayed + '[estimator]\nkind = "kalman"\n'), name="plain")
    assert told.csv.read_text() == plain.csv.read_text()


def test_kalman_estimates_equal_the_reference_on_the_recorded_samples(
    simulator: Path, tmp_path: Path
) -> None:
    for measured in ([0, 1], [0]):
        table = f"[sensors]\nmeasured = {measured}\nresolution = 2048\nnoise = 0.001\nseed = 4\n"
        r = Run(simulator, tmp_path, scene_text(table + '[estimator]\nkind = "kalman"\n'))
        hat = np.column_stack([r[f"hat_{n}"] for n in ("theta0", "theta1", "dtheta0", "dtheta1")])
        np.testing.assert_allclose(hat, kalman_reference(r, measured), rtol=1e-9, atol=1e-9)
        # ipgen.estimation's Python filter (h-est32's) on the recorded y_* and u: the same estimates.
        sensors = Sensors.of(2, measured, 2048, 0.001)
        qn, rn = default_covariances(PENDULUM, PERIOD, sensors, u_scale=5.0)
        python = replay(SteadyStateKalman(ipgen.kalman(PENDULUM, PERIOD, qn, rn, measured=measured)), r.csv)
        np.testing.assert_allclose(python.estimate[: len(hat)], hat, rtol=1e-9, atol=1e-9)
        assert abs(r.data[-1, 2]) < 0.05  # the 0.05 rad tilt not grown: balanced on the estimate


def model_functions(m: list[float] = M) -> tuple:
    """ẋ = f(x, u) from ipgen.derive's M and bias (sympy, lambdified here) and ∂f/∂x from ipgen.linearize,
    with the masses `m` (the paper's by default)."""
    eq = ipgen.derive("rotary", 1)
    s = eq.symbols
    values = dict(zip([*s.m, *s.l, *s.delta, s.g], [*m, *L, *DELTA, 9.81], strict=True))
    mass = sp.lambdify([*s.q], eq.mass_matrix.subs(values), "numpy")
    bias = sp.lambdify([*s.q, *s.qd], eq.bias.subs(values), "numpy")

    def f(x: np.ndarray, u: float) -> np.ndarray:
        qdd = np.linalg.solve(
            np.array(mass(*x[:2]), float), np.array([u, 0.0]) - np.array(bias(*x), float).ravel()
        )
        return np.concatenate([x[2:], qdd])

    def jacobian(x: np.ndarray, u: float) -> np.ndarray:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return ipgen.linearize("rotary", 1, m, L, DELTA, q=x[:2], qd=x[2:], u=u)[0]

    return f, jacobian


# controller.model.*: the loop's design model (a sweep's nominal one) where the plant differs
DESIGN_MASSES = [1.25 * v for v in M]
DESIGN = "".join(
    f"controller.model.{key} = {' '.join(repr(v) for v in values)}\n"
    for key, values in (("m", DESIGN_MASSES), ("l", L), ("delta", DELTA), ("g", [9.81]))
)


@pytest.mark.parametrize("design", [False, True], ids=["plant", "design"])
def test_ekf_estimates_equal_an_independent_ekf_on_the_recorded_samples(
    simulator: Path, tmp_path: Path, design: bool
) -> None:
    """The EKF runs the loop's design model: the plant's, or controller.model.*'s (masses × 1.25)."""
    r = Run(simulator, tmp_path, scene_text('[sensors]\nmeasured = [0, 1]\nresolution = 2048\nnoise = 0.002\n'
                                            '[estimator]\nkind = "ekf"\n', t_end=0.2),
            cfg_lines=DESIGN if design else "")  # fmt: skip
    f, jacobian = model_functions(DESIGN_MASSES if design else M)
    qn, rn = r.matrix("estimator.process_noise", 4), r.matrix("estimator.measurement_noise", 2)
    x_eq = np.array(r.keys["estimator.equilibrium"].split(), dtype=float)
    c, eye, t = np.eye(4)[:2], np.eye(4), PERIOD
    y = np.column_stack([r["y_theta0"], r["y_theta1"]])
    x, p = x_eq.copy(), np.diag([rn[0, 0], rn[1, 1], 1.0, 1.0])
    x[:2] = y[0]
    hat = []
    for k in range(len(y)):
        gain = p @ c.T @ np.linalg.inv(c @ p @ c.T + rn)
        x = x + gain @ (y[k] - c @ x)
        p = (eye - gain @ c) @ p @ (eye - gain @ c).T + gain @ rn @ gain.T
        hat.append(x)
        u = r["u"][k]
        k1 = f(x, u)
        k2 = f(x + t / 2 * k1, u)
        k3 = f(x + t / 2 * k2, u)
        k4 = f(x + t * k3, u)
        ta = t * jacobian(x, u)
        big_f = eye + ta + ta @ ta / 2
        x = x + t / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        p = big_f @ p @ big_f.T + qn
    got = np.column_stack([r[f"hat_{n}"] for n in ("theta0", "theta1", "dtheta0", "dtheta1")])
    np.testing.assert_allclose(got, np.array(hat), rtol=1e-9, atol=1e-9)
    pendulum = {**PENDULUM, "m": DESIGN_MASSES} if design else PENDULUM
    python = replay(ExtendedKalman(pendulum, PERIOD, qn, rn, measured=[0, 1]), r.csv)  # ipgen.estimation's
    np.testing.assert_allclose(python.estimate[: len(got)], got, rtol=1e-9, atol=1e-9)


def noise_of(r: Run) -> np.ndarray:
    return np.column_stack([r["y_theta0"] - r["theta0"], r["y_theta1"] - r["theta1"]])


def test_noise_is_reproducible_from_the_seed_and_independent_of_the_integrator(
    simulator: Path, tmp_path: Path
) -> None:
    text = scene_text("[sensors]\nnoise = 0.002\nseed = 11\n", actuator="[actuator]\nnoise = 0.05")
    first = Run(simulator, tmp_path, text, name="a")
    again = Run(simulator, tmp_path, text, name="b")
    assert first.csv.read_bytes() == again.csv.read_bytes()
    other = Run(simulator, tmp_path, text.replace("seed = 11", "seed = 12"), name="c")
    n, n_other = noise_of(first), noise_of(other)
    assert np.max(np.abs(n - n_other)) > 1e-3
    # σ = 2 mrad: the sample standard deviation of 1000 draws within 10 % (5 standard errors).
    assert np.std(n) == pytest.approx(0.002, rel=0.1) and abs(np.mean(n)) < 5 * 0.002 / math.sqrt(n.size)
    assert abs(np.corrcoef(n[:, 0], n[:, 1])[0, 1]) < 0.15
    loose = Run(simulator, tmp_path, text, "--rtol", "1e-6", name="d")
    fixed = Run(simulator, tmp_path, text, "--method", "rk4", "--step", "0.0002", name="e")
    for r in (loose, fixed):
        assert not np.array_equal(r["theta1"], first["theta1"])  # another integration...
        np.testing.assert_allclose(noise_of(r), n, atol=1e-13)  # ...the same draws


def test_a_disturbance_pulse_is_an_input_pulse(simulator: Path, tmp_path: Path) -> None:
    """An [actuator] pulse of 0.2 N m on [0.1, 0.15) s moves the open loop exactly as an
    [input] pulse of the same force does."""
    open_loop = SCENE.split("[controller]")[0].format(m=M, l=L, delta=DELTA, tilt=0.0, actuator="{actuator}")
    tail = "[simulation]\nt_end = 0.4\nsample = 0.001\n"
    given = open_loop.format(
        actuator='[input]\nkind = "pulse"\namplitude = 0.2\nstart = 0.1\nduration = 0.05\n'
    )
    pulsed = open_loop.format(actuator="[actuator]\npulses = [[0.1, 0.05, 0.2]]\n")
    a = Run(simulator, tmp_path, given + tail, name="input")
    b = Run(simulator, tmp_path, pulsed + tail, name="pulses")
    np.testing.assert_allclose(b.data[:, 1:5], a.data[:, 1:5], rtol=1e-12, atol=1e-15)
    assert np.max(np.abs(a.data[:, 3])) > 0.01  # it did move the arm
    assert "Disturbance pulse 0.2 N m" in b.summary


def test_the_drive_lag_is_a_first_order_state(simulator: Path, tmp_path: Path) -> None:
    """A lag far below the period changes nothing visible; a 20 ms lag does; and the energy
    ledger, integrated with the lagged force, still balances."""
    plain = Run(simulator, tmp_path, scene_text(), name="plain")
    quick = Run(simulator, tmp_path, scene_text(actuator="[actuator]\nlag = 1e-6"), name="quick")
    slow = Run(simulator, tmp_path, scene_text(actuator="[actuator]\nlag = 0.02"), "--energy", name="slow")
    np.testing.assert_allclose(quick.data[:, 1:5], plain.data[:, 1:5], atol=1e-4)
    assert np.max(np.abs(slow.data[:, 2] - plain.data[:, 2])) > 1e-3
    balance = float(slow.summary.split("balance error ")[1].split(" J")[0])
    assert abs(balance) < 1e-8


@pytest.mark.parametrize("design", [False, True], ids=["plant", "design"])
def test_the_energy_law_runs_the_design_model(simulator: Path, tmp_path: Path, design: bool) -> None:
    """The energy swing-up's first command from hanging at rest, u = M00 a + M01 q̈1 + b0 with
    q̈1 = −(M10 a + b1)/M11 and a = −a_max (the energy far below the target), from ipgen.derive's
    M and bias (sympy) with the design model's masses: the plant's, or controller.model.*'s."""
    text = SCENE.split("[initial]")[0].format(m=M, l=L, delta=DELTA) + (
        '[simulation]\nt_end = 0.01\nsample = 0.001\n'
        '[swingup]\nmethod = "energy"\nu_max = 50.0\nperiod = 0.001\n'
    )
    r = Run(simulator, tmp_path, text, cfg_lines=DESIGN if design else "", name="swing")
    eq = ipgen.derive("rotary", 1)
    sym = eq.symbols
    expected = {}
    for name, masses in (("plant", M), ("design", DESIGN_MASSES)):
        values = dict(zip([*sym.m, *sym.l, *sym.delta, sym.g], [*masses, *L, *DELTA, 9.81], strict=True))
        q, qd = [0.0, math.pi], [0.0, 0.0]
        mass = np.array(sp.lambdify([*sym.q], eq.mass_matrix.subs(values))(*q), dtype=float)
        bias = np.array(sp.lambdify([*sym.q, *sym.qd], eq.bias.subs(values))(*q, *qd), dtype=float).ravel()
        a = -float(r.keys["swingup.accel_max"])
        qdd1 = -(mass[1, 0] * a + bias[1]) / mass[1, 1]
        expected[name] = mass[0, 0] * a + mass[0, 1] * qdd1 + bias[0]
    got = r["u"][0]
    assert got == pytest.approx(expected["design" if design else "plant"], rel=1e-9)
    assert abs(expected["design"] - expected["plant"]) > 1e-3 * abs(got)  # the two models tell apart


def test_the_energy_law_gives_the_design_motors_volts(simulator: Path, tmp_path: Path) -> None:
    """A dc_motor scene whose design model's force per volt is 1.25 × the plant's (a sweep's run
    with Rm × 0.8): the law's force is the same (the same design parameters), its volts are that
    force over the design's gain, so the first command is 1/1.25 of the plant-designed run's."""
    from ipgen.sweeps.design_model import model_lines

    motor = '[actuator]\nkind = "dc_motor"\nRm = 8.4\nkt = 0.042\nkm = 0.042\n'
    text = SCENE.split("[initial]")[0].format(m=M, l=L, delta=DELTA) + motor + (
        '[simulation]\nt_end = 0.01\nsample = 0.001\n'
        '[swingup]\nmethod = "energy"\nu_max = 50.0\nperiod = 0.001\n'
    )
    plain = Run(simulator, tmp_path, text, name="plain")
    gain = float(plain.keys["actuator.gain"])
    lines = [
        f"controller.model.gain = {1.25 * gain!r}" if line.startswith("controller.model.gain") else line
        for line in model_lines((tmp_path / "plain.cfg").read_text())
    ]
    assert any(line.startswith("controller.model.gain") for line in lines)
    design = Run(simulator, tmp_path, text, name="design", cfg_lines="".join(f"{line}\n" for line in lines))
    assert abs(plain["u"][0]) > 0.1  # volts
    assert design["u"][0] == pytest.approx(plain["u"][0] / 1.25, rel=1e-9)


def test_an_energy_swingup_on_encoders_with_an_ekf_reaches_the_hold(simulator: Path, tmp_path: Path) -> None:
    """The swing-up law sees the EKF's estimate from 2048-count encoders; it still swings up and
    holds, and the phase stays the CSV's last column."""
    text = SCENE.split("[initial]")[0].format(m=M, l=L, delta=DELTA) + (
        '[simulation]\nt_end = 8.0\nsample = 0.01\n[swingup]\nmethod = "energy"\nu_max = 5.0\nhold = 0.5\n'
        '[sensors]\nresolution = 2048\n[estimator]\nkind = "ekf"\n'
    )
    path = tmp_path / "swing.toml"
    path.write_text(text)
    cfg = tmp_path / "swing.cfg"
    cfg.write_text(resolved_config(load_scene(path)))
    csv = tmp_path / "swing.csv"
    result = subprocess.run([str(simulator), str(cfg), "--csv", str(csv)], capture_output=True, text=True)
    assert result.returncode == 0, result.stderr
    header, *rows = csv.read_text().splitlines()
    assert header.split(",")[-1] == "phase" and "hat_dtheta1" in header
    assert rows[-1].endswith(",hold") and "Estimator: ekf" in result.stdout
    last = [float(v) for v in rows[-1].split(",")[:-1]]
    assert abs(math.remainder(last[2], 2 * math.pi)) < 0.05  # θ1 upright
    # Its CSV is the simulator's: a second run replaces it without --force (before, the y_ and
    # hat_ columns made it a user's file, refused)
    again = subprocess.run([str(simulator), str(cfg), "--csv", str(csv)], capture_output=True, text=True)
    assert again.returncode == 0, again.stderr


def test_the_simulator_refuses_compensate_lag_without_sensors(simulator: Path, tmp_path: Path) -> None:
    """A .cfg not written by ipgen with estimator.compensate_lag but no measured loop: one line,
    exit 2 (ipgen writes the key only with [sensors])."""
    path = tmp_path / "plain.toml"
    path.write_text(scene_text())
    cfg = tmp_path / "bad.cfg"
    cfg.write_text(resolved_config(load_scene(path)) + "estimator.compensate_lag = 1\n")
    result = subprocess.run([str(simulator), str(cfg)], capture_output=True, text=True)
    assert result.returncode == 2 and "estimator.compensate_lag needs the sensors.* keys" in result.stderr
    assert result.stderr.count("\n") == 1


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"sensors.delay": "0.0015"}, "whole multiple of the period"),
        ({"sensors.resolution": "-1 2048"}, "-1 must be 0 or >= 1 (the rule of [sensors] resolution)"),
        ({"sensors.resolution": "0.5 2048"}, "sensors.resolution[0] = 0.5 must be 0 or >= 1"),
        ({"sensors.noise": "nan 0"}, "sensors.noise[0] = nan must be >= 0 and <= 1e+100"),
        ({"sensors.measured": "1 0"}, "ascending"),
        ({"sensors.resolution": "2048"}, "has 1 values, expected 2"),
        ({"estimator": "luenberger"}, "estimator must be"),
        ({"estimator": "filter", "sensors.measured": "1", "sensors.resolution": "0", "sensors.noise": "0"},
         "needs every coordinate measured"),
        ({"controller.period": "0"}, "controller.period = 0 must be > 0"),
        ({"actuator.pulses": "0.1 0.2"}, "3 numbers a pulse"),
        ({"estimator.predict": "1"}, "estimator.predict needs estimator exact or ekf"),
        ({"estimator.predict": "0.5"}, "estimator.predict must be 0 or 1"),
        ({"estimator.compensate_lag": "2"}, "estimator.compensate_lag must be 0 or 1"),
        ({"estimator.compensate_lag": "-1"}, "estimator.compensate_lag must be 0 or 1"),
        ({"estimator.lag": "0.01"}, "estimator.lag needs estimator.compensate_lag = 1"),
        ({"estimator.noise_memory": "1", "estimator.noise_margin": "10", "estimator.noise_floor": "1e-6 1e-6",
          "estimator.noise_ceiling": "1e-3 1e-3"}, "estimator.noise_memory needs estimator = ekf"),
        ({"estimator.noise_memory": "0"}, "estimator.noise_memory = 0 must be > 0"),
        ({"estimator.noise_margin": "10"}, "estimator.noise_margin needs estimator.noise_memory"),
        ({"estimator.noise_floor": "1e-6 1e-6"}, "estimator.noise_floor needs estimator.noise_memory"),
    ],
)  # fmt: skip
def test_the_simulator_refuses_bad_loop_keys(
    simulator: Path, tmp_path: Path, change: dict, message: str
) -> None:
    """A .cfg not written by ipgen: one line `simulate: error: ...`, exit 2, no CSV."""
    path = tmp_path / "bad.toml"
    path.write_text(scene_text('[sensors]\nresolution = 2048\n[estimator]\nkind = "difference"\n'))
    keys = [line.split(" = ", 1) for line in resolved_config(load_scene(path)).splitlines() if " = " in line]
    keys = [(key, change.get(key, value)) for key, value in keys]
    keys += [(key, value) for key, value in change.items() if key not in dict(keys)]
    cfg = tmp_path / "bad.cfg"
    cfg.write_text("".join(f"{key} = {value}\n" for key, value in keys))
    result = subprocess.run(
        [str(simulator), str(cfg), "--csv", str(tmp_path / "bad.csv")], capture_output=True, text=True
    )
    assert result.returncode == 2 and message in result.stderr, result.stderr
    assert result.stderr.startswith("simulate: error: ") and result.stderr.count("\n") == 1
    assert not (tmp_path / "bad.csv").exists()
