"""Presets travel with the package: found through `presets_dir()` (the installed package's
presets/, a checkout's scenes/), listed by `ipgen presets` with where their values come from,
taken by `--preset NAME` in ipgen run, excite, identify and sweep. (The installed wheel's presets are
checked by tests/test_readme_verbatim.py.) Also: the build announcement states the cache's own
history, not a guess."""

from __future__ import annotations

import tomllib
from pathlib import Path

import pytest

from ipgen.command.cli import run as cli
from ipgen.common import build_cache
from ipgen.common.locations import presets_dir
from ipgen.common.presets import preset_path, presets
from ipgen.errors import Error
from ipgen.pipeline import simulator

ROOT = Path(__file__).resolve().parents[1]


def test_the_presets_are_the_shipped_scenes() -> None:
    assert presets_dir() == (ROOT / "scenes").resolve()
    names = [preset.name for preset in presets()]
    shipped = sorted(path.stem for path in (ROOT / "scenes").rglob("*.toml"))
    assert names == shipped and len(set(names)) == len(names)  # one namespace, no clash
    assert {"qube_servo2", "ip02_sip", "srv02_dbip", "rdip_lqr", "rsip_swingup"} <= set(names)


def test_every_preset_says_where_its_values_come_from() -> None:
    for preset in presets():
        assert len(preset.source) > 10, preset
        assert preset.title.endswith(".") and len(preset.title) > 15, preset
        system = tomllib.loads(preset.path.read_text(encoding="utf-8"))["system"]
        assert preset.system.startswith(system["type"] + ", ")


def test_a_source_over_two_lines_stays_the_source() -> None:
    """cdip_mpc's "# Values from:" runs onto a second comment line: all of it is the source, none
    of it the title (before, the second line ended the title and left the source cut)."""
    preset = next(p for p in presets() if p.name == "cdip_mpc")
    assert preset.source.endswith("(as cdip_swingup); MPC by ipgen"), preset.source
    assert "cdip_swingup)" not in preset.title and preset.title.endswith(
        "(LQR with a clipped force cannot know the rail)."
    )


def test_the_wheel_ships_the_presets() -> None:
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
    assert {"ipgen.presets", "ipgen.presets.rigs"} <= set(project["packages"])
    assert project["package-dir"]["ipgen.presets"] == "scenes"
    assert project["package-data"]["ipgen.presets"] == ["*.toml"]
    assert project["package-data"]["ipgen.presets.rigs"] == ["*.toml", "*.plan.csv"]  # the swing-up plans
    assert not list((ROOT / "scenes").rglob("*/*/*.toml"))  # nothing deeper than rigs/


def test_an_unknown_preset_names_the_choices(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(Error, match="qube_servo2"):
        preset_path("qube")
    assert cli(["run", "--preset", "qube", "-o", "out"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "no preset 'qube'" in err and "ipgen presets" in err


@pytest.mark.parametrize(
    ("name", "meant"),
    [("cdip_puls", "did you mean cdip_pulse,"), ("Acrobot", "did you mean acrobot_mpc, acrobot_swingup?")],
)
def test_a_misspelt_preset_gets_the_names_it_may_mean(
    name: str, meant: str, capsys: pytest.CaptureFixture[str]
) -> None:
    """A near miss is answered with the presets it may mean, whole (the list of every name was
    cut in its middle by the CLI's 400 characters, hiding pendubot_swingup and qube_servo2)."""
    assert cli(["presets", name]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and meant in err and "..." not in err, err


def test_ipgen_presets_lists_and_prints(capsys: pytest.CaptureFixture[str]) -> None:
    assert cli(["presets"]) == 0
    listing = capsys.readouterr().out
    for preset in presets():
        assert f"{preset.name}  ({preset.system})  {preset.path}" in listing
        assert f"values from: {preset.source}" in listing
    assert cli(["presets", "srv02_dbip"]) == 0
    assert capsys.readouterr().out == (ROOT / "scenes" / "rigs" / "srv02_dbip.toml").read_text()


def test_a_scene_file_or_a_preset(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert cli(["run", "-o", str(tmp_path)]) == 2
    assert "missing the scene" in capsys.readouterr().err
    scene = ROOT / "scenes" / "rsip_pulse.toml"
    assert cli(["run", str(scene), "--preset", "rsip_pulse", "-o", str(tmp_path)]) == 2
    assert "not both" in capsys.readouterr().err


def test_excite_takes_a_preset(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    experiment = tmp_path / "qube_experiment.toml"
    assert (
        cli(["excite", "--preset", "qube_servo2", "--u-max", "10", "--travel", "1", "-o", str(experiment)])
        == 0
    )
    assert f"wrote {experiment}" in capsys.readouterr().out
    assert tomllib.loads(experiment.read_text())["input"]["kind"] == "multisine"


def test_sweep_takes_a_preset(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """The preset is read (its keys are known: a bad one is refused before anything runs)."""
    out = str(tmp_path / "s")
    assert cli(["sweep", "--preset", "rsip_lqr", "--vary", "parameters.mass=1,2", "-o", out]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "parameters.mass" in err
    assert cli(["sweep", "--preset", "rsip", "--scorecard", "-o", str(tmp_path / "s")]) == 2
    assert "no preset 'rsip'" in capsys.readouterr().err
    assert cli(["sweep", "--scorecard", "-o", str(tmp_path / "s")]) == 2
    assert "missing the scene" in capsys.readouterr().err
    assert not (tmp_path / "s").exists()


def test_docs_blocks_a_reader_copies_name_no_checkout_file() -> None:
    """docs/*.md shell and Python blocks run outside a checkout too: a shipped scene is named as
    a preset (--preset NAME, Pendulum.preset, ipgen presets NAME > file), never as scenes/...;
    and an inline command naming a scene, preset or data gives -o (an audit found four without,
    which exit 2: "missing -o OUT")."""
    import re

    checkout = re.compile(r"(^|[\s\"'(=])(bench/)?scenes/", re.M)
    for page in sorted((ROOT / "docs").glob("*.md")):
        text = page.read_text(encoding="utf-8")
        for language, body in re.findall(r"```(\w*)\n(.*?)```", text, re.S):
            if language in ("sh", "bash", "python", "console"):
                assert not checkout.search(body), f"{page.name}:\n{body}"
        prose = re.sub(r"```.*?```", "", text, flags=re.S)
        for span in re.findall(r"`([^`]*\bipgen[ .][^`]*)`", prose):  # a span may wrap a line
            span = " ".join(span.split())
            assert not checkout.search(span), f"{page.name}: `{span}`"
            # a whole command a reader copies (a scene, preset or data named) says where it writes
            command = re.match(r"ipgen (run|identify|sweep|excite)\b|ipgen --(scene|type)\b", span)
            named = re.search(r"--preset \S|\.toml\b|--data \S|--links \d", span)
            if command and named:
                writes = re.search(r"(^| )(-o|--output|--help|--describe)\b", span)
                assert writes, f"{page.name}: `{span}` says not where it writes (-o)"


def test_the_build_announcement_states_the_last_build(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """No '~10 s' guess: the first build in a cache says nothing about time, the next states how
    long the previous one took (before: 'first run for this model, ~10 s' whatever the machine)."""

    def fake_compile(cc: str, entry: Path, name: str, library: Path) -> list[str]:
        return ["sh", "-c", 'sleep 0.2 && cp /bin/true "$0"', str(library)]

    def fake_core(cxx: str, output: Path) -> list[str]:
        return ["cp", "/bin/true", str(output)]

    def fake_program(cxx: str, output: Path, core: Path) -> list[str]:
        return ["cp", "/bin/true", str(output)]

    monkeypatch.setattr(simulator, "compile_command", fake_compile)
    monkeypatch.delenv(simulator.SIMULATOR_VARIABLE, raising=False)  # the cache's own simulator
    monkeypatch.setattr(simulator, "core_command", fake_core)
    monkeypatch.setattr(simulator, "program_command", fake_program)
    said: list[str] = []
    sources = {"a.h": "/* model a */\n", "a_model.c": "/* adapter a */\n"}
    first = simulator.build(sources, "a", tmp_path, said.append)
    once = [
        "building ipsim's model-independent code (once for all models)…",
        "building ipsim's simulator (once for every model)…",
    ]
    assert first.built and said == [*once, "building the model library of a…"]  # the simulator: once
    del said[:2]
    library = build_cache.last_build(tmp_path / "models")
    assert library is not None and 0.2 <= library <= first.seconds
    second = simulator.build({"b.h": "/* model b */\n", "b_model.c": "/* b */\n"}, "b", tmp_path, said.append)
    assert second.built
    assert said[1] == f"building the model library of b (the last build in this cache took {library:.0f} s)…"
    (tmp_path / "models" / build_cache.LAST_BUILD).write_text("garbage\n")
    assert build_cache.last_build(tmp_path / "models") is None


def test_a_presets_outputs_name_the_preset_not_this_installations_path(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """`--preset NAME` writes "preset NAME" where a file names its scene (it wrote the absolute
    path of this installation's preset, so the same command gave other bytes elsewhere); a
    scene given by its path keeps the path as given."""
    import os

    from ipgen.common.presets import scene_source

    assert (
        cli(
            [
                "excite",
                "--preset",
                "qube_servo2",
                "--u-max",
                "10",
                "--travel",
                "1",
                "-o",
                str(tmp_path / "e.toml"),
            ]
        )
        == 0
    )
    first = (tmp_path / "e.toml").read_text().splitlines()[0]
    assert "from preset qube_servo2:" in first and str(preset_path("qube_servo2")) not in first, first
    assert scene_source(preset_path("rsip_lqr")) == "preset rsip_lqr"
    relative = Path(os.path.relpath(preset_path("rsip_lqr")))
    assert scene_source(relative) == relative.as_posix()
    copy = tmp_path / "rsip_lqr.toml"
    copy.write_text(preset_path("rsip_lqr").read_text())
    assert scene_source(copy) == copy.as_posix()  # a file of the same name elsewhere is no preset
