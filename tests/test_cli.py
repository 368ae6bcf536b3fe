"""The ipgen command: options, bad input, safe writing, determinism, packaging."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from ipgen.command.cli import run
from ipgen.common import files as output

ROOT = Path(__file__).resolve().parents[1]


def ipgen(
    *args: str, env: dict[str, str] | None = None, cwd: Path | None = None
) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "ipgen", *args], capture_output=True, text=True, env=env, cwd=cwd
    )


def snapshot(directory: Path) -> dict[str, bytes]:
    if not directory.exists():
        return {}
    return {
        str(p.relative_to(directory)): p.read_bytes() for p in sorted(directory.rglob("*")) if p.is_file()
    }


def test_help_is_a_manual(capsys: pytest.CaptureFixture[str]) -> None:
    assert run(["--help"]) == 0
    text = capsys.readouterr().out
    for word in ("--type", "--links", "--inertia", "--name", "--scene", "forward_dynamics", "Examples"):
        assert word in text


def test_version(capsys: pytest.CaptureFixture[str]) -> None:
    from ipgen import __version__

    assert run(["--version"]) == 0
    assert __version__ in capsys.readouterr().out


def test_writes_header_and_says_so(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "new" / "dir"
    assert run(["--type", "rotary", "--links", "2", "-o", str(out)]) == 0
    header = out / "rotary2.hpp"
    assert header.is_file()
    text = header.read_text()
    assert "namespace ipgen::rotary2 {" in text and "inline constexpr int kDof = 3;" in text
    assert "ipgen --type rotary --links 2 --inertia pivot --name rotary2" in text
    assert f"wrote {header}" in capsys.readouterr().out
    assert run(["--type", "rotary", "--links", "2", "-o", str(out)]) == 0
    assert "unchanged" in capsys.readouterr().out
    assert [p.name for p in out.iterdir()] == ["rotary2.hpp"]  # no temporary file left


def test_name_option_names_file_and_namespace(tmp_path: Path) -> None:
    assert run(["--type", "classical", "--links", "1", "--name", "cart_pole", "-o", str(tmp_path)]) == 0
    assert "namespace ipgen::cart_pole {" in (tmp_path / "cart_pole.hpp").read_text()


def test_same_input_gives_identical_bytes_across_processes(tmp_path: Path) -> None:
    """Different hash seeds reorder sets and dicts of symbols: the output must not change."""
    texts = []
    for seed in ("0", "12345"):
        out = tmp_path / seed
        env = {**os.environ, "PYTHONHASHSEED": seed}
        result = ipgen("--type", "rotary", "--links", "3", "--inertia", "full", "-o", str(out), env=env)
        assert result.returncode == 0, result.stderr
        texts.append((out / "rotary3.hpp").read_bytes())
    assert texts[0] == texts[1]


def test_generation_does_not_import_sympy(tmp_path: Path) -> None:
    """sympy alone takes longer to import than a small model takes to generate: never load it."""
    scene = ROOT / "scenes" / "cdip_pulse.toml"
    runs = [
        ["--type", "rotary", "--links", "2", "--inertia", "full", "-o", str(tmp_path / "a")],
        ["--type", "classical", "--links", "2", "--fix", "m1=0.3,delta2=0", "--outputs", "bias"],
        ["--scene", str(scene), "-o", str(tmp_path / "b")],
    ]
    runs[1] += ["-o", str(tmp_path / "c")]
    program = (
        "import sys\nfrom ipgen.command.cli import run\n"
        f"statuses = [run(args) for args in {runs!r}]\n"
        "print(statuses, sorted(m for m in sys.modules if m.split('.')[0] == 'sympy'))\n"
    )
    result = subprocess.run([sys.executable, "-c", program], capture_output=True, text=True, cwd=ROOT)
    assert result.returncode == 0, result.stderr
    assert result.stdout.splitlines()[-1] == "[0, 0, 0] []"


CDIP = ["--type", "classical", "--links", "2"]
BAD_INPUTS = [
    (["--type", "pendulum", "--links", "2"], "--type"),
    (["--type", "classical", "--links", "0"], "--links must be an integer >= 1"),
    (["--type", "classical", "--links", "-3"], "--links must be an integer >= 1"),
    (["--type", "classical", "--links", "two"], "'two' is not a valid integer"),
    (["--type", "classical", "--links", "2.5"], "not a valid integer"),
    (["--links", "2"], "missing --type"),
    (["--type", "rotary"], "missing --links"),
    (["--type", "classical", "--links", "2", "--inertia", "full"], "applies to rotary systems only"),
    (["--type", "rotary", "--links", "2", "--inertia", "heavy"], "--inertia"),
    (["--type", "rotary", "--links", "2", "--name", "3links"], "not a C++ identifier"),
    (["--type", "rotary", "--links", "2", "--name", "my-model"], "not a C++ identifier"),
    (["--type", "rotary", "--links", "2", "--name", "class"], "reserved"),
    (["--type", "rotary", "--links", "2", "--name", "a__b"], "not a C++ identifier"),
    (["--type", "rotary", "--links", "2", "--name", "Model"], "reserved"),
    (["--type", "rotary", "--links", "2", "--bogus"], "No such option"),
    (["--scene", "does_not_exist.toml"], "does_not_exist.toml: no such file"),
    (["--scene", str(ROOT / "scenes" / "cdip_pulse.toml"), "--links", "3"], "--scene fixes the system"),
    # specialisation options
    ([*CDIP, "--fix", "m9=1"], "unknown parameter 'm9'"),
    ([*CDIP, "--fix", "l1=0"], "must be > 0"),
    ([*CDIP, "--fix", "delta1=-0.1"], "must be >= 0"),
    ([*CDIP, "--fix", "m1"], "expected NAME=VALUE"),
    ([*CDIP, "--fix", "m1=1,m1=2"], "names m1 twice"),
    ([*CDIP, "--fix", "l0=1"], "a cart has no length l0"),
    ([*CDIP, "--outputs", "mass_matrix,jacobian"], "unknown function 'jacobian'"),
    ([*CDIP, "--outputs", ","], "--outputs is empty"),
]


@pytest.mark.parametrize(("args", "message"), BAD_INPUTS, ids=[" ".join(a) for a, _ in BAD_INPUTS])
def test_bad_input_is_one_line_exit_2_and_touches_nothing(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], args: list[str], message: str
) -> None:
    out = tmp_path / "out"
    out.mkdir()
    (out / "keep.txt").write_text("mine")
    before = snapshot(out)
    assert run([*args, "-o", str(out)]) == 2
    captured = capsys.readouterr()
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1, captured.err
    assert lines[0].startswith("ipgen: error: ") and message in lines[0]
    assert "Traceback" not in captured.err
    assert snapshot(out) == before


def test_bad_input_in_a_subprocess_has_no_traceback(tmp_path: Path) -> None:
    result = ipgen("--type", "classical", "--links", "x", "-o", str(tmp_path / "o"))
    assert result.returncode == 2
    assert result.stderr.count("\n") == 1 and "Traceback" not in result.stderr
    assert not (tmp_path / "o").exists()


def test_missing_output_option(capsys: pytest.CaptureFixture[str]) -> None:
    assert run(["--type", "classical", "--links", "1"]) == 2
    assert capsys.readouterr().err == "ipgen: error: missing -o DIR: say where to write the header\n"


def test_describe_prints_the_scene_system_and_writes_nothing(tmp_path: Path) -> None:
    """What CMake's ipgen_add_scene reads at configure time; run as CMake runs it."""
    result = ipgen("--scene", str(ROOT / "scenes" / "rsip_pulse.toml"), "--describe", cwd=tmp_path)
    assert result.returncode == 0, result.stderr
    assert result.stdout == "name=rsip type=rotary links=1 inertia=pivot stem=rsip_pulse specialise=false\n"
    assert result.stderr == ""
    assert list(tmp_path.iterdir()) == []


def test_describe_defaults_name_and_inertia(tmp_path: Path) -> None:
    scene = tmp_path / "my-scene.toml"
    scene.write_text(
        '[system]\ntype = "classical"\nlinks = 3\n'
        "[parameters]\nm = [1, 1, 1, 1]\nl = [0, 1, 1, 1]\ndelta = [0, 0, 0, 0]\n"
        "[simulation]\nt_end = 1\n"
    )
    result = ipgen("--scene", str(scene), "--describe")
    expected = "name=classical3 type=classical links=3 inertia=pivot stem=my-scene specialise=false\n"
    assert result.stdout == expected


def test_describe_reports_scene_warnings_on_stderr(tmp_path: Path) -> None:
    scene = tmp_path / "tight.toml"
    text = (ROOT / "scenes" / "rsip_pulse.toml").read_text()
    scene.write_text(text.replace("t_end = 10.0", "t_end = 10.0\nrtol = 1e-15"))
    result = ipgen("--scene", str(scene), "--describe")
    assert result.returncode == 0
    assert result.stdout == "name=rsip type=rotary links=1 inertia=pivot stem=tight specialise=false\n"
    assert (
        result.stderr == f"ipgen: {scene.as_posix()}: warning: simulation.rtol = 1e-15 is below 1e-14 "
        "and may not be met in double precision\n"
    )


DESCRIBE_ERRORS = [
    ('[system]\ntype = "rotary"\n', "missing required key 'system.links'"),
    ("[system\n", "bad.toml: malformed TOML"),
]


@pytest.mark.parametrize(("text", "message"), DESCRIBE_ERRORS, ids=["missing_key", "bad_toml"])
def test_describe_bad_scene_is_one_line_exit_2(tmp_path: Path, text: str, message: str) -> None:
    scene = tmp_path / "bad.toml"
    scene.write_text(text)
    result = ipgen("--scene", str(scene), "--describe")
    assert result.returncode == 2
    assert result.stdout == ""
    lines = result.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith("ipgen: error: ") and message in lines[0], result.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.toml"]


def test_describe_needs_a_scene(capsys: pytest.CaptureFixture[str]) -> None:
    assert run(["--type", "rotary", "--links", "1", "--describe"]) == 2
    assert "--describe needs --scene FILE" in capsys.readouterr().err


def test_output_path_that_is_a_file(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    target = tmp_path / "file"
    target.write_text("x")
    assert run(["--type", "classical", "--links", "1", "-o", str(target)]) == 2
    assert "is a file, not a directory" in capsys.readouterr().err
    assert target.read_text() == "x"


def test_header_path_that_is_a_directory(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    (tmp_path / "classical1.hpp").mkdir()
    assert run(["--type", "classical", "--links", "1", "-o", str(tmp_path)]) == 2
    assert "is a directory" in capsys.readouterr().err


def test_uncreatable_output_directory(capsys: pytest.CaptureFixture[str]) -> None:
    assert run(["--type", "classical", "--links", "1", "-o", "/proc/ipgen-cannot-be-here"]) == 2
    assert "cannot create output directory" in capsys.readouterr().err


def test_never_overwrites_a_file_ipgen_did_not_write(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    mine = tmp_path / "classical1.hpp"
    mine.write_text("// my own hand-written model\n")
    assert run(["--type", "classical", "--links", "1", "-o", str(tmp_path)]) == 2
    assert "was not written by ipgen" in capsys.readouterr().err
    assert mine.read_text() == "// my own hand-written model\n"
    assert run(["--type", "classical", "--links", "1", "-o", str(tmp_path), "--force"]) == 0
    assert "replaced" in capsys.readouterr().out
    assert "namespace ipgen::classical1" in mine.read_text()


def test_replacing_an_earlier_ipgen_header_is_reported(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert run(["--type", "rotary", "--links", "1", "--name", "arm", "-o", str(tmp_path)]) == 0
    pivot = (tmp_path / "arm.hpp").read_text()
    args = ["--type", "rotary", "--links", "1", "--name", "arm", "--inertia", "full", "-o", str(tmp_path)]
    assert run(args) == 0
    assert "replaced" in capsys.readouterr().out
    assert (tmp_path / "arm.hpp").read_text() != pivot


def test_interrupted_write_leaves_no_partial_file(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    target = tmp_path / "model.hpp"
    target.write_text("// Generated by ipgen, old\n")

    def interrupted(src: str, dst: str) -> None:
        raise KeyboardInterrupt

    monkeypatch.setattr(output.os, "replace", interrupted)
    with pytest.raises(KeyboardInterrupt):
        output.write_file(target, "// Generated by ipgen, new\n")
    assert [p.name for p in tmp_path.iterdir()] == ["model.hpp"]
    assert target.read_text() == "// Generated by ipgen, old\n"


def test_scene_writes_header_and_resolved_config(tmp_path: Path) -> None:
    assert run(["--scene", str(ROOT / "scenes" / "rsip_pulse.toml"), "-o", str(tmp_path)]) == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["rsip.hpp", "rsip_pulse.cfg"]
    config = (tmp_path / "rsip_pulse.cfg").read_text()
    assert "model = rsip" in config and "input = pulse" in config


def test_templates_ship_with_a_plain_install(tmp_path: Path) -> None:
    """`pip install .` (not editable) must carry templates/ into the package."""
    target = tmp_path / "site"
    install = subprocess.run(
        [sys.executable, "-m", "pip", "install", "-q", "--no-deps", "--target", str(target), str(ROOT)],
        capture_output=True,
        text=True,
    )
    assert install.returncode == 0, install.stderr
    assert (target / "ipgen" / "templates" / "model.hpp.jinja").is_file()
    assert not (target / "generator").exists(), "only the ipgen package is installed"
    env = {**os.environ, "PYTHONPATH": str(target)}
    result = ipgen("--type", "classical", "--links", "1", "-o", str(tmp_path / "o"), env=env, cwd=tmp_path)
    assert result.returncode == 0, result.stderr
    assert (tmp_path / "o" / "classical1.hpp").is_file()


def test_an_output_directory_made_meanwhile_by_a_concurrent_run_is_used(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Two runs into one new -o: the one that loses the race to mkdir uses the folder the other
    made (it failed "file exists" before); a path that became a file is still refused."""
    from ipgen.common.files import OutputError, prepare_directory

    def raced(self: Path, *args: object, **kwargs: object) -> None:
        os.makedirs(self, exist_ok=True)  # the other run made it first
        raise FileExistsError(17, "File exists", str(self))

    monkeypatch.setattr(Path, "mkdir", raced)
    out = tmp_path / "new" / "out"
    assert prepare_directory(out) is False and out.is_dir()

    def raced_to_a_file(self: Path, *args: object, **kwargs: object) -> None:
        self.write_text("not a folder")
        raise FileExistsError(17, "File exists", str(self))

    monkeypatch.setattr(Path, "mkdir", raced_to_a_file)
    with pytest.raises(OutputError, match="cannot create output directory"):
        prepare_directory(tmp_path / "other")
