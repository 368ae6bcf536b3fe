"""`ipgen sweep` under hostile input (issue 48): each class of problem is refused in one line,
before any run, or ends cleanly; nothing is silently wrong.

One class per test, each a hypothesis property over the class (examples bounded: most refuse
before any simulator runs, so an example costs milliseconds to a second):

- resume: a runs.csv is resumed only by the sweep that wrote it (the scene, the success test:
  `table.sweep_digest` in every row) and only as ipgen wrote it (`table.problem`);
- the total number of runs is bounded before any is planned (`spec.check_total`);
- a Dask address is checked (`engine.check_address`) and probed within 5 s (`engine.probe`);
- OUT goes through the output policy (`files.check_directory`);
- a --vary key or index the scene cannot have is refused before any run (`runner._check_keys`);
- the scratch folders honour $TMPDIR and are removed on SIGTERM/SIGINT (`execute.release`,
  `command.sweep`'s SIGTERM handler).

The runs use test_sweep.py's scene (its simulator is shared through the test cache).
"""

from __future__ import annotations

import contextlib
import os
import resource
import shutil
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest
from cxx import require_toolchain
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from test_sweep import SCENE

import ipgen
from ipgen.command.cli import run
from ipgen.sweeps.spec import MAX_RUNS, SweepError

VARY = "initial.theta[1]=0,0.05"
FIXTURE = [HealthCheck.function_scoped_fixture]


def _cli(
    *arguments: str, env: dict[str, str] | None = None, timeout: float = 60, limit: int | None = None
) -> subprocess.CompletedProcess[str]:
    """`python -m ipgen ARGUMENTS` in a subprocess (its own interpreter: what a user sees,
    tracebacks printed at exit included) in a session of its own, under an address-space limit
    of `limit` bytes; past `timeout` the whole session is killed (a sweep that does not stop has
    worker processes too) and the result is a failure with the stderr so far."""

    def limited() -> None:
        if limit is not None:
            resource.setrlimit(resource.RLIMIT_AS, (limit, limit))

    process = subprocess.Popen(
        [sys.executable, "-m", "ipgen", *arguments],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env={**os.environ, **(env or {})},
        preexec_fn=limited,
        start_new_session=True,
    )
    try:
        out, err = process.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        _end_session(process)
        out, err = "", f"still running after {timeout} s"
    finally:
        _end_session(process)
    return subprocess.CompletedProcess(process.args, process.returncode, out, err)


def _end_session(process: subprocess.Popen) -> None:
    """Kill what is left of the session `process` leads (its workers too): a test that fails
    never leaves processes behind."""
    with contextlib.suppress(ProcessLookupError, PermissionError):
        os.killpg(process.pid, signal.SIGKILL)
    with contextlib.suppress(subprocess.TimeoutExpired, ValueError):
        process.communicate(timeout=5)


def _one_line(stderr: str) -> bool:
    return stderr.count("\n") == 1 and "Traceback" not in stderr and stderr.startswith("ipgen: error: ")


@pytest.fixture(scope="module")
def scene(tmp_path_factory: pytest.TempPathFactory) -> Path:
    require_toolchain()
    path = tmp_path_factory.mktemp("scene") / "rsip_hostile.toml"
    path.write_text(SCENE)
    return path


@pytest.fixture(scope="module")
def swept(scene: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A finished two-run sweep of `scene`: the table the resume properties start from."""
    out = tmp_path_factory.mktemp("swept") / "out"
    ipgen.sweep(scene, out, vary=[VARY], jobs=1, plots=False)
    return out


# ---------------------------------------------------------------------------- resume


OTHER_SCENES = st.sampled_from(
    [
        ("m = [0.5, 0.275]", "m = [0.5, 0.3]"),  # other masses
        ("theta = [0, 0.1]", "theta = [0, 0.12]"),  # another nominal state
        ("t_end = 2.0", "t_end = 2.5"),
        ("saturation = 5.0", "saturation = 4.0"),
    ]
)
DAMAGE = st.sampled_from(
    [
        ("angle_error", "1e999"),
        ("angle_error", "inf"),
        ("rate_error", "0.1000"),
        ("run", "²"),
        ("level", "01"),
        ("seed", "-1"),
        ("status", "x"),
        ("values", "[NaN]"),
        ("seconds", "-1"),
        ("outcome", "PASS"),
    ]
)


def _copy(swept: Path, tmp_path: Path, name: str) -> Path:
    out = tmp_path / name
    shutil.rmtree(out, ignore_errors=True)
    shutil.copytree(swept, out)
    return out


@settings(max_examples=12, deadline=None, suppress_health_check=FIXTURE)
@given(
    change=st.one_of(
        st.tuples(st.just("scene"), OTHER_SCENES),
        st.tuples(st.just("tolerance"), st.floats(0.01, 3.0).filter(lambda x: x != 0.35)),
        st.tuples(st.just("damage"), DAMAGE),
        st.tuples(st.just("bytes"), st.sampled_from([b"\xff\xfe", b"\x00", b"\xc3("])),
    )
)
def test_a_table_is_resumed_only_by_its_own_sweep_as_written(
    scene: Path, swept: Path, tmp_path: Path, change: tuple
) -> None:
    """Another scene or success test, or a table not as ipgen wrote it: a one-line SweepError
    before any run, the table left as it was."""
    out = _copy(swept, tmp_path, "resume")
    table = out / "runs.csv"
    path, angle = scene, 0.35
    kind, what = change
    if kind == "scene":
        path = tmp_path / "other.toml"
        assert what[0] in SCENE
        path.write_text(SCENE.replace(*what))
    elif kind == "tolerance":
        angle = what
    elif kind == "damage":
        column, text = what
        lines = table.read_text().splitlines(keepends=True)
        header = lines[0].rstrip("\n").split(",")
        import csv
        import io

        row = next(csv.DictReader(io.StringIO(lines[0] + lines[1])))
        row[column] = text
        buffer = io.StringIO()
        csv.DictWriter(buffer, fieldnames=header, lineterminator="\n").writerow(row)
        table.write_text(lines[0] + buffer.getvalue() + "".join(lines[2:]))
    else:
        lines = table.read_bytes().splitlines(keepends=True)
        table.write_bytes(lines[0] + what + lines[1] + b"".join(lines[2:]))
    before = table.read_bytes()
    with pytest.raises(SweepError) as caught:
        ipgen.sweep(path, out, vary=[VARY], jobs=1, plots=False, angle_tolerance=angle)
    assert "\n" not in str(caught.value) and "--force" in str(caught.value)
    assert table.read_bytes() == before


@pytest.mark.parametrize("tail", ["×", "é", "€", "😀"])
def test_a_last_line_cut_inside_a_character_is_run_again(
    scene: Path, swept: Path, tmp_path: Path, tail: str
) -> None:
    """An interruption may cut the last line of runs.csv inside a character of several bytes (a
    reason's "×"): that line is run again, as one cut between two bytes of ASCII (it was refused
    as damaged)."""
    from ipgen.sweeps import table

    out = _copy(swept, tmp_path, "cut")
    whole = table.read(out / "runs.csv")
    lines = (out / "runs.csv").read_bytes().splitlines(keepends=True)
    (out / "runs.csv").write_bytes(b"".join(lines[:-1]) + lines[-1][:20] + tail.encode()[:-1])
    assert table.read(out / "runs.csv") == whole[:-1]
    outcome = ipgen.sweep(scene, out, vary=[VARY], jobs=1, plots=False)
    assert (outcome.runs, outcome.ran) == (2, 1)


def test_starting_over_removes_the_earlier_sweeps_scores_and_pictures(
    scene: Path, swept: Path, tmp_path: Path
) -> None:
    """--force starts over: the earlier sweep's scores and PNGs (those of the criteria its runs.csv
    names, here with another criterion's rows too) do not stay beside the new runs; files a sweep
    did not write stay, a criterion_*.png of a criterion it never ran among them."""
    out = _copy(swept, tmp_path, "again")
    table = (out / "runs.csv").read_text().splitlines()
    assert table[0].split(",")[1] == "criterion"
    first = table[1].split(",")
    table.append(",".join([first[0], "mass", *first[2:]]))  # an earlier sweep's row of criterion mass
    (out / "runs.csv").write_text("\n".join(table) + "\n")
    pictures = ("criterion_mass.png", "criterion_holiday.png", "grid.png", "scores.png")
    for name in (*pictures, "scores.json", "notes.txt"):
        (out / name).write_text("earlier")
    ipgen.sweep(scene, out, vary=[VARY], jobs=1, plots=False, force=True)
    assert not any((out / name).exists() for name in ("criterion_mass.png", "grid.png", "scores.png"))
    assert (out / "scores.json").read_text() != "earlier" and (out / "notes.txt").read_text() == "earlier"
    assert (out / "criterion_holiday.png").read_text() == "earlier"


def test_starting_over_keeps_a_grid_png_no_grid_wrote(scene: Path, swept: Path, tmp_path: Path) -> None:
    """An earlier sweep of criteria only (no --vary grid): a grid.png beside it is a user's, kept."""
    out = _copy(swept, tmp_path, "criteria")
    rows = [line.split(",") for line in (out / "runs.csv").read_text().splitlines()]
    renamed = [",".join([*r[:1], "mass", *r[2:]] if i else r) for i, r in enumerate(rows)]
    (out / "runs.csv").write_text("\n".join(renamed) + "\n")
    for name in ("grid.png", "criterion_mass.png"):
        (out / name).write_text("earlier")
    ipgen.sweep(scene, out, vary=[VARY], jobs=1, plots=False, force=True)
    assert not (out / "criterion_mass.png").exists() and (out / "grid.png").read_text() == "earlier"


def test_the_same_sweep_resumes_its_own_table(scene: Path, swept: Path, tmp_path: Path) -> None:
    """The check does not refuse what it should accept: the same sweep resumes, running nothing."""
    out = _copy(swept, tmp_path, "same")
    outcome = ipgen.sweep(scene, out, vary=[VARY], jobs=1, plots=False)
    assert (outcome.runs, outcome.ran) == (2, 0)


# ---------------------------------------------------------------------------- bounded work


@settings(max_examples=2, deadline=None, suppress_health_check=FIXTURE)
@given(
    repeat=st.integers(MAX_RUNS // 2 + 1, 10**15),
    scorecard=st.booleans(),
)
def test_the_total_of_runs_is_bounded_before_any_is_planned(
    scene: Path, tmp_path: Path, repeat: int, scorecard: bool
) -> None:
    """--repeat R with --vary or --scorecard --only: more than MAX_RUNS runs is one line at once,
    under a 2 GB address-space limit and in a few seconds."""
    what = ["--scorecard", "--only", "drive_noise"] if scorecard else ["--vary", VARY]
    out = tmp_path / "bounded"
    started = time.monotonic()
    arguments = ["sweep", str(scene), "-o", str(out), *what, "--repeat", str(repeat)]
    done = _cli(*arguments, env={"OPENBLAS_NUM_THREADS": "1"}, timeout=30, limit=2 << 30)
    assert done.returncode == 2 and _one_line(done.stderr), done.stderr[-2000:]
    assert f"at most {MAX_RUNS:,}" in done.stderr
    assert time.monotonic() - started < 20 and not out.exists()


# ---------------------------------------------------------------------------- Dask addresses


MALFORMED = st.one_of(
    st.sampled_from(["nonsense", "", "tcp://127.0.0.1", "inproc://x", "tls://…", "ucx://…", "tcp://:8786"]),
    st.text(alphabet=st.characters(codec="ascii", exclude_characters=":"), max_size=20),
)


@settings(max_examples=6, deadline=None, suppress_health_check=FIXTURE)
@given(address=MALFORMED)
def test_a_malformed_dask_address_is_one_line_at_once(
    scene: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str], address: str
) -> None:
    """Refused before a Dask client exists (whose teardown printed a traceback and took 15 s)."""
    pytest.importorskip("distributed")
    out = tmp_path / "dask"
    started = time.monotonic()
    status = run(["sweep", str(scene), "-o", str(out), "--vary", VARY, "--dask", address])
    err = capsys.readouterr().err
    assert status == 2 and _one_line(err), err
    assert "--dask" in err and "SCHEME://HOST:PORT" in err and not out.exists()
    assert time.monotonic() - started < 3


def test_a_malformed_address_exits_at_once_without_a_traceback(scene: Path, tmp_path: Path) -> None:
    """What the user sees of the property above, in an interpreter of its own: the one line and
    the exit, with no traceback from a Dask client's teardown (15 s before the fix)."""
    pytest.importorskip("distributed")
    started = time.monotonic()
    done = _cli("sweep", str(scene), "-o", str(tmp_path / "o"), "--vary", VARY, "--dask", "tcp://127.0.0.1")
    assert done.returncode == 2 and _one_line(done.stderr), done.stderr[-2000:]
    assert time.monotonic() - started < 10


def test_a_listener_that_never_answers_is_an_error_within_5_s(scene: Path, tmp_path: Path) -> None:
    """A loopback socket that accepts connections and never writes: the sweep's one line well
    within the promised 5 s (plus the interpreter's start), nothing written."""
    pytest.importorskip("distributed")
    listener = socket.socket()
    listener.bind(("127.0.0.1", 0))
    listener.listen(8)
    listener.settimeout(0.2)
    accepted: list[socket.socket] = []
    stop = threading.Event()

    def accept() -> None:
        while not stop.is_set():
            try:
                accepted.append(listener.accept()[0])
            except OSError:
                continue

    thread = threading.Thread(target=accept, daemon=True)
    thread.start()
    out = tmp_path / "silent"
    try:
        started = time.monotonic()
        address = f"tcp://127.0.0.1:{listener.getsockname()[1]}"
        done = _cli("sweep", str(scene), "-o", str(out), "--vary", VARY, "--dask", address, timeout=60)
        seconds = time.monotonic() - started
    finally:
        stop.set()
        thread.join(2)
        for connection in accepted:
            connection.close()
        listener.close()
    assert done.returncode == 2 and _one_line(done.stderr), done.stderr[-2000:]
    assert "cannot reach a Dask scheduler" in done.stderr and not out.exists()
    assert len(accepted) >= 2 and seconds < 15  # the plain connection, then Dask's


# ---------------------------------------------------------------------------- OUT and the policy


@settings(max_examples=6, deadline=None, suppress_health_check=FIXTURE)
@given(
    where=st.sampled_from(["file/sub", "file", "long", "long/sub", "proc", "file/a/b"]),
    length=st.integers(256, 400),
)
def test_an_output_folder_the_system_refuses_is_one_line(
    scene: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str], where: str, length: int
) -> None:
    (tmp_path / "file").write_text("not a folder\n")
    out = {
        "long": tmp_path / ("x" * length),
        "long/sub": tmp_path / ("x" * length) / "sub",
        "proc": Path("/proc/1/ipgen-out"),
    }.get(where, tmp_path / where)
    status = run(["sweep", str(scene), "-o", str(out), "--vary", VARY])
    err = capsys.readouterr().err
    assert status == 2 and _one_line(err), err
    assert "pass another -o" in err or "name a folder" in err
    assert (tmp_path / "file").read_text() == "not a folder\n"


# ---------------------------------------------------------------------------- impossible keys


@settings(max_examples=8, deadline=None, suppress_health_check=FIXTURE)
@given(
    key=st.sampled_from(["parameters.m", "parameters.l", "parameters.delta", "parameters.com",
                         "parameters.J", "initial.theta", "initial.dtheta", "parameters.coulomb"]),
    index=st.integers(2, 9999),
)  # fmt: skip
def test_an_index_the_scene_cannot_have_is_refused_before_any_run(
    scene: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str], key: str, index: int
) -> None:
    """The scene is a single pendulum (2 coordinates): index 2 or more of any of its arrays."""
    out = tmp_path / "index"
    status = run(["sweep", str(scene), "-o", str(out), "--vary", f"{key}[{index}]=0.1,0.2"])
    err = capsys.readouterr().err
    assert status == 2 and _one_line(err), err
    assert f"{key}[{index}]" in err and "2 entries" in err and not out.exists()


# ---------------------------------------------------------------------------- scratch and signals


@settings(max_examples=2, deadline=None, suppress_health_check=FIXTURE)
@given(number=st.sampled_from([signal.SIGTERM, signal.SIGINT]))
def test_scratch_goes_to_tmpdir_and_is_removed_when_the_sweep_is_ended(
    scene: Path, tmp_path: Path, number: signal.Signals
) -> None:
    """A sweep ended by SIGTERM or SIGINT (sent to the command alone, as `timeout` does) while its
    workers run: the scratch folder was under $TMPDIR and is gone, the workers too, one line."""
    scratch = tmp_path / "tmp"
    shutil.rmtree(scratch, ignore_errors=True)
    scratch.mkdir()
    out = tmp_path / "ended"
    shutil.rmtree(out, ignore_errors=True)
    process = subprocess.Popen(
        [sys.executable, "-m", "ipgen", "sweep", str(scene), "-o", str(out), "--jobs", "2",
         "--vary", "initial.theta[1]=-0.3:0.3:4000"],  # far from its end when signalled
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        env={**os.environ, "TMPDIR": str(scratch)}, start_new_session=True,
        preexec_fn=_interruptible,
    )  # fmt: skip
    try:
        deadline = time.monotonic() + 120  # the first call may compile the simulator
        table = out / "runs.csv"
        while time.monotonic() < deadline and process.poll() is None:
            if table.exists() and table.read_text().count("\n") > 2:
                break
            time.sleep(0.05)
        assert process.poll() is None, "the sweep ended before it could be interrupted"
        assert list(scratch.glob("ipgen-sweep.*")), "the scratch folder is not under $TMPDIR"
        children = _children(process.pid)
        process.send_signal(number)  # to the command alone, as `timeout` does
        _, err = process.communicate(timeout=30)
        leftover = [pid for pid in children if _alive(pid)]
    finally:
        _end_session(process)  # whatever the outcome, nothing of the sweep is left running
    assert process.returncode == 128 + number and "Traceback" not in err, err[-2000:]
    assert "interrupted" in err and not list(scratch.glob("ipgen-sweep.*"))
    assert not leftover, "worker processes outlived the sweep"


def test_an_interrupted_pool_has_ended_its_manager_thread_before_the_exit() -> None:
    """Interrupted, the local pool ends its workers and then its manager thread, so Python's exit
    hook finds no thread still closing its wake-up pipe (a race that printed "OSError: Bad file
    descriptor" after the one-line message: seen once, in a make test on a loaded machine)."""
    from ipgen.sweeps.engine import _local

    with pytest.raises(KeyboardInterrupt), _local(2) as pool:
        futures = [pool.submit(time.sleep, 30) for _ in range(4)]
        deadline = time.monotonic() + 10
        while not futures[0].running() and time.monotonic() < deadline:  # the workers at work
            time.sleep(0.01)
        manager = pool._executor_manager_thread  # type: ignore[attr-defined]
        raise KeyboardInterrupt
    assert manager is not None and not manager.is_alive()


def _interruptible() -> None:
    """SIGINT at its default in the sweep's process: a shell that runs the tests in the background
    (a CI job, `make test &`) starts them with SIGINT ignored, which the sweep would inherit and
    keep, as a program should."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def _children(pid: int) -> list[int]:
    """The process ids of `pid`'s children (Linux /proc)."""
    try:
        return [int(child) for child in Path(f"/proc/{pid}/task/{pid}/children").read_text().split()]
    except OSError:
        return []


def _alive(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state != "Z"
