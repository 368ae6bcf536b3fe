"""The Makefile's install and build steps, read by make itself (`make -n`, nothing run) and as text:
the defects an audit found (2026-12-01) stay mended."""

from __future__ import annotations

import re
import shutil
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
MAKEFILE = ROOT / "Makefile"

pytestmark = pytest.mark.skipif(shutil.which("make") is None, reason="needs GNU make")


def dry_run(*arguments: str) -> list[str]:
    """The commands `make -n` would run for `arguments`, one per line (nothing is run)."""
    done = subprocess.run(
        ["make", "--no-print-directory", "-n", *arguments],
        cwd=ROOT,
        capture_output=True,
        text=True,
        check=True,
    )
    return done.stdout.splitlines()


def recipes() -> dict[str, str]:
    """Each rule's target (its first name) and its recipe lines, from the Makefile's text."""
    rules: dict[str, list[str]] = {}
    target = None
    for line in MAKEFILE.read_text(encoding="utf-8").splitlines():
        if line.startswith("\t") and target is not None:
            rules[target].append(line)
        elif re.match(r"^[\w$(). /-]+:(?!=)", line) and not line.startswith((".PHONY", "define")):
            target = line.split(":", 1)[0].split()[0]
            rules.setdefault(target, [])
        elif not line.startswith("\t"):
            target = None
    return {name: "\n".join(lines) for name, lines in rules.items()}


def test_the_simulator_is_configured_with_this_runs_flags_before_pytest_uses_it() -> None:
    """A build folder configured with other flags (make stability's -O3) was switched back by
    test-cpp's configure while pytest ran: the simulator and ipsim's library were rebuilt under
    it. ipsim-simulate now configures (with this run's flags) before it builds."""
    lines = dry_run("ipsim-simulate", "CMAKE_OPT=-O1")
    build = max(
        i for i, line in enumerate(lines) if line.startswith("cmake --build") and "ipsim_simulate" in line
    )
    configure = [
        i
        for i, line in enumerate(lines)
        if line.startswith("cmake -S") and "IPGEN_WITH_GENERATOR=AUTO" in line
    ]
    assert configure and configure[-1] < build, lines
    assert "-DCMAKE_CXX_FLAGS_RELEASE=-O1 -DNDEBUG" in lines[configure[-1]], lines[configure[-1]]


def test_only_the_deps_targets_call_apt_get_each_after_the_one_before() -> None:
    """Under make -j bench three benchmarks ran apt-get at once (dpkg's lock refuses the others):
    apt-get is called only by the deps-* targets, which form one chain."""
    rules = recipes()
    callers = sorted(name for name, recipe in rules.items() if "apt_install" in recipe or "apt-get" in recipe)
    assert callers == ["deps-bench-arm", "deps-bench-time", "deps-build", "deps-docs"], callers
    text = MAKEFILE.read_text(encoding="utf-8")
    assert re.search(r"^deps-docs: deps-build$", text, flags=re.M)
    assert re.search(r"^deps-bench-time: deps-build$", text, flags=re.M)
    assert re.search(r"^deps-bench-arm: deps-bench-time$", text, flags=re.M)


def test_apt_get_keeps_its_non_interactive_setting_under_sudo() -> None:
    """`VAR=x sudo cmd` loses VAR (sudo resets the environment): the setting goes after sudo."""
    define = MAKEFILE.read_text(encoding="utf-8").split("define apt_install", 1)[1].split("endef", 1)[0]
    assert "$(SUDO) env DEBIAN_FRONTEND=noninteractive apt-get install" in define, define


def test_the_two_bench_extras_install_one_after_the_other() -> None:
    """Two pip installs into one virtualenv at once (make -j bench) could leave it broken."""
    text = MAKEFILE.read_text(encoding="utf-8")
    rule = re.search(r"^\$\(VENV\)/\.workprecision-installed:(.*)$", text, flags=re.M)
    assert rule and "$(VENV)/.bench-installed" in rule.group(1), rule


def test_the_benchmarks_that_write_one_page_take_turns() -> None:
    rules = recipes()
    for name in ("bench-mpc", "bench-mpc-m4"):
        assert "flock docs/bench/mpc.md" in rules[name], rules[name]


def test_make_bench_finds_dfkis_recordings_in_a_fresh_clone() -> None:
    """bench-dfki read them from outside the checkout: make bench failed in a fresh clone."""
    text = MAKEFILE.read_text(encoding="utf-8")
    folder = re.search(r"^DFKI_RECORDINGS \?= (\S+)$", text, flags=re.M)
    assert folder, "DFKI_RECORDINGS has no default"
    path = ROOT / folder.group(1)
    assert path.resolve().is_relative_to(ROOT), path
    names = ("00", "01", "02", "03", "04", "05", "06", "12", "13")
    for name in names:
        assert (path / f"design_C.0_20220914_sys_id_trajectory_{name}.csv.gz").is_file(), name
    assert (path / "LICENSE").is_file()


def test_make_clean_leaves_a_users_files_in_out() -> None:
    """The README's commands write into out/, where a user's files may be: clean removes only
    what make wrote there (out/demo)."""
    removals = [line for line in dry_run("clean") if line.startswith("rm ")]
    assert removals == ["rm -rf build out/demo"], removals


def test_an_interrupted_virtualenv_is_made_again() -> None:
    """`test -x .venv/bin/python` accepted a .venv whose creation stopped before pip."""
    recipe = recipes()["$(VENV)/.installed"]
    assert "$(PY) -m pip --version >/dev/null 2>&1 || $(PYTHON) -m venv --clear $(VENV)" in recipe, recipe
