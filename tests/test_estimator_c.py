"""Software in the loop: the C header's estimator and controller (`ipgen_<name>_loop_step`),
compiled in double and float, driven with the measured samples (y_* columns) the simulator
recorded, against the simulator's own loop (its hat_* columns and the command u): 1e-9 in
double; in float within FLOAT_ANGLE / FLOAT_RATE / FLOAT_INPUT (stated in docs/estimation.md).
Also against the Python estimators (ipgen.estimation) on the same samples.

The QUBE-Servo 2 preset (a DC motor: u in volts; Quanser's counter-clockwise α) on its 2048-count
encoders, with noise, sampled at 1 kHz; every estimator kind, one with a delay of two periods, and
the EKF with a delay of four that its law predicts over ([estimator] predict), one whose loop
is built for a delay of three on a rig without one ([estimator] delay), and a Kalman filter and
an EKF (with a delay predicted over) on a drive with a 10 ms lag the loop compensates
([estimator] compensate_lag), and an EKF that learns its measurement noise ([estimator]
noise_memory) from encoders 2 mrad noisy.
"""

from __future__ import annotations

import io
import subprocess
from contextlib import redirect_stderr, redirect_stdout
from pathlib import Path

import numpy as np
import pytest
from c_models import c_command, compile_c, require_cc
from cxx import require_toolchain
from run_csv import read_run_csv

import ipgen
from ipgen.command.cli import run
from ipgen.common.build_cache import cache_root
from ipgen.estimation import Sensors, design, replay
from ipgen.pipeline import job
from ipgen.pipeline.simulator import build, model_sources

ROOT = Path(__file__).resolve().parent.parent
PRESET = ROOT / "scenes" / "rigs" / "qube_servo2_sensors.toml"
DOUBLE = 1e-9  # relative to the column's largest value
FLOAT_ANGLE = 1e-4  # rad
FLOAT_RATE = 2e-2  # rad/s
FLOAT_INPUT = 5e-3  # V
VARIANTS = {  # name: ([sensors] extra lines, [estimator] table)
    "difference": ("noise = 2e-4\n", 'kind = "difference"\n'),
    "filter": ("noise = 2e-4\n", 'kind = "filter"\ncutoff = 50\n'),
    "kalman": ("noise = 2e-4\n", 'kind = "kalman"\n'),
    "kalman-delay": ("noise = 2e-4\ndelay = 0.002\n", 'kind = "kalman"\n'),
    "ekf": ("noise = 2e-4\n", 'kind = "ekf"\n'),
    # the law on the estimate carried over a delay of 4 periods (ipgen_loop_predict)
    "ekf-predict": ("noise = 2e-4\ndelay = 0.004\n", 'kind = "ekf"\npredict = true\n'),
    # a loop built for 3 periods on a rig without delay ([estimator] delay): the header's queue
    "ekf-told": ("noise = 2e-4\n", 'kind = "ekf"\ndelay = 0.003\npredict = true\n'),
    # a 10 ms drive lag the loop is built for ([estimator] compensate_lag): the lag's inverse
    "kalman-lag": ("noise = 2e-4\n", 'kind = "kalman"\ncompensate_lag = true\n'),
    "ekf-lag": ("noise = 2e-4\ndelay = 0.002\n", 'kind = "ekf"\npredict = true\ncompensate_lag = true\n'),
    # each encoder's noise learnt from the innovations over 50 ms ([estimator] noise_memory)
    "ekf-noise": ("noise = 2e-3\n", 'kind = "ekf"\nnoise_memory = 0.05\n'),
}
DELAYS = {"kalman-delay": 2, "ekf-predict": 4, "ekf-lag": 2}  # periods: the rig's
LAGS = {"kalman-lag": "0.01", "ekf-lag": "0.01"}  # s: [actuator] lag

DRIVER = """\
#include <stdio.h>
#include "qube_servo2.h"
int main(void) {
  ipgen_qube_servo2_estimator_state s;
  double y0, y1;
  IPGEN_SCALAR y[2];
%(ekf_setup)s
  ipgen_qube_servo2_estimator_init(&s);
  while (scanf("%%lf %%lf", &y0, &y1) == 2) {
    IPGEN_SCALAR u;
    y[0] = (IPGEN_SCALAR)y0;
    y[1] = (IPGEN_SCALAR)y1;
    u = ipgen_qube_servo2_loop_step(&s, y%(ekf_args)s);
    printf("%%.17g %%.17g %%.17g %%.17g %%.17g\\n", (double)s.x[0], (double)s.x[1], (double)s.x[2],
           (double)s.x[3], (double)u);
  }
  return 0;
}
"""


def _array(values) -> str:
    return "{" + ", ".join(f"(IPGEN_SCALAR){float(v)!r}" for v in values) + "}"


def ekf_setup() -> str:
    """The EKF's parameters: the preset's, the motor folded in (ipgen_qube_servo2_with_motor)."""
    p = ipgen.Pendulum.from_scene(ROOT / "scenes" / "rigs" / "qube_servo2.toml")
    params = p.params()
    return (
        f"  ipgen_qube_servo2_params p = {{{_array(params['m'])}, {_array(params['l'])}, "
        f"{_array(params['delta'])}, (IPGEN_SCALAR){params['g']!r}}};\n"
        f"  ipgen_qube_servo2_links links = {{{_array(params['com'])}, {_array(params['J'])}, "
        f"{_array(params['J_axial'])}, {_array(params['tip'])}}};\n"
        "  const ipgen_qube_servo2_dc_motor motor = {(IPGEN_SCALAR)8.4, (IPGEN_SCALAR)0.042, "
        "(IPGEN_SCALAR)0.042, (IPGEN_SCALAR)1, (IPGEN_SCALAR)1, (IPGEN_SCALAR)1, (IPGEN_SCALAR)0};\n"
        "  ipgen_qube_servo2_with_motor(&motor, &p, &links);"
    )


def scene_text(sensors: str, estimator: str, lag: str = "") -> str:
    text = PRESET.read_text().replace('emit = ["cpp"]', 'emit = ["cpp", "c"]')
    if lag:
        text = text.replace('kind = "dc_motor"', f'kind = "dc_motor"\nlag = {lag}', 1)
    text = text.replace("t_end = 5.0", "t_end = 0.6\nsample = 0.001")
    text = text.replace(
        "delay = 0.0                   # s: the voltage is applied in the sample it is computed\n", ""
    )
    head, _, _ = text.partition("[estimator]")
    return head.replace("[sensors]\n", "[sensors]\n" + sensors) + "[estimator]\n" + estimator


@pytest.fixture(scope="module")
def generated(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """Every variant generated (.h, .hpp, .cfg); the simulator built from the kalman variant's .hpp."""
    require_toolchain()
    require_cc()
    root = tmp_path_factory.mktemp("sil")
    folders = {}
    for name, (sensors, estimator) in VARIANTS.items():
        folder = root / name
        folder.mkdir()
        text = scene_text(sensors, estimator, LAGS.get(name, ""))
        assert (f"\nlag = {LAGS[name]}" in text) if name in LAGS else "\nlag = " not in text
        (folder / "scene.toml").write_text(text)
        with redirect_stdout(io.StringIO()), redirect_stderr(io.StringIO()) as err:
            assert run(["--scene", str(folder / "scene.toml"), "-o", str(folder)]) == 0, err.getvalue()
        # what `ipgen run` compiles and reads: the model's library and a .cfg naming it (in sim/)
        simulated = job.for_the_simulator(job.plan(folder / "sim", scene=folder / "scene.toml"))
        job.run(simulated)
        folders[name] = folder
    # the shared content-keyed cache (locked per key): the xdist workers and later runs build it once
    sources = model_sources(folders["kalman"] / "sim", simulated.name)
    folders["simulator"] = build(sources, simulated.name, cache_root()).path
    return folders


def simulate(simulator: Path, folder: Path) -> dict[str, np.ndarray]:
    csv = folder / "run.csv"
    result = subprocess.run(
        [str(simulator), str(folder / "sim" / "scene.cfg"), "--csv", str(csv), "--force"],
        capture_output=True,
        text=True,
    )
    assert result.returncode == 0, result.stderr
    return read_run_csv(csv, phase=False).columns(slice(-1))  # the sampling instants


def run_c(folder: Path, kind: str, scalar: str, y: np.ndarray) -> np.ndarray:
    source = folder / f"driver_{scalar}.c"
    ekf = kind == "ekf"
    source.write_text(
        DRIVER % {"ekf_setup": ekf_setup() if ekf else "", "ekf_args": ", &p, &links" if ekf else ""}
    )
    program = folder / f"driver_{scalar}"
    problem = compile_c(c_command(f"-I{folder}", str(source), "-o", str(program), scalar=scalar))
    assert problem is None, problem
    text = "\n".join(f"{a!r} {b!r}" for a, b in y.tolist()) + "\n"
    result = subprocess.run([str(program)], input=text, capture_output=True, text=True, check=True)
    return np.array([[float(v) for v in line.split()] for line in result.stdout.splitlines()])


@pytest.mark.parametrize("name", list(VARIANTS))
def test_c_loop_matches_the_simulator(generated, name) -> None:
    folder = generated[name]
    kind = name.split("-")[0]
    columns = simulate(generated["simulator"], folder)
    y = np.column_stack([columns["y_theta0"], columns["y_theta1"]])
    hat = np.column_stack([columns[c] for c in ("hat_theta0", "hat_theta1", "hat_dtheta0", "hat_dtheta1")])
    delay = DELAYS.get(name, 0)
    applied = columns["u"]
    assert np.all(np.abs(hat[:, 1]) < 0.2), "the loop must stay near upright for this check"
    for scalar in ("double", "float"):
        out = run_c(folder, kind, scalar, y)
        estimate, command = out[:, :4], out[:, 4]
        assert estimate.shape == hat.shape
        # the simulator's u at row k is the command of row k − delay (zero before)
        commanded = command[: len(command) - delay] if delay else command
        sent = applied[delay:]
        if scalar == "double":
            scale = np.maximum(np.max(np.abs(hat), axis=0), 1e-300)
            assert np.all(np.abs(estimate - hat) <= DOUBLE * scale), (
                name,
                np.max(np.abs(estimate - hat), axis=0),
            )
            assert np.max(np.abs(commanded - sent)) <= DOUBLE * max(1.0, np.max(np.abs(sent)))
            assert np.all(applied[:delay] == 0.0)
        else:
            error = np.max(np.abs(estimate - hat), axis=0)
            assert np.all(error[:2] <= FLOAT_ANGLE) and np.all(error[2:] <= FLOAT_RATE), (name, error)
            assert np.max(np.abs(commanded - sent)) <= FLOAT_INPUT, (name, np.max(np.abs(commanded - sent)))


@pytest.mark.parametrize("name", ["difference", "filter", "kalman", "ekf"])
def test_a_sample_that_is_not_finite_leaves_the_c_estimate_as_it_was(generated, name) -> None:
    """One NaN or inf reading in the middle of the simulator's samples: the header's estimator skips
    it (the update returns 3, its state unchanged), the law acts on the kept estimate, and every
    later sample is estimated and commanded as without it (before, a Kalman filter's or an EKF's
    estimate and every command stayed NaN from there on, a filter's rate too)."""
    folder = generated[name]
    columns = simulate(generated["simulator"], folder)
    y = np.column_stack([columns["y_theta0"], columns["y_theta1"]])
    plain = run_c(folder, name, "double", y)
    for bad in ([np.nan, y[300, 1]], [y[300, 0], np.inf]):
        glitched = run_c(folder, name, "double", np.insert(y, 300, bad, axis=0))
        assert np.all(np.isfinite(glitched))
        np.testing.assert_array_equal(glitched[300], plain[299])  # the kept estimate, its command
        np.testing.assert_array_equal(np.delete(glitched, 300, axis=0), plain)


# replay feeds the CSV's applied u; the "told" loop predicts with the commands it believes act,
# a lagged loop with their lagged means
@pytest.mark.parametrize(
    "name", [name for name in VARIANTS if name not in ("ekf-told", "ekf-noise") and name not in LAGS]
)
def test_python_estimators_on_the_simulators_samples(generated, name) -> None:
    """ipgen.estimation.replay over the simulator's CSV: the same estimates (1e-9)."""
    folder = generated[name]
    kind = name.split("-")[0]
    columns = simulate(generated["simulator"], folder)
    pendulum = ipgen.Pendulum.from_scene(folder / "scene.toml")
    sensors = Sensors.of(2, None, 2048, 2e-4)
    est = design(pendulum, kind, 1e-3, sensors, u_scale=10.0).build(pendulum)
    got = replay(est, folder / "run.csv")
    hat = np.column_stack([columns[c] for c in ("hat_theta0", "hat_theta1", "hat_dtheta0", "hat_dtheta1")])
    scale = np.maximum(np.max(np.abs(hat), axis=0), 1e-300)
    assert np.all(np.abs(got.estimate[: len(hat)] - hat) <= DOUBLE * scale), np.max(
        np.abs(got.estimate[: len(hat)] - hat), axis=0
    )


def test_an_ekf_header_without_the_dynamics_is_refused() -> None:
    """The EKF needs the header's forward dynamics and their derivatives (a scene always emits
    them; a header request without them is refused in one line naming the fix)."""
    from ipgen.codegen.c_header import ControllerError, estimator_context
    from ipgen.estimation.measurement import Sensors
    from ipgen.estimation.printed import EstimatorNumbers, PrintedEstimator

    def printed(measured: tuple[int, ...], **numbers: object) -> PrintedEstimator:
        sensors = Sensors(measured, (0.0,) * len(measured), (0.0,) * len(measured))
        return PrintedEstimator(EstimatorNumbers(**numbers), sensors, period=1e-3)  # type: ignore[arg-type]

    ekf = printed((0, 1), kind="ekf", equilibrium=(0.0,) * 4)
    with pytest.raises(ControllerError) as info:
        estimator_context(ekf, 2, ("mass_matrix", "bias"))
    message = str(info.value)
    assert "\n" not in message and "forward_dynamics" in message and "outputs" in message, message
    with pytest.raises(ControllerError, match="every coordinate measured"):
        estimator_context(printed((1,), kind="filter", cutoff=50.0), 2, ())
    nan = printed((0, 1), kind="ekf", equilibrium=(0.0, float("nan"), 0.0, 0.0))
    with pytest.raises(ControllerError, match="not a finite number"):
        estimator_context(nan, 2, ("forward_dynamics", "forward_dynamics_derivatives"))


def test_scenes_without_an_estimator_print_none(tmp_path) -> None:
    """The shipped QUBE preset (no [sensors]) has no estimator in its C header; its sensors
    variant has the Kalman filter's tables."""
    for source, expected in (("qube_servo2.toml", False), ("qube_servo2_sensors.toml", True)):
        text = (ROOT / "scenes" / "rigs" / source).read_text().replace('emit = ["cpp"]', 'emit = ["c"]')
        scene = tmp_path / source
        scene.write_text(text)
        with redirect_stdout(io.StringIO()), redirect_stderr(io.StringIO()):
            assert run(["--scene", str(scene), "-o", str(tmp_path / source.removesuffix(".toml"))]) == 0
        header = (tmp_path / source.removesuffix(".toml") / "qube_servo2.h").read_text()
        assert ("ipgen_qube_servo2_estimator_update" in header) is expected
        assert ("static const IPGEN_SCALAR ipgen_qube_servo2_estimator_M[8]" in header) is expected
