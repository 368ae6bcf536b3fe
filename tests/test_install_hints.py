"""Install hints name this project's distribution, ipgen-pendulum (PyPI's `ipgen` is an unrelated
IP-core generator: `pip install 'ipgen[swingup]'` installed it), and the energy swing-up, which
plans nothing, runs without CasADi.

Every install hint works in a fresh virtualenv (issue 49). ipgen-pendulum is installed from its
checkout, not from a package index: `pip install 'ipgen-pendulum[identify]'` fails in a fresh
virtualenv ("No matching distribution"). Checked over every `pip install` of the package's
strings, the README and docs/: each names packages that pyproject.toml lists (so PyPI has them)
or the checkout itself (`./`, `'./[extra]'` with an extra that exists), never `ipgen-pendulum`.
Then the hints at work: without CasADi `ipgen identify`, without gymnasium `import ipgen.gym` say
the command in one line; a missing file of the package says how to reinstall it from the checkout."""

from __future__ import annotations

import ast
import re
import subprocess
import sys
import tomllib
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
    right = ("pip install './[swingup]'", "pip install casadi", "ipgen run x.toml")
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


def test_install_messages_name_what_installs() -> None:
    from ipgen.control import casadi_model

    hint = "pip install casadi (or, in ipgen's checkout, pip install './[identify]')"
    assert hint in casadi_model._INSTALL_HINT


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


def test_trajectory_planning_without_casadi_names_what_installs() -> None:
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
    assert "needs CasADi: pip install casadi (or" in done.stdout, done.stdout + done.stderr


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


# ---------------------------------------------------------------------------- issue 49

PIP = re.compile(r"pip install ((?:[^`\n;)(]|\([^)\n]*\))+)")


def _name(requirement: str) -> str:
    return re.split(r"[\[<>=!~ ]", requirement.strip("'\""), maxsplit=1)[0].lower().replace("_", "-")


def known_packages() -> tuple[set[str], set[str]]:
    """(requirement names of pyproject.toml, its extras)."""
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    extras = project["optional-dependencies"]
    names = {_name(r) for r in project["dependencies"]} | {_name(r) for rs in extras.values() for r in rs}
    return names, set(extras)


def install_commands() -> list[tuple[str, str]]:
    """(where, arguments) of every `pip install` in the package's strings, the README and docs/."""
    from ipgen.common.install import PACKAGES, REINSTALL, install_hint

    hints = [install_hint(feature) for feature in PACKAGES] + [REINSTALL]  # what install.py says
    found = [("generator/common/install.py", m) for text in hints for m in PIP.findall(text)]
    for path in sorted((ROOT / "generator").rglob("*.py")):
        if path.name == "install.py":  # its templates and docstring: rendered above
            continue
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Constant) and isinstance(node.value, str):
                found += [(f"{path.relative_to(ROOT)}:{node.lineno}", m) for m in PIP.findall(node.value)]
            if isinstance(node, ast.JoinedStr):  # f-strings: their constant parts
                text = "".join(v.value for v in node.values if isinstance(v, ast.Constant))
                found += [(f"{path.relative_to(ROOT)}:{node.lineno}", m) for m in PIP.findall(text)]
    for path in [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]:
        text = path.read_text(encoding="utf-8")
        found += [(str(path.relative_to(ROOT)), m) for m in PIP.findall(text)]
    return found


def test_every_install_hint_names_what_an_index_or_the_checkout_has() -> None:
    names, extras = known_packages()
    commands = install_commands()
    assert len(commands) > 10
    wrong = []
    for where, arguments in commands:
        for word in re.split(r"[#(;]", arguments)[0].split():
            word = word.strip("'\"`,:")
            word = word if word in (".", "./") else word.rstrip(".")  # a sentence's full stop
            if not word or word.startswith("-") or word in ("or", "in", "the", "its", "run", "there"):
                continue
            if word.startswith("."):  # the checkout: ./, '.[extra]', './[extra]'
                extra = re.fullmatch(r"\.?/?(?:\[([\w,-]+)\])?", word)
                if extra is None or (extra.group(1) and not set(extra.group(1).split(",")) <= extras):
                    wrong.append(f"{where}: {word}")
            elif _name(word) == "ipgen-pendulum":
                wrong.append(f"{where}: {word} (no index has it: install from the checkout)")
            elif _name(word) not in names | {"uv"}:
                wrong.append(f"{where}: {word} (not a requirement of pyproject.toml)")
    assert not wrong, wrong


def test_identify_without_casadi_says_the_command(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    """On main 1302ddc: "pip install 'ipgen-pendulum[identify]' (or pip install casadi)"."""
    from ipgen.command.cli import run

    monkeypatch.setitem(sys.modules, "casadi", None)  # import casadi fails as if not installed
    arguments = ["identify", "--preset", "qube_servo2", "--data", "x.csv", "--free", "J1"]
    arguments += ["-o", str(tmp_path)]
    status = run(arguments)
    err = capsys.readouterr().err
    assert status == 2 and err.count("\n") == 1, err
    assert "needs CasADi: pip install casadi (or, in ipgen's checkout, pip install './[identify]')" in err
    assert "ipgen-pendulum[" not in err


def test_import_ipgen_gym_without_gymnasium_says_the_command() -> None:
    """On main 1302ddc a bare `ModuleNotFoundError: No module named 'gymnasium'`."""
    code = (
        "import sys; sys.modules['gymnasium'] = None\n"
        "try:\n    import ipgen.gym\nexcept ModuleNotFoundError as e:\n    print(e, e.name)"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert done.stdout.startswith("ipgen.gym needs gymnasium >= 1.0: pip install gymnasium "), done.stdout
    assert done.stdout.strip().endswith("gymnasium"), done.stdout  # .name, for code that checks it


def test_a_missing_part_of_the_package_says_how_to_reinstall(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    """On main 1302ddc "reinstall ipgen": reinstall it how? From the checkout, with pip install ./."""
    from ipgen.errors import Error
    from ipgen.pipeline import simulator

    monkeypatch.setattr(simulator, "cmake_dir", lambda: tmp_path / "cmake")  # an installation without cpp/
    with pytest.raises(Error, match=r"reinstall ipgen from its checkout: pip install \./ \(run there"):
        simulator.simulator_sources()
    texts = [t for _, t in install_commands()]
    assert texts  # and no message says a bare "reinstall ipgen" any more
    for path in sorted((ROOT / "generator").rglob("*.py")):
        assert not re.search(r"reinstall ipgen\"", path.read_text(encoding="utf-8")), path
