"""Install hints name this project's distribution, ipgen-pendulum (PyPI's `ipgen` is an unrelated
IP-core generator: `pip install 'ipgen[swingup]'` installed it), and the energy swing-up, which
plans nothing, runs without CasADi."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
# `pip install ipgen`, `pip install 'ipgen[...]'`, `ipgen[swingup]` quoted or in backticks: the
# other project's name used as a distribution.
WRONG_PACKAGE = re.compile(r"""pip3?\s+install\s+(?:-\S+\s+)*['"]?ipgen(?![-\w])|['"`(]ipgen\[""")


def tracked_files() -> list[Path]:
    listed = subprocess.run(["git", "ls-files", "-z"], cwd=ROOT, capture_output=True, text=True)
    if listed.returncode == 0 and listed.stdout:
        return [ROOT / name for name in listed.stdout.split("\0") if name]
    skip = {".git", ".venv", "build", "out", "__pycache__"}  # a copy without .git
    return [p for p in ROOT.rglob("*") if p.is_file() and not skip & set(p.relative_to(ROOT).parts)]


def test_the_pattern_catches_the_wrong_forms() -> None:
    wrong = ("pip install 'ipgen[swingup]'", "pip install ipgen", 'pip install -U "ipgen"', "`ipgen[x]`")
    right = ("pip install 'ipgen-pendulum[swingup]'", "pip install ipgen-pendulum", "ipgen run x.toml")
    assert all(WRONG_PACKAGE.search(text) for text in wrong)
    assert not any(WRONG_PACKAGE.search(text) for text in right)


def test_no_file_points_at_the_other_ipgen() -> None:
    """Every message, doc and docstring that names an install names ipgen-pendulum."""
    this = Path(__file__).resolve()
    found = []
    for path in tracked_files():
        if path.resolve() == this or not path.is_file():
            continue
        try:
            text = path.read_text(encoding="utf-8")
        except (UnicodeDecodeError, OSError):
            continue  # binary
        for number, line in enumerate(text.splitlines(), 1):
            if WRONG_PACKAGE.search(line):
                found.append(f"{path.relative_to(ROOT)}:{number}: {line.strip()}")
    assert not found, "\n".join(found)


def test_install_messages_name_the_distribution() -> None:
    from ipgen.control import casadi_model

    assert "pip install 'ipgen-pendulum[swingup]'" in casadi_model._INSTALL_HINT


ENERGY_WITHOUT_CASADI = """
import sys
sys.modules["casadi"] = None  # as if CasADi were not installed: `import casadi` raises ImportError
import json
import numpy as np
from ipgen.control.casadi_model import plant
from ipgen.control.energy import energy_swingup
law = energy_swingup(plant("rotary", 1, [0.095, 0.024], [0.085, 0.129], [0.0, 0.0]), u_max=0.5)
u = [law.control(k, np.array([0.01 * k, np.pi - 0.1 * k, 0.2, 0.3 * k])) for k in range(5)]
print(json.dumps({"hold": list(law.hold_gain), "a_max": law.accel_max, "u": [v for v, _ in u]}))
"""


def test_energy_swingup_runs_without_casadi() -> None:
    """Without CasADi the energy law is built (numpy model, exact zero-order-hold LQR) and agrees
    with the CasADi-built one: same inputs to 1e-9, hold gain to 1e-6 (RK4 flow map against the
    matrix exponential)."""
    pytest.importorskip("casadi")
    import json

    from ipgen.control.casadi_model import plant
    from ipgen.control.energy import energy_swingup

    done = subprocess.run([sys.executable, "-c", ENERGY_WITHOUT_CASADI], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr[-2000:]
    without = json.loads(done.stdout)
    law = energy_swingup(plant("rotary", 1, [0.095, 0.024], [0.085, 0.129], [0.0, 0.0]), u_max=0.5)
    states = [np.array([0.01 * k, np.pi - 0.1 * k, 0.2, 0.3 * k]) for k in range(5)]
    with_casadi = [law.control(k, x)[0] for k, x in enumerate(states)]
    np.testing.assert_allclose(without["u"], with_casadi, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(without["a_max"], law.accel_max, rtol=1e-12)
    np.testing.assert_allclose(without["hold"], law.hold_gain, rtol=1e-6)


def test_trajectory_planning_without_casadi_names_the_distribution() -> None:
    code = """
import sys
sys.modules["casadi"] = None
from ipgen.control.casadi_model import plant, casadi_model
try:
    casadi_model(plant("rotary", 2, [0.5, 0.275, 0.275], [0.6, 0.5, 0.5], [0.3, 0.01, 0.01]))
except Exception as e:
    print(e)
"""
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert "pip install 'ipgen-pendulum[swingup]'" in done.stdout, done.stdout + done.stderr


def test_the_energy_swingup_scene_loads_without_casadi() -> None:
    """The scene stage designs the preset rsip_swingup's law without CasADi (what `ipgen run
    --preset rsip_swingup` needs before it compiles)."""
    code = """
import sys
sys.modules["casadi"] = None
from ipgen.common.presets import preset_path
from ipgen.experiment.scene import load_scene
scene = load_scene(preset_path("rsip_swingup"))
print(type(scene.swingup).__name__, scene.swingup is not None)
"""
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.strip().endswith("True"), done.stdout
