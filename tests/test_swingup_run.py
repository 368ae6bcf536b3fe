"""Swing-up scenes through `ipgen run`: the C++ simulator's hybrid closed loop (swing or track,
then hold) on the exact model ends upright and at rest, and matches the Python reference loop.

One compile per model (about 10-20 s each on the shared 2-core machine), cached for the module;
holds are short (0.5 s) to keep the runs brief. A scene that several tests check (the rotary
single's energy swing-up: four tests) is run once per module (`runs`): each test asserts on that
run's CSV, summary and .cfg, as it did on a run of its own of the same scene and simulator.
"""

from __future__ import annotations

import math
import os
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from cxx import require_toolchain
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from run_csv import read_run_csv
from run_summary import simulator_of
from swingup_reference import simulate

from ipgen.control.casadi_model import plant
from ipgen.control.energy import energy_swingup

HOLD = 0.5
# (type, links, method, u_max, duration, x_max, hold): the cases, the paper's parameters.
# The cart's energy swing-up has no travel limit: it catches the link 4.6 m from the start and
# needs 4 s of hold to bring the cart back.
CASES = [
    ("classical", 1, "trajectory", 20.0, 2.0, 1.0, HOLD),
    ("classical", 2, "trajectory", 50.0, 3.0, 1.0, HOLD),
    ("classical", 3, "trajectory", 50.0, 3.5, 1.0, HOLD),
    ("rotary", 1, "trajectory", 5.0, 2.0, None, HOLD),
    ("rotary", 2, "trajectory", 10.0, 3.0, None, HOLD),
    ("rotary", 1, "energy", 5.0, None, None, HOLD),
    ("classical", 1, "energy", 20.0, None, None, 4.0),
]


def paper(kind: str, links: int) -> tuple[list[float], list[float], list[float]]:
    if kind == "classical":
        return [0.3] + [0.275] * links, [0.0] + [0.5] * links, [0.3] + [0.1] * links
    return [0.5] + [0.275] * links, [0.6] + [0.5] * links, [0.3] + [0.011458] * links


def scene_text(
    kind: str, links: int, method: str, u_max: float, duration: float | None, x_max: float | None, hold: float
) -> str:
    m, l, delta = paper(kind, links)  # noqa: E741
    lines = [
        "[system]",
        f'type = "{kind}"',
        f"links = {links}",
        "[parameters]",
        f"m = {m}",
        f"l = {l}",
        f"delta = {delta}",
        "[simulation]",
        "t_end = 15.0",
        "[swingup]",
        f'method = "{method}"',
        f"u_max = {u_max}",
        f"hold = {hold}",
    ]
    if duration is not None:
        lines.append(f"duration = {duration}")
    if x_max is not None:
        lines.append(f"x_max = {x_max}")
    return "\n".join(lines) + "\n"


@pytest.fixture(scope="module")
def cache(tmp_path_factory: pytest.TempPathFactory) -> dict[str, str]:
    return {"IPGEN_CACHE_DIR": os.environ.get("IPGEN_CACHE_DIR") or str(tmp_path_factory.mktemp("cache"))}


def run_scene(tmp_path: Path, text: str, env: dict[str, str]) -> tuple[list[str], np.ndarray, list[str], str]:
    require_toolchain()
    scene = tmp_path / "swing.toml"
    scene.write_text(text)
    out = tmp_path / "out"
    result = subprocess.run(
        [sys.executable, "-m", "ipgen", "run", str(scene), "-o", str(out), "--no-plot"],
        capture_output=True,
        text=True,
        env={**os.environ, **env},
    )
    assert result.returncode == 0, result.stderr
    run_ = read_run_csv(out / "swing.csv", phase=True)
    assert run_.names[-1] == "u" and run_.phase
    return [*run_.names, "phase"], run_.data, run_.phase, (out / "swing.txt").read_text()


Run = tuple[list[str], np.ndarray, list[str], str, Path]  # run_scene's four, then the output folder


@pytest.fixture(scope="module")
def runs(tmp_path_factory: pytest.TempPathFactory, cache: dict[str, str]) -> Callable[[str], Run]:
    """`run_scene` of a scene text, once per module and text (`ipgen run` is deterministic: the
    same scene and simulator write the same CSV), into a folder of its own; each call gets its
    own copy of the arrays and lists. A run that fails is not kept: each test asking for it fails."""
    done: dict[str, Run] = {}

    def run(text: str) -> Run:
        if text not in done:
            folder = tmp_path_factory.mktemp("run")
            done[text] = (*run_scene(folder, text, cache), folder / "out")
        columns, data, phases, summary, out = done[text]
        return list(columns), data.copy(), list(phases), summary, out

    return run


@pytest.mark.parametrize("case", CASES, ids=[f"{c[0]}{c[1]}-{c[2]}" for c in CASES])
def test_swingup_ends_upright_and_at_rest(runs: Callable[[str], Run], case: tuple) -> None:
    _, links, method, u_max, duration, _, hold = case
    _, data, phases, summary, _ = runs(scene_text(*case))
    dof = links + 1
    t, x, u = data[:, 0], data[:, 1 : 1 + 2 * dof], data[:, 1 + 2 * dof]
    np.testing.assert_allclose(x[0, 1:dof], math.pi)  # started hanging
    assert phases[0] == ("swing" if method == "energy" else "track") and phases[-1] == "hold"
    # Phases in order, each once; the run ends HOLD s into the hold phase.
    order = [p for i, p in enumerate(phases) if i == 0 or p != phases[i - 1]]
    assert order == [phases[0], "hold"], order
    start = t[phases.index("hold")]
    assert t[-1] == pytest.approx(start + hold, abs=1e-9)
    if duration is not None:
        assert start == pytest.approx(duration, abs=1e-9)
    assert np.max(np.abs(u)) <= u_max * (1 + 1e-12)  # saturation honoured
    # Upright (each link within 0.05 rad of a whole turn) and nearly at rest at the end.
    final = x[-1]
    for i in range(1, dof):
        assert abs(math.remainder(final[i], 2 * math.pi)) < 0.05, (i, final)
    assert np.max(np.abs(final[dof + 1 :])) < 0.5, final
    assert "Swing-up:" in summary and "hold (LQR) from t =" in summary


def test_a_lost_plan_stops_the_run_at_once(tmp_path: Path, runs: Callable[[str], Run]) -> None:
    """While a plan is tracked, a link farther from its planned angle than --divergence-angle
    stops the run with exit status 5 and a line naming the link (before: it ran on into the
    hold). With a bound of 1 mrad the rotary single pendulum's tracking (ZOH, RK4 plan) leaves
    it within the first second; the stop comes within one period of the first sample whose
    deviation from the plan (the .cfg's swingup.states, checked here) exceeds the bound."""
    case = ("rotary", 1, "trajectory", 5.0, 2.0, None, HOLD)
    _, _, _, summary, out = runs(scene_text(*case))  # exit 0 at the default bound
    cfg = out / "swing.cfg"
    lines = dict(line.split(" = ", 1) for line in cfg.read_text().splitlines() if " = " in line)
    period = float(lines["swingup.period"])
    states = np.array([float(v) for v in lines["swingup.states"].split()]).reshape(-1, 4)
    csv = tmp_path / "lost.csv"
    done = subprocess.run(
        [str(simulator_of(summary)), str(cfg), "--csv", str(csv), "--divergence-angle", "0.001"],
        capture_output=True,
        text=True,
    )
    assert done.returncode == 5, done.stderr
    message = done.stderr.strip()
    assert "\n" not in message and "the swing-up lost its plan at t = " in message, message
    assert "link 1 is " in message and "beyond --divergence-angle 0.001 rad" in message, message
    run_ = read_run_csv(csv, phase=True)
    assert run_.phase and set(run_.phase) == {"track"}  # stopped before the hold
    data = run_.data
    k = np.rint(data[:, 0] / period).astype(int)
    off = np.abs(data[:, 2] - states[k, 1])
    first = int(np.argmax(off > 0.001))
    assert off[first] > 0.001 and data[-1, 0] - data[first, 0] <= period + 1e-9, (data[first, 0], data[-1, 0])


def test_energy_swingup_matches_the_python_reference(runs: Callable[[str], Run]) -> None:
    """The rotary single's energy swing-up in the simulator against tests/swingup_reference.py
    (scipy DOP853 on the sympy model, the Python controller): same phases at the same samples,
    the same states to 1e-6 through the swing."""
    case = ("rotary", 1, "energy", 5.0, None, None, HOLD)
    _, data, phases, _, _ = runs(scene_text(*case))
    m, l, delta = paper("rotary", 1)  # noqa: E741
    p = plant("rotary", 1, m, l, delta)
    controller = energy_swingup(p, u_max=5.0, period=0.01)
    t_end = data[-1, 0]
    ref = simulate(p, controller.control, [0.0, math.pi, 0.0, 0.0], t_end, 0.01)
    assert len(ref.t) == len(data)
    assert list(ref.phase[:-1]) == phases[:-1]
    swing = [i for i, p_ in enumerate(phases) if p_ == "swing"]
    np.testing.assert_allclose(data[swing, 1:5], ref.x[swing], atol=1e-6)
    np.testing.assert_allclose(data[:-1, 5], ref.u[:-1], atol=1e-5)
    np.testing.assert_allclose(data[-1, 1:5], ref.x[-1], atol=1e-5)


C_DRIVER = r"""
#include <math.h>
#include <stdio.h>
#include "MODEL.h"
/* Reads rows t, q[0..n-1], qd[0..n-1], u (a swing-up run of the simulator, one per period) and
 * prints the largest |u_C - u_simulator| of the C header's swing-up over the rows but the last. */
int main(void) {
  PREFIX_swingup_state s;
  PREFIX_params p = PARAMS;
  double row[2 * DOF + 2], worst = 0.0, next[2 * DOF + 2];
  int i, have;
  PREFIX_swingup_init(&s);
  have = 1;
  for (i = 0; i < 2 * DOF + 2; ++i) have = have && scanf("%lf", &row[i]) == 1;
  while (have) {
    double q[DOF], qd[DOF], u;
    int more = 1;
    for (i = 0; i < 2 * DOF + 2; ++i) more = more && scanf("%lf", &next[i]) == 1;
    if (!more) break; /* the last row: its u is the one held before it */
    for (i = 0; i < DOF; ++i) { q[i] = row[1 + i]; qd[i] = row[1 + DOF + i]; }
    u = PREFIX_swingup(&s, q, qd, &p, 0);
    if (fabs(u - row[1 + 2 * DOF]) > worst) worst = fabs(u - row[1 + 2 * DOF]);
    for (i = 0; i < 2 * DOF + 2; ++i) row[i] = next[i];
  }
  printf("%.17g %d\n", worst, s.phase);
  return 0;
}
"""


@pytest.mark.parametrize(
    "case",
    [("rotary", 1, "energy", 5.0, None, None, HOLD), ("classical", 2, "trajectory", 50.0, 3.0, 1.0, HOLD)],
    ids=["rotary1-energy", "classical2-trajectory"],
)
def test_c_header_swingup_computes_the_simulators_inputs(
    tmp_path: Path, runs: Callable[[str], Run], case: tuple
) -> None:
    """The C header's swing-up controller (--emit c), fed the states the C++ simulator sampled,
    returns the u the simulator applied at every sampling instant (the same law, the same
    sampling semantics), and ends in the hold phase."""
    kind, links, *_rest = case
    text = scene_text(*case)
    _, data, phases, _, _ = runs(text)
    dof = links + 1
    folder = tmp_path / "c"
    scene = tmp_path / "c.toml"
    scene.write_text(text.replace("[system]\n", '[system]\nname = "swing"\nemit = ["c"]\n'))
    result = subprocess.run(
        [sys.executable, "-m", "ipgen", "--scene", str(scene), "-o", str(folder)],
        capture_output=True,
        text=True,
    )
    assert result.returncode == 0, result.stderr
    m, l, delta = paper(kind, links)  # noqa: E741
    params = "{{" + ", ".join(map(repr, m)) + "}, {" + ", ".join(map(repr, l)) + "}, {"
    params += ", ".join(map(repr, delta)) + "}, 9.81}"
    source = C_DRIVER.replace("MODEL", "swing").replace("PREFIX", "ipgen_swing")
    source = source.replace("DOF", str(dof)).replace("PARAMS", params)
    (folder / "driver.c").write_text(source)
    flags = ["-std=c99", "-Wall", "-Wextra", "-Wpedantic", "-Werror", "-I", str(folder)]
    command = ["gcc", *flags, str(folder / "driver.c"), "-o", str(folder / "driver"), "-lm"]
    build = subprocess.run(command, capture_output=True, text=True)
    assert build.returncode == 0, build.stderr[:3000]
    rows = "\n".join(" ".join(repr(float(v)) for v in row[: 2 * dof + 2]) for row in data)
    out = subprocess.run([str(folder / "driver")], input=rows, capture_output=True, text=True, check=True)
    worst, phase = out.stdout.split()
    assert float(worst) <= 1e-9 * case[3], worst
    assert int(phase) == 2 and phases[-1] == "hold"


# ---------------------------------------------------------------------------- bad .cfg input

SWINGUP_KEYS = [
    "swingup",
    "swingup.u_max",
    "swingup.period",
    "swingup.hold",
    "swingup.hold_gain",
    "swingup.target",
    "swingup.gain_energy",
    "swingup.accel_max",
    "swingup.catch_angle",
    "swingup.energy_inertia",
    "swingup.steps",
]
BAD_VALUES = st.one_of(
    st.sampled_from(["0", "-1", "nan", "inf", "-inf", "x", "1e400", "trajectory", "energy", "1 2", "0 0 0"]),
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.lists(st.floats(-10, 10).map(repr), min_size=0, max_size=6).map(" ".join).filter(bool),
)


@pytest.fixture(scope="module")
def energy_run(runs: Callable[[str], Run]) -> tuple[str, str]:
    """(simulator path, resolved .cfg text) of the rotary single's energy swing-up."""
    _, _, _, summary, out = runs(scene_text("rotary", 1, "energy", 5.0, None, None, HOLD))
    simulator = summary.rsplit("Simulator ", 1)[1].split(" (")[0]
    return simulator, (out / "swing.cfg").read_text()


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(key=st.sampled_from(SWINGUP_KEYS), value=BAD_VALUES)
def test_simulator_refuses_bad_swingup_settings_in_one_line(
    tmp_path: Path, energy_run: tuple[str, str], key: str, value: str
) -> None:
    """A corrupted swingup.* line in the .cfg: the simulator refuses it on one line naming the key
    (exit 2), or runs to the end (0) or to a diverged hold (3); never a crash or a hang."""
    simulator, config = energy_run
    lines = [f"{key} = {value}" if line.split(" = ")[0] == key else line for line in config.splitlines()]
    if not any(line.startswith(f"{key} = ") for line in lines):
        lines.append(f"{key} = {value}")
    cfg = tmp_path / "bad.cfg"
    cfg.write_text("\n".join(lines) + "\n")
    result = subprocess.run(
        [simulator, str(cfg), "--csv", str(tmp_path / "bad.csv"), "--force", "--t-end", "2"],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert result.returncode in (0, 2, 3), result.stderr
    if result.returncode == 2:
        err = result.stderr.strip().splitlines()
        assert len(err) == 1 and err[0].startswith("simulate: error: ") and "swingup" in err[0], err


def test_a_lost_plan_gets_the_measured_hint(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """`ipgen run` follows exit status 5 with what docs/swingup.md measured to help (the plan's
    duration), and names the section; no other status has a hint. (The simulator's run is
    stood in for: test_a_lost_plan_stops_the_run_at_once gives a real status 5.)"""
    from types import SimpleNamespace

    import ipgen.pipeline.run
    from ipgen.command.cli import EXIT_HINTS
    from ipgen.command.cli import run as cli

    assert set(EXIT_HINTS) == {5}
    assert "duration" in EXIT_HINTS[5] and "When the plan is lost" in EXIT_HINTS[5]
    docs = (Path(__file__).resolve().parent.parent / "docs" / "swingup.md").read_text()
    assert "### When the plan is lost" in docs
    scene = tmp_path / "s.toml"
    scene.write_text("")
    for status in (5, 3):
        outcome = SimpleNamespace(simulator=SimpleNamespace(built=False), files=[], summary="", messages="",
                                  status=status)  # fmt: skip
        monkeypatch.setattr(ipgen.pipeline.run, "run_scene", lambda *_, **__: outcome)  # noqa: B023
        assert cli(["run", str(scene), "-o", str(tmp_path / "out")]) == status
        err = capsys.readouterr().err
        assert ("ipgen: hint: " + EXIT_HINTS[5] in err) == (status == 5), err
