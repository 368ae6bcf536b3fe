"""`ipgen run --no-plot` and the plan a run keeps in the cache (pipeline/run_plan.py): a cached run
checks, derives and designs nothing again, and draws no PNG when asked not to.

The runs use the rotary single pendulum (rotary1), whose simulator the test cache usually holds
(tests/conftest.py); a fresh cache compiles it once.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
from cxx import require_toolchain
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from ipgen.command.cli import run
from ipgen.pipeline import job
from ipgen.pipeline.run_plan import FOLDER, RunPlan, load_plan, plan_key, store_plan

ROOT = Path(__file__).resolve().parents[1]
SCENE = """\
[system]
type = "rotary"
links = 1

[parameters]
m = [0.2, 0.1]
l = [0.2, 0.3]
delta = [0.01, 0.001]

[initial]
theta = [0, THETA1]

[simulation]
t_end = 0.2
"""
# A scene with an LQR controller: a cached run designs no gain again (no sympy, no scipy).
CONTROLLED = SCENE + '\n[controller]\nkind = "lqr"\n'


def cache_dir() -> Path:
    return Path(os.environ["IPGEN_CACHE_DIR"])  # set for the whole run by tests/conftest.py


def scene_file(folder: Path, text: str = SCENE, theta: str = "0.05", name: str = "single") -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / f"{name}.toml"
    path.write_text(text.replace("THETA1", theta))
    return path


def test_no_plot_writes_no_png_and_imports_no_matplotlib(tmp_path: Path) -> None:
    """--no-plot: the CSV, .cfg and summary, no PNG, and matplotlib never imported; without it the
    same run draws the PNG."""
    require_toolchain()
    scene = scene_file(tmp_path)
    out = tmp_path / "out"
    program = (
        "import sys; from ipgen.command.cli import run; "
        f"status = run(['run', {str(scene)!r}, '-o', {str(out)!r}, '--no-plot']); "
        "print(status, 'matplotlib' in sys.modules)"
    )
    done = subprocess.run([sys.executable, "-c", program], capture_output=True, text=True, env=os.environ)
    assert done.returncode == 0, done.stderr
    assert done.stdout.split()[-2:] == ["0", "False"], done.stdout
    assert sorted(path.name for path in out.iterdir()) == ["single.cfg", "single.csv", "single.txt"]
    assert "single.png" not in done.stdout
    assert run(["run", str(scene), "-o", str(out)]) == 0
    assert (out / "single.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_no_plot_leaves_a_png_there_as_it_is(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """A file named like the PNG is neither checked nor replaced by a run without the plot."""
    require_toolchain()
    scene = scene_file(tmp_path)
    out = tmp_path / "out"
    out.mkdir()
    (out / "single.png").write_text("the user's notes, not a PNG")
    assert run(["run", str(scene), "-o", str(out), "--no-plot"]) == 0
    assert (out / "single.png").read_text() == "the user's notes, not a PNG"
    assert "single.png" not in capsys.readouterr().out
    assert run(["run", str(scene), "-o", str(out)]) == 2  # with the plot: the user's file is refused
    assert "single.png" in capsys.readouterr().err


def test_run_help_names_no_plot() -> None:
    done = subprocess.run(
        [sys.executable, "-m", "ipgen", "run", "--help"], capture_output=True, text=True, env=os.environ
    )
    assert done.returncode == 0
    assert "--no-plot" in done.stdout and "SCENE.png" in " ".join(done.stdout.split())


def test_a_second_run_takes_the_plan_from_the_cache(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The second run of an unchanged scene neither checks the scene nor derives the model nor
    designs the gain (job.plan and job.run are not called) and writes the same files; an edited
    scene is planned again."""
    require_toolchain()
    scene = scene_file(tmp_path, CONTROLLED)
    first, second = tmp_path / "first", tmp_path / "second"
    assert run(["run", str(scene), "-o", str(first), "--no-plot"]) == 0
    key = plan_key(scene, False)
    assert key is not None and (cache_dir() / FOLDER / f"{key}.json").is_file()

    def refused(*args: object, **kwargs: object) -> None:
        raise AssertionError("planned again")

    with monkeypatch.context() as patch:
        patch.setattr(job, "plan", refused)
        patch.setattr(job, "run", refused)
        assert run(["run", str(scene), "-o", str(second), "--no-plot"]) == 0
    for suffix in ("cfg", "csv"):
        assert (second / f"single.{suffix}").read_bytes() == (first / f"single.{suffix}").read_bytes()
    assert "controller.gain" in (second / "single.cfg").read_text()  # designed by the first run

    calls: list[object] = []
    original = job.plan
    monkeypatch.setattr(job, "plan", lambda *a, **k: calls.append(a) or original(*a, **k))
    scene_file(tmp_path, CONTROLLED, theta="-0.05")  # edited: another key
    assert plan_key(scene, False) != key
    assert run(["run", str(scene), "-o", str(second), "--no-plot"]) == 0
    assert len(calls) == 1
    assert (second / "single.cfg").read_text() != (first / "single.cfg").read_text()


def test_the_key_follows_the_scene_its_path_and_force(tmp_path: Path) -> None:
    scene = scene_file(tmp_path)
    key = plan_key(scene, False)
    assert key is not None and key == plan_key(scene, False)
    assert plan_key(scene, True) != key
    copy = scene_file(tmp_path / "elsewhere")
    assert plan_key(copy, False) != key  # the path is part of it (messages name the file)
    scene.write_text(scene.read_text() + "\n")
    assert plan_key(scene, False) != key
    assert plan_key(tmp_path / "missing.toml", False) is None
    assert plan_key(tmp_path, False) is None  # a folder


PLAN = RunPlan(
    name="rotary1",
    stem="single",
    type="rotary",
    links=1,
    angles="absolute",
    zero="upright",
    positive="clockwise",
    unit=None,
    warnings=("a warning \udcff",),
    cfg="type = rotary\n",
    sources={"rotary1.h": "/* h */", "rotary1_model.c": "/* c */"},
)


def test_a_plan_is_kept_and_read_back(tmp_path: Path) -> None:
    store_plan(tmp_path, "k", PLAN)
    assert load_plan(tmp_path, "k") == PLAN
    assert load_plan(tmp_path, "other") is None


@pytest.mark.parametrize(
    "damage",
    [
        lambda text: text[: len(text) // 2],  # truncated
        lambda text: text.replace("rotary1_model.c", "rotary2_model.c"),  # altered: checksum differs
        lambda text: "\xff not json",
        lambda text: "[]",
    ],
)
def test_a_damaged_entry_is_ignored(tmp_path: Path, damage: object) -> None:
    store_plan(tmp_path, "k", PLAN)
    entry = tmp_path / FOLDER / "k.json"
    entry.write_text(damage(entry.read_text()))  # type: ignore[operator]
    assert load_plan(tmp_path, "k") is None


@pytest.mark.parametrize(
    ("field", "value"),
    [
        ("links", 0),
        ("links", True),
        ("links", "1"),
        ("angles", "sideways"),  # no such convention
        ("sources", {"../escape.c": "x"}),
        ("sources", {"a.c": 1}),
        ("warnings", "one"),
        ("unit", 3),
        ("cfg", None),
    ],
)
def test_an_entry_of_the_wrong_kind_is_ignored(tmp_path: Path, field: str, value: object) -> None:
    """Values of the wrong kind, even under a matching checksum, are not a plan."""
    import hashlib

    store_plan(tmp_path, "k", PLAN)
    entry = tmp_path / FOLDER / "k.json"
    record = json.loads(entry.read_text())
    record["plan"][field] = value
    record["sha256"] = hashlib.sha256(json.dumps(record["plan"], sort_keys=True).encode()).hexdigest()
    entry.write_text(json.dumps(record))
    assert load_plan(tmp_path, "k") is None


def test_a_damaged_entry_is_planned_again_and_replaced(tmp_path: Path) -> None:
    require_toolchain()
    scene = scene_file(tmp_path)
    out = tmp_path / "out"
    assert run(["run", str(scene), "-o", str(out), "--no-plot"]) == 0
    key = plan_key(scene, False)
    assert key is not None
    entry = cache_dir() / FOLDER / f"{key}.json"
    entry.write_text("{}")
    assert run(["run", str(scene), "-o", str(out), "--no-plot"]) == 0
    assert load_plan(None, key) is not None


def test_a_refused_scene_is_not_kept(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    scene = scene_file(tmp_path, SCENE.replace("links = 1", "links = 0"))
    assert run(["run", str(scene), "-o", str(tmp_path / "out"), "--no-plot"]) == 2
    assert "links" in capsys.readouterr().err
    key = plan_key(scene, False)
    assert key is not None and not (cache_dir() / FOLDER / f"{key}.json").exists()


def test_a_cached_plan_still_checks_the_outputs(tmp_path: Path) -> None:
    """A run from a cached plan refuses a CSV the simulator did not write, as any run does."""
    require_toolchain()
    scene = scene_file(tmp_path)
    out = tmp_path / "out"
    assert run(["run", str(scene), "-o", str(out), "--no-plot"]) == 0
    (out / "single.csv").write_text("the user's data\n")
    assert run(["run", str(scene), "-o", str(out), "--no-plot"]) == 2
    assert (out / "single.csv").read_text() == "the user's data\n"


def test_a_cached_run_without_the_plot_imports_none_of_the_heavy_libraries(tmp_path: Path) -> None:
    """The cheap path: a run whose simulator and plan are cached imports neither the scene's
    checks (pydantic) nor the derivation and design (sympy, flint, scipy) nor matplotlib."""
    require_toolchain()
    scene = scene_file(tmp_path, CONTROLLED)
    out = tmp_path / "out"
    heavy = ("pydantic", "sympy", "flint", "scipy", "numpy", "matplotlib", "ipgen.experiment.scene")
    program = (
        "import sys; from ipgen.command.cli import run; "
        f"status = run(['run', {str(scene)!r}, '-o', {str(out)!r}, '--no-plot']); "
        f"print(status, *[name for name in {heavy!r} if name in sys.modules])"
    )
    first = subprocess.run([sys.executable, "-c", program], capture_output=True, text=True, env=os.environ)
    assert first.returncode == 0, first.stderr
    assert "scipy" in first.stdout.split()  # the first run designs the LQR gain
    again = subprocess.run([sys.executable, "-c", program], capture_output=True, text=True, env=os.environ)
    assert again.returncode == 0, again.stderr
    assert again.stdout.split()[-1:] == ["0"], again.stdout


def _plan_scene(folder: Path) -> Path:
    """The acrobot's swing-up preset with its plan CSV beside it, shortened to its 4 s plan."""
    folder.mkdir(parents=True, exist_ok=True)
    rigs = ROOT / "scenes" / "rigs"
    (folder / "acrobot_swingup.plan.csv").write_bytes((rigs / "acrobot_swingup.plan.csv").read_bytes())
    text = (rigs / "acrobot_swingup.toml").read_text(encoding="utf-8")
    text = text.replace("\nt_end = 10.0\n", "\nt_end = 4.0\n").replace(
        "\nsample = 0.002\n", "\nsample = 0.01\n"
    )
    assert "\nt_end = 4.0\n" in text and "\nsample = 0.01\n" in text
    scene = folder / "acrobot_swingup.toml"
    scene.write_text(text, encoding="utf-8")
    return scene


def test_the_key_follows_the_plan_file_a_scene_names(tmp_path: Path) -> None:
    """A fixed chain's `[swingup] plan` CSV is part of the key: edited or deleted, it is another
    key (a folder in its place counts as deleted); rewritten with the same bytes, the same."""
    scene = _plan_scene(tmp_path)
    plan = tmp_path / "acrobot_swingup.plan.csv"
    key = plan_key(scene, False)
    assert key is not None
    plan.write_bytes(plan.read_bytes())
    assert plan_key(scene, False) == key
    keys = {key}
    plan.write_bytes(plan.read_bytes().replace(b"\n", b"\n ", 1))
    keys.add(plan_key(scene, False))
    plan.unlink()
    missing = plan_key(scene, False)
    keys.add(missing)
    assert len(keys) == 3 and None not in keys
    plan.mkdir()  # not a file: as if missing (the run refuses both)
    assert plan_key(scene, False) == missing


def test_a_plan_file_edited_after_a_run_is_read_again(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A cached run of a scene whose plan CSV has since been broken or deleted reads it again:
    the run is refused in one line instead of simulating the old plan."""
    require_toolchain()
    scene = _plan_scene(tmp_path)
    plan = tmp_path / "acrobot_swingup.plan.csv"
    assert run(["run", str(scene), "-o", str(tmp_path / "first"), "--no-plot"]) == 0
    capsys.readouterr()
    plan.write_text("garbage, not a plan\n", encoding="utf-8")
    assert run(["run", str(scene), "-o", str(tmp_path / "second"), "--no-plot"]) == 2
    assert "expected columns t, u1..u1" in capsys.readouterr().err
    plan.unlink()
    assert run(["run", str(scene), "-o", str(tmp_path / "third"), "--no-plot"]) == 2
    assert "acrobot_swingup.plan.csv" in capsys.readouterr().err
    assert not (tmp_path / "second" / "acrobot_swingup.csv").exists()


def test_the_plan_a_scene_names_is_never_written_over_not_even_with_force(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A scene whose plan CSV has the name of the run's own CSV (acro.toml, plan = "acro.csv"): the
    run refuses in one line, with --force too, and the plan is unchanged (--force replaced it by
    the trajectory, and the next run found no plan)."""
    scene = _plan_scene(tmp_path)
    plan = tmp_path / "acrobot_swingup.plan.csv"
    renamed = tmp_path / "acro.csv"
    plan.rename(renamed)
    text = scene.read_text(encoding="utf-8").replace('plan = "acrobot_swingup.plan.csv"', 'plan = "acro.csv"')
    (tmp_path / "acro.toml").write_text(text, encoding="utf-8")
    before = renamed.read_bytes()
    for force in ([], ["--force"]):
        assert run(["run", str(tmp_path / "acro.toml"), "-o", str(tmp_path), "--no-plot", *force]) == 2
        err = capsys.readouterr().err
        assert "acro.csv" in err and ("is one of the command's inputs" in err or "--force" in err), err
        assert renamed.read_bytes() == before


@pytest.mark.parametrize("when", ["after the simulator", "while plotting"])
def test_an_interrupted_run_says_which_files_are_new(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str], when: str
) -> None:
    """A second run interrupted once its simulator has written the new CSV (its rename done, the
    signal just after) or while it plots: the message names the CSV among the files written and
    the earlier run's PNG and summary still there (it said "no CSV written", or "no file was
    written"), exit 130."""
    require_toolchain()
    from ipgen.pipeline import run as run_module

    scene = scene_file(tmp_path)
    out = tmp_path / "out"
    assert run(["run", str(scene), "-o", str(out)]) == 0
    scene_file(tmp_path, theta="0.2")
    if when == "after the simulator":
        real = run_module._simulate

        def simulated_then_interrupted(command, progress=lambda t, end: None):
            real(command, progress)
            raise KeyboardInterrupt  # the signal just after the simulator's rename

        monkeypatch.setattr(run_module, "_simulate", simulated_then_interrupted)
    else:
        import ipgen.plots.run as plots

        def interrupted(*args: object, **kwargs: object) -> None:
            raise KeyboardInterrupt

        monkeypatch.setattr(plots, "plot_run", interrupted)
    capsys.readouterr()
    assert run(["run", str(scene), "-o", str(out)]) == 130
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert "single.csv" in err.split("; still")[0] and "no CSV written" not in err, err
    assert "still the earlier run's: " in err and "single.png" in err and "single.txt" in err, err


@settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(
    keep=st.integers(1, 12),
    uses=st.lists(st.tuples(st.sampled_from(["store", "load"]), st.integers(0, 30)), min_size=1, max_size=60),
)
def test_the_plans_kept_are_the_most_recently_used(
    tmp_path_factory: pytest.TempPathFactory, monkeypatch: pytest.MonkeyPatch, keep: int, uses: list
) -> None:
    """The plans folder grew by one entry (about 40 kB) per distinct scene, forever (an audit:
    100 scenes, 4.4 MB). At most MAX_PLANS are kept; beyond it the least recently stored or read
    go, down to nine tenths, so every plan used since is still there."""

    from ipgen.pipeline import run_plan

    monkeypatch.setattr(run_plan, "MAX_PLANS", keep)
    cache = tmp_path_factory.mktemp("cache")
    folder = cache / FOLDER
    clock = 1_000_000.0
    recent: list[str] = []  # keys by last use, most recent last
    for action, number in uses:
        key = f"k{number}"
        clock += 10
        if action == "store":
            store_plan(cache, key, PLAN)
        elif load_plan(cache, key) is None:
            continue  # never stored, or pruned: not a use
        entry = folder / f"{key}.json"
        os.utime(entry, (clock, clock))  # the file system's clock, made distinct per use
        recent = [k for k in recent if k != key] + [key]
        kept = {path.stem for path in folder.glob("*.json")}
        assert len(kept) <= keep, kept
        assert key in kept  # what was just used stays
        survivors = [k for k in recent if k in kept]
        assert survivors == recent[len(recent) - len(survivors) :], (recent, kept)  # the newest kept
        recent = survivors


def test_a_crashed_writers_temporary_entry_goes_when_old(tmp_path: Path) -> None:
    """A run killed between writing and renaming its plan left `.KEY.json.PID` for good."""
    from ipgen.pipeline.run_plan import STALE_PARTIAL, prune_plans

    folder = tmp_path / FOLDER
    folder.mkdir()
    old, fresh = folder / ".a.json.11", folder / ".b.json.12"
    for path in (old, fresh):
        path.write_text("{")
    os.utime(old, (0, 0))
    store_plan(tmp_path, "k", PLAN)  # prunes as it stores
    assert not old.exists() and fresh.exists() and load_plan(tmp_path, "k") == PLAN
    assert STALE_PARTIAL >= 60  # a writer in progress is never taken for a crashed one
    os.utime(fresh, (0, 0))
    prune_plans(folder)
    assert not fresh.exists() and load_plan(tmp_path, "k") == PLAN
