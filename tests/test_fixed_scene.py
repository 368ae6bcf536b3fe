"""Fixed-pivot scenes (`[system] type = "fixed"`): the DFKI presets equal DFKI's parameter files
mapped, `ipgen presets` lists them, the commands that cannot take them yet refuse them in one
line, and bad input for the new keys is refused in one line (hypothesis)."""

from __future__ import annotations

from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import ipgen
from ipgen.command.cli import run as cli
from ipgen.errors import SceneError
from ipgen.model.dfki import dfki_pendulum, read_model_parameters
from ipgen.scene.fixed import load_fixed_scene

DATA = Path(__file__).parent / "data" / "dfki"


@pytest.mark.parametrize(
    ("preset", "source"), [("dfki_c0", "design_C.0_model_3.0"), ("dfki_c1", "design_C.1_model_1.0")]
)
def test_dfki_presets_are_dfki_parameter_files(preset: str, source: str) -> None:
    assert ipgen.FixedPendulum.preset(preset) == dfki_pendulum(read_model_parameters(DATA / f"{source}.yml"))


def test_presets_list_the_fixed_chains(capsys: pytest.CaptureFixture[str]) -> None:
    assert cli(["presets"]) == 0
    listing = capsys.readouterr().out
    assert "dfki_c0  (fixed, 2 links)" in listing and "BSD-3-Clause" in listing


@pytest.mark.parametrize(
    "arguments",
    [
        ["--type", "fixed", "--links", "2", "--angles", "relative", "--emit", "fmu", "-o", "{out}"],
        ["--type", "fixed", "--links", "2", "--fix", "m1=1", "-o", "{out}"],
        ["excite", "--preset", "dfki_c0", "--u-max", "1", "-o", "{out}"],
    ],
)
def test_commands_without_fixed_support_refuse_in_one_line(
    arguments: list[str], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert cli([a.replace("{out}", str(tmp_path / "out")) for a in arguments]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "not yet supported for fixed-pivot models" in err
    assert not (tmp_path / "out").exists()


def test_pendulum_preset_of_a_fixed_chain_is_one_line() -> None:
    with pytest.raises(ipgen.Error) as refused:
        ipgen.Pendulum.preset("dfki_c0")
    assert "\n" not in str(refused.value) and "fixed" in str(refused.value)


SCENE = """\
[system]
type = "fixed"
links = {links}

[parameters]
m = {m}
l = {l}
delta = {delta}

[actuator]
{actuator}
"""


def _scene(
    tmp_path: Path, links: int = 2, *, extra: str = "", actuator: str = "joints = [1]", **arrays
) -> Path:
    values = {"m": [1.0] * links, "l": [0.5] * links, "delta": [0.0] * links} | arrays
    path = tmp_path / "chain.toml"
    path.write_text(SCENE.format(links=links, actuator=actuator, **values) + extra, encoding="utf-8")
    return path


def _refused(path: Path) -> str:
    with pytest.raises(SceneError) as caught:
        load_fixed_scene(path)
    message = str(caught.value)
    assert "\n" not in message and "chain.toml" in message
    return message


def test_a_good_fixed_scene(tmp_path: Path) -> None:
    p = load_fixed_scene(_scene(tmp_path, 3, actuator="joints = [2, 3]\nIr = [1e-4, 2e-4]\ngr = [6, -6]"))
    assert p.joints == (2, 3) and p.gr == (6.0, -6.0)


@pytest.mark.parametrize(
    ("lines", "refused"),
    [
        ('coulomb_law = "atan"\ncoulomb_speed = 0.5', "coulomb_speed"),
        ("coulomb_gain = 50", "coulomb_gain"),  # the default law is tanh
        ('coulomb_law = "tanh"\ncoulomb_gain = 50', "coulomb_gain"),
        ('coulomb_law = "atan"\ncoulomb_gain = 50', None),
        ("coulomb_speed = 0.5", None),
    ],
)
def test_a_setting_of_the_other_coulomb_law_is_refused(
    tmp_path: Path, lines: str, refused: str | None
) -> None:
    """coulomb_speed belongs to the tanh law, coulomb_gain to DFKI's atan law: one given for the
    other law was silently dropped; it is refused in one line naming both."""
    path = _scene(tmp_path, extra="")
    text = path.read_text().replace("[parameters]\n", f"[parameters]\ncoulomb = [0.1, 0.1]\n{lines}\n", 1)
    path.write_text(text)
    if refused is None:
        chain = load_fixed_scene(path)
        assert chain.coulomb == (0.1, 0.1)
        assert chain.coulomb_speed == 0.5 or chain.coulomb_gain == 50.0
    else:
        message = _refused(path)
        assert f"parameters.{refused}" in message and "coulomb_law" in message


def test_other_tables_wait_for_the_runtime(tmp_path: Path) -> None:
    message = _refused(_scene(tmp_path, extra="[sensors]\nnoise = 0.1\n"))
    assert "[sensors] is not yet supported for fixed-pivot models" in message


@settings(max_examples=25, deadline=None)
@given(st.integers(1, 4), st.lists(st.integers(-3, 8), min_size=1, max_size=3))
def test_joint_out_of_range_refused(links: int, joints: list[int]) -> None:
    import tempfile

    with tempfile.TemporaryDirectory() as folder:
        path = _scene(Path(folder), links, actuator=f"joints = {joints}")
        if all(1 <= j <= links for j in joints) and len(set(joints)) == len(joints):
            assert load_fixed_scene(path).joints == tuple(joints)
        else:
            assert "joint" in _refused(path)


@settings(max_examples=20, deadline=None)
@given(st.integers(1, 4), st.sampled_from(["m", "l", "delta"]))
def test_base_entry_refused(links: int, group: str) -> None:
    import tempfile

    with tempfile.TemporaryDirectory() as folder:
        path = _scene(Path(folder), links, **{group: [0.3] * (links + 1)})
        assert "no base entry" in _refused(path)


@settings(max_examples=15, deadline=None)
@given(st.floats(0, 1e-2))
def test_rotor_without_gear_refused(rotor: float) -> None:
    import tempfile

    with tempfile.TemporaryDirectory() as folder:
        path = _scene(Path(folder), actuator=f"joints = [1]\nIr = [{rotor!r}]")
        assert "Ir without gr" in _refused(path)


RUN_SCENE = """\
[system]
type = "fixed"
links = 2

[parameters]
m = [0.6, 0.6]
l = [0.3, 0.2]
delta = [0.01, 0.01]

[actuator]
joints = [2]

[initial]
theta = [@ANGLE@, 0.0]
dtheta = [0.0, @RATE@]

[controller]
kind = "lqr"
saturation = @SATURATION@
period = @PERIOD@
q = [@Q@, 1, 1, 1]

[simulation]
t_end = 0.1
"""
HUGE_KEYS = ("ANGLE", "RATE", "SATURATION", "PERIOD", "Q")
DEFAULTS = {"ANGLE": "3.0", "RATE": "0.0", "SATURATION": "5.0", "PERIOD": "0.01", "Q": "10"}


@settings(max_examples=20, deadline=None)
@given(key=st.sampled_from(HUGE_KEYS), digits=st.integers(310, 4000), sign=st.sampled_from(["", "-"]))
def test_an_integer_beyond_a_double_is_one_line(key: str, digits: int, sign: str) -> None:
    """An integer too large for a double in a fixed scene's [initial] or [controller] (ipgen run):
    one line naming the key, exit 2 (float() raised an OverflowError: a traceback)."""
    import contextlib
    import io
    import tempfile

    text = RUN_SCENE
    for name, value in DEFAULTS.items():
        text = text.replace(f"@{name}@", sign + "9" * digits if name == key else value)
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "chain.toml"
        path.write_text(text, encoding="utf-8")
        error = io.StringIO()
        with contextlib.redirect_stderr(error):
            status = cli(["run", str(path), "-o", str(Path(folder) / "out"), "--no-plot"])
    lines = error.getvalue().strip().splitlines()
    assert status == 2 and len(lines) == 1, error.getvalue()
    field = {"ANGLE": "initial.theta", "RATE": "initial.dtheta"}.get(key, f"controller.{key.lower()}")
    assert field in lines[0] and "Traceback" not in lines[0], lines[0]


def test_a_fixed_run_that_writes_gigabytes_of_csv_says_so(tmp_path: Path) -> None:
    """As for a cart or an arm: 1e7 samples of a double pendulum on a pivot come to about a GB
    of CSV, and the run's plan carries the warning (a fixed chain said nothing)."""
    from ipgen.pipeline.fixed_run import fixed_plan
    from ipgen.scene.load import parse_document

    path = _scene(tmp_path, extra="\n[simulation]\nt_end = 100000.0\nsample = 0.01\n")
    reader, document = parse_document(path)
    warnings = fixed_plan(path, document, reader).warnings
    assert any("GB of CSV (10,000,001 rows" in warning for warning in warnings), warnings
    path = _scene(tmp_path, extra="\n[simulation]\nt_end = 10.0\n")
    reader, document = parse_document(path)
    assert fixed_plan(path, document, reader).warnings == ()
