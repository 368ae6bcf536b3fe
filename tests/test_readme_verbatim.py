"""Every block of the README, verbatim and in order, as a user who only installed the package
runs it: an installed wheel, a fresh virtualenv outside the checkout, a fresh HOME, a work folder
of its own; each example's outputs checked (the files it says it writes, what it prints).

How (slow by design: marker `fresh_venv`, `make test-slow`; about a minute unloaded, plus a
simulator compile for each model the machine has not built before):

- the wheel is built from a copy of the sources (`pip wheel --no-deps`: the build backend,
  setuptools, from pip's cache as for tests/test_package.py) and installed with `--no-deps` into
  a virtualenv made at the README's own path, `~/.venvs/ipgen`, in the fresh HOME; its
  dependencies come from the project's .venv through one .pth line (a "--system-site-packages"
  of the project's virtualenv: nothing downloaded, nothing copied). The install lines themselves
  (`pip install ./` with its dependencies) run verbatim in tests/test_package.py.
- the shell blocks run with that virtualenv activated (the README's `. ~/.venvs/ipgen/bin/activate`),
  file blocks are written to the file named on their first line, the Python block runs in the
  virtualenv's python; the apt-get line is checked (every package installed), not run (root, the
  dpkg lock).
- compiled simulators are shared with the machine's cache ($IPGEN_CACHE_DIR, else
  ~/.cache/ipgen of the real HOME): keyed by content, so the installed package's sources build
  the same binaries as the checkout's.

A fast variant (`test_readme_blocks_are_all_accounted_for`) checks without installing that every
block is one this test knows how to run and check."""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
import tomllib
from dataclasses import dataclass
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"


@dataclass(frozen=True)
class Block:
    language: str  # "" for an untagged block
    body: str

    @property
    def file_name(self) -> str | None:
        """The file a source block names on its first line (`// my_controller.cpp`)."""
        first = self.body.splitlines()[0] if self.body else ""
        match = re.fullmatch(r"\s*(?://|/\*|#)\s*([\w.-]+\.(?:cpp|c|toml|py))\s*(?:\*/)?\s*", first)
        return match.group(1) if match else None


def readme_blocks() -> list[Block]:
    text = README.read_text(encoding="utf-8")
    return [Block(lang, body) for lang, body in re.findall(r"^```(\w*)\n(.*?)^```$", text, flags=re.S | re.M)]


def inline_commands() -> list[str]:
    """Inline code spans outside the blocks that are complete `ipgen --option` commands."""
    text = re.sub(r"^```.*?^```$", "", README.read_text(encoding="utf-8"), flags=re.S | re.M)
    return [span for span in re.findall(r"`([^`\n]+)`", text) if re.fullmatch(r"ipgen --[\w-]+", span)]


APT = "apt-get install"
INSTALL = "pip install ./"


def kind(block: Block) -> str:
    """How the test handles a block: apt, install, shell, file, fragment, python, text."""
    if block.language == "text":
        return "text"
    if block.language in ("", "sh") and APT in block.body:
        return "apt"
    if block.language in ("", "sh") and INSTALL in block.body:
        return "install"
    if block.language in ("", "sh"):
        return "shell"
    if block.language == "python":
        return "python"
    if block.file_name is not None:
        return "file"
    if block.language == "toml":
        return "fragment"
    return "unknown"


# What each shell block must produce: (a line of the block, the files it must leave in the work
# folder). Every shell block of the README must have an entry (the fast test checks it).
OUTPUTS: dict[str, tuple[str, ...]] = {
    "ipgen --type rotary --links 3 -o out/": (
        "out/rotary3.hpp", "out/cdip.hpp", "out/rsip.hpp", "out/rsip.h", "out/rsip.md", "out/rsip.tex",
        "out/cdip_folded.hpp",
    ),
    "g++ -std=c++17": ("my_controller",),
    "ipgen run my_pendulum.toml -o out/": (
        "out/my_pendulum.csv", "out/my_pendulum.png", "out/my_pendulum.txt", "out/my_pendulum.cfg",
    ),
    "ipgen plot out/my_pendulum.csv -o picture.png": ("picture.png", "out/my_pendulum.gif"),
    "ipgen presets": (
        "out/qube_servo2.csv", "out/qube_servo2.png", "out/qube_servo2.txt", "out/qube_servo2.cfg",
        "my_rig.toml",
    ),
    "ipgen excite --preset qube_servo2": (
        "qube_experiment.toml", "out/qube_experiment.csv", "out/ident/qube_servo2_identified.toml",
        "out/ident/qube_servo2_identify.txt", "out/ident/qube_servo2_identify.png",
    ),
    "ipgen run --preset rdip_lqr -o out/": ("out/rdip_lqr.csv",),
    "gcc -std=c99": ("my_program",),
    "ipgen run --preset rsip_swingup -o out/": ("out/rsip_swingup.csv", "out/rsip_swingup.gif"),
    "pip install gymnasium": (),
}  # fmt: skip

# The optional features a README block uses, and the install line the README gives first (issue 49:
# a package of PyPI, not `ipgen-pendulum[extra]`, which no index has).
EXTRAS = {"ipgen identify": "pip install casadi", "import ipgen.gym": "pip install gymnasium"}


def expectation(block: Block) -> str:
    keys = [key for key in OUTPUTS if key in block.body]
    assert len(keys) == 1, f"no (or more than one) expected output for the README block:\n{block.body}"
    return keys[0]


def test_readme_blocks_are_all_accounted_for() -> None:
    """Fast: every README block is one the verbatim test runs or checks, every shell block has
    its expected outputs, every complete inline `ipgen --…` command is run too, and no block
    points at a file of the checkout that an installed package does not have."""
    blocks = readme_blocks()
    kinds = [kind(block) for block in blocks]
    assert "unknown" not in kinds, [b.body[:80] for b, k in zip(blocks, kinds, strict=True) if k == "unknown"]
    assert kinds.count("apt") == 1 and kinds.count("install") == 1 and kinds.count("python") >= 1
    shells = [block for block, k in zip(blocks, kinds, strict=True) if k == "shell"]
    assert sorted(expectation(block) for block in shells) == sorted(OUTPUTS)
    for block, k in zip(blocks, kinds, strict=True):
        if k == "text":
            assert not re.search(r"^\s*(ipgen|pip|gcc|g\+\+) ", block.body, flags=re.M), block.body
        if k in ("shell", "python", "file"):
            assert "scenes/" not in block.body, f"a checkout path in a README block:\n{block.body}"
    assert "ipgen --help" in inline_commands()  # each one the slow test runs too
    # the apt line runs unattended and installs only what is needed (issue 49)
    apt = next(b for b, k in zip(blocks, kinds, strict=True) if k == "apt").body
    assert " -y " in apt and " --no-install-recommends " in apt, apt
    # a fresh Debian image has no package lists: the install finds nothing without an update first
    assert apt.index("apt-get update") < apt.index(APT), apt
    # a block that needs an extra installs it first, with a command that works without this
    # distribution on an index; no hint names ipgen-pendulum[...] (issue 49)
    for use, install in EXTRAS.items():
        index = next(i for i, b in enumerate(blocks) if use in b.body)
        before = blocks[index].body.split(use, 1)[0] + (blocks[index - 1].body if index else "")
        assert install in before, f"the README block with {use!r} needs {install!r} before it"
    assert "ipgen-pendulum[" not in README.read_text()
    # the swing-up fragment is the table of the preset the README names after it
    fragment = next(b for b, k in zip(blocks, kinds, strict=True) if k == "fragment")
    # ...and what its comments call optional is (issue 49: trajectory's duration was listed as
    # optional; a trajectory swing-up without it is refused)
    optional = re.search(r"optional: ([^;\n]*)", fragment.body)
    assert optional is not None, fragment.body
    assert "duration" not in optional.group(1) and "duration (required)" in fragment.body
    table = tomllib.loads(fragment.body)["swingup"]
    preset = tomllib.loads((ROOT / "scenes" / "rsip_swingup.toml").read_text(encoding="utf-8"))["swingup"]
    assert all(preset[key] == value for key, value in table.items()), (table, preset)


# ---------------------------------------------------------------------------- the slow test


def project_site_packages() -> Path:
    import sysconfig

    return Path(sysconfig.get_paths()["purelib"])


def user_environment(home: Path, venv: Path) -> dict[str, str]:
    """A fresh user's environment: HOME, the virtualenv activated, nothing of the checkout."""
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV", "IPGEN_PYTHON")}
    venv_bin = str(Path(sys.prefix) / "bin")
    path = [p for p in env.get("PATH", "").split(os.pathsep) if p != venv_bin]
    cache = os.environ.get("IPGEN_CACHE_DIR") or str(Path.home() / ".cache" / "ipgen")
    env.update(
        HOME=str(home),
        VIRTUAL_ENV=str(venv),
        PATH=os.pathsep.join([str(venv / "bin"), *path]),
        IPGEN_CACHE_DIR=cache,  # the machine's compiled simulators (keyed by content)
        PIP_DISABLE_PIP_VERSION_CHECK="1",
        PIP_NO_INDEX="1",  # a README line that would download something fails here
        MPLBACKEND="Agg",
    )
    env.pop("XDG_CACHE_HOME", None)
    return env


def install_wheel(tmp: Path) -> tuple[Path, Path]:
    """(HOME, virtualenv) with the wheel of this checkout installed (module docstring)."""
    source = tmp / "source"
    ignore = shutil.ignore_patterns(".venv", "build", "out", ".git", "*.egg-info", "__pycache__", ".*cache")
    shutil.copytree(ROOT, source, ignore=ignore)
    dist = tmp / "dist"
    built = subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "-q", "--no-deps", "-w", str(dist), str(source)],
        capture_output=True, text=True,
    )  # fmt: skip
    assert built.returncode == 0, built.stdout[-2000:] + built.stderr[-2000:]
    wheel = next(dist.glob("ipgen_pendulum-*.whl"))
    shutil.rmtree(source)  # the installation must not need the sources
    home = tmp / "home"
    home.mkdir()
    venv = home / ".venvs" / "ipgen"
    subprocess.run([sys._base_executable, "-m", "venv", str(venv)], check=True)  # type: ignore[attr-defined]
    site = next((venv / "lib").glob("python3*/site-packages"))
    (site / "zz_project_dependencies.pth").write_text(f"{project_site_packages()}\n")
    installed = subprocess.run(
        [str(venv / "bin" / "python"), "-m", "pip", "install", "-q", "--no-deps", str(wheel)],
        capture_output=True, text=True, env=user_environment(home, venv),
    )  # fmt: skip
    assert installed.returncode == 0, installed.stderr[-2000:]
    return home, venv


def run_shell(script: str, work: Path, env: dict[str, str]) -> subprocess.CompletedProcess[str]:
    done = subprocess.run(
        ["bash", "-eu", "-o", "pipefail", "-c", script], cwd=work, capture_output=True, text=True, env=env
    )
    assert done.returncode == 0, f"$ {script}\n{done.stdout[-3000:]}\n{done.stderr[-3000:]}"
    assert "Traceback" not in done.stderr, done.stderr
    return done


def cdip_accelerations() -> list[float]:
    """The README's C++ program's numbers, from the derivation evaluated in Python (numpy)."""
    from ipgen.control.linear import dynamics
    from ipgen.model.system import System

    qdd = dynamics(System("classical", 2)).forward_dynamics(
        [0.0, 0.1, 0.0], [0.0, 0.0, 0.0], 0.0, [0.3, 0.275, 0.275, 0.0, 0.5, 0.5, 0.3, 0.1, 0.1, 9.81]
    )
    return [float(v) for v in qdd]


def rsip_euler_angle() -> float:
    """The README's C program's link angle after 100 explicit Euler steps of 1 ms, in double."""
    import numpy as np

    from ipgen.control.linear import dynamics
    from ipgen.model.system import System

    model = dynamics(System("rotary", 1))
    q, qd = np.array([0.0, 0.1]), np.zeros(2)
    params = [0.5, 0.275, 0.6, 0.5, 0.3, 0.011458, 9.81]
    for _ in range(100):
        qdd = model.forward_dynamics(q, qd, 0.0, params)
        q, qd = q + 0.001 * qd, qd + 0.001 * qdd
    return float(q[1])


def check_block(key: str, done: subprocess.CompletedProcess[str], work: Path, venv: Path) -> None:
    """What the README says each block makes, beyond its files."""
    from PIL import Image

    if key.startswith("ipgen --type rotary"):
        assert "replaced" not in done.stdout, done.stdout  # no command overwrote another's header
        assert "SPECIALISED" in (work / "out" / "cdip_folded.hpp").read_text()
    elif key.startswith("g++"):
        ran = subprocess.run([str(work / "my_controller")], capture_output=True, text=True, check=True)
        numbers = [float(v) for v in re.fullmatch(r"qdd = (\S+) (\S+) (\S+)\n", ran.stdout).groups()]  # type: ignore[union-attr]
        assert numbers == pytest.approx(cdip_accelerations(), abs=2e-6), ran.stdout
    elif key.startswith("ipgen run my_pendulum"):
        assert (work / "out" / "my_pendulum.csv").read_text().startswith("t,theta0,theta1,theta2,dtheta0,")
        assert "~10 s" not in done.stderr and "first run" not in done.stderr
    elif key.startswith("ipgen plot"):
        width, height = Image.open(work / "out" / "my_pendulum.gif").size
        assert width > 420 and height > 216
    elif key == "ipgen presets":
        listing = done.stdout
        assert re.search(r"^qube_servo2 +\(rotary, 1 link\) +\S+", listing, flags=re.M), listing
        assert "values from: Quanser setup file qube2_rotpen_param.m" in listing
        # the presets come from the installed package, not from any checkout
        shown = Path(re.search(r"^qube_servo2 .* (/\S+\.toml)$", listing, flags=re.M).group(1))  # type: ignore[union-attr]
        assert shown.is_relative_to(venv) and shown.name == "qube_servo2.toml", shown
        assert (work / "my_rig.toml").read_text() == shown.read_text()
    elif key.startswith("ipgen excite"):
        report = (work / "out" / "ident" / "qube_servo2_identify.txt").read_text()
        assert "J1" in report and "kt" in report
        header = (work / "out" / "qube_experiment.csv").read_text().splitlines()[0]
        assert header.startswith("t,theta0,theta1,") and header.endswith(",u")
    elif key.startswith("ipgen run --preset rdip_lqr"):
        assert (work / "out" / "rdip_lqr.csv").read_text().splitlines()[0].endswith(",u")
    elif key.startswith("gcc"):
        ran = subprocess.run([str(work / "my_program")], capture_output=True, text=True, check=True)
        match = re.fullmatch(r"link angle after 0\.1 s: (\S+) rad\n", ran.stdout)
        assert match is not None, ran.stdout
        assert float(match.group(1)) == pytest.approx(rsip_euler_angle(), abs=2e-4)
        assert float(match.group(1)) > 0.1  # it falls
    elif key.startswith("ipgen run --preset rsip_swingup"):
        rows = (work / "out" / "rsip_swingup.csv").read_text().splitlines()
        assert rows[0].endswith(",phase") and rows[-1].endswith(",hold")


@pytest.mark.fresh_venv
def test_every_readme_block_runs_verbatim_from_an_installed_wheel(tmp_path: Path) -> None:
    from cxx import require_toolchain

    require_toolchain()
    home, venv = install_wheel(tmp_path)
    env = user_environment(home, venv)
    work = tmp_path / "work"  # outside the checkout
    work.mkdir()
    done = run_shell("ipgen --version", work, env)
    assert re.fullmatch(r"ipgen, version \S+\n", done.stdout)
    ran = []
    for block in readme_blocks():
        k = kind(block)
        if k == "apt":  # checked, not run: it needs root and the dpkg lock
            packages = [word for word in block.body.split(APT, 1)[1].split() if not word.startswith("-")]
            status = subprocess.run(
                ["dpkg-query", "-W", "-f=${Status}\n", *packages], capture_output=True, text=True
            )
            assert status.stdout.count("install ok installed") == len(packages), status.stdout
        elif k == "file":
            (work / block.file_name).write_text(block.body, encoding="utf-8")  # type: ignore[operator]
        elif k == "python":
            python = str(venv / "bin" / "python")
            out = subprocess.run(
                [python, "-c", block.body], cwd=work, capture_output=True, text=True, env=env
            )
            assert out.returncode == 0, out.stderr[-3000:]
        elif k == "shell":
            key = expectation(block)
            done = run_shell(block.body, work, env)
            for name in OUTPUTS[key]:
                assert (work / name).is_file(), f"{name} missing after:\n{block.body}\n{done.stderr[-2000:]}"
            check_block(key, done, work, venv)
            ran.append(key)
    assert sorted(ran) == sorted(OUTPUTS)
    for command in inline_commands():
        done = run_shell(command, work, env)
        assert done.stdout.strip()
    # The README's install lines for the extras ran above, with the packages present and no index
    # (PIP_NO_INDEX): pip only confirms them. Each one again, said so.
    for hint in EXTRAS.values():
        done = run_shell(hint, work, env)
        assert "Requirement already satisfied" in done.stdout, done.stdout
    listed = run_shell("pip list --format=freeze", work, env).stdout
    assert not re.search(r"^ipgen==", listed, flags=re.M), listed
