"""A command that fails or is interrupted after making its output folder leaves no empty folder
behind (common/files.py `removed_if_left_empty`): generate, run (a first compile that fails),
plot, identify and sweep, for -o folders nested at any depth under one that exists. A folder with
anything in it, every folder that existed before, and one another process made meanwhile (a
concurrent run into the same new -o) stays; a run whose folder another one removed makes it again."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from ipgen.command.cli import run
from ipgen.common import files

ROOT = Path(__file__).resolve().parent.parent
# What may stop a command after it made its folder: a refusal, Ctrl-C or SIGTERM, a file system error.
FAILURES = (files.OutputError, KeyboardInterrupt, OSError)


def _tree(base: Path) -> list[str]:
    return sorted(str(p.relative_to(base)) for p in base.rglob("*"))


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(
    existing=st.integers(0, 2),
    new=st.integers(1, 3),
    failure=st.sampled_from((None, *FAILURES)),  # a class: a new exception each example
    written=st.one_of(st.none(), st.integers(0, 2)),
)
def test_the_folders_a_failed_block_made_empty_are_removed(
    tmp_path_factory: pytest.TempPathFactory, existing: int, new: int, failure: BaseException | None,
    written: int | None,
) -> None:  # fmt: skip
    base = tmp_path_factory.mktemp("tree")
    have = base.joinpath(*(f"e{k}" for k in range(existing)))
    have.mkdir(parents=True, exist_ok=True)
    (have / "mine.txt").write_text("keep")
    target = have.joinpath(*(f"n{k}" for k in range(new)))
    made = [have.joinpath(*(f"n{k}" for k in range(j + 1))) for j in range(new)]  # outermost first
    kept_file = None
    try:
        with files.removed_if_left_empty():
            files.prepare_directory(target)
            if written is not None:
                kept_file = made[min(written, new - 1)] / "result.txt"
                kept_file.write_text("written")
            if failure is not None:
                raise failure("stopped")
    except (OSError, KeyboardInterrupt, files.OutputError) as raised:
        assert type(raised) is failure  # the failure goes on, as it was
    assert (have / "mine.txt").read_text() == "keep"
    if failure is None:
        assert target.is_dir()
        return
    for folder in made:  # a folder stays exactly when the written file is in it or below it
        assert folder.is_dir() == (kept_file is not None and kept_file.is_relative_to(folder))
    assert have.is_dir()


def _fail_inside(monkeypatch: pytest.MonkeyPatch, module: str, name: str, failure: BaseException) -> None:
    def failing(*args: object, **kwargs: object) -> None:
        raise failure

    monkeypatch.setattr(f"{module}.{name}", failing)


@pytest.mark.parametrize(
    "failure", [files.OutputError("refused"), KeyboardInterrupt()], ids=("refused", "interrupt")
)
def test_generate_leaves_no_folder(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, failure: BaseException
) -> None:
    _fail_inside(monkeypatch, "ipgen.pipeline.generate", "write_files", failure)
    out = tmp_path / "a" / "b"
    status = run(["--type", "rotary", "--links", "1", "-o", str(out)])
    assert status != 0
    assert _tree(tmp_path) == []


def test_plot_and_animate_leave_no_folder(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from test_output_paths_properties import _csv  # a short run's CSV

    csv = _csv(tmp_path)
    _fail_inside(monkeypatch, "ipgen.common.files", "write_file", files.OutputError("disk full"))
    for command, suffix in (("plot", ".png"), ("animate", ".gif")):
        out = tmp_path / command / "deeper" / f"run{suffix}"
        assert run([command, str(csv), "-o", str(out)]) != 0
        assert not (tmp_path / command).exists()
    assert _tree(tmp_path) == ["run.csv"]


def test_identify_leaves_no_folder(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    import math

    import numpy as np
    from test_identify import QUBE, measure, qube_setup, truth_of, volts, write_csv

    from ipgen.experiment.scene import load_scene

    setup = qube_setup()
    truth = truth_of(setup, {"delta1": 0.7, "kt": 0.93})
    t = np.arange(0.0, 2.5, 1 / 250)
    data = measure(truth, t, volts, np.array([0.0, math.pi + 0.1, 0, 0]), 0.002, np.random.default_rng(4))
    frame = load_scene(QUBE).coordinates
    state = np.hstack([data.theta, np.zeros_like(data.theta)])
    measured = np.array([frame.to_user(x, setup.system.links) for x in state])[:, : setup.system.dof]
    csv = tmp_path / "rig.csv"
    write_csv(csv, t, measured, data.u)
    _fail_inside(monkeypatch, "ipgen.pipeline.identify", "write_files", KeyboardInterrupt())
    out = tmp_path / "fit" / "here"
    assert run(["identify", "--scene", str(QUBE), "--data", str(csv), "--free", "kt", "-o", str(out)]) == 130
    assert not (tmp_path / "fit").exists()


def test_identify_of_torques_leaves_no_folder(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    data = ROOT / "tests" / "data" / "dfki" / "design_C.0_20220914_sys_id_trajectory_02_excerpt.csv.gz"
    failure = files.OutputError("disk full")
    _fail_inside(monkeypatch, "ipgen.pipeline.identify_torques", "write_files", failure)
    out = tmp_path / "dfki" / "fit"
    assert run(["identify", "--preset", "dfki_c0", "--data", str(data), "-o", str(out)]) != 0
    assert not (tmp_path / "dfki").exists()


def test_a_sweep_stopped_before_its_first_run_leaves_no_folder(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    _fail_inside(monkeypatch, "ipgen.sweeps.runner", "_run", KeyboardInterrupt())
    monkeypatch.setattr("ipgen.sweeps.runner.prepare", lambda source: _Prepared())
    out = tmp_path / "sweeps" / "first"
    status = run(["sweep", "--preset", "rsip_lqr", "--vary", "initial.theta[1]=0.1,0.2", "-o", str(out)])
    assert status == 130
    assert not (tmp_path / "sweeps").exists()


class _Prepared:
    """What `runner.prepare` hands on: the model's name and header (no simulator is built here)."""

    model = "rsip"
    header = ()


FAILING_CXX = "#!/bin/sh\necho 'fake compiler: no' >&2\nexit 1\n"


def test_a_run_whose_first_compile_fails_leaves_no_folder(tmp_path: Path) -> None:
    compiler = tmp_path / "fail-c++"
    compiler.write_text(FAILING_CXX)
    compiler.chmod(0o755)
    cache = str(tmp_path / "cache")
    env = {
        **os.environ,
        "CXX": str(compiler),
        "CC": str(compiler),
        "IPGEN_CACHE_DIR": cache,
        "IPGEN_SIMULATOR": "",
    }
    out = tmp_path / "results" / "rsip"
    done = subprocess.run(
        [sys.executable, "-m", "ipgen", "run", "--preset", "rsip_lqr", "-o", str(out), "--no-plot"],
        env=env, capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    assert done.returncode != 0, done.stdout
    assert "Traceback" not in done.stderr
    assert not (tmp_path / "results").exists()


def test_a_fixed_chains_generation_leaves_no_folder(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    _fail_inside(monkeypatch, "ipgen.pipeline.fixed_generate", "write_files", KeyboardInterrupt())
    out = tmp_path / "dfki" / "headers"
    assert run(["--scene", str(ROOT / "scenes" / "rigs" / "dfki_c0.toml"), "-o", str(out)]) == 130
    assert not (tmp_path / "dfki").exists()


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(new=st.integers(1, 3), theirs=st.integers(0, 2), dots=st.booleans())
def test_only_the_folders_this_command_made_are_removed(
    tmp_path_factory: pytest.TempPathFactory, new: int, theirs: int, dots: bool
) -> None:
    """Another process makes the folder this command wants, or one on its way, while the command
    runs (its compile): the command's failure removes none of that process's folders. And a path
    through `..` (new/../out) leaves neither `new` nor `out` (a review found `new` left)."""
    base = tmp_path_factory.mktemp("race")
    target = base.joinpath(*(f"n{k}" for k in range(new)))
    if dots:
        target = base / "new" / ".." / target.relative_to(base)
    theirs = min(theirs, new)
    other = base.joinpath(*(f"n{k}" for k in range(theirs)))  # theirs = 0: none
    with pytest.raises(KeyboardInterrupt), files.removed_if_left_empty():
        if theirs:
            other.mkdir(parents=True)  # the other process, before this one gets there
        files.prepare_directory(target)
        raise KeyboardInterrupt
    expected = [str(Path(*(f"n{k}" for k in range(j + 1)))) for j in range(theirs)]  # theirs stay
    assert _tree(base) == expected


def test_a_run_whose_folder_another_run_removed_makes_it_again(tmp_path: Path) -> None:
    """Run B into a new -o that run A made; A fails and removes it (empty) while B compiles: B makes
    it again and writes its files (it wrote into a folder that was gone: exit 2)."""
    from test_run import fake_compiler, single_scene

    env = {**os.environ, **fake_compiler(tmp_path), "FAKE_SECONDS": "1"}
    out = tmp_path / "results"
    out.mkdir()  # as run A made it
    process = subprocess.Popen(
        [sys.executable, "-m", "ipgen", "run", str(single_scene(tmp_path)), "-o", str(out), "--no-plot"],
        env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    while not (tmp_path / "count").exists():  # B is compiling
        assert process.poll() is None, process.communicate()
    out.rmdir()  # A's clean-up
    _, err = process.communicate(timeout=120)
    assert process.returncode == 0, err
    assert (out / "single_0_1.csv").is_file()


def test_a_folder_made_in_an_inner_block_that_succeeded_goes_with_the_outer_failure(tmp_path: Path) -> None:
    """Blocks nest (a run generates its model inside its own block): a folder the inner one made,
    left empty, is removed when the outer one fails later."""
    target = tmp_path / "a" / "b"
    with pytest.raises(KeyboardInterrupt), files.removed_if_left_empty():
        with files.removed_if_left_empty():
            files.prepare_directory(target)
        raise KeyboardInterrupt
    assert _tree(tmp_path) == []
