"""Bad input to ipgen, class by class (issue #16): each class has a regression test for the
reported case and a hypothesis property over the space it belongs to. The promise checked
everywhere: exit 0 with the files, or exit 2 with one line `ipgen: error: ...` of bounded
length, no traceback, nothing written, no user file touched, no hang.

The simulator's side (its CSV, the shared limits in use) is in test_simulator_bad_input.py,
which ctest runs against a built simulator.
"""

from __future__ import annotations

import contextlib
import io
import re
import subprocess
import tempfile
import time
from fractions import Fraction
from pathlib import Path

import pytest
from cxx import CXX, EIGEN_INCLUDE, require_toolchain
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from ipgen.command.cli import MESSAGE_CHARS, run
from ipgen.common import limits
from ipgen.common.naming import name_problem
from ipgen.common.safetext import abbreviate, quote_path
from ipgen.errors import SceneError
from ipgen.experiment.config import resolved_config
from ipgen.experiment.scene import load_scene
from ipgen.model.specialise import SpecialisationError, parse_fix
from ipgen.model.system import System

ROOT = Path(__file__).resolve().parent.parent
_CHECKS = [HealthCheck.too_slow, HealthCheck.function_scoped_fixture, HealthCheck.data_too_large]


def examples(count: int) -> settings:
    """`count` examples per property, no deadline (the machine is shared); timing is asserted
    where a hang is the failure."""
    return settings(max_examples=count, deadline=None, suppress_health_check=_CHECKS)


# The longest line an error may be: the message cap plus "ipgen: error: " and a hint.
LONGEST_ERROR = MESSAGE_CHARS + 40

SCENE = """\
[system]
type = "rotary"
links = 1
{system}
[parameters]
m = [0.2, 0.1]
l = [0.3, 0.5]
delta = [0.01, 0.001]
{parameters}
[simulation]
t_end = 1.0
{simulation}
"""


def scene_text(system: str = "", parameters: str = "", simulation: str = "") -> str:
    return SCENE.format(system=system, parameters=parameters, simulation=simulation)


def _clocks() -> tuple[float, float]:
    """(wall, this process's CPU) seconds now."""
    return time.monotonic(), time.process_time()


def _assert_quick(started: tuple[float, float], seconds: float) -> None:
    """A refusal took under `seconds` of this process's CPU (it checked before deriving anything)
    and under ten times that of wall time (no hang); the wall's margin is for a machine that runs
    other work beside the tests (a 5 s wall bound failed once at 5.6 s under such load)."""
    wall, cpu = _clocks()
    assert cpu - started[1] < seconds, f"{cpu - started[1]:.2f} s of CPU"
    assert wall - started[0] < 10 * seconds, f"{wall - started[0]:.2f} s"


def call(*argv: str) -> tuple[int, str, str]:
    """Run the ipgen command in-process, in an empty current folder: (exit status, stdout, stderr)."""
    out, err = io.StringIO(), io.StringIO()
    with (
        tempfile.TemporaryDirectory() as cwd,
        contextlib.chdir(cwd),
        contextlib.redirect_stdout(out),
        contextlib.redirect_stderr(err),
    ):
        status = run(list(argv))
    return status, out.getvalue(), err.getvalue()


def assert_clean_error(status: int, stderr: str, context: object = "") -> None:
    """Exit 2 and one bounded line `ipgen: error: ...` (no traceback)."""
    assert status == 2, (context, status, stderr)
    lines = stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith("ipgen: error: "), (context, stderr)
    assert len(lines[0]) <= LONGEST_ERROR, (context, len(lines[0]))


def listing(folder: Path) -> dict[str, bytes | None]:
    """Every path under `folder` with its bytes (None for a folder)."""
    return {
        str(p.relative_to(folder)): (None if p.is_dir() else p.read_bytes())
        for p in sorted(folder.rglob("*"))
    }


# ---------------------------------------------------------------- class 1: no traceback


def test_class1_regressions(tmp_path: Path) -> None:
    deep = tmp_path / "deep.toml"
    deep.write_text("x = " + "[" * 5000 + "]" * 5000 + "\n")
    long_name = tmp_path / "long.toml"
    long_name.write_text(scene_text(system=f'name = "{"a" * 252}"'))
    cases = [
        ("--scene", str(deep), "-o", str(tmp_path / "o")),
        ("--scene", str(long_name), "-o", str(tmp_path / "o")),
        ("--type", "rotary", "--links", "1", "--name", "a" * 252, "-o", str(tmp_path / "o")),
        ("--type", "rotary", "--links", "1", "-o", str(tmp_path / ("d" * 300) / "x")),
        ("--type", "rotary", "--links", "1", "--fix", "m0=1e999", "-o", str(tmp_path / "o")),
    ]
    for argv in cases:
        status, _, stderr = call(*argv)
        assert_clean_error(status, stderr, argv)
    assert not (tmp_path / "o").exists()


# Pieces of scene text that reach every corner of the TOML reader: nesting, dotted keys, long
# and odd names, numbers out of every range.
toml_fragments = st.one_of(
    st.integers(1, 6000).map(lambda n: "x = " + "[" * n + "]" * n),
    st.integers(1, 6000).map(lambda n: "x = " + "{a = " * n + "1" + "}" * n),
    st.integers(1, 3000).map(lambda n: ".".join(["k"] * n) + " = 1"),
    st.integers(1, 300).map(lambda n: f"[{'.'.join(['t'] * n)}]"),
    st.text(min_size=0, max_size=400).map(lambda s: f"name = {s!r}".replace("\\", "\\\\")),
    st.from_regex(r"[A-Za-z_][A-Za-z0-9_]{0,300}", fullmatch=True).map(lambda s: f'name = "{s}"'),
    st.sampled_from(
        ["1e999", "-1e999", "1e-99999999", "nan", "inf", "9223372036854775807", "1e308", "0"]
    ).map(lambda v: f"g = {v}"),
    st.text(max_size=200),
)


@examples(150)
@given(fragment=toml_fragments, where=st.sampled_from(["top", "system", "parameters", "simulation"]))
def test_class1_any_scene_text_is_a_scene_or_a_scene_error(fragment: str, where: str) -> None:
    text = fragment + "\n" + scene_text() if where == "top" else scene_text(**{where: fragment})
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "s.toml"
        path.write_text(text, encoding="utf-8", errors="surrogatepass")
        started = _clocks()
        try:
            load_scene(path)
        except SceneError as e:
            message = str(e)
            assert "\n" not in message and len(message) <= LONGEST_ERROR + len(str(path)), message
        _assert_quick(started, 5)


long_components = st.integers(200, 400).map(lambda n: "c" * n)


@examples(60)
@given(
    name=st.one_of(st.none(), st.from_regex(r"[a-z][a-z0-9_]{0,400}", fullmatch=True)),
    component=st.one_of(st.none(), long_components),
    fix=st.one_of(
        st.none(),
        st.builds(lambda e, m: f"m0={m}e{e}", st.integers(-(10**9), 10**9), st.integers(1, 99)),
        st.floats(allow_nan=True, allow_infinity=True).map(lambda x: f"g={x!r}"),
    ),
)
def test_class1_names_paths_numbers_never_raise(
    name: str | None, component: str | None, fix: str | None
) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / (component or "out")
        argv = ["--type", "rotary", "--links", "1", "-o", str(out)]
        argv += ["--name", name] if name is not None else []
        argv += ["--fix", fix] if fix is not None else []
        status, _, stderr = call(*argv)
        if status != 0:
            assert_clean_error(status, stderr, argv)
            assert not (Path(tmp) / "out").exists() and not any(Path(tmp).iterdir())


# ---------------------------------------------------------------- class 2: no hang


def test_class2_regressions(tmp_path: Path) -> None:
    started = _clocks()
    status, _, stderr = call(
        "--type", "rotary", "--links", "1", "--fix", "m0=1e-99999999", "-o", str(tmp_path)
    )
    assert_clean_error(status, stderr)
    assert "1e-30 to 1e30" in stderr
    tiny = tmp_path / "tiny.toml"
    tiny.write_text(scene_text(system="specialise = true").replace("[0.01, 0.001]", "[0.01, 1e-99999999]"))
    status, _, stderr = call("--scene", str(tiny), "-o", str(tmp_path / "o"))
    assert_clean_error(status, stderr)
    assert "parameters.delta[1]" in stderr and "free" in stderr
    big = tmp_path / "big.toml"
    big.write_text(
        scene_text()
        .replace("links = 1", "links = 1000")
        .replace("m = [0.2, 0.1]", f"m = [{', '.join(['1'] * 1001)}]")
        .replace("l = [0.3, 0.5]", f"l = [{', '.join(['1'] * 1001)}]")
        .replace("delta = [0.01, 0.001]", f"delta = [{', '.join(['0'] * 1001)}]")
    )
    status, _, stderr = call("--scene", str(big), "-o", str(tmp_path / "o"))
    assert_clean_error(status, stderr)
    _assert_quick(started, 10)


@examples(200)
@given(
    mantissa=st.one_of(
        st.integers(0, 10**40).map(str), st.decimals(allow_nan=False, allow_infinity=False).map(str)
    ),
    exponent=st.integers(-(10**9), 10**9),
)
def test_class2_folding_is_bounded(mantissa: str, exponent: int) -> None:
    """Any decimal: refused at once, or an exact rational of bounded size."""
    text = f"{mantissa}e{exponent}" if "e" not in mantissa.lower() else mantissa
    started = _clocks()
    try:
        ((_, value),) = parse_fix(System("rotary", 1), f"delta1={text}")
    except SpecialisationError as e:
        assert "\n" not in str(e)
    else:
        assert value == 0 or (
            len(str(value.numerator)) <= 2 * limits.FOLD_MAX_DIGITS + 1
            and len(str(value.denominator)) <= limits.FOLD_MAX_DIGITS - limits.FOLD_MIN_EXPONENT + 1
        )
        assert value == Fraction(text)
    _assert_quick(started, 1)


@examples(40)
@given(links=st.integers(31, 5000))
def test_class2_large_scenes_need_force(links: int, tmp_path_factory: pytest.TempPathFactory) -> None:
    folder = tmp_path_factory.mktemp("big")
    count = links + 1
    text = (
        scene_text()
        .replace("links = 1", f"links = {links}")
        .replace("m = [0.2, 0.1]", f"m = [{', '.join(['1'] * count)}]")
        .replace("l = [0.3, 0.5]", f"l = [{', '.join(['1'] * count)}]")
        .replace("delta = [0.01, 0.001]", f"delta = [{', '.join(['0'] * count)}]")
    )
    path = folder / "big.toml"
    path.write_text(text)
    started = _clocks()
    status, _, stderr = call("--scene", str(path), "-o", str(folder / "out"))
    assert_clean_error(status, stderr)
    assert "--force" in stderr and not (folder / "out").exists()
    _assert_quick(started, 5)


# ---------------------------------------------------------------- class 3: all or nothing


obstacles = st.sampled_from(["user file", "folder", "unreadable"])


@examples(25)
@given(target=st.sampled_from(["scene.cfg", "rotary1.hpp"]), obstacle=obstacles, second=st.booleans())
def test_class3_all_files_or_none(target: str, obstacle: str, second: bool) -> None:
    """Something in the way of one output of a scene command: exit 2, nothing written or changed."""
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        scene = root / "scene.toml"
        scene.write_text(scene_text())
        out = root / "out"
        out.mkdir()
        if second:  # an earlier run's files are there too (ipgen may replace them)
            assert call("--scene", str(scene), "-o", str(out))[0] == 0
            (out / target).unlink()
        if obstacle == "folder":
            (out / target).mkdir()
        else:
            (out / target).write_text("a user's file\n")
            if obstacle == "unreadable":
                (out / target).chmod(0)
        before = {k: v for k, v in listing(out).items() if k != target}
        status, _, stderr = call("--scene", str(scene), "-o", str(out))
        assert_clean_error(status, stderr, (target, obstacle))
        after = {k: v for k, v in listing(out).items() if k != target}
        assert after == before  # no new file, no temporary file, nothing replaced


def test_class3_regression_user_cfg_keeps_header_away(tmp_path: Path) -> None:
    scene = tmp_path / "cdip.toml"
    scene.write_text((ROOT / "scenes" / "cdip_pulse.toml").read_text())
    (tmp_path / "out").mkdir()
    (tmp_path / "out" / "cdip.cfg").write_text("mine\n")
    status, _, stderr = call("--scene", str(scene), "-o", str(tmp_path / "out"))
    assert_clean_error(status, stderr)
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == ["cdip.cfg"]


# ---------------------------------------------------------------- class 4: no exit 0 on bad input


def test_class4_regression_empty_output(tmp_path: Path) -> None:
    scene = tmp_path / "s.toml"
    scene.write_text(scene_text())
    status, _, stderr = call("--scene", str(scene), "-o", "")
    assert_clean_error(status, stderr)
    assert "-o '' is empty" in stderr


@examples(40)
@given(
    option=st.sampled_from(["-o", "--name", "--fix", "--outputs", "--emit", "--scene", "--links", "--type"]),
    value=st.sampled_from(["", " ", ",", "=", ",,", "\t"]),
)
def test_class4_empty_values_are_errors(option: str, value: str) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        argv = {"--type": "rotary", "--links": "1", "-o": str(Path(tmp) / "out")}
        argv[option] = value
        status, _, stderr = call(*[part for pair in argv.items() for part in pair])
        if option == "-o" and value.strip():
            return  # a folder named "," is a folder
        assert_clean_error(status, stderr, (option, value))
        assert not any(Path(tmp).iterdir())


# ---------------------------------------------------------------- class 6: shared limits


def cpp_limits() -> dict[str, float]:
    """The constants of cpp/include/ipsim/limits.hpp."""
    text = (ROOT / "cpp" / "include" / "ipsim" / "limits.hpp").read_text()
    found = re.findall(r"inline constexpr [\w:]+ (k\w+) = ([0-9.e+-]+);", text)
    return {name: float(value) for name, value in found}


def test_class6_limits_are_the_same_in_python_and_cpp() -> None:
    cpp = cpp_limits()
    assert cpp == {
        "kMaxSamples": limits.MAX_SAMPLES,
        "kMinTEnd": limits.MIN_T_END,
        "kRtolMin": limits.RTOL_MIN,
        "kMessageValueChars": limits.MESSAGE_VALUE_CHARS,
        "kMessagePathChars": limits.MESSAGE_PATH_CHARS,
        "kMaxDelayPeriods": limits.MAX_DELAY_PERIODS,
        "kDelayTolerance": limits.DELAY_TOLERANCE,
    }


def test_class6_regressions(tmp_path: Path) -> None:
    for simulation, key in [
        ("t_end = 1e7", "sample"),
        ("t_end = 1.0\nsample = 1e-300", "sample"),
        ("t_end = 9223372036854775807", "sample"),
    ]:
        path = tmp_path / "s.toml"
        path.write_text(scene_text().replace("t_end = 1.0\n", "") + simulation + "\n")
        with pytest.raises(SceneError, match=f"simulation.{key} = .*output samples"):
            load_scene(path)


# ---------------------------------------------------------------- class 7: no injection


folder_names = st.text(
    alphabet=st.characters(blacklist_categories=("Cs",), blacklist_characters="/\x00"),
    min_size=1,
    max_size=30,
).filter(lambda s: s not in (".", ".."))


def cfg_entries(text: str) -> dict[str, str]:
    """The resolved scene as the C++ reader sees it: `#` to the end of a line is a comment."""
    entries = {}
    for line in text.split("\n"):
        line = line.split("#", 1)[0].strip(" \t\r")
        if line:
            key, _, value = line.partition("=")
            entries[key.strip()] = value.strip()
    return entries


@examples(40)
@given(folder=folder_names)
def test_class7_paths_stay_inside_comments(folder: str) -> None:
    """Any folder name around a scene: the resolved scene has the same settings, and the
    header differs only by the quoted path, whose characters cannot leave a C/C++ comment."""
    with tempfile.TemporaryDirectory() as tmp:
        plain, odd = Path(tmp) / "plain", Path(tmp) / "odd" / folder
        text = scene_text(system="specialise = true")
        for where in (plain, odd):
            where.mkdir(parents=True)
            (where / "s.toml").write_text(text)
            assert call("--scene", str(where / "s.toml"), "-o", str(where / "out"))[0] == 0
        quoted = quote_path((odd / "s.toml").as_posix())
        assert re.fullmatch(r"[A-Za-z0-9/._\-+~:=,@%]+", quoted)
        assert cfg_entries((odd / "out" / "s.cfg").read_text()) == cfg_entries(
            (plain / "out" / "s.cfg").read_text()
        )
        plain_header = (plain / "out" / "rotary1.hpp").read_text()
        expected = plain_header.replace(quote_path((plain / "s.toml").as_posix()), quoted)
        assert (odd / "out" / "rotary1.hpp").read_text() == expected


def test_class7_regression_newline_in_folder(tmp_path: Path) -> None:
    folder = tmp_path / "x\nenergy = true"
    folder.mkdir()
    (folder / "s.toml").write_text(scene_text())
    cfg = resolved_config(load_scene(folder / "s.toml"))
    assert "energy" not in cfg_entries(cfg)
    assert "/x%0Aenergy%20=%20true/s.toml; do not edit\n" in cfg


# ---------------------------------------------------------------- class 8: macro names


def compiler_macros() -> set[str]:
    """Every macro the standard C and C++ headers, glibc and Eigen define, from the compiler."""
    require_toolchain()
    c_headers = """assert complex ctype errno fenv float inttypes iso646 limits locale math setjmp signal
    stdarg stdbool stddef stdint stdio stdlib string tgmath time wchar wctype""".split()
    c_source = "".join(f"#include <{h}.h>\n" for h in c_headers)
    runs = [
        (["gcc", "-std=c99"], c_source, "c"),
        (["gcc", "-std=gnu11"], c_source, "c"),
        (
            [CXX, "-std=gnu++17", f"-I{EIGEN_INCLUDE}"],
            "#include <bits/stdc++.h>\n#include <Eigen/Dense>\n",
            "c++",
        ),
    ]
    macros: set[str] = set()
    for command, source, language in runs:
        dump = subprocess.run(
            [*command, "-dM", "-E", "-x", language, "-"],
            input=source,
            capture_output=True,
            text=True,
            check=True,
        ).stdout
        macros |= set(re.findall(r"^#define (\w+)", dump, flags=re.M))
    return macros


def test_class8_regressions() -> None:
    for name in [
        "NULL",
        "errno",
        "EOF",
        "assert",
        "stdin",
        "INFINITY",
        "M_PI",
        "linux",
        "IPGEN_SCALAR",
        "ipgen_x",
    ]:
        assert name_problem(name) is not None, name


def test_class8_every_compiler_macro_is_refused() -> None:
    """The whole class, exhaustively: each of the ~1,600 macro names the compiler reports."""
    macros = compiler_macros()
    assert len(macros) > 1000  # the dump worked
    accepted = sorted(m for m in macros if name_problem(m) is None)
    assert accepted == []


def test_class8_header_identifiers_are_refused(tmp_path: Path) -> None:
    """Every identifier the generated header declares in its namespace."""
    assert call("--type", "rotary", "--links", "1", "-o", str(tmp_path))[0] == 0
    header = (tmp_path / "rotary1.hpp").read_text()
    declared = set(re.findall(r"(?:struct|using|namespace|constexpr \w+\*?|const char\*) (\w+)\b", header))
    declared |= set(re.findall(r"^(?:\w+<Scalar>|Scalar|void|const char\*) (\w+)\(", header, flags=re.M))
    declared -= {"ipgen", "std", "cos", "sin"}
    assert {"mass_matrix", "Params", "kDof", "Model", "check_folded"} <= declared
    assert sorted(d for d in declared if name_problem(d) is None) == []


@examples(300)
@given(name=st.from_regex(r"[A-Za-z][A-Za-z0-9_]{0,20}", fullmatch=True))
def test_class8_accepted_names_are_no_macro(name: str, macro_set: set[str]) -> None:
    if name_problem(name) is None:
        assert name not in macro_set and not name.isupper() and "__" not in name


@pytest.fixture(scope="module")
def macro_set() -> set[str]:
    return compiler_macros()


# ---------------------------------------------------------------- class 9: bounded echo


long_text = st.text(min_size=0, max_size=12000)


@examples(80)
@given(
    where=st.sampled_from(
        ["unknown key", "value", "name", "--name", "--fix", "--emit", "--links", "-o", "--type"]
    ),
    text=long_text,
)
def test_class9_messages_stay_one_bounded_line(where: str, text: str) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        out = str(Path(tmp) / "out")
        if where in ("unknown key", "value", "name"):
            toml_string = (
                '"'
                + "".join(c if c.isalnum() else f"\\u{ord(c):04x}" for c in text if ord(c) < 0x10000)
                + '"'
            )
            line = {
                "unknown key": f"{toml_string} = 1",
                "value": f"type = {toml_string}",
                "name": f"name = {toml_string}",
            }[where]
            scene = Path(tmp) / "s.toml"
            scene.write_text(
                scene_text(system=line).replace(
                    'type = "rotary"\n', "" if where == "value" else 'type = "rotary"\n'
                )
            )
            argv = ["--scene", str(scene), "-o", out]
        else:
            argv = {"--type": "rotary", "--links": "1", "-o": out} | {where: text.replace("\x00", "")}
            argv = [part for pair in argv.items() for part in pair]
        status, _, stderr = call(*argv)
        if status != 0:
            assert_clean_error(status, stderr, where)


def test_class9_regression_long_key_and_value(tmp_path: Path) -> None:
    scene = tmp_path / "s.toml"
    scene.write_text(scene_text(simulation="k" * 1000 + " = 1"))
    with pytest.raises(SceneError) as error:
        load_scene(scene)
    assert len(str(error.value)) < 300 and "..." in str(error.value)
    assert abbreviate("a\nb" + "c" * 100) == "a\\nb" + "c" * 34 + "..." + "c" * 19


# ---------------------------------------------------------------- scene size and depth (borderline)


def test_scene_size_and_dotted_keys_refused_before_parsing(tmp_path: Path) -> None:
    dotted = tmp_path / "dotted.toml"
    dotted.write_text(".".join(["a"] * 20000) + " = 1\n")
    big = tmp_path / "big.toml"
    big.write_text(scene_text() + "# " + "x" * limits.MAX_SCENE_BYTES + "\n")
    started = _clocks()
    with pytest.raises(SceneError, match="dotted key of more than 16 parts"):
        load_scene(dotted)
    with pytest.raises(SceneError, match="more than a scene needs"):
        load_scene(big)
    _assert_quick(started, 1)


@pytest.mark.parametrize("scene", ["scenes/cdip_pulse.toml", "scenes/rigs/dfki_c0.toml"])
@pytest.mark.parametrize("api", [False, True])
def test_class3_force_never_writes_over_the_scene_itself(tmp_path: Path, scene: str, api: bool) -> None:
    """A scene named like the .cfg its generation writes (s.cfg into its own folder): refused in
    one line even with --force, the scene unchanged, as `ipgen run` does (it was replaced by the
    resolved scene: the user's input lost)."""
    import ipgen

    path = tmp_path / "s.cfg"
    path.write_text((ROOT / scene).read_text())
    before = path.read_bytes()
    err = io.StringIO()
    if api and "dfki" not in scene:
        with pytest.raises(ipgen.Error, match="the scene file itself"):
            ipgen.write_header(tmp_path, scene=path, force=True)
    else:
        with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(err):
            assert run(["--scene", str(path), "-o", str(tmp_path), "--force"]) == 2
        assert "the scene file itself" in err.getvalue() and err.getvalue().count("\n") == 1
    assert path.read_bytes() == before


@settings(max_examples=30, deadline=None)
@given(exponent=st.integers(-(10**9), 10**9), digits=st.integers(1, 3000))
def test_class2_an_exact_decimal_of_any_size_is_quick(exponent: int, digits: int) -> None:
    """A Decimal parameter (the API's) or a scene's decimal made exact (Pendulum.from_scene(...,
    exact=True)): taken, or one line, within a second of CPU (1e-99999999 as a Fraction took
    minutes, 1e-999999999 never ended)."""
    from decimal import Decimal

    import ipgen

    text = "1." + "7" * (digits - 1) + f"e{exponent}"
    started = time.process_time()
    with contextlib.suppress(ipgen.Error):
        ipgen.Pendulum("rotary", 1, m=[0.5, 0.275], l=[0.6, 0.5], delta=[0.3, Decimal(text)])
    with tempfile.TemporaryDirectory() as folder:
        scene = Path(folder) / "s.toml"
        scene.write_text((ROOT / "scenes" / "rsip_pulse.toml").read_text().replace("0.011458", text))
        with contextlib.suppress(ipgen.Error):
            ipgen.Pendulum.from_scene(scene, exact=True)
    assert time.process_time() - started < 1.0
