"""Scenes and commands under hostile input (issue 48): one rule where the scene layer and the
simulator meet, bounds on what a scene accepts, bad paths and a full standard output as one line.

- sensors.delay: the scene layer accepts a delay exactly when the simulator accepts the resolved
  scene (`common.limits.MAX_DELAY_PERIODS`, `DELAY_TOLERANCE`, the same numbers in
  cpp/include/ipsim/limits.hpp);
- estimator.cutoff at most the Nyquist frequency π / period (`estimation.measurement.cutoff_problem`);
- an empty path option is a usage error (`command.paths.NonEmptyPath`);
- a standard output that cannot be written is one line and a non-zero status (`command.cli.run`).
"""

from __future__ import annotations

import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from cxx import require_toolchain
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st
from test_sweep import SCENE

from ipgen.command.cli import run
from ipgen.errors import Error
from ipgen.experiment.config import resolved_config
from ipgen.experiment.scene import load_scene
from ipgen.sweeps.execute import Prepared, SceneSource, prepare

FIXTURE = [HealthCheck.function_scoped_fixture]
PERIODS = (0.01, 0.005, 0.002)  # whole fractions of the scene's sample, 0.01 s


@pytest.fixture(scope="module")
def prepared(tmp_path_factory: pytest.TempPathFactory) -> Prepared:
    """test_sweep.py's scene (rotary single, sampled LQR) with its simulator from the test cache."""
    require_toolchain()
    cache = os.environ.get("IPGEN_CACHE_DIR")
    return prepare(SceneSource("rsip_limits", SCENE, cache))


def _scene(folder: Path, period: float, extra: str) -> Path:
    text = SCENE.replace("period = 0.01", f"period = {period!r}").replace("t_end = 2.0", "t_end = 0.05")
    path = folder / "limits.toml"
    path.write_text(text + extra)
    return path


@settings(max_examples=10, deadline=None, suppress_health_check=FIXTURE)
@given(
    period=st.sampled_from(PERIODS),
    periods=st.one_of(st.integers(0, 5), st.integers(999_995, 1_000_005)),
    offset=st.sampled_from([0.0, 1e-13, 1e-10, 1e-8, 1e-6, 0.25, 0.5]),
)
@example(period=0.01, periods=1_000_000, offset=0.0)  # the documented maximum (issue 48)
@example(period=0.002, periods=1_000_001, offset=0.0)
@example(period=0.005, periods=999_999, offset=0.5)
def test_the_scene_accepts_a_delay_exactly_when_the_simulator_does(
    prepared: Prepared, tmp_path: Path, period: float, periods: int, offset: float
) -> None:
    delay = (periods + offset) * period
    path = _scene(tmp_path, period, f"\n[sensors]\ndelay = {delay!r}\n")
    try:
        scene = load_scene(path)
    except Error as error:
        assert "sensors.delay" in str(error) and "\n" not in str(error)
        accepted = False
        # the simulator is asked about the delay as written (the scene's own .cfg with it changed)
        nominal = load_scene(_scene(tmp_path, period, "\n[sensors]\ndelay = 0.0\n"))
        text = resolved_config(nominal, model=prepared.model)
        assert "sensors.delay = 0" in text
        text = text.replace("sensors.delay = 0\n", f"sensors.delay = {delay!r}\n")
    else:
        accepted = True
        text = resolved_config(scene, model=prepared.model)
    cfg = tmp_path / "limits.cfg"
    cfg.write_text(text)
    done = subprocess.run(
        [str(prepared.simulator), str(cfg), "--csv", str(tmp_path / "limits.csv"), "--force"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    refused = done.returncode == 2 and "sensors.delay" in done.stderr
    assert accepted == (not refused), (delay, done.returncode, done.stderr[-500:])


FILTER = "\n[sensors]\nresolution = 2048\n[estimator]\nkind = 'filter'\ncutoff = {cutoff!r}\n"


@settings(max_examples=40, deadline=None, suppress_health_check=FIXTURE)
@given(
    period=st.sampled_from(PERIODS),
    cutoff=st.one_of(
        st.floats(1e-3, 1e308, allow_nan=False, allow_infinity=False),
        st.sampled_from([50.0, 314.0, 315.0, 1e6, 1e300]),
    ),
)
@example(period=0.01, cutoff=1e300)  # issue 48: ran, printed inf, wrote no PNG
def test_a_filter_cutoff_is_accepted_exactly_up_to_the_nyquist_frequency(
    tmp_path: Path, period: float, cutoff: float
) -> None:
    """Accepted: at most π / period, and the estimation's rates stay finite; above: one line."""
    from ipgen.estimation.estimators import DerivativeFilter

    path = _scene(tmp_path, period, FILTER.format(cutoff=cutoff))
    try:
        scene = load_scene(path)
    except Error as error:
        assert "estimator.cutoff" in str(error) and "Nyquist" in str(error) and "\n" not in str(error)
        assert cutoff > math.pi / period
        return
    assert cutoff <= math.pi / period and scene.loop.estimator.cutoff == cutoff
    rates = DerivativeFilter(period, 2, cutoff)
    rates.step([0.0, 0.0])
    assert np.isfinite(rates.step([2 * math.pi, 2 * math.pi])).all()


EMPTY_PATH_COMMANDS = st.sampled_from(
    [
        ["run", "--preset", "rsip_lqr", "-o", "out", "--cache-dir", "{}"],
        ["run", "--preset", "rsip_lqr", "-o", "{}"],
        ["sweep", "--preset", "rsip_lqr", "-o", "out", "--vary", "initial.theta[1]=0", "--cache-dir", "{}"],
        ["sweep", "--preset", "rsip_lqr", "-o", "{}", "--vary", "initial.theta[1]=0"],
        ["--type", "rotary", "--links", "1", "-o", "{}"],
        ["excite", "--preset", "qube_servo2", "-o", "{}"],
        ["plot", "{}"],
    ]
)


@settings(max_examples=10, deadline=None, suppress_health_check=FIXTURE)
@given(command=EMPTY_PATH_COMMANDS, blank=st.sampled_from(["", " ", "\t"]))
@example(command=["run", "--preset", "rsip_lqr", "-o", "out", "--cache-dir", "{}"], blank="")
def test_an_empty_path_is_a_usage_error_and_writes_nothing(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch, command: list[str],
    blank: str,
) -> None:  # fmt: skip
    here = tmp_path / "cwd"
    here.mkdir(exist_ok=True)
    monkeypatch.chdir(here)
    status = run([blank if part == "{}" else part for part in command])
    err = capsys.readouterr().err
    assert status == 2 and err.count("\n") == 1 and "is empty: name a file or folder" in err, err
    assert not any(here.iterdir())


HELPERS = st.sampled_from(
    [["--help"], ["presets"], ["presets", "rsip_lqr"], ["sweep", "--help"], ["run", "--help"], ["--version"],
     ["--scene-schema"]]
)  # fmt: skip


@settings(max_examples=4, deadline=None)
@given(arguments=HELPERS)
def test_a_full_standard_output_is_one_line_and_a_failure(arguments: list[str]) -> None:
    with open("/dev/full", "w") as full:
        done = subprocess.run(
            [sys.executable, "-m", "ipgen", *arguments],
            stdout=full,
            stderr=subprocess.PIPE,
            text=True,
            timeout=60,
        )
    assert done.returncode != 0 and done.stderr.count("\n") == 1 and "Traceback" not in done.stderr, (
        done.stderr
    )
    assert done.stderr.startswith("ipgen: error: cannot write to standard output")
