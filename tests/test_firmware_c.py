"""The whole loop as firmware (issue 33): the C header's `ipgen_<name>_step(state, counts)` of the
QUBE-Servo 2 swing-up preset (scenes/rigs/qube_servo2_swingup.toml: 2048-count encoders, the
derivative filter, energy swing-up, catch and LQR hold, volts at 1 kHz).

- Replay, double: fed the encoder counts of the simulator's own run (its y_* columns), `step`
  returns the voltage the simulator applied at every sample (1e-9 of 10 V) and ends in the hold.
- Closed loop, float: `step` compiled with IPGEN_SCALAR=float (C99, -Wdouble-promotion
  -Wconversion -Werror) drives a plant integrated in double in another translation unit (RK4,
  ten substeps per millisecond, the same header's forward dynamics) through quantised counts;
  it swings up, catches and holds within 10 V, as the simulator's run does.
- The loop runtime: the header carries cpp/include/ipgen_loop.h whole and wraps it; it compiles
  as C++17 too, and two loop headers share one translation unit (C99 and C++17).
"""

from __future__ import annotations

import io
import math
import subprocess
from contextlib import redirect_stderr, redirect_stdout
from pathlib import Path

import numpy as np
import pytest
from c_models import CC, FLOAT_WARNINGS, WARNINGS, require_cc
from cxx import CXX, require_toolchain
from run_csv import read_run_csv

from ipgen.command.cli import run

ROOT = Path(__file__).resolve().parent.parent
PRESET = ROOT / "scenes" / "rigs" / "qube_servo2_swingup.toml"
NAME = "qube_servo2_swingup"
P = f"ipgen_{NAME}"
U_MAX = 10.0  # V

REPLAY = """\
#include <stdio.h>
#include "NAME.h"
/* Reads counts per line, prints the voltage step returns and the swing-up's phase. */
int main(void) {
  P_loop_state s;
  long counts[2];
  P_loop_init(&s);
  while (scanf("%ld %ld", &counts[0], &counts[1]) == 2) {
    double u = P_step(&s, counts);
    printf("%.17g %d\\n", u, s.swingup.phase);
  }
  return 0;
}
"""

FIRMWARE = """\
#define IPGEN_SCALAR float
#include "NAME.h"
/* The firmware's side of the loop, in float: its state and one sample. */
static P_loop_state state;
void firmware_init(void) { P_loop_init(&state); }
float firmware_step(const long counts[]) { return P_step(&state, counts); }
int firmware_phase(void) { return state.swingup.phase; }
"""

PLANT = """\
#include <math.h>
#include <stdio.h>
#include "NAME.h"
void firmware_init(void);
float firmware_step(const long counts[]);
int firmware_phase(void);

/* x' of the rig in its own coordinates (q, qd) with the motor voltage V held. */
static void rates(const double x[4], double volts, double dx[4]) {
  const P_dc_motor motor = {8.4, 0.042, 0.042, 1.0, 1.0, 1.0, 0.0};
  double qdd[2];
  P_forward_dynamics_built(x, x + 2, P_motor_gain(&motor) * volts, &P_loop_params, &P_loop_links, qdd);
  dx[0] = x[2]; dx[1] = x[3]; dx[2] = qdd[0]; dx[3] = qdd[1];
}

int main(void) {
  double x[4] = {0.0, -3.141592653589793, 0.0, 0.0}; /* hanging at rest, the encoders reset here */
  double worst = 0.0, caught = -1.0;
  const int substeps = 10;
  const double T = 0.001, h = T / substeps;
  long k, counts[2];
  int i, j;
  firmware_init();
  for (k = 0; k < 10000; ++k) {
    double volts;
    for (i = 0; i < 2; ++i) counts[i] = lround((x[i] - P_count_zero[i]) / P_count_step[i]);
    volts = (double)firmware_step(counts);
    if (fabs(volts) > worst) worst = fabs(volts);
    if (caught < 0 && firmware_phase() == 2) caught = (double)k * T;
    for (j = 0; j < substeps; ++j) { /* RK4 */
      double k1[4], k2[4], k3[4], k4[4], y[4];
      rates(x, volts, k1);
      for (i = 0; i < 4; ++i) y[i] = x[i] + 0.5 * h * k1[i];
      rates(y, volts, k2);
      for (i = 0; i < 4; ++i) y[i] = x[i] + 0.5 * h * k2[i];
      rates(y, volts, k3);
      for (i = 0; i < 4; ++i) y[i] = x[i] + h * k3[i];
      rates(y, volts, k4);
      for (i = 0; i < 4; ++i) x[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
    }
  }
  printf("%.17g %.17g %.17g %.17g %.17g %.17g\\n", x[0], x[1], x[2], x[3], worst, caught);
  return 0;
}
"""


def _source(text: str) -> str:
    return text.replace("NAME", NAME).replace("P_", f"{P}_")


@pytest.fixture(scope="module")
def folder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The preset's C header (--emit c) and the simulator's run of the preset (CSV)."""
    require_toolchain()
    require_cc()
    root = tmp_path_factory.mktemp("firmware")
    scene = root / "scene.toml"
    # release_angle: the header's release with the hold LQR compiles (-Werror) and, never reached
    # here (the hold keeps the link within 1.2 rad), changes nothing
    text = PRESET.read_text().replace(f'name = "{NAME}"', f'name = "{NAME}"\nemit = ["c"]')
    scene.write_text(text.replace('method = "energy"\n', 'method = "energy"\nrelease_angle = 1.2\n', 1))
    generate = ["--scene", str(scene), "-o", str(root)]
    for argv in (generate, ["run", str(scene), "-o", str(root / "run"), "--no-plot"]):
        with redirect_stdout(io.StringIO()), redirect_stderr(io.StringIO()) as err:
            assert run(argv) == 0, err.getvalue()
    return root


def _csv(path: Path) -> dict[str, np.ndarray]:
    run_ = read_run_csv(path, phase=True)
    return {**run_.columns(), "phase": np.array(run_.phase)}


def _compile(command: list[str]) -> None:
    result = subprocess.run(command, capture_output=True, text=True)
    assert result.returncode == 0, result.stderr[:3000]


def test_step_replays_the_simulators_voltages(folder: Path) -> None:
    run_ = _csv(folder / "run" / "scene.csv")
    step = 2 * math.pi / 2048
    zero = np.array([0.0, -math.pi])  # the rig at rest: arm centred, pendulum hanging (Quanser's α)
    y = np.column_stack([run_["y_theta0"], run_["y_theta1"]])
    counts = np.rint((y - zero) / step).astype(int)
    assert np.allclose(zero + counts * step, y, atol=1e-12), "the simulator's y are whole counts"
    (folder / "replay.c").write_text(_source(REPLAY))
    program = folder / "replay"
    flags = [CC, "-std=c99", "-O1", *WARNINGS, f"-I{folder}"]
    _compile([*flags, str(folder / "replay.c"), "-o", str(program), "-lm"])
    text = "\n".join(f"{a} {b}" for a, b in counts.tolist()) + "\n"
    out = subprocess.run([str(program)], input=text, capture_output=True, text=True, check=True).stdout
    volts, phases = zip(*(line.split() for line in out.splitlines()), strict=True)
    volts_c = np.array([float(v) for v in volts])
    samples = len(volts_c) - 1  # the last row repeats the command held at the end
    assert np.max(np.abs(volts_c[:samples] - run_["u"][:samples])) <= 1e-9 * U_MAX
    assert int(phases[-1]) == 2 and run_["phase"][-1] == "hold"
    assert "release_angle = 1.2" in (folder / "scene.toml").read_text()
    assert "1.2, /* release_angle" in (folder / f"{NAME}.h").read_text()


def test_float_firmware_swings_up_and_holds_a_double_plant(folder: Path) -> None:
    (folder / "firmware.c").write_text(_source(FIRMWARE))
    (folder / "plant.c").write_text(_source(PLANT))
    objects = folder / "firmware.o"
    base = [CC, "-std=c99", "-O1", *WARNINGS, f"-I{folder}"]
    _compile([*base, *FLOAT_WARNINGS[1:], "-c", str(folder / "firmware.c"), "-o", str(objects)])
    program = folder / "plant"
    _compile([*base, str(folder / "plant.c"), str(objects), "-o", str(program), "-lm"])
    out = subprocess.run([str(program)], capture_output=True, text=True, check=True).stdout
    arm, link, arm_rate, link_rate, worst, caught = (float(v) for v in out.split())
    upright = link - 2 * math.pi * round(link / (2 * math.pi))
    simulated = _csv(folder / "run" / "scene.csv")
    caught_simulated = float(simulated["t"][np.argmax(simulated["phase"] == "hold")])
    assert 0 < caught < 3.0 and 0 < caught_simulated < 3.0, (caught, caught_simulated)
    assert abs(upright) < 0.02 and abs(link_rate) < 0.5 and abs(arm_rate) < 0.5, out
    assert abs(arm) < 1.0 and worst <= U_MAX, out


CART = """\
[system]
type = "classical"
links = 1
name = "cart_fw"
emit = ["c"]
[parameters]
m = [0.57, 0.23]
l = [0, 0.6413]
delta = [4.3, 0.0024]
[initial]
theta = [0.1, 0.02]
[controller]
kind = "lqr"
q = [10, 10, 1, 1]
r = 0.1
period = 0.002
saturation = 20
[sensors]
resolution = [40000, 4096]   # counts per metre (the cart), per revolution (the pendulum)
[estimator]
kind = "kalman"
[simulation]
t_end = 0.1
"""

CART_DRIVER = """\
#define IPGEN_SCALAR float
#include <stdio.h>
#include "cart_fw.h"
int main(void) {
  ipgen_cart_fw_loop_state s;
  long counts[2] = {COUNTS}; /* from the encoders' zero pose */
  float u;
  ipgen_cart_fw_loop_init(&s);
  u = ipgen_cart_fw_step(&s, counts);
  printf("%.9g %.9g %.9g\\n", (double)u, (double)s.estimator.x[0], (double)s.estimator.x[1]);
  return 0;
}
"""


@pytest.mark.parametrize(
    ("zero", "counts", "pose"),
    [
        # default: the rig at rest (issue 49) — the cart centred, the pendulum hanging (π); 4000
        # counts = 0.1 m, −2048 counts = half a turn back to upright
        ("", "4000, -2048", (0.1, 0.0)),
        # [sensors] zero: the encoders reset elsewhere (here the scene's initial pose)
        ("zero = [0.1, 0.02]\n", "4000, 0", (0.2, 0.02)),
    ],
)
def test_a_carts_counts_are_per_metre_and_its_step_compiles_in_float(
    tmp_path: Path, zero: str, counts: str, pose: tuple[float, float]
) -> None:
    """A cart's coordinate 0 counts per metre (Δ = 1/resolution m), a link's per revolution
    (Δ = 2π/resolution rad), both from the encoders' zero pose ([sensors] zero; default the rig at
    rest, as on main 1302ddc it was the scene's initial pose); the balance loop's `step` compiles in
    float with -Werror and estimates the pose its counts say (Kalman first sample: the measured
    coordinates as measured)."""
    require_cc()
    scene = tmp_path / "cart.toml"
    scene.write_text(CART.replace("[sensors]\n", f"[sensors]\n{zero}"))
    with redirect_stdout(io.StringIO()), redirect_stderr(io.StringIO()) as err:
        assert run(["--scene", str(scene), "-o", str(tmp_path)]) == 0, err.getvalue()
    (tmp_path / "driver.c").write_text(CART_DRIVER.replace("{COUNTS}", "{" + counts + "}"))
    program = tmp_path / "driver"
    flags = [CC, "-std=c99", "-O1", *WARNINGS, *FLOAT_WARNINGS[1:], f"-I{tmp_path}"]
    _compile([*flags, str(tmp_path / "driver.c"), "-o", str(program), "-lm"])
    out = subprocess.run([str(program)], capture_output=True, text=True, check=True).stdout
    u, x, theta = (float(v) for v in out.split())
    assert x == pytest.approx(pose[0], abs=1e-6) and theta == pytest.approx(pose[1], abs=1e-5)
    assert math.isfinite(u) and abs(u) <= 20.0


def test_the_firmwares_encoder_zero_is_the_rig_at_rest(tmp_path: Path) -> None:
    """Issue 49: on main 1302ddc the QUBE firmware's count_zero was the scene's initial pose,
    {0, 0.1}: encoders zeroed at a 0.1 rad tilt. A rig's encoders are reset where it rests when
    powered: the arm centred, the pendulum hanging (−π in Quanser's α); [sensors] zero moves it."""
    preset = Path(__file__).resolve().parents[1] / "scenes" / "rigs" / "qube_servo2_sensors.toml"
    scene = preset.read_text().replace('emit = ["cpp"]', 'emit = ["c"]')
    cases = (("rest", "", (0.0, -math.pi)), ("moved", "zero = [0.5, 0.25]\n", (0.5, 0.25)))
    for name, extra, expected in cases:
        path = tmp_path / f"{name}.toml"
        path.write_text(scene.replace("[sensors]\n", f"[sensors]\n{extra}"))
        with redirect_stdout(io.StringIO()), redirect_stderr(io.StringIO()) as err:
            assert run(["--scene", str(path), "-o", str(tmp_path / name)]) == 0, err.getvalue()
        header = (tmp_path / name / "qube_servo2.h").read_text()
        line = next(text for text in header.splitlines() if "_count_zero[" in text and "=" in text)
        entries = line.split("{")[1].split("}")[0].split(",")
        values = [float(v.replace("(IPGEN_SCALAR)", "").strip().rstrip("f")) for v in entries]
        assert values == pytest.approx(expected, abs=1e-12), line
        # the firmware entry of a motor's LQR loop says it returns volts (it said "the units of u")
        assert "command to send (the motor voltage [V])" in header


TWO_HEADERS = """\
#include <stdio.h>
#include "cart_fw.h"
#include "NAME.h"
/* Two ipgen headers with a loop in one translation unit: one copy of ipgen_loop.h is compiled. */
int main(void) {
  ipgen_cart_fw_loop_state cart;
  P_loop_state qube;
  const long counts[2] = {0, 0};
  IPGEN_SCALAR u, v;
  ipgen_cart_fw_loop_init(&cart);
  P_loop_init(&qube);
  u = ipgen_cart_fw_step(&cart, counts);
  v = P_step(&qube, counts);
  printf("%.9g %.9g\\n", (double)u, (double)v);
  return 0;
}
"""


def test_the_header_carries_the_loop_runtime_and_compiles_as_cpp(folder: Path, tmp_path: Path) -> None:
    """Issue 45: the estimator, the swing-up and the loop steps are cpp/include/ipgen_loop.h's
    functions, printed whole into the header (one file to drop into firmware) and called with the
    header's constants. The header compiles as C++17 as well (-Wall -Wextra -Wpedantic -Werror),
    and with another loop header in one translation unit (the runtime's include guard), in C99
    (double; float with -Wdouble-promotion -Wconversion) and C++17."""
    header = (folder / f"{NAME}.h").read_text()
    runtime = (ROOT / "cpp" / "include" / "ipgen_loop.h").read_text()
    assert runtime.rstrip("\n") in header, "ipgen_loop.h is printed whole"
    assert header.count("#define IPGEN_LOOP_H_INCLUDED") == 1
    for call in ("ipgen_loop_filter(", "ipgen_loop_swingup_step(&law, s, x, work)", "ipgen_loop_delay("):
        assert call in header, call
    scene = tmp_path / "cart.toml"
    scene.write_text(CART)
    with redirect_stdout(io.StringIO()), redirect_stderr(io.StringIO()) as err:
        assert run(["--scene", str(scene), "-o", str(tmp_path)]) == 0, err.getvalue()
    (tmp_path / f"{NAME}.h").write_text(header)
    source = tmp_path / "two.c"
    source.write_text(_source(TWO_HEADERS))
    cpp = [CXX, "-x", "c++", "-std=c++17", "-O1", *WARNINGS]
    c = [CC, "-std=c99", "-O1", *WARNINGS]
    builds = {
        "c-double": c,
        "c-float": [*c, *FLOAT_WARNINGS],
        "cpp-double": cpp,
        "cpp-float": [*cpp, "-DIPGEN_SCALAR=float", "-Wconversion"],
    }
    for label, flags in builds.items():
        program = tmp_path / label
        _compile([*flags, f"-I{tmp_path}", str(source), "-o", str(program), "-lm"])
        out = subprocess.run([str(program)], capture_output=True, text=True, check=True).stdout
        u, v = (float(value) for value in out.split())
        assert math.isfinite(u) and abs(u) <= 20.0 and math.isfinite(v) and abs(v) <= U_MAX, (label, u, v)
