"""The MPC in the C header (issue 47): a scene with [controller] kind = "mpc" and emit = ["c"]
gets `ipgen_NAME_mpc_step` (ipgen_mpc.h printed whole, the design as constants, the header's
own model as the callback, static memory) and, when the scene measures, `ipgen_NAME_step` from
encoder counts to volts. Along the simulator's closed loop (the QUBE-Servo 2 in volts, 2048-count
encoders, a Kalman filter, u on its bound and the arm near its travel):

- the firmware entry fed the simulator's counts returns the voltage the simulator applied at
  every sample, in double to 1e-9;
- the MPC step fed the estimates the simulator's controller saw returns its u: double 1e-9
  (3.0e-11 measured), float (IPGEN_SCALAR=float, every operation single precision) within
  FLOAT_INPUT = 1e-3 u_max (3.6e-5 V measured);
- compiled with -std=c99 -Wall -Wextra -Wpedantic -Werror (float: -Wdouble-promotion -Wconversion).
"""

from __future__ import annotations

import io
import math
import subprocess
from contextlib import redirect_stderr, redirect_stdout
from pathlib import Path

import numpy as np
import pytest
from c_models import CC, FLOAT_WARNINGS, MPC_STEP_PROGRAM, WARNINGS, require_cc
from cxx import CXX, require_toolchain
from run_csv import read_run_csv
from test_mpc_scene import FAST, MEASURED, PUSHED, QUBE, U_MAX

from ipgen.command.cli import run

P = "ipgen_qube_servo2"
# The float step against the simulator's (double) fed the same estimates: measured 3.6e-5 V
# (3.6e-6 of u_max) along this loop; the bound is docs/mpc.md's FLOAT_INPUT.
FLOAT_INPUT = 1e-3 * U_MAX

FIRMWARE = """\
#include <stdio.h>
#include "qube_servo2.h"
/* Reads the counts of a sample per line, prints the voltage the firmware entry returns. */
static P_loop_state s;
int main(void) {
  long counts[2];
  P_loop_init(&s);
  while (scanf("%ld %ld", &counts[0], &counts[1]) == 2) printf("%.17g\\n", (double)P_step(&s, counts));
  return 0;
}
"""

STEP = MPC_STEP_PROGRAM.replace("ipgen_NAME_", "P_").replace("NAME", "qube_servo2")


@pytest.fixture(scope="module")
def folder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The scene's C header (--emit c) and the simulator's run of it (CSV)."""
    require_toolchain()
    require_cc()
    root = tmp_path_factory.mktemp("mpc_c")
    scene = root / "qube_mpc.toml"
    text = QUBE.format(controller="", extra=MEASURED, t_end=1.0, initial=PUSHED)
    scene.write_text(text.replace('name = "qube_servo2"', 'name = "qube_servo2"\nemit = ["c"]'))
    for argv in (
        ["--scene", str(scene), "-o", str(root)],
        ["run", str(scene), "-o", str(root / "run"), "--no-plot"],
    ):
        with redirect_stdout(io.StringIO()), redirect_stderr(io.StringIO()) as err:
            assert run(argv) == 0, err.getvalue()
    return root


def _columns(folder: Path) -> dict[str, np.ndarray]:
    run_ = read_run_csv(folder / "run" / "qube_mpc.csv", phase=False)
    return run_.columns(slice(-1))  # the sampling instants


def _program(
    folder: Path, name: str, source: str, scalar: str = "double", flags: tuple[str, ...] = ()
) -> Path:
    (folder / f"{name}.c").write_text(source.replace("P_", f"{P}_"))
    extra = [*(FLOAT_WARNINGS if scalar == "float" else ()), *flags]
    command = [CC, "-std=c99", "-O1", *WARNINGS, *extra, f"-I{folder}", str(folder / f"{name}.c")]
    result = subprocess.run([*command, "-o", str(folder / name), "-lm"], capture_output=True, text=True)
    assert result.returncode == 0, result.stderr[:3000]
    return folder / name


def _counts(columns: dict[str, np.ndarray], zero: tuple[float, float]) -> np.ndarray:
    """The encoders' counts (2048 a revolution) the simulator's measured y are, counted from `zero`
    (the angles where the counts are 0); asserts that every y is a whole count."""
    step, offset = 2 * math.pi / 2048, np.array(zero)
    y = np.column_stack([columns["y_theta0"], columns["y_theta1"]])
    counts = np.rint((y - offset) / step).astype(int)
    assert np.allclose(offset + counts * step, y, atol=1e-12), "the simulator's y are whole counts"
    return counts


def _run(program: Path, rows: np.ndarray, fmt: str) -> list[list[str]]:
    text = "\n".join(" ".join(fmt.format(v) for v in row) for row in rows.tolist()) + "\n"
    out = subprocess.run([str(program)], input=text, capture_output=True, text=True, check=True).stdout
    return [line.split() for line in out.splitlines()]


def test_a_scene_headers_regenerate_line_names_the_scene(folder: Path) -> None:
    """The header's "regenerate with" is `ipgen --scene S --emit c`, which writes it again with its
    MPC, estimator and loop (before, it named `--type rotary --links 1 ...`, a model-only header)."""
    header = (folder / "qube_servo2.h").read_text()
    command = header.split("regenerate with", 1)[1].split("\n", 2)[1].strip(" *")
    assert command == f"ipgen --scene {(folder / 'qube_mpc.toml').as_posix()} --emit c -o <dir>", command


def test_firmware_step_replays_the_simulators_volts(folder: Path) -> None:
    columns = _columns(folder)
    counts = _counts(columns, (0.0, math.pi))  # the encoders read 0 hanging at rest
    volts = np.array([float(v[0]) for v in _run(_program(folder, "firmware", FIRMWARE), counts, "{:d}")])
    assert np.max(np.abs(volts - columns["u"])) <= 1e-9
    assert np.max(np.abs(columns["u"])) > 6 and np.max(np.abs(volts)) <= U_MAX


@pytest.mark.parametrize("scalar", ["double", "float"])
def test_mpc_step_replays_the_simulators_controller(folder: Path, scalar: str) -> None:
    columns = _columns(folder)
    estimate = np.column_stack([columns[f"hat_{n}"] for n in ("theta0", "theta1", "dtheta0", "dtheta1")])
    out = _run(_program(folder, f"step_{scalar}", STEP, scalar), estimate, "{!r}")
    u = np.array([float(v[0]) for v in out])
    assert all(v[1] == "0" for v in out), "every status ok"
    bound = 1e-9 if scalar == "double" else FLOAT_INPUT
    assert np.max(np.abs(u - columns["u"])) <= bound, np.max(np.abs(u - columns["u"]))
    assert np.max(np.abs(u)) <= U_MAX


def _fast_scene(folder: Path, name: str, controller: str) -> tuple[Path, dict[str, np.ndarray]]:
    """The measured QUBE scene with `controller`'s lines: its C header and the simulator's run."""
    scene = folder / f"{name}.toml"
    text = QUBE.format(controller=controller, extra=MEASURED, t_end=1.0, initial=PUSHED)
    scene.write_text(text.replace('name = "qube_servo2"', f'name = "{name}"\nemit = ["c"]'))
    for argv in (
        ["--scene", str(scene), "-o", str(folder)],
        ["run", str(scene), "-o", str(folder / name), "--no-plot"],
    ):
        with redirect_stdout(io.StringIO()), redirect_stderr(io.StringIO()) as err:
            assert run(argv) == 0, err.getvalue()
    return folder / f"{name}.h", read_run_csv(folder / name / f"{name}.csv", phase=False).columns(slice(-1))


@pytest.fixture(scope="module")
def fast(folder: Path) -> tuple[Path, dict[str, np.ndarray]]:
    """The measured QUBE scene with FAST: its C header and the simulator's run (CSV columns)."""
    return _fast_scene(folder, "qube_fast", FAST)


@pytest.fixture(scope="module")
def shifted(folder: Path) -> tuple[Path, dict[str, np.ndarray]]:
    """The same with two Newton steps a sample on shifted sensitivities (most stages' A, B kept
    from the last sample): the step's only path through RK4 without sensitivities."""
    controller = FAST.replace("qp_iterations = 1", "qp_iterations = 2").replace('"frozen"', '"shifted"')
    return _fast_scene(folder, "qube_shifted", controller)


@pytest.mark.parametrize("scalar", ["double", "float"])
@pytest.mark.parametrize(
    ("scene", "method"), [("fast", "IPGEN_MPC_FROZEN"), ("shifted", "IPGEN_MPC_SHIFTED")]
)
def test_the_microcontrollers_method_replays_the_simulators_controller(
    folder: Path, request: pytest.FixtureRequest, scene: str, method: str, scalar: str
) -> None:
    """The measured QUBE scene with FAST (barrier 1e-3, one Newton step a sample, frozen
    sensitivities) and with two Newton steps on shifted ones: the header's step (its fixed-size
    forms) fed the estimates the simulator's controller saw (the run-time forms) returns its u:
    double 1e-9, float within FLOAT_INPUT."""
    header, columns = request.getfixturevalue(scene)
    assert f"m->sensitivities = {method};" in header.read_text()
    estimate = np.column_stack([columns[f"hat_{n}"] for n in ("theta0", "theta1", "dtheta0", "dtheta1")])
    step = STEP.replace('"qube_servo2.h"', f'"{header.name}"').replace("P_", f"ipgen_{header.stem}_")
    out = _run(_program(folder, f"{header.stem}_{scalar}", step, scalar), estimate, "{!r}")
    u = np.array([float(v[0]) for v in out])
    assert all(v[1] == "0" for v in out), "every status ok"
    bound = 1e-9 if scalar == "double" else FLOAT_INPUT
    assert np.max(np.abs(u - columns["u"])) <= bound, np.max(np.abs(u - columns["u"]))
    assert np.max(np.abs(u)) > 6 and np.max(np.abs(u)) <= U_MAX


def test_the_microcontrollers_method_in_the_firmware_entry(
    folder: Path, fast: tuple[Path, dict[str, np.ndarray]]
) -> None:
    """The same scene's firmware entry (counts in, volts out, its Kalman filter and the fast
    step) fed the simulator's counts returns the simulator's volts, double, 1e-9."""
    header, columns = fast
    counts = _counts(columns, (0.0, math.pi))
    firmware = FIRMWARE.replace('"qube_servo2.h"', f'"{header.name}"').replace("P_", f"ipgen_{header.stem}_")
    volts = np.array([float(v[0]) for v in _run(_program(folder, "fast_firmware", firmware), counts, "{:d}")])
    assert np.max(np.abs(volts - columns["u"])) <= 1e-9


TWO = """\
#include <stdio.h>
#include "qube_servo2.h"
#include "qube_short.h"
/* Two MPC scenes of different horizons in one file: both steps run (status 0 each). */
static ipgen_qube_servo2_mpc_state a;
static ipgen_qube_short_mpc_state b;
int main(void) {
  double x[4] = {0.1, 0.05, 0.0, 0.0};
  double ua, ub;
  ipgen_qube_servo2_mpc_init(&a);
  ipgen_qube_short_mpc_init(&b);
  ua = ipgen_qube_servo2_mpc_step(&a, x);
  ub = ipgen_qube_short_mpc_step(&b, x);
  printf("%d %d %.17g %.17g\\n", a.info.status, b.info.status, ua, ub);
  return 0;
}
"""


def test_two_mpc_scenes_of_other_sizes_in_one_file(folder: Path) -> None:
    """The first header fixes the MPC step's sizes (N = 30): a second scene's header with N = 20
    stops the compile with an #error naming IPGEN_MPC_RUNTIME_SIZES (its step would refuse its
    settings at run time, u = 0); with IPGEN_MPC_RUNTIME_SIZES both steps run."""
    scene = folder / "qube_short.toml"
    text = QUBE.format(controller="horizon = 20\n", extra="", t_end=1.0, initial=PUSHED)
    scene.write_text(text.replace('name = "qube_servo2"', 'name = "qube_short"\nemit = ["c"]'))
    with redirect_stdout(io.StringIO()), redirect_stderr(io.StringIO()) as err:
        assert run(["--scene", str(scene), "-o", str(folder)]) == 0, err.getvalue()
    (folder / "two.c").write_text(TWO)
    command = [CC, "-std=c99", "-O1", *WARNINGS, f"-I{folder}", str(folder / "two.c"), "-lm"]
    fixed = subprocess.run([*command, "-o", str(folder / "two")], capture_output=True, text=True)
    assert fixed.returncode != 0 and "define IPGEN_MPC_RUNTIME_SIZES before including" in fixed.stderr
    runtime = [*command, "-DIPGEN_MPC_RUNTIME_SIZES", "-o", str(folder / "two")]
    built = subprocess.run(runtime, capture_output=True, text=True)
    assert built.returncode == 0, built.stderr[:3000]
    status_a, status_b, ua, ub = subprocess.run(
        [str(folder / "two")], capture_output=True, text=True, check=True
    ).stdout.split()
    assert (status_a, status_b) == ("0", "0") and float(ua) != 0 and float(ub) != 0


@pytest.mark.parametrize("mode", ["rti", "converged", "fast"])
def test_fixed_sizes_with_soft_bounds_are_the_run_time_step(folder: Path, mode: str) -> None:
    """A design with a soft bound (IPGEN_MPC_SOFT = 1, which the QUBE preset has not): the header's
    step with its sizes fixed at compile time (ipgen_mpc.h's fixed-size forms) returns the
    run-time-size step's u (the path ipsim and ipgen.mpc run, checked against IPOPT in
    tests/test_mpc.py) and status to 1e-9 along the simulator's estimates, the pendulum beyond the
    soft bound at first; in the real-time iteration and in the converged mode (its exact Hessian's
    gradient and Riccati factorisation are the run-time forms', the rest the fixed ones); and with
    the microcontroller's method (one barrier Newton step a sample, frozen sensitivities: 1e-8,
    its rounding carried over from sample to sample)."""
    name = f"qube_soft_{mode}"
    scene = folder / f"{name}.toml"
    controller = (
        "soft_bounds = [[1, -0.1, 0.1]]\n"
        + {"rti": "", "converged": 'mode = "converged"\n', "fast": FAST}[mode]
    )
    text = QUBE.format(controller=controller, extra="", t_end=1.0, initial=PUSHED)
    scene.write_text(text.replace('name = "qube_servo2"', f'name = "{name}"\nemit = ["c"]'))
    with redirect_stdout(io.StringIO()), redirect_stderr(io.StringIO()) as err:
        assert run(["--scene", str(scene), "-o", str(folder)]) == 0, err.getvalue()
    assert "#define IPGEN_MPC_SOFT 1" in (folder / f"{name}.h").read_text()
    columns = _columns(folder)
    estimate = np.column_stack([columns[f"hat_{n}"] for n in ("theta0", "theta1", "dtheta0", "dtheta1")])
    assert np.max(np.abs(estimate[:, 1])) > 0.1  # the pendulum beyond the soft bound at first
    step = STEP.replace('"qube_servo2.h"', f'"{name}.h"').replace("P_", f"ipgen_{name}_")
    results, statuses = {}, {}
    for kind, defines in (("fixed", ""), ("runtime", "#define IPGEN_MPC_RUNTIME_SIZES\n")):
        out = _run(_program(folder, f"{name}_{kind}", defines + step), estimate, "{!r}")
        results[kind] = np.array([float(v[0]) for v in out])
        statuses[kind] = [v[1] for v in out]
    difference = np.max(np.abs(results["fixed"] - results["runtime"]))
    # fast: one Newton step a sample carries each form's rounding over in t and lam (a QP solved to
    # its tolerance would reset it), so it accumulates along the loop: 2.9e-9 V measured
    assert difference <= (1e-8 if mode == "fast" else 1e-9), difference
    # The same statuses: mostly ok, a few QPs at their iteration budget (the soft bound is tight).
    assert statuses["fixed"] == statuses["runtime"]
    assert statuses["fixed"].count("0") > 0.9 * len(estimate)
    assert np.max(np.abs(results["fixed"])) > 1


def _replay_swing_up(
    folder: Path,
    name: str,
    changes: tuple[tuple[str, str], ...] = (),
    delay: int = 0,
    firmware: str = FIRMWARE,
    flags: tuple[str, ...] = (),
) -> tuple[list[str], str]:
    """The preset `name` (scenes/rigs) with emit = ["c"] and the text `changes` made: its firmware
    entry fed the simulator's counts returns the simulator's volts at every sample (`delay`
    samples later: what it sends now acts then), in double to 1e-9 (`firmware`: the program, given
    the counts of a sample per line; `flags`: more compiler flags). Returns the phase at each
    sample and the simulator's summary."""
    preset = Path(__file__).resolve().parents[1] / "scenes" / "rigs" / f"{name}.toml"
    text = preset.read_text().replace(f'name = "{name}"', f'name = "{name}"\nemit = ["c"]')
    for old, new in changes:
        assert old in text, old
        text = text.replace(old, new)
    scene = folder / f"{name}.toml"
    scene.write_text(text)
    for argv in (
        ["--scene", str(scene), "-o", str(folder)],
        ["run", str(scene), "-o", str(folder / "run"), "--no-plot"],
    ):
        with redirect_stdout(io.StringIO()) as out, redirect_stderr(io.StringIO()) as err:
            assert run(argv) == 0, err.getvalue()
    run_ = read_run_csv(folder / "run" / f"{name}.csv", phase=True)
    phase = run_.phase[:-1]  # the sampling instants
    columns = run_.columns(slice(-1))
    counts = _counts(columns, (0.0, math.pi))  # the encoders read 0 hanging at rest
    source = firmware.replace('"qube_servo2.h"', f'"{name}.h"').replace("P_", f"ipgen_{name}_")
    program = _program(folder, "swingup_firmware", source, flags=flags)
    volts = np.array([float(v[0]) for v in _run(program, counts, "{:d}")])
    applied = columns["u"]
    assert np.all(applied[:delay] == 0.0)  # nothing has arrived yet
    volts, applied = volts[: len(volts) - delay], applied[delay:]
    assert np.max(np.abs(volts - applied)) <= 1e-9, np.max(np.abs(volts - applied))
    assert np.max(np.abs(volts)) <= U_MAX
    return phase, out.getvalue()


def test_swing_up_caught_by_the_mpc_replays_the_simulators_volts(tmp_path: Path) -> None:
    """The preset qube_servo2_mpc_swingup with emit = ["c"]: the firmware entry (energy law at
    1 kHz, then the MPC step every 10th sample from the catch on, its u held in between, all in
    ipgen_loop.h's swing-up with a catch law) fed the simulator's counts returns the voltage the
    simulator applied at every sample of the swing, the catch and the hold, in double to 1e-9."""
    require_toolchain()
    require_cc()
    phase, _ = _replay_swing_up(tmp_path, "qube_servo2_mpc_swingup")
    assert "swing" in phase and "hold" in phase, "the run swings and is caught"


@pytest.mark.parametrize("flag", ["-ffast-math", "-ffinite-math-only"])
def test_the_firmware_refuses_finite_math_unless_told(tmp_path: Path, flag: str) -> None:
    """Under -ffast-math the loop's checks for NaN fold away: with the m4f preset's EKF forced to
    NaN, its step sent 10 V instead of 0 (a clang and gcc audit). Each runtime (the loop's, the
    MPC's) now refuses the flag in an #error naming the fix, said once in a header that prints
    both, and compiles when the caller defines IPGEN_ALLOW_FINITE_MATH."""
    require_cc()
    m4f = Path(__file__).resolve().parents[1] / "scenes" / "rigs" / "qube_servo2_mpc_swingup_m4f.toml"
    with redirect_stdout(io.StringIO()), redirect_stderr(io.StringIO()) as err:
        assert run(["--scene", str(m4f), "--emit", "c", "-o", str(tmp_path)]) == 0, err.getvalue()
    include = Path(__file__).resolve().parents[1] / "cpp" / "include"
    sources = {
        "firmware": GLITCH,
        "loop": '#include "ipgen_loop.h"\nint main(void) { return 0; }\n',
        "mpc": '#include "ipgen_mpc.h"\nint main(void) { return 0; }\n',
    }
    for name, source in sources.items():
        (tmp_path / f"{name}.c").write_text(source)
        command = [
            CC,
            "-std=c99",
            "-O1",
            *WARNINGS,
            flag,
            f"-I{tmp_path}",
            f"-I{include}",
            str(tmp_path / f"{name}.c"),
        ]
        refused = subprocess.run(
            [*command, "-o", str(tmp_path / name), "-lm"], capture_output=True, text=True
        )
        assert refused.returncode != 0, (name, refused.stderr)
        assert "or define IPGEN_ALLOW_FINITE_MATH to accept that" in refused.stderr, (name, refused.stderr)
        assert refused.stderr.count("error: #error") == 1, (name, refused.stderr)  # said once
        told = subprocess.run(
            [*command, "-DIPGEN_ALLOW_FINITE_MATH", "-o", str(tmp_path / name), "-lm"],
            capture_output=True,
            text=True,
        )
        assert told.returncode == 0, (name, told.stderr[:3000])


LONG_RUNNING = """\
#include <limits.h>
#include <stdio.h>
#include "qube_servo2.h"
/* FIRMWARE with its sample counters moved on at sample AT to 3 short of LONG_MAX (the catch's
 * sample with them), as on a rig that has run for good; or (CLOCK) its swing-up's k set each
 * sample from a clock that passes IPGEN_LOOP_COUNT_CAP at sample AT: what it sends must not
 * change. */
static P_loop_state s;
int main(void) {
  long counts[2], k = 0;
  P_loop_init(&s);
  while (scanf("%ld %ld", &counts[0], &counts[1]) == 2) {
#ifdef CLOCK /* the swing-up's k set from a clock each sample (as ipgen's simulator sets it) */
    s.swingup.loop.k = k + ((1L << 30) - AT); /* past IPGEN_LOOP_COUNT_CAP from sample AT on */
    ++k;
#else
    if (k++ == AT) {
      const long jump = LONG_MAX - 3 - s.swingup.loop.k;
      s.swingup.loop.k += jump;
      s.swingup.loop.hold_sample += jump;
      s.estimator.k = LONG_MAX - 3;
    }
#endif
    printf("%.17g\\n", (double)P_step(&s, counts));
  }
  return 0;
}
"""


@pytest.mark.parametrize(("at", "clock"), [(1, False), (1700, False), (1700, True)])
def test_the_firmware_runs_on_past_its_counters_range(tmp_path: Path, at: int, clock: bool) -> None:
    """The firmware's sample counters (longs) overflowed after 2^31 samples on a 32-bit target
    (24.8 days at 1 kHz; undefined behaviour, and the estimator restarted where one wrapped to 0).
    Moved on to 3 short of LONG_MAX in the swing (sample 1) or in the MPC's hold (sample 1700: the
    cadence of its step every 10th sample kept), the entry still returns the simulator's volts at
    every sample, compiled with -fsanitize=signed-integer-overflow (any overflow ends the run).
    So it does with the swing-up's k set each sample from a clock past the cap, as the simulator
    sets it: the move back keeps k's residue modulo the MPC's period (a review's case)."""
    require_toolchain()
    require_cc()
    source = LONG_RUNNING.replace("AT)", f"{at})")
    source = ("#define CLOCK\n" if clock else "") + source
    flags = ("-fsanitize=signed-integer-overflow", "-fno-sanitize-recover=all")
    phase, _ = _replay_swing_up(tmp_path, "qube_servo2_mpc_swingup", firmware=source, flags=flags)
    assert phase[at] == ("swing" if at == 1 else "hold"), phase[at]
    assert "#define IPGEN_LOOP_COUNT_CAP 1073741824L" in (tmp_path / "qube_servo2_mpc_swingup.h").read_text()


def test_a_released_hold_swings_again_in_the_firmware_as_in_the_simulator(tmp_path: Path) -> None:
    """The preset qube_servo2_mpc_swingup_ekf (EKF, release_angle) knocked off upright by a pulse on
    the arm 2 s in: the hold gives the link back to the energy law, which swings it up for a second
    catch, the MPC cold again. The firmware entry (its EKF, the release, the MPC's reset) fed the
    simulator's counts returns its volts at every sample, in double to 1e-9."""
    require_toolchain()
    require_cc()
    pulse = ("km = 0.042                    # V s/rad\n", "km = 0.042\npulses = [[2.0, 0.05, 0.05]]\n")
    phase, summary = _replay_swing_up(tmp_path, "qube_servo2_mpc_swingup_ekf", (pulse,))
    held = [i for i, p in enumerate(phase) if p == "hold"]
    assert held and "swing" in phase[held[0] :], "caught, released, swung again"
    assert phase[-1] == "hold", "caught again"
    assert "(the hold released the link back to the swing 1 time)" in summary


def test_a_predicted_delay_in_the_firmware_replays_the_simulators_volts(tmp_path: Path) -> None:
    """The preset qube_servo2_mpc_swingup_delay (20 ms of delay, [estimator] predict): the
    firmware entry carries its EKF's estimate over the delay with the commands in flight
    (ipgen_loop_predict) before the energy law, the catch and the MPC, as the simulator does: its
    volts at every sample, in double to 1e-9. Without the prediction the swing stalls (below)."""
    require_toolchain()
    require_cc()
    phase, summary = _replay_swing_up(tmp_path, "qube_servo2_mpc_swingup_delay", delay=20)
    assert "swing" in phase and phase[-1] == "hold", "the run swings and is caught"
    assert "predicted over the delay" in summary
    plain = (("predict = true", ""),)
    (tmp_path / "plain").mkdir()
    stalled, _ = _replay_swing_up(tmp_path / "plain", "qube_servo2_mpc_swingup_delay", plain, delay=20)
    assert "hold" not in stalled, "without predict the 20 ms delay stalls the swing"


def test_firmware_in_the_rigs_coordinates_replays_the_simulators_volts(tmp_path: Path) -> None:
    """The QUBE in Quanser's convention (positive = counterclockwise, zero = hanging) with encoders
    + Kalman filter: the firmware entry estimates in the rig's coordinates, maps the estimate to
    ipgen's (ipgen_NAME_to_canonical) for the MPC step, and fed the simulator's counts returns its
    volts at every sample, in double to 1e-9."""
    require_toolchain()
    require_cc()
    quanser = 'name = "qube_servo2"\nemit = ["c"]\npositive = "counterclockwise"\nzero = "hanging"'
    initial = f"theta = [0.3, {math.pi - 0.15!r}]\ndtheta = [1.0, 0]"  # PUSHED, in the rig's angles
    text = QUBE.format(controller="", extra=MEASURED, t_end=1.0, initial=initial)
    scene = tmp_path / "qube_mpc.toml"
    scene.write_text(text.replace('name = "qube_servo2"', quanser))
    for argv in (
        ["--scene", str(scene), "-o", str(tmp_path)],
        ["run", str(scene), "-o", str(tmp_path / "run"), "--no-plot"],
    ):
        with redirect_stdout(io.StringIO()), redirect_stderr(io.StringIO()) as err:
            assert run(argv) == 0, err.getvalue()
    columns = _columns(tmp_path)
    counts = _counts(columns, (0.0, 0.0))  # hanging at rest is 0 in this convention
    volts = np.array([float(v[0]) for v in _run(_program(tmp_path, "firmware", FIRMWARE), counts, "{:d}")])
    assert np.max(np.abs(volts - columns["u"])) <= 1e-9, np.max(np.abs(volts - columns["u"]))
    assert np.max(np.abs(columns["u"])) > 6


TRACKER = """\
#include <stdio.h>
#include "NAME.h"
/* Reads the state at a sample per line (2 DOF numbers), prints the swing-up's u and its phase. */
static P_swingup_state s;
int main(void) {
  double x[2 * DOF];
  IPGEN_SCALAR q[DOF], qd[DOF];
  int i, ok = 1;
  P_swingup_init(&s);
  while (ok) {
    for (i = 0; i < 2 * DOF && ok; ++i) ok = scanf("%lf", &x[i]) == 1;
    if (!ok) break;
    for (i = 0; i < DOF; ++i) {
      q[i] = (IPGEN_SCALAR)x[i];
      qd[i] = (IPGEN_SCALAR)x[DOF + i];
    }
    printf("%.17g %d\\n", (double)P_swingup(&s, q, qd, 0, 0), s.loop.phase); /* p, links: energy law only */
  }
  return 0;
}
"""

# The QUBE-Servo 2 in volts (its DC motor folded in: the simulator tracks in N m, the header in
# volts) swung up by its MPC along a plan within ±1.5 rad of arm travel.
QUBE_TRACK = """\
[system]
type = "rotary"
links = 1
name = "qube_track"
emit = ["c"]

[parameters]
m = [0.095, 0.024]
l = [0.085, 0.129]
J = [5.7197916666666667e-05, 3.3282e-05]
delta = [5e-6, 1e-6]

[actuator]
kind = "dc_motor"
Rm = 8.4
kt = 0.042
km = 0.042

[limits]
travel = 2.0

[swingup]
method = "trajectory"
tracking = "mpc"
u_max = 10
x_max = 1.5
duration = 1.5
period = 0.01
hold = 2

[controller]
kind = "mpc"
q = [1, 10, 0.1, 0.1]
r = 0.1
u_max = 10
period = 0.02
horizon = 30

[simulation]
t_end = 3.5
"""


@pytest.mark.parametrize(
    ("name", "dof", "u_max", "float_bound"),
    [("cdip_mpc_track", 3, 50.0, 2e-3), ("qube_track", 2, 10.0, 1e-2)],
    ids=["cart", "qube-volts"],
)
def test_a_plan_tracked_by_the_mpc_replays_the_simulators_inputs(
    tmp_path: Path, name: str, dof: int, u_max: float, float_bound: float
) -> None:
    """A plan tracked by the MPC in the header (ipgen_loop.h's track law: the plan's reference per
    stage from its tables, ipgen_mpc_track every second sample in the fixed-size forms, then the
    MPC's hold), fed the simulator's states at its samples, returns the input the simulator
    applied (its run-time step) at every sample: double 1e-9, float within float_bound u_max (the
    plan's tables in float too). The cart (scenes/cdip_mpc_track.toml: 6e-13 and 0.07 N of 50
    measured) and the QUBE in volts (the simulator tracks in N m, the header in volts: 5e-15 and
    0.047 V of 10 measured)."""
    require_toolchain()
    require_cc()
    scene = tmp_path / f"{name}.toml"
    if name == "qube_track":
        scene.write_text(QUBE_TRACK)
    else:
        preset = Path(__file__).resolve().parents[1] / "scenes" / f"{name}.toml"
        line = f'name = "{name}"'
        scene.write_text(preset.read_text().replace(line, line + '\nemit = ["c"]'))
    for argv in (
        ["--scene", str(scene), "-o", str(tmp_path)],
        ["run", str(scene), "-o", str(tmp_path / "run"), "--no-plot"],
    ):
        with redirect_stdout(io.StringIO()), redirect_stderr(io.StringIO()) as err:
            assert run(argv) == 0, err.getvalue()
    run_ = read_run_csv(tmp_path / "run" / f"{name}.csv", phase=True)
    column = run_.columns(slice(-1))  # the sampling instants
    state_names = [f"theta{i}" for i in range(dof)] + [f"dtheta{i}" for i in range(dof)]
    states = np.column_stack([column[n] for n in state_names])
    source = TRACKER.replace("NAME", name).replace("P_", f"ipgen_{name}_").replace("DOF", str(dof))
    for scalar, bound in (("double", 1e-9), ("float", float_bound * u_max)):
        out = _run(_program(tmp_path, f"track_{scalar}", source, scalar), states, "{!r}")
        inputs, phases = np.array([float(v[0]) for v in out]), [int(v[1]) for v in out]
        assert np.max(np.abs(inputs - column["u"])) <= bound, (scalar, np.max(np.abs(inputs - column["u"])))
        assert phases[0] == 1 and phases[-1] == 2  # IPGEN_LOOP_TRACK, then IPGEN_LOOP_HOLD
    assert np.max(np.abs(column["u"])) > 0.9 * u_max
    # the header is C++17 too, without a warning (the QUBE's MPC has no hard state bound: its
    # fixed count 0 must not reach a division)
    program = tmp_path / "track_cpp"
    program.with_suffix(".cpp").write_text(source)
    command = [CXX, "-std=c++17", "-O1", *WARNINGS, f"-I{tmp_path}", str(program.with_suffix(".cpp"))]
    result = subprocess.run([*command, "-o", str(program)], capture_output=True, text=True)
    assert result.returncode == 0, result.stderr[:3000]


INIT_ON_GARBAGE = """\
#include <stdio.h>
#include <string.h>
#include "qube_servo2.h"
/* The loop state on memory that held anything (0xA5 bytes), initialised: what the MPC reports. */
static P_loop_state s;
int main(void) {
  memset(&s, 0xA5, sizeof s);
  P_loop_init(&s);
  printf("%d %d %d %g %g %g\\n", s.mpc.info.status, s.mpc.info.sqp_iterations, s.mpc.info.qp_iterations,
         (double)s.mpc.info.step, (double)s.mpc.info.defect, (double)s.mpc.info.qp_residual);
  return 0;
}
"""


def test_the_loops_init_leaves_no_garbage_in_the_mpcs_report(folder: Path) -> None:
    """The firmware's init set the MPC's workspace and not its info: read before the first MPC
    step (a catch not yet made), it held whatever the memory held (a firmware audit: 0xA5...)."""
    out = _run(_program(folder, "init_on_garbage", INIT_ON_GARBAGE), np.zeros((0, 1)), "{}")
    assert out == [["0", "0", "0", "0", "0", "0"]], out


GLITCH = """\
#include <stdio.h>
#include <stdlib.h>
#include "qube_servo2_mpc_swingup_m4f.h"
/* Hanging at rest, one glitch of 2^POWER counts on encoder CHANNEL at sample 200: how many of the
 * 3000 commands are not numbers, and the largest |u| of the others. */
static ipgen_qube_servo2_mpc_swingup_m4f_loop_state s;
int main(int argc, char **argv) {
  long counts[2];
  int channel = atoi(argv[1]), power = atoi(argv[2]), k, nan = 0;
  double largest = 0;
  (void)argc;
  ipgen_qube_servo2_mpc_swingup_m4f_loop_init(&s);
  for (k = 0; k < 3000; ++k) {
    double u;
    counts[0] = counts[1] = 0;
    if (k == 200) counts[channel] = 1L << power;
    u = (double)ipgen_qube_servo2_mpc_swingup_m4f_step(&s, counts);
    if (u != u) ++nan; else if (fabs(u) > largest) largest = fabs(u);
  }
  printf("%d %.17g\\n", nan, largest);
  return 0;
}
"""


def test_the_firmware_never_sends_nan_whatever_a_glitch_reads(tmp_path: Path) -> None:
    """One absurd reading (a glitch of 2^23 counts or more on the pendulum's encoder) threw the
    m4f preset's EKF off for good, and its firmware sent NaN volts to the drive from then on (a
    firmware audit: 2,797 of 2,800 samples). Its command now stays a number within the limit (0
    while the loop's state is not finite)."""
    m4f = Path(__file__).resolve().parents[1] / "scenes" / "rigs" / "qube_servo2_mpc_swingup_m4f.toml"
    with redirect_stdout(io.StringIO()), redirect_stderr(io.StringIO()) as err:
        assert run(["--scene", str(m4f), "--emit", "c", "-o", str(tmp_path)]) == 0, err.getvalue()
    program = _program(tmp_path, "glitch", GLITCH)
    for channel in ("0", "1"):
        for power in ("23", "30", "40", "62"):
            done = subprocess.run([str(program), channel, power], capture_output=True, text=True, check=True)
            nan, largest = done.stdout.split()
            assert nan == "0" and float(largest) <= U_MAX, (channel, power, done.stdout)
