"""Scene files: loading, defaults, every validation error, and the resolved config."""

from __future__ import annotations

import math
import os
import struct
from fractions import Fraction
from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st

from generator import __version__
from generator.scene import (
    InputSpec,
    Scene,
    SceneError,
    format_number,
    load_scene,
    resolved_config,
)

REPO = Path(__file__).resolve().parent.parent
SCENES = sorted((REPO / "scenes").glob("*.toml"))

# A valid classical double pendulum; tests change single keys ("table.key" -> TOML text).
BASE: dict[str, dict[str, str]] = {
    "system": {"type": '"classical"', "links": "2"},
    "parameters": {
        "m": "[0.3, 0.275, 0.275]",
        "l": "[0, 0.5, 0.5]",
        "delta": "[0.3, 0.1, 0.1]",
    },
    "input": {"kind": '"pulse"', "amplitude": "0.4", "duration": "1.0"},
    "simulation": {"t_end": "10.0"},
}
ROTARY = {
    "system.type": '"rotary"',
    "system.links": "1",
    "parameters.m": "[0.5, 0.275]",
    "parameters.l": "[0.6, 0.5]",
    "parameters.delta": "[0.3, 0.011458]",
}


def scene_text(changes: dict[str, str | None]) -> str:
    """BASE with changes applied; a None value removes the key."""
    tables = {name: dict(keys) for name, keys in BASE.items()}
    for dotted, value in changes.items():
        table, key = dotted.split(".", 1)
        keys = tables.setdefault(table, {})
        if value is None:
            keys.pop(key, None)
        else:
            keys[key] = value
    parts = [
        f"[{name}]\n" + "".join(f"{k} = {v}\n" for k, v in keys.items()) for name, keys in tables.items()
    ]
    return "\n".join(parts)


def write(tmp_path: Path, text: str, name: str = "x.toml") -> Path:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


def make(tmp_path: Path, changes: dict[str, str | None] | None = None) -> Path:
    return write(tmp_path, scene_text(changes or {}))


def expect_error(path: Path, *fragments: str) -> str:
    """Loading fails with a one-line message that starts with the file and contains fragments."""
    with pytest.raises(SceneError) as info:
        load_scene(path)
    message = str(info.value)
    assert "\n" not in message and "\r" not in message, message
    assert message.startswith(f"{path.as_posix()}: "), message
    for fragment in fragments:
        assert fragment in message, f"{fragment!r} not in {message!r}"
    return message


def config_dict(text: str) -> dict[str, str]:
    lines = [line for line in text.splitlines() if not line.startswith("#")]
    return dict(line.split(" = ", 1) for line in lines)


def bits(x: float) -> bytes:
    return struct.pack("<d", x)


# ---------------------------------------------------------------------------- shipped scenes


@pytest.mark.parametrize("path", SCENES, ids=[p.stem for p in SCENES])
def test_shipped_scene_loads(path: Path) -> None:
    scene = load_scene(path)
    assert scene.stem == path.stem
    assert len(scene.m) == len(scene.l) == len(scene.delta) == scene.links + 1
    assert scene.warnings == ()
    first = path.read_text(encoding="utf-8").splitlines()[0]
    assert first.startswith("# ") and len(first) > 20


def test_expected_scenes_are_shipped() -> None:
    names = {load_scene(path).name: path.stem for path in SCENES}
    assert names == {
        "cdip": "cdip_pulse",
        "rsip": "rsip_pulse",
        "ctip": "ctip_pulse",
        "rdip": "rdip_pulse",
    }


def test_cdip_resolved_config_is_exact(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(REPO)
    scene = load_scene(Path("scenes/cdip_pulse.toml"))
    expected = f"""\
# resolved from scenes/cdip_pulse.toml by ipgen {__version__}; do not edit
name = cdip_pulse
model = cdip
type = classical
links = 2
inertia = pivot
m = 0.3 0.275 0.275
l = 0 0.5 0.5
delta = 0.3 0.1 0.1
g = 9.81
theta = 0 0 0
dtheta = 0 0 0
input = pulse
input.amplitude = 0.4
input.start = 0
input.duration = 1
t_end = 10
sample = 0.01
method = bdf
rtol = 1e-10
atol = 1e-12
max_steps = 100000
"""
    assert resolved_config(scene) == expected


def test_rsip_matches_the_paper() -> None:
    scene = load_scene(REPO / "scenes" / "rsip_pulse.toml")
    assert (scene.type, scene.links, scene.inertia, scene.name) == (
        "rotary",
        1,
        "pivot",
        "rsip",
    )
    assert scene.m == (0.5, 0.275) and scene.l == (0.6, 0.5)
    assert scene.delta == (0.3, 0.011458) and scene.g == 9.81
    assert scene.input == InputSpec(kind="pulse", amplitude=0.4, start=0.0, duration=1.0)
    assert scene.t_end == 10.0 and scene.theta == (0.0, 0.0) and scene.dtheta == (0.0, 0.0)


# ---------------------------------------------------------------------------- defaults and API


def test_defaults_are_filled(tmp_path: Path) -> None:
    changes: dict[str, str | None] = {"input.kind": None, "input.amplitude": None}
    changes["input.duration"] = None
    scene = load_scene(make(tmp_path, changes))
    assert scene.name == "classical2" and scene.inertia == "pivot" and scene.g == 9.81
    assert scene.theta == (0.0, 0.0, 0.0) and scene.dtheta == (0.0, 0.0, 0.0)
    assert scene.input == InputSpec(kind="zero")
    assert (scene.sample, scene.method, scene.rtol, scene.atol) == (
        0.01,
        "bdf",
        1e-10,
        1e-12,
    )
    assert scene.max_steps == 100000 and scene.free == () and scene.energy is False


def test_rotary_default_name_and_full_inertia(tmp_path: Path) -> None:
    scene = load_scene(make(tmp_path, {**ROTARY, "system.inertia": '"full"'}))
    assert scene.name == "rotary1" and scene.inertia == "full" and scene.l == (0.6, 0.5)


def test_cart_length_is_ignored(tmp_path: Path) -> None:
    scene = load_scene(make(tmp_path, {"parameters.l": "[0.7, 0.5, 0.5]"}))
    assert scene.l == (0.0, 0.5, 0.5)
    assert scene.exact("l0") == 0


def test_integers_are_accepted_as_floats(tmp_path: Path) -> None:
    scene = load_scene(make(tmp_path, {"parameters.m": "[1, 2, 3]", "simulation.t_end": "5"}))
    assert scene.m == (1.0, 2.0, 3.0) and isinstance(scene.m[0], float)
    assert scene.t_end == 5.0 and isinstance(scene.t_end, float)


def test_exact_parameters_keep_the_decimal_text(tmp_path: Path) -> None:
    long = "0.1000000000000000000001"  # more digits than a double holds
    scene = load_scene(make(tmp_path, {"parameters.delta": f"[0.3, {long}, 1e-1]"}))
    assert scene.exact("delta1") == Fraction(long)
    assert scene.exact("delta2") == Fraction(1, 10)
    assert scene.exact("m1") == Fraction(11, 40)
    assert scene.exact("g") == Fraction(981, 100)
    assert scene.value("delta1") == 0.1 and scene.value("g") == 9.81
    with pytest.raises(KeyError):
        scene.value("m3")


def test_free_and_energy_are_carried(tmp_path: Path) -> None:
    changes = {"parameters.free": '["m0", "delta1", "g"]', "outputs.energy": "true"}
    scene = load_scene(make(tmp_path, changes))
    assert scene.free == ("m0", "delta1", "g") and scene.energy is True
    assert set(scene.free) <= set(scene.parameter_names())


def test_tight_rtol_is_a_warning_not_an_error(tmp_path: Path) -> None:
    path = make(tmp_path, {"simulation.rtol": "5e-15"})
    scene = load_scene(path)
    assert scene.rtol == 5e-15
    assert len(scene.warnings) == 1 and "simulation.rtol" in scene.warnings[0]
    assert scene.warnings[0].startswith(path.as_posix())


def test_scene_is_frozen_and_hashable(tmp_path: Path) -> None:
    scene = load_scene(make(tmp_path))
    with pytest.raises(AttributeError):
        scene.t_end = 1.0  # type: ignore[misc]
    assert hash(scene) == hash(load_scene(make(tmp_path)))
    assert isinstance(scene, Scene)


# ---------------------------------------------------------------------------- inputs


@pytest.mark.parametrize(
    ("changes", "keys"),
    [
        ({"input.kind": '"zero"', "input.amplitude": None, "input.duration": None}, []),
        ({"input.kind": '"constant"', "input.duration": None}, ["amplitude"]),
        ({"input.start": "2.5"}, ["amplitude", "start", "duration"]),
        (
            {"input.kind": '"step"', "input.duration": None, "input.time": "1"},
            ["amplitude", "time"],
        ),
        (
            {"input.kind": '"sine"', "input.duration": None, "input.frequency": "0.5"},
            ["amplitude", "frequency", "phase"],
        ),
    ],
    ids=["zero", "constant", "pulse", "step", "sine"],
)
def test_input_keys_in_config(tmp_path: Path, changes: dict[str, str | None], keys: list[str]) -> None:
    config = config_dict(resolved_config(load_scene(make(tmp_path, changes))))
    emitted = [key.removeprefix("input.") for key in config if key.startswith("input.")]
    assert emitted == keys


def test_input_values_over_time() -> None:
    pulse = InputSpec(kind="pulse", amplitude=0.4, start=1.0, duration=2.0)
    assert [pulse.value(t) for t in (0.5, 1.0, 2.9, 3.0)] == [0.0, 0.4, 0.4, 0.0]
    assert pulse.breakpoints() == (1.0, 3.0)
    step = InputSpec(kind="step", amplitude=-2.0, time=1.5)
    assert (step.value(1.4), step.value(1.5), step.breakpoints()) == (0.0, -2.0, (1.5,))
    sine = InputSpec(kind="sine", amplitude=2.0, frequency=0.25, phase=0.0)
    assert sine.value(1.0) == pytest.approx(2.0) and sine.breakpoints() == ()
    assert InputSpec().value(3.0) == 0.0 and InputSpec(kind="constant", amplitude=1.5).value(9) == 1.5


# ---------------------------------------------------------------------------- errors


ERRORS: list[tuple[str, dict[str, str | None], tuple[str, ...]]] = [
    # (id, changes to BASE, fragments the message must contain)
    ("negative mass", {"parameters.m": "[0.3, 0.275, -0.1]"}, ("parameters.m[2] = -0.1", "> 0 kg")),
    ("zero cart mass", {"parameters.m": "[0, 0.275, 0.275]"}, ("parameters.m[0] = 0", "> 0 kg")),
    (
        "short array",
        {"parameters.m": "[0.3, 0.275]"},
        ("parameters.m has 2 entries, expected 3", "base + 2 links"),
    ),
    (
        "long array",
        {"parameters.delta": "[0.3, 0.1, 0.1, 0.1]"},
        ("parameters.delta has 4 entries, expected 3",),
    ),
    ("short initial", {"initial.theta": "[0]"}, ("initial.theta has 1 entry, expected 3",)),
    ("scalar for array", {"parameters.l": "0.5"}, ("parameters.l = 0.5", "expected an array of 3 numbers")),
    ("zero link length", {"parameters.l": "[0, 0.5, 0]"}, ("parameters.l[2] = 0", "> 0 m")),
    ("negative cart length", {"parameters.l": "[-1, 0.5, 0.5]"}, ("parameters.l[0] = -1", "write 0")),
    (
        "rotary arm length",
        {**ROTARY, "parameters.l": "[0, 0.5]"},
        ("parameters.l[0] = 0", "arm length must be > 0 m"),
    ),
    ("negative damping", {"parameters.delta": "[0.3, -0.1, 0.1]"}, ("parameters.delta[1] = -0.1", ">= 0")),
    ("negative g", {"parameters.g": "-9.81"}, ("parameters.g = -9.81", ">= 0")),
    (
        "bool is not a number",
        {"parameters.g": "true"},
        ("parameters.g = true", "expected a number, got a boolean"),
    ),
    (
        "string is not a number",
        {"simulation.t_end": '"10"'},
        ('simulation.t_end = "10"', "expected a number, got a string"),
    ),
    (
        "bool in array",
        {"parameters.m": "[0.3, false, 0.275]"},
        ("parameters.m[1] = false", "expected a number"),
    ),
    ("nan", {"parameters.delta": "[0.3, nan, 0.1]"}, ("parameters.delta[1] = nan", "finite")),
    ("inf", {"simulation.t_end": "inf"}, ("simulation.t_end = inf", "finite")),
    ("-inf in initial", {"initial.dtheta": "[0, -inf, 0]"}, ("initial.dtheta[1] = -inf", "finite")),
    ("huge float", {"parameters.m": "[1e400, 1, 1]"}, ("parameters.m[0]", "too large")),
    ("huge integer", {"initial.theta": f"[{10**400}, 0, 0]"}, ("initial.theta[0]", "too large")),
    ("missing t_end", {"simulation.t_end": None}, ("missing required key 'simulation.t_end'",)),
    (
        "missing type",
        {"system.type": None},
        ("missing required key 'system.type'", '"classical" or "rotary"'),
    ),
    ("missing links", {"system.links": None}, ("missing required key 'system.links'",)),
    ("missing mass", {"parameters.m": None}, ("missing required key 'parameters.m'", "3 numbers")),
    ("missing damping", {"parameters.delta": None}, ("missing required key 'parameters.delta'",)),
    ("t_end zero", {"simulation.t_end": "0"}, ("simulation.t_end = 0", "> 0 s")),
    ("t_end negative", {"simulation.t_end": "-1.5"}, ("simulation.t_end = -1.5", "> 0 s")),
    ("sample zero", {"simulation.sample": "0.0"}, ("simulation.sample = 0.0", "> 0 s and <= t_end")),
    ("sample > t_end", {"simulation.sample": "20"}, ("simulation.sample = 20", "<= t_end (10 s)")),
    ("rtol >= 1", {"simulation.rtol": "1.0"}, ("simulation.rtol = 1.0", "(0, 1)")),
    ("rtol zero", {"simulation.rtol": "0"}, ("simulation.rtol = 0", "(0, 1)")),
    (
        "rtol unmeetable",
        {"simulation.rtol": "1e-16"},
        ("simulation.rtol = 1e-16", "double precision", "1e-14"),
    ),
    ("atol negative", {"simulation.atol": "-1e-12"}, ("simulation.atol = -1e-12", ">= 0")),
    ("max_steps zero", {"simulation.max_steps": "0"}, ("simulation.max_steps = 0", ">= 1")),
    (
        "max_steps float",
        {"simulation.max_steps": "1e5"},
        ("simulation.max_steps = 1e+5", "integer", "float", "without '.'"),
    ),
    ("method", {"simulation.method": '"rk4"'}, ('simulation.method = "rk4"', '"bdf" or "adams"')),
    ("links zero", {"system.links": "0"}, ("system.links = 0", ">= 1")),
    ("links float", {"system.links": "2.0"}, ("system.links = 2.0", "expected an integer, got a float")),
    ("links string", {"system.links": '"2"'}, ('system.links = "2"', "expected an integer, got a string")),
    ("type", {"system.type": '"cart"'}, ('system.type = "cart"', '"classical" or "rotary"')),
    ("inertia classical", {"system.inertia": '"pivot"'}, ('system.inertia = "pivot"', "rotary systems only")),
    (
        "inertia value",
        {**ROTARY, "system.inertia": '"half"'},
        ('system.inertia = "half"', '"pivot" or "full"'),
    ),
    ("name not identifier", {"system.name": '"my-model"'}, ('system.name = "my-model"', "C++ identifier")),
    ("name starts with digit", {"system.name": '"2dip"'}, ('system.name = "2dip"', "C++ identifier")),
    ("name reserved __", {"system.name": '"a__b"'}, ('system.name = "a__b"', "'__'")),
    ("name keyword", {"system.name": '"class"'}, ('system.name = "class"', "reserved in C++")),
    ("name std", {"system.name": '"std"'}, ('system.name = "std"', "reserved in C++")),
    ("name not string", {"system.name": "3"}, ("system.name = 3", "expected a string")),
    ("pulse duration zero", {"input.duration": "0"}, ("input.duration = 0", "> 0 s")),
    ("pulse start negative", {"input.start": "-1"}, ("input.start = -1", ">= 0 s")),
    ("pulse without duration", {"input.duration": None}, ("missing required key 'input.duration'",)),
    ("pulse without amplitude", {"input.amplitude": None}, ("missing required key 'input.amplitude'",)),
    (
        "sine frequency negative",
        {"input.kind": '"sine"', "input.duration": None, "input.frequency": "-1"},
        ("input.frequency = -1", ">= 0 Hz"),
    ),
    (
        "step time negative",
        {"input.kind": '"step"', "input.duration": None, "input.time": "-2"},
        ("input.time = -2", ">= 0 s"),
    ),
    (
        "input kind",
        {"input.kind": '"square"'},
        ('input.kind = "square"', '"zero", "constant", "pulse", "step" or "sine"'),
    ),
    ("input without kind", {"input.kind": None}, ("missing required key 'input.kind'",)),
    (
        "key of another kind",
        {"input.time": "1.0"},
        ("input.time is not used by a 'pulse' input", "amplitude, start, duration"),
    ),
    ("energy not bool", {"outputs.energy": '"yes"'}, ('outputs.energy = "yes"', "true or false")),
    ("free not array", {"parameters.free": '"m0"'}, ('parameters.free = "m0"', "array of names")),
    (
        "free unknown",
        {"parameters.free": '["m0", "delta9"]'},
        ('parameters.free[1] = "delta9"', "delta0..delta2"),
    ),
    (
        "free typo",
        {"parameters.free": '["dleta1"]'},
        ('parameters.free[0] = "dleta1"', "did you mean 'delta1'?"),
    ),
    ("free twice", {"parameters.free": '["g", "g"]'}, ('parameters.free[1] = "g"', "twice")),
    ("free cart length", {"parameters.free": '["l0"]'}, ('parameters.free[0] = "l0"', "cart has no length")),
    ("free not string", {"parameters.free": "[1]"}, ("parameters.free[0] = 1", "parameter name", "or g")),
    (
        "unknown key typo",
        {"simulation.rtoll": "1e-8"},
        ("unknown key 'simulation.rtoll' (did you mean 'rtol'?)",),
    ),
    ("key in wrong table", {"system.g": "9.81"}, ("unknown key 'system.g' (it belongs in [parameters])",)),
    (
        "per-link parameter",
        {"parameters.m1": "0.3"},
        ("unknown key 'parameters.m1'", "m = [base, link 1, ...]"),
    ),
    ("unknown key no match", {"outputs.zzz": "1"}, ("unknown key 'outputs.zzz' (expected one of: energy)",)),
    ("unknown table", {"simulaton.t_end": "1"}, ("unknown table 'simulaton' (did you mean 'simulation'?)",)),
    ("nested table", {"system.extra.x": "1"}, ("unknown key 'system.extra'",)),
]


@pytest.mark.parametrize(("changes", "fragments"), [e[1:] for e in ERRORS], ids=[e[0] for e in ERRORS])
def test_error(tmp_path: Path, changes: dict[str, str | None], fragments: tuple[str, ...]) -> None:
    expect_error(make(tmp_path, changes), *fragments)


def test_one_entry_array_message_says_link(tmp_path: Path) -> None:
    expect_error(
        make(tmp_path, {**ROTARY, "parameters.m": "[0.5]"}),
        "expected 2 (links + 1 = base + 1 link)",
    )


def test_table_given_as_value(tmp_path: Path) -> None:
    expect_error(write(tmp_path, "system = 3\n"), "system = 3", "expected a table")


def test_top_level_key_names_its_table(tmp_path: Path) -> None:
    expect_error(
        write(tmp_path, "t_end = 3\n" + scene_text({})),
        "unknown key 't_end'",
        "[simulation]",
    )


def test_empty_file_asks_for_system(tmp_path: Path) -> None:
    expect_error(write(tmp_path, ""), "missing required key 'system.type'")


def test_malformed_toml(tmp_path: Path) -> None:
    message = expect_error(write(tmp_path, "[system]\ntype = classical\n"), "malformed TOML: ", "line 2")
    assert message.count(":") >= 2


def test_duplicate_key_is_malformed(tmp_path: Path) -> None:
    expect_error(write(tmp_path, scene_text({}) + "\n[system]\nlinks = 3\n"), "malformed TOML")


def test_missing_file(tmp_path: Path) -> None:
    expect_error(tmp_path / "nope.toml", "no such file")


def test_directory_is_not_a_scene(tmp_path: Path) -> None:
    directory = tmp_path / "dir.toml"
    directory.mkdir()
    expect_error(directory, "is a directory")


@pytest.mark.skipif(os.name != "posix" or os.geteuid() == 0, reason="root can read anything")
def test_unreadable_file(tmp_path: Path) -> None:
    path = make(tmp_path)
    path.chmod(0)
    expect_error(path, "cannot read file")


def test_not_utf8(tmp_path: Path) -> None:
    path = tmp_path / "x.toml"
    path.write_bytes(b"# caf\xe9\n")
    expect_error(path, "not UTF-8")


def test_bad_file_name(tmp_path: Path) -> None:
    expect_error(
        write(tmp_path, scene_text({}), name="my scene.toml"),
        "scene file name 'my scene'",
    )


def test_long_values_are_shortened(tmp_path: Path) -> None:
    long = '"' + "x" * 500 + '"'
    message = expect_error(make(tmp_path, {"parameters.g": long}), "parameters.g = ", "...")
    assert len(message) < 200 + len(tmp_path.as_posix())


# ---------------------------------------------------------------------------- round trip


def test_config_floats_round_trip(tmp_path: Path) -> None:
    changes = {
        "parameters.m": "[0.30000000000000004, 1e-300, 123456789.123456789]",
        "parameters.g": "9.80665",
        "initial.theta": "[-0.0, 3.141592653589793, 1e16]",
        "input.amplitude": "-0.1",
        "simulation.t_end": "12.3",
        "simulation.sample": "0.001",
    }
    scene = load_scene(make(tmp_path, changes))
    config = config_dict(resolved_config(scene))
    for key, values in (("m", scene.m), ("theta", scene.theta), ("g", (scene.g,))):
        parsed = tuple(float(text) for text in config[key].split())
        assert [bits(x) for x in parsed] == [bits(x) for x in values]
    for key in ("t_end", "sample"):
        assert bits(float(config[key])) == bits(getattr(scene, key))
    assert float(config["input.amplitude"]) == -0.1
    assert config["theta"].split()[0] == "-0"


@given(st.floats(allow_nan=False, allow_infinity=False))
def test_format_number_round_trips(x: float) -> None:
    text = format_number(x)
    assert bits(float(text)) == bits(x)
    assert " " not in text and "inf" not in text


def test_format_number_examples() -> None:
    assert [format_number(x) for x in (10.0, 0.0, 0.1, 1e-10, 1e16, 2.5e-324)] == [
        "10",
        "0",
        "0.1",
        "1e-10",
        "1e+16",
        "5e-324",
    ]
    assert math.isclose(float(format_number(1 / 3)), 1 / 3, rel_tol=0)


def test_resolved_config_is_deterministic(tmp_path: Path) -> None:
    path = make(tmp_path, {"parameters.free": '["g"]'})
    first = resolved_config(load_scene(path))
    assert first == resolved_config(load_scene(path))
    lines = first.splitlines()
    assert lines[0] == f"# resolved from {path.as_posix()} by ipgen {__version__}; do not edit"
    assert all(" = " in line for line in lines[1:]) and "free" not in first
