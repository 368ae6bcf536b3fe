"""The public Python API: ipgen.derive, ipgen.write_header, ipgen.Error, ipgen.cmake_dir, and the
"Python API" example (docs/generator.md, linked from the README) run as it stands there."""

from __future__ import annotations

import contextlib
import io
import os
import re
import subprocess
import sys
import tempfile
from pathlib import Path

import pytest
import sympy as sp
from hypothesis import given, settings
from hypothesis import strategies as st

import ipgen
from ipgen.command.cli import run

ROOT = Path(__file__).resolve().parents[1]


def readme_block(language: str, marker: str, document: str = "docs/generator.md") -> str:
    """The ```language block that contains `marker` (the Python API example moved from the README
    to docs/generator.md)."""
    blocks = re.findall(rf"```{language}\n(.*?)```", (ROOT / document).read_text(), flags=re.S)
    matching = [block for block in blocks if marker in block]
    assert len(matching) == 1, f"expected one ```{language} block with {marker!r} in {document}"
    return matching[0]


def test_readme_python_example_runs_and_does_what_it_says(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    example = readme_block("python", "ipgen.derive(")
    monkeypatch.chdir(tmp_path)
    printed = io.StringIO()
    namespace: dict[str, object] = {}
    with contextlib.redirect_stdout(printed):
        exec(compile(example, "docs/generator.md", "exec"), namespace)
    lines = printed.getvalue().splitlines()
    assert float(lines[0]) == pytest.approx(0.85, abs=1e-15)  # m0 + m1 + m2
    assert lines[1] == "--links must be an integer >= 1 (got 0): it counts the rods in the chain"
    assert namespace["paths"] == [Path("out/furuta.hpp")]
    assert "namespace ipgen::furuta" in (tmp_path / "out" / "furuta.hpp").read_text()


def test_derive_matches_the_cart_pendulum_by_hand() -> None:
    """Classical n = 1, from T = ½ m0 ẋ² + ½ m1 |v|² + ½ (m1 l²/12) θ̇², V = m1 g (l/2) cos θ."""
    eq = ipgen.derive("classical", 1)
    s = eq.symbols
    (m0, m1), (_, l1), (d0, d1), g = s.m, s.l, s.delta, s.g
    th, dx, dth = s.q[1], s.qd[0], s.qd[1]
    mass = sp.Matrix([[m0 + m1, m1 * l1 / 2 * sp.cos(th)], [m1 * l1 / 2 * sp.cos(th), m1 * l1**2 / 3]])
    bias = sp.Matrix([d0 * dx - m1 * l1 / 2 * sp.sin(th) * dth**2, d1 * dth - m1 * g * l1 / 2 * sp.sin(th)])
    assert sp.simplify(eq.mass_matrix - mass) == sp.zeros(2, 2)
    assert sp.simplify(eq.bias - bias) == sp.zeros(2, 1)
    assert sp.simplify(eq.n_matrix * sp.Matrix(s.qd) + eq.gravity - eq.bias) == sp.zeros(2, 1)
    assert sp.simplify(eq.coriolis + eq.damping - eq.n_matrix) == sp.zeros(2, 2)
    assert sp.simplify(eq.dissipation - (d0 * dx**2 + d1 * dth**2) / 2) == 0
    assert sp.simplify(eq.potential_energy - m1 * g * l1 / 2 * sp.cos(th)) == 0
    quadratic = (sp.Matrix(s.qd).T * eq.mass_matrix * sp.Matrix(s.qd))[0] / 2
    assert sp.simplify(eq.kinetic_energy - quadratic) == 0
    assert isinstance(s.u, sp.Symbol)


def test_lambdify_as_documented_and_rotary_inertia_variants() -> None:
    values = ([0.2, 0.7], [0.0, 0.0], [0.5, 0.275], [0.6, 0.5], [0.3, 0.011], 9.81)
    results = {}
    for inertia in ("pivot", "full"):
        eq = ipgen.derive("rotary", 1, inertia)
        s = eq.symbols
        results[inertia] = sp.lambdify([s.q, s.qd, s.m, s.l, s.delta, s.g], eq.mass_matrix)(*values)
    # docs/model.md, eq. 31: M00 = J0 + m1 l0² + k m1 l1² sin²θ1 with k = 1/4 (pivot) or 1/3 (full).
    difference = results["full"][0][0] - results["pivot"][0][0]
    assert difference == pytest.approx((1 / 3 - 1 / 4) * 0.275 * 0.5**2 * float(sp.sin(0.7)) ** 2, rel=1e-12)


def test_import_is_light() -> None:
    """`import ipgen` (and hence the command's start) imports neither sympy, jinja2 nor click."""
    code = "import sys, ipgen; print(sorted(m for m in ('sympy', 'jinja2', 'click') if m in sys.modules))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"


def test_derive_submodule_does_not_shadow_the_function() -> None:
    import ipgen.model.derivation as _  # noqa: F401 (importing the implementation module)
    from ipgen.model.derivation import Equations

    assert callable(ipgen.derive) and not isinstance(ipgen.derive, type(sys))
    assert isinstance(ipgen.derive("classical", 1), Equations)
    assert ipgen.Equations is Equations


def test_write_header_writes_what_the_command_writes(tmp_path: Path) -> None:
    paths = ipgen.write_header(tmp_path / "api", "rotary", 2, name="rdip", inertia="full", fix={"m0": 0.3})
    argv = ["--type", "rotary", "--links", "2", "--name", "rdip", "--inertia", "full", "--fix", "m0=0.3"]
    assert run([*argv, "-o", str(tmp_path / "cli")]) == 0
    assert paths == [tmp_path / "api" / "rdip.hpp"]
    assert paths[0].read_bytes() == (tmp_path / "cli" / "rdip.hpp").read_bytes()
    scene = ROOT / "scenes" / "cdip_pulse.toml"
    written = ipgen.write_header(tmp_path / "scene", scene=scene)
    assert [p.name for p in written] == ["cdip.hpp", "cdip_pulse.cfg"]


# (API keyword arguments, the same as command-line options)
BAD = [
    ({"type": "classical", "links": 0}, ["--type", "classical", "--links", "0"]),
    (
        {"type": "classical", "links": 2, "inertia": "full"},
        ["--type", "classical", "--links", "2", "--inertia", "full"],
    ),
    ({"type": "rotary", "links": 31}, ["--type", "rotary", "--links", "31"]),
    (
        {"type": "rotary", "links": 1, "name": "class"},
        ["--type", "rotary", "--links", "1", "--name", "class"],
    ),
    ({"type": "rotary", "links": 1, "name": "a-b"}, ["--type", "rotary", "--links", "1", "--name", "a-b"]),
    ({"type": "rotary", "links": 1, "fix": "m9=1"}, ["--type", "rotary", "--links", "1", "--fix", "m9=1"]),
    ({"type": "rotary", "links": 1, "fix": "m0=-1"}, ["--type", "rotary", "--links", "1", "--fix", "m0=-1"]),
    (
        {"type": "rotary", "links": 1, "outputs": "nope"},
        ["--type", "rotary", "--links", "1", "--outputs", "nope"],
    ),
    ({"type": "rotary", "links": 1, "emit": ""}, ["--type", "rotary", "--links", "1", "--emit", ""]),
    ({"type": "rotary"}, ["--type", "rotary"]),
    ({"links": 2}, ["--links", "2"]),
    ({"scene": "scenes/cdip_pulse.toml", "links": 2}, ["--scene", "scenes/cdip_pulse.toml", "--links", "2"]),
    ({"scene": "scenes/missing.toml"}, ["--scene", "scenes/missing.toml"]),
]


@pytest.mark.parametrize(("kwargs", "argv"), BAD, ids=[" ".join(argv) for _, argv in BAD])
def test_bad_input_raises_the_commands_message(
    kwargs: dict[str, object], argv: list[str], tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys
) -> None:
    monkeypatch.chdir(ROOT)
    out = tmp_path / "out"
    with pytest.raises(ipgen.Error) as raised:
        ipgen.write_header(out, **kwargs)  # type: ignore[arg-type]
    assert run([*argv, "-o", str(out)]) == 2
    assert capsys.readouterr().err == f"ipgen: error: {raised.value}\n"
    assert "\n" not in str(raised.value)
    assert not out.exists()


@settings(max_examples=60, deadline=None)
@given(
    system_type=st.one_of(st.sampled_from(["classical", "rotary"]), st.text(max_size=8), st.integers()),
    links=st.one_of(
        st.integers(-3, 3), st.floats(allow_nan=True), st.text(max_size=3), st.booleans(), st.none()
    ),
    inertia=st.one_of(st.none(), st.sampled_from(["pivot", "full"]), st.text(max_size=5)),
)
def test_derive_refuses_bad_arguments_with_an_error(
    system_type: object, links: object, inertia: object
) -> None:
    """Any argument either derives or raises ipgen.Error with one line; never another exception."""
    if isinstance(links, int) and links >= 1 and system_type in ("classical", "rotary"):
        links = 1  # keep the successful derivations small
    try:
        eq = ipgen.derive(system_type, links, inertia)  # type: ignore[arg-type]
    except ipgen.Error as e:
        assert str(e) and "\n" not in str(e)
    else:
        assert eq.mass_matrix.shape == (2, 2)


def test_cmake_dir_holds_the_package_and_its_version() -> None:
    folder = ipgen.cmake_dir()
    assert (folder / "ipgenConfig.cmake").is_file() and (folder / "ipgen.cmake").is_file()
    version = re.search(
        r'set\(PACKAGE_VERSION "([^"]+)"\)', (folder / "ipgenConfigVersion.cmake").read_text()
    )
    assert version is not None and version.group(1) == ipgen.__version__
    printed = subprocess.run(
        [sys.executable, "-m", "ipgen", "--cmake-dir"], capture_output=True, text=True, check=True, cwd=os.sep
    ).stdout
    assert Path(printed.strip()) == folder


@settings(max_examples=40, deadline=None)
@given(
    name=st.one_of(st.none(), st.text(max_size=12)),
    fix=st.one_of(
        st.none(),
        st.text(max_size=12),
        st.dictionaries(
            st.sampled_from(["m0", "m1", "l1", "delta1", "g", "m5", "x", "m0,m1"]), st.floats(), max_size=3
        ),
    ),
    outputs=st.one_of(st.none(), st.lists(st.sampled_from(["mass_matrix", "bias", "nope", ""]), max_size=3)),
)
def test_write_header_any_options_write_or_raise_one_line(name: object, fix: object, outputs: object) -> None:
    """Any name, --fix and --outputs: the header is written, or an ipgen.Error of one line leaves
    nothing behind."""
    with tempfile.TemporaryDirectory() as folder:
        out = Path(folder) / "out"
        try:
            paths = ipgen.write_header(out, "classical", 1, name=name, fix=fix, outputs=outputs)  # type: ignore[arg-type]
        except ipgen.Error as e:
            assert str(e) and "\n" not in str(e)
            assert not out.exists()
        else:
            assert [p.suffix for p in paths] == [".hpp"] and paths[0].is_file()


@pytest.mark.parametrize(("inertia", "k"), [("pivot", sp.Rational(1, 4)), ("full", sp.Rational(1, 3))])
def test_docs_model_eq31_for_both_inertia_variants(inertia: str, k: sp.Rational) -> None:
    """docs/model.md's eq. 31 with k = 1/4 (pivot) or 1/3 (full): M, and N θ̇ + P = the bias."""
    eq = ipgen.derive("rotary", 1, inertia)
    s = eq.symbols
    (m0, m1), (l0, l1), (d0, d1), g = s.m, s.l, s.delta, s.g
    th, dth0, dth1 = s.q[1], s.qd[0], s.qd[1]
    j0, j1 = m0 * l0**2 / 3, m1 * l1**2 / 3
    mass = sp.Matrix(
        [
            [j0 + m1 * l0**2 + k * m1 * l1**2 * sp.sin(th) ** 2, m1 * l0 * l1 * sp.cos(th) / 2],
            [m1 * l0 * l1 * sp.cos(th) / 2, j1],
        ]
    )
    n = sp.Matrix(
        [
            [d0 + k * m1 * l1**2 * dth1 * sp.sin(2 * th), -m1 * l0 * l1 * dth1 * sp.sin(th) / 2],
            [-k / 2 * m1 * l1**2 * dth0 * sp.sin(2 * th), d1],
        ]
    )
    p = sp.Matrix([0, -m1 * g * l1 * sp.sin(th) / 2])
    assert sp.simplify(eq.mass_matrix - mass) == sp.zeros(2, 2)
    assert sp.simplify(eq.bias - (n * sp.Matrix(s.qd) + p)) == sp.zeros(2, 1)


def test_help_lists_every_public_function() -> None:
    """help(ipgen) names each function of __all__ (the lazy linearize and lqr too), and the module
    docstring describes each of them."""
    import inspect
    import pydoc

    text = pydoc.render_doc(ipgen, renderer=pydoc.plaintext)
    functions = text[text.index("FUNCTIONS") : text.index("DATA") if "DATA" in text else None]
    public = [name for name in ipgen.__all__ if inspect.isfunction(getattr(ipgen, name))]
    assert set(public) >= {"derive", "write_header", "cmake_dir", "linearize", "lqr"}
    for name in public:
        assert re.search(rf"^    {name}\(", functions, flags=re.M), f"help(ipgen) does not list {name}"
        assert f"`{name}(" in (ipgen.__doc__ or ""), f"ipgen's docstring does not describe {name}"


def test_lqr_gain_is_a_row_as_in_python_control() -> None:
    """K is 1 × 2(n+1): the textbook A - B @ K is the closed loop, and it is stable."""
    import numpy as np

    m, lengths, delta = [0.5, 0.275], [0.6, 0.5], [0.3, 0.011458]
    a, b = ipgen.linearize("rotary", 1, m, lengths, delta)
    k = ipgen.lqr("rotary", 1, m, lengths, delta, Q=np.ones(4), R=1.0)
    assert k.shape == (1, 4)
    assert np.max(np.linalg.eigvals(a - b @ k).real) < 0
    assert np.max(np.linalg.eigvals(a).real) > 0  # upright is unstable without the gain
