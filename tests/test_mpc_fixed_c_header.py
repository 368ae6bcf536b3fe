"""A fixed chain's MPC in its C header (issue 47): `ipgen --scene FIXED.toml -o DIR` writes the
chain's targets (`[system] emit`, default cpp) and the resolved config; with `[controller] kind =
"mpc"` its C header carries `ipgen_NAME_mpc_step` (ipgen_mpc.h printed whole, the design as
constants, the chain's own functions as the model the step predicts with).

- Along the simulator's closed loop (the acrobot of tests/test_mpc_fixed.py in DFKI's coordinates
  balanced by the MPC from a tilt; the pendubot with a geared rotor; the acrobot with the
  microcontroller's method), the header's step fed the simulator's states mapped to ipgen's
  coordinates returns the simulator's torque with DFKI's counterclockwise sign flipped back: double
  to 1e-9, float (every operation single precision) within FLOAT_INPUT (the cold first step
  FLOAT_COLD); compiled with -std=c99
  -Wall -Wextra -Wpedantic -Werror (float: -Wdouble-promotion -Wconversion too).
- The command: its files all or none, nothing overwritten without --force, a bad `[system] emit`
  or `name` one line (hypothesis over the kinds of bad value), the system options refused.
"""

from __future__ import annotations

import io
import math
import re
import shutil
import subprocess
from contextlib import redirect_stderr, redirect_stdout
from pathlib import Path

import numpy as np
import pytest
from c_models import MPC_STEP_PROGRAM, c_command, compile_c, require_cc
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from test_fixed_lqr import CHAIN as LQR_CHAIN
from test_fixed_lqr import CONTROLLER as LQR_CONTROLLER
from test_mpc_fixed import BALANCE, U_MAX, canonical, simulate
from test_mpc_scene import FAST

from ipgen.command.cli import run
from ipgen.common.presets import preset_path
from ipgen.control.fixed_linear import canonical_states
from ipgen.model.fixed import FixedPendulum
from ipgen.pipeline.fixed_generate import FIXED_TARGETS

# Float against the simulator (double) fed the same states. The MPC step: 1e-3 of the torque
# bound, the cart's and the arm's (measured 9e-6 N m; 1.7e-3 N m with the microcontroller's
# method, whose one Newton step a sample carries its rounding over), its cold first step, whose
# iterations stop at float's tolerances, 1e-2 of it (measured 0.016 N m for the pendubot). The LQR
# and the swing-ups: 1e-4 of it (measured 1.2e-5 and 4.5e-5 N m).
FLOAT_INPUT = 1e-3 * U_MAX
FLOAT_LOOP = 1e-4 * U_MAX
FLOAT_COLD = 1e-2 * U_MAX
RIG_KEYS = ("angles", "zero", "positive")  # DFKI's coordinates, in BALANCE
ROTOR = "Ir = [0.001]\ngr = [-6.0]\n"

STEP = MPC_STEP_PROGRAM

# the header's name: (the driven joint, lines added to [actuator], lines added to [controller])
CASES = {
    "acrobot": ("2", "", ""),
    "pendubot_rotor": ("1", ROTOR, ""),  # a geared rotor at the shoulder
    "acrobot_fast": ("2", "", FAST),  # the microcontroller's method
}


def scene_text(joint: str, rotor: str, method: str, name: str) -> str:
    """BALANCE with the driven joint, a rotor and the method; named, emitting the C header."""
    text = BALANCE.format(extra="").replace("joints = [2]\n", f"joints = [{joint}]\n{rotor}")
    text = text.replace("[controller]\n", f"[controller]\n{method}")
    return text.replace('type = "fixed"\n', f'type = "fixed"\nname = "{name}"\nemit = ["c"]\n', 1)


def generate(scene: Path, out: Path, *options: str) -> tuple[int, str]:
    """`ipgen --scene SCENE -o OUT [options]`: (exit status, stderr)."""
    with redirect_stdout(io.StringIO()), redirect_stderr(io.StringIO()) as err:
        status = run(["--scene", str(scene), "-o", str(out), *options])
    return status, err.getvalue()


def describe(scene: Path, *options: str) -> tuple[int, str, str]:
    """`ipgen --scene SCENE --describe [options]`: (exit status, stdout, stderr)."""
    with redirect_stdout(io.StringIO()) as out, redirect_stderr(io.StringIO()) as err:
        status = run(["--scene", str(scene), "--describe", *options])
    return status, out.getvalue(), err.getvalue()


def compiled(folder: Path, name: str, scalar: str, program_text: str = STEP) -> Path:
    """`program_text` (NAME: the header's name) compiled against the header, C99, warnings as errors."""
    source = folder / f"{name}_{scalar}.c"
    source.write_text(program_text.replace("NAME", name))
    program = folder / f"{name}_{scalar}"
    failure = compile_c(c_command(f"-I{folder}", str(source), "-o", str(program), scalar=scalar))
    assert failure is None, failure
    return program


def state_rows(columns: dict[str, np.ndarray]) -> np.ndarray:
    """The simulator's states [q; q̇] a row (its CSV's columns, the rig's coordinates)."""
    return np.column_stack([columns[k] for k in ("theta0", "theta1", "dtheta0", "dtheta1")])


def replay(program: Path, states: np.ndarray) -> list[list[str]]:
    """The program's output line by line (split), fed one state a line."""
    text = "\n".join(" ".join(repr(v) for v in row) for row in states.tolist()) + "\n"
    out = subprocess.run([str(program)], input=text, capture_output=True, text=True, check=True).stdout
    return [line.split() for line in out.splitlines() if line]


@pytest.fixture(scope="module", params=list(CASES))
def loop(request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, str, dict]:
    """A case's header (`ipgen --scene`) and the simulator's run of the same scene."""
    require_cc()
    name = request.param
    joint, rotor, method = CASES[name]
    folder = tmp_path_factory.mktemp("fixed_mpc_c")
    scene = folder / "balance.toml"
    scene.write_text(scene_text(joint, rotor, method, name))
    status, err = generate(scene, folder)
    assert status == 0, err
    columns, _ = simulate(folder, scene.read_text())
    return folder, name, columns


@pytest.mark.parametrize("scalar", ["double", "float"])
def test_the_headers_step_replays_the_simulators_mpc(loop: tuple[Path, str, dict], scalar: str) -> None:
    folder, name, columns = loop
    chain = FixedPendulum.from_scene(folder / "balance.toml")
    rows = state_rows(columns)
    states = canonical(chain, rows)[:-1]  # the sampling instants (sample = the MPC's period)
    steps = replay(compiled(folder, name, scalar), states)
    u = -np.array([float(v[0]) for v in steps])  # ipgen's clockwise -> DFKI's counterclockwise
    assert len(u) == len(states) and all(v[1] == "0" for v in steps), "a step a sample, every status ok"
    error = np.abs(u - columns["u"][:-1])
    if scalar == "double":
        assert np.max(error) <= 1e-9, np.max(error)
    else:
        assert error[0] <= FLOAT_COLD and np.max(error[1:]) <= FLOAT_INPUT, (error[0], np.max(error[1:]))
    assert np.max(np.abs(u)) > 1.0 and np.max(np.abs(u)) <= U_MAX + 1e-12  # a real push, within the bound


def test_the_header_follows_the_simulator_through_a_breakdown(tmp_path: Path) -> None:
    """The pendubot of pendubot_mpc (N = 40, no hard state bound) 0.14 rad off moving at 3 rad/s,
    a start its first QPs break down from (status 4): the header's step (its fixed-size forms) fed
    the simulator's states (the run-time forms) returns its torque through the breakdowns and the
    recovery, double, 1e-8 (measured 9.8e-10). Before a QP diverging without a hard bound was a
    breakdown too, rounding sent the header to status 6 (the guess kept) for 45 steps and 12 N m
    away, the simulator to status 4 and back after 2 (checked: this test failed then). Which of
    the two a cold step from here gives turns on the last bits of x: the states are mapped as
    when it was found (`canonical_states`)."""
    require_cc()
    text = preset_path("pendubot_mpc").read_text().split("[swingup]")[0]
    text += "[controller]" + preset_path("pendubot_mpc").read_text().split("[controller]")[1]
    for key in ("\ntheta", "dtheta"):  # 0.14 rad from upright (DFKI's q1 = pi), at 3 rad/s
        text = text.replace(f"{key} = [0.0, 0.0]", f"{key} = [3.0, 0.1]")
    text = text.replace("t_end = 10.0", "t_end = 2.0").replace("sample = 0.002", "sample = 0.01")
    text = text.replace('type = "fixed"\n', 'type = "fixed"\nname = "violent"\nemit = ["c"]\n', 1)
    scene = tmp_path / "violent.toml"
    scene.write_text(text)
    status, err = generate(scene, tmp_path)
    assert status == 0, err
    columns, _ = simulate(tmp_path, text, "violent", ("--divergence-angle", "inf"))  # the whole 2 s
    chain = FixedPendulum.from_scene(scene)
    rows = state_rows(columns)
    states = canonical_states(chain, rows)  # which of 4 and 6 rounding picks: this map's rounding
    steps = replay(compiled(tmp_path, "violent", "double"), states[:-1])
    u = -np.array([float(v[0]) for v in steps])
    assert steps[0][1] == "4" and steps[-1][1] == "0"  # a breakdown at first, recovered
    assert np.max(np.abs(u - columns["u"][:-1])) <= 1e-8


def test_the_header_states_the_chains_model_and_the_method(loop: tuple[Path, str, dict]) -> None:
    """The model constants are the scene's chain (a rotor's Ir and gr where given); the method is
    printed only where the scene sets it; the .cfg written beside it is `ipgen run`'s but for its
    model, the header's."""
    folder, name, _ = loop
    header = (folder / f"{name}.h").read_text()
    assert f"ipgen_{name}_mpc_step" in header and "IPGEN_MPC_NX 4" in header
    assert ("(IPGEN_SCALAR)-6.0}" in header) == (name == "pendubot_rotor")  # gr = -6 in the params
    assert (f"ipgen_{name}_mpc_method" in header) == (name == "acrobot_fast")
    written, ran = (folder / "balance.cfg").read_text(), (folder / "out" / "balance.cfg").read_text()
    assert f"\nmodel = {name}\n" in written
    assert re.sub(r"\nmodel = \w+\n", "\n", written) == re.sub(r"\nmodel = \w+\n", "\n", ran)


def test_a_chain_without_a_controller_gets_the_plain_header(tmp_path: Path) -> None:
    """Without [controller], in ipgen's coordinates, the scene's C header is `ipgen --type fixed`'s
    for its chain (named by the scene), and cpp is the default target."""
    text = scene_text("2", "", "", "plain").split("[controller]")[0] + "[simulation]\nt_end = 1.0\n"
    text = "".join(line for line in text.splitlines(keepends=True) if line.split(" =")[0] not in RIG_KEYS)
    scene = tmp_path / "plain.toml"
    scene.write_text(text)
    status, err = generate(scene, tmp_path / "scene")
    assert status == 0, err
    with redirect_stdout(io.StringIO()):
        args = ["--type", "fixed", "--links", "2", "--joints", "2", "--name", "plain", "--emit", "c"]
        assert run([*args, "-o", str(tmp_path / "command")]) == 0
    body = (tmp_path / "scene" / "plain.h").read_text().split("Do not edit")[1].split("\n", 3)[3]
    assert body == (tmp_path / "command" / "plain.h").read_text().split("Do not edit")[1].split("\n", 3)[3]
    assert "mpc" not in body
    scene.write_text(text.replace('emit = ["c"]\n', ""))
    status, err = generate(scene, tmp_path / "default")
    assert status == 0, err
    assert sorted(p.name for p in (tmp_path / "default").iterdir()) == ["plain.cfg", "plain.hpp"]


CONTROL = """\
#include <stdio.h>
#include "NAME.h"
/* Reads a state per line in the rig's coordinates, prints the state feedback's torques in the
 * rig's sense (the header's mapping both ways). */
int main(void) {
  double x[4];
  IPGEN_SCALAR q_rig[2], qd_rig[2], q[2], qd[2], u[IPGEN_NAME_INPUTS];
  int k;
  while (scanf("%lf %lf %lf %lf", &x[0], &x[1], &x[2], &x[3]) == 4) {
    q_rig[0] = (IPGEN_SCALAR)x[0];
    q_rig[1] = (IPGEN_SCALAR)x[1];
    qd_rig[0] = (IPGEN_SCALAR)x[2];
    qd_rig[1] = (IPGEN_SCALAR)x[3];
    ipgen_NAME_to_canonical(q_rig, q);
    ipgen_NAME_rates_to_canonical(qd_rig, qd);
    ipgen_NAME_control(q, qd, u);
    for (k = 0; k < IPGEN_NAME_INPUTS; ++k) printf("%.17g ", (double)ipgen_NAME_torque_from_canonical(u[k]));
    printf("\\n");
  }
  return 0;
}
"""


@pytest.mark.parametrize(
    ("joints", "period", "equilibrium"),
    [([1], 0.002, ""), ([2], 0.002, ""), ([1, 2], None, ""), ([1], 0.002, 'equilibrium = "hanging"')],
    ids=["pendubot", "acrobot", "both", "pendubot-hanging"],
)
def test_an_lqr_in_the_header_replays_the_simulators(
    tmp_path: Path, joints: list[int], period: float | None, equilibrium: str
) -> None:
    """[controller] kind = "lqr" on a fixed chain (test_fixed_lqr's scenes: DFKI's coordinates, a
    tilt held within 6 N m, sampled or continuous, one input or two; and held hanging, where x_eq
    is not 0 in ipgen's coordinates): `ipgen_NAME_control` (K
    mapped to ipgen's coordinates) fed the simulator's states in DFKI's coordinates through the
    header's `_to_canonical` and `_rates_to_canonical` returns, through `_torque_from_canonical`,
    its torques: double to 1e-9 (the
    acrobot's on its clip at first), float within FLOAT_LOOP."""
    require_cc()
    text = LQR_CHAIN.format(joints=joints, tilt=0.3 if equilibrium else math.pi - 0.08)
    text += LQR_CONTROLLER.format(period="" if period is None else f"period = {period}") + equilibrium + "\n"
    text = text.replace('type = "fixed"\n', 'type = "fixed"\nname = "lqr"\nemit = ["c"]\n', 1)
    scene = tmp_path / "hold.toml"
    scene.write_text(text)
    status, err = generate(scene, tmp_path)
    assert status == 0 and "warning: angles" in err, err
    columns, _ = simulate(tmp_path, text, "hold")
    rows = state_rows(columns)[:-1]
    names = ["u"] if len(joints) == 1 else [f"u{k + 1}" for k in range(len(joints))]  # the CSV's
    torques = np.column_stack([columns[name] for name in names])[:-1]  # the last row: u held to t_end
    for scalar, bound in (("double", 1e-9), ("float", FLOAT_LOOP)):
        program = compiled(tmp_path, "lqr", scalar, CONTROL.replace("IPGEN_NAME_INPUTS", "IPGEN_LQR_INPUTS"))
        u = np.array([[float(v) for v in line] for line in replay(program, rows)])
        error = np.max(np.abs(u - torques))
        assert error <= bound, (scalar, error)
    assert 0.4 < np.max(np.abs(torques)) <= 6.0 + 1e-12  # a real push, within the clip (on it: the acrobot)


def test_nothing_is_overwritten_without_force(tmp_path: Path) -> None:
    scene = tmp_path / "balance.toml"
    scene.write_text(scene_text("2", "", "", "kept"))
    (tmp_path / "out").mkdir()
    (tmp_path / "out" / "kept.h").write_text("mine\n")
    status, err = generate(scene, tmp_path / "out")
    assert status != 0 and "--force" in err and len(err.strip().splitlines()) == 1
    assert (tmp_path / "out" / "kept.h").read_text() == "mine\n"
    assert not (tmp_path / "out" / "balance.cfg").exists()  # all or none
    assert generate(scene, tmp_path / "out", "--force")[0] == 0
    assert "ipgen_kept_mpc_step" in (tmp_path / "out" / "kept.h").read_text()


BAD_EMIT = st.one_of(
    st.just("[]"), st.just('["gym"]'), st.just('["c", "library"]'), st.just('"c"'), st.just("[1]"),
    st.just('[["c"]]'), st.just("[[]]"), st.just("[{a = 1}]"), st.just('["c", 2]'),
    st.text(alphabet="abcxyz_+", min_size=1, max_size=8).filter(lambda s: s not in FIXED_TARGETS).map(
        lambda s: f'["{s}"]'
    ),
)  # fmt: skip
BAD_NAME = st.one_of(
    st.just('"1abc"'), st.just('"a b"'), st.just('"int"'), st.just('"a__b"'), st.just("3"),
    st.text(alphabet="-.;é ", min_size=1, max_size=6).map(lambda s: f'"{s}"'),
)  # fmt: skip


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(key=st.sampled_from(["emit", "name"]), data=st.data())
def test_a_bad_emit_or_name_is_one_line_and_writes_nothing(
    tmp_path: Path, key: str, data: st.DataObject
) -> None:
    """`--scene -o` refuses it in one line, writing nothing; so does `--describe` (CMake's)."""
    value = data.draw(BAD_EMIT if key == "emit" else BAD_NAME)
    text = scene_text("2", "", "", "chain")
    old = 'emit = ["c"]' if key == "emit" else '"chain"'
    text = text.replace(old, f"emit = {value}" if key == "emit" else value)
    scene = tmp_path / "bad.toml"
    scene.write_text(text)
    out = tmp_path / "bad_out"
    shutil.rmtree(out, ignore_errors=True)  # hypothesis reuses tmp_path
    status, err = generate(scene, out)
    assert status == 2 and len(err.strip().splitlines()) == 1 and "Traceback" not in err, err
    assert f"system.{key}" in err, err
    assert not out.exists() or not any(out.iterdir())
    status, printed, described = describe(scene)
    assert (status, printed, described) == (2, "", err)


def test_describe_gives_cmake_the_fixed_scenes_own_model(tmp_path: Path) -> None:
    """What CMake's ipgen_add_scene reads: the header's name, a specialised model (the scene's own
    header), the warnings `--scene -o` prints; nothing written. And the .cfg `--scene -o` writes
    names that model (the simulator linked to DIR/<name>_model.c takes it), where `ipgen run`'s
    names the library it builds; the rest of the two files is the same."""
    scene = tmp_path / "balance.toml"
    text = scene_text("2", "", "", "chain")
    scene.write_text(text)
    status, out, err = describe(scene)
    assert status == 0, err
    assert out == "name=chain type=fixed links=2 inertia=full stem=balance specialise=true\n"
    assert err.count("\n") == 1 and "warning: angles = 'relative'" in err, err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["balance.toml"]
    status, err = generate(scene, tmp_path / "generated")
    assert status == 0, err
    written = (tmp_path / "generated" / "balance.cfg").read_text().splitlines()
    ran = simulate(tmp_path, text, "balance")[1].splitlines()
    assert "model = chain" in written and "model = fixed2_j2" in ran
    assert [line for line in written if not line.startswith("model =")] == [
        line for line in ran if not line.startswith("model =")
    ]
    ignored = describe(scene, "-o", str(tmp_path / "unused"), "--emit", "c", "--force")  # as a cart's
    assert ignored[:2] == (0, out) and not (tmp_path / "unused").exists()
    status, out, err = describe(scene, "--links", "2")
    assert status == 2 and out == "" and len(err.strip().splitlines()) == 1 and "--describe" in err, err


@pytest.mark.parametrize("option", [["--links", "2"], ["--name", "x"], ["--type", "fixed"], ["--fix", "g"]])
def test_system_options_with_a_fixed_scene_are_one_line(tmp_path: Path, option: list[str]) -> None:
    scene = tmp_path / "balance.toml"
    scene.write_text(scene_text("2", "", "", "chain"))
    status, err = generate(scene, tmp_path / "out", *option)
    assert status == 2 and len(err.strip().splitlines()) == 1, err
    assert not (tmp_path / "out").exists()


def test_a_scene_in_the_rigs_coordinates_is_warned_and_gets_no_fmu(tmp_path: Path) -> None:
    """DFKI's coordinates: the headers are written in ipgen's with one warning line saying so; an
    FMU (its variables ipgen's) is refused in one line, nothing written."""
    scene = tmp_path / "balance.toml"
    scene.write_text(scene_text("2", "", "", "chain"))
    status, err = generate(scene, tmp_path / "out")
    assert status == 0 and err.count("\n") == 1 and "warning: angles = 'relative'" in err, err
    canonical_scene = tmp_path / "ipgen.toml"
    text = scene.read_text()
    text = "".join(line for line in text.splitlines(keepends=True) if line.split(" =")[0] not in RIG_KEYS)
    tilt = "[initial]\ntheta = [0.08, 0.05]"  # near upright in ipgen's coordinates
    canonical_scene.write_text(text.replace("[initial]\ntheta = [3.06, 0.12]", tilt))
    status, err = generate(canonical_scene, tmp_path / "canonical")
    assert status == 0 and err == "", err
    status, err = generate(scene, tmp_path / "fmu", "--emit", "c,fmu")
    assert status == 2 and err.count("\n") == 1 and "FMU" in err, err
    assert not (tmp_path / "fmu").exists()
    status, err = generate(scene, tmp_path / "cpp", "--emit", "cpp")  # the MPC would go nowhere
    assert status == 0 and err.count("\n") == 2 and "go into the C header only" in err, err


def test_a_name_the_printed_runtime_defines_is_one_line(tmp_path: Path) -> None:
    """name = "loop" with a swing-up makes ipgen_loop_swingup, the loop runtime's struct: refused in
    one line, nothing written; "mpc" with the MPC clashes with nothing and compiles."""
    source = preset_path("pendubot_mpc")
    shutil.copy(source.parent / "pendubot_swingup.plan.csv", tmp_path)
    for name, expected in (("loop", 2), ("mpc", 0)):
        named = f'type = "fixed"\nname = "{name}"\nemit = ["c"]\n'
        text = source.read_text().replace('type = "fixed"\n', named, 1)
        scene = tmp_path / f"{name}.toml"
        scene.write_text(text)
        status, err = generate(scene, tmp_path / name)
        assert status == expected, err
        if expected:
            assert "ipgen_loop_swingup" in err and err.count("\n") == 1 and not (tmp_path / name).exists()
    program = tmp_path / "mpc" / "main.c"
    program.write_text(
        '#include "mpc.h"\nint main(void) {\n  static ipgen_mpc_swingup_state s;\n'
        "  ipgen_mpc_swingup_init(&s);\n  return 0;\n}\n"
    )
    failure = compile_c(c_command(str(program), "-o", str(tmp_path / "mpc" / "main")))
    assert failure is None, failure
    cart = tmp_path / "cart.toml"  # the arm's swing-up named "loop": the same check on the cart's path
    named = preset_path("rsip_swingup").read_text().replace("[system]\n", '[system]\nname = "loop"\n', 1)
    cart.write_text(named)
    status, err = generate(cart, tmp_path / "cart", "--emit", "c")
    assert status == 2 and "ipgen_loop_swingup" in err and err.count("\n") == 1, err
    assert not (tmp_path / "cart").exists()


SWINGUP = """\
#include <stdio.h>
#include "NAME.h"
/* Reads a state per line (ipgen's coordinates), prints u of the swing-up and its phase. */
static ipgen_NAME_swingup_state s;
int main(void) {
  double x[4];
  IPGEN_SCALAR q[2], qd[2];
  ipgen_NAME_params p = ipgen_NAME_PARAMS; /* read by the energy law only: a plan's swing-up ignores them */
  ipgen_NAME_swingup_init(&s);
  while (scanf("%lf %lf %lf %lf", &x[0], &x[1], &x[2], &x[3]) == 4) {
    q[0] = (IPGEN_SCALAR)x[0];
    q[1] = (IPGEN_SCALAR)x[1];
    qd[0] = (IPGEN_SCALAR)x[2];
    qd[1] = (IPGEN_SCALAR)x[3];
    printf("%.17g\\n", (double)ipgen_NAME_swingup(&s, q, qd, &p, 0));
  }
  return 0;
}
"""


@pytest.mark.parametrize("preset", ["pendubot_mpc", "acrobot_swingup"])
def test_a_plans_swing_up_in_the_header_replays_the_simulators(tmp_path: Path, preset: str) -> None:
    """A fixed scene's [swingup] in its C header: the plan as const tables, tracked by the MPC
    (pendubot_mpc: ipgen_NAME_mpc_track every 5 samples about the plan's reference) or by its
    time-varying LQR (acrobot_swingup), then held (the MPC, or the hold's LQR): ipgen_NAME_swingup
    fed the simulator's states at its samples (ipgen's coordinates) returns the simulator's torque
    (DFKI's sign flipped back), double, 1e-9 (measured 5e-13), float within FLOAT_LOOP (measured
    4.5e-5 N m); 4.5 s of the preset's run (the plan and the catch)."""
    require_cc()
    source = preset_path(preset)
    shutil.copy(source.parent / source.read_text().split('plan = "')[1].split('"')[0], tmp_path)
    text = source.read_text().replace("t_end = 10.0", "t_end = 4.5")
    text = text.replace('type = "fixed"\n', 'type = "fixed"\nname = "chain"\nemit = ["c"]\n', 1)
    scene = tmp_path / f"{preset}.toml"
    scene.write_text(text)
    status, err = generate(scene, tmp_path)
    assert status == 0, err
    columns, _ = simulate(tmp_path, text, preset)
    chain = FixedPendulum.from_scene(scene)
    rows = state_rows(columns)
    states = canonical(chain, rows)[:-1]
    header = (tmp_path / "chain.h").read_text()
    params = header.split("ipgen_chain_mpc_params = ")[1].split(";")[0] if "_mpc_params" in header else "{0}"
    for scalar, bound in (("double", 1e-9), ("float", FLOAT_LOOP)):
        program = compiled(tmp_path, "chain", scalar, SWINGUP.replace("ipgen_NAME_PARAMS", params))
        u = -np.array([float(v[0]) for v in replay(program, states)])
        assert len(u) == len(states)
        error = np.max(np.abs(u - columns["u"][:-1]))
        assert error <= bound, (scalar, error)
    assert np.max(np.abs(u)) > 1.0 and abs(rows[-1, 0] - np.pi) < 0.05  # a real swing; upright at the end
