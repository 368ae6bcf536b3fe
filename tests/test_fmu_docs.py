"""docs/fmu.md: its `ipgen` command and its FMPy example run verbatim."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest
from c_models import require_cc

ROOT = Path(__file__).resolve().parents[1]
DOC = ROOT / "docs" / "fmu.md"


def _blocks(language: str) -> list[str]:
    return re.findall(rf"```{language}\n(.*?)```", DOC.read_text(), re.S)


def test_the_fmpy_example_runs_verbatim(tmp_path: Path) -> None:
    pytest.importorskip("fmpy")
    require_cc()
    (commands,) = [b for b in _blocks("sh") if "ipgen --scene" in b]
    env = {**os.environ, "PATH": f"{Path(sys.executable).parent}{os.pathsep}{os.environ.get('PATH', '')}"}
    script = ["bash", "-euo", "pipefail", "-c", commands]
    subprocess.run(script, cwd=tmp_path, check=True, capture_output=True, env=env)
    assert (tmp_path / "out" / "cdip.fmu").is_file()
    (example,) = _blocks("python")
    result = subprocess.run(
        [sys.executable, "-c", example], cwd=tmp_path, capture_output=True, text=True, env=os.environ.copy()
    )
    assert result.returncode == 0, result.stderr
    cart, energy = result.stdout.splitlines()
    assert cart.startswith("cart at ") and " m, link 1 at " in cart
    # the push adds energy, the damping takes it: the pendulum ends hanging, energy below the start
    start, end = (float(x) for x in re.findall(r"(-?\d+\.\d+) J", energy))
    assert end < start


def test_the_fmu_demo_writes_both_fmus_and_the_overlay(tmp_path: Path) -> None:
    """tools/fmu_demo.py against a simulator CSV (here the golden run): both FMUs, the PNG, and
    agreement figures below the test's tolerance; a missing CSV is one line, exit 1."""
    pytest.importorskip("fmpy")
    require_cc()
    demo = [sys.executable, str(ROOT / "tools" / "fmu_demo.py"), "--out", str(tmp_path)]
    golden = ROOT / "tests" / "data" / "rsip_pulse.golden.csv"
    result = subprocess.run(
        [*demo, "--csv", str(golden), "--scene", "rsip_pulse", "--fmi", "3"], capture_output=True, text=True
    )
    assert result.returncode == 0, result.stderr
    assert (tmp_path / "cdip.fmu").is_file() and (tmp_path / "rsip.fmu").is_file()
    assert (tmp_path / "rsip_fmu.png").stat().st_size > 10_000
    figures = [float(x) for x in re.findall(r"theta\d (\S+?)(?:,|$)", result.stdout, re.M)]
    assert len(figures) == 2 and max(figures) < 1e-6, result.stdout
    missing = subprocess.run([*demo, "--csv", str(tmp_path / "none.csv")], capture_output=True, text=True)
    assert missing.returncode == 1 and missing.stderr.startswith("fmu_demo: error:")
    assert len(missing.stderr.strip().splitlines()) == 1
