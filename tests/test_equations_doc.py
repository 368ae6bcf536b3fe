"""`--emit equations`: the printed equations mean the derived ones, and the documents build.

- every displayed entry (M, N, P, the energies, each body's position, velocity, energies and
  Rayleigh term) of the Markdown and of the LaTeX is read back (tests/latex_reader.py) and
  compared with the derived expression, exactly (trig normal form), for classical n = 1..3 and
  rotary n = 1..2 in both inertia variants;
- each body's printed position equals docs/model.md's (transcribed here), its printed velocity is
  the time derivative of that position, and its printed T_i, V_i follow from them;
- for classical 2 and rotary 1 the printed M, N θ̇ and P equal the corrected eqs. 30 and 31
  (the transcription in test_equations.py);
- the .tex compiles with pdflatex; the model name and the command are escaped (hypothesis).
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
from functools import cache
from pathlib import Path

import pytest
import sympy as sp
from cases import CASES, case_id
from hypothesis import given, settings
from hypothesis import strategies as st
from latex_reader import displayed, parse
from test_equations import assert_identical, column, eq30, eq31

from ipgen.codegen.equations import markdown_escape, render_equations, tex_escape
from ipgen.codegen.header import HeaderRequest
from ipgen.command.cli import run
from ipgen.common.safetext import quote_path
from ipgen.model.derivation import Equations, derive
from ipgen.model.symbols import Symbols
from ipgen.model.system import System


@cache
def equations(kind: str, links: int, inertia: str = "pivot") -> Equations:
    return derive(System(kind, links, inertia)).rod()  # type: ignore[arg-type]


@cache
def documents(kind: str, links: int, inertia: str = "pivot", name: str = "model") -> dict[str, str]:
    return render_equations(equations(kind, links, inertia), HeaderRequest(name, f"ipgen --name {name}"))


@cache
def entries(kind: str, links: int, inertia: str, doc: str) -> dict[str, sp.Expr]:
    """{lhs: parsed rhs} of one document ("md" or "tex")."""
    sym = equations(kind, links, inertia).symbols
    text = documents(kind, links, inertia)[f".{doc}"]
    return {lhs: parse(rhs, sym) for lhs, rhs in displayed(text, doc).items()}


def expected_entries(eqs: Equations) -> dict[str, sp.Expr]:
    """The derived quantities under the names the documents display them."""
    dof = eqs.system.dof
    wanted: dict[str, sp.Expr] = {
        "T": eqs.kinetic_energy,
        "V": eqs.potential_energy,
        "D": eqs.dissipation,
    }
    for j in range(dof):
        wanted[f"P_{{{j}}}"] = eqs.gravity[j, 0]
        for k in range(dof):
            wanted[f"N_{{{j}{k}}}"] = eqs.n_matrix[j, k]
            if j <= k:
                wanted[f"M_{{{j}{k}}}"] = eqs.mass_matrix[j, k]
    return wanted


DOCS = ["md", "tex"]


@pytest.mark.parametrize("doc", DOCS)
@pytest.mark.parametrize("case", CASES, ids=case_id)
def test_every_entry_reads_back_as_the_derived_expression(case: tuple[str, int, str], doc: str) -> None:
    eqs = equations(*case)
    printed = entries(*case, doc)
    wanted = expected_entries(eqs)
    missing = sorted(set(wanted) - set(printed))
    assert not missing, f"{case_id(case)} .{doc}: not displayed: {missing}"
    for name, expr in wanted.items():
        assert_identical(printed[name], expr, eqs.symbols.q, f"{case_id(case)} .{doc}: {name}")


def model_position(sym: Symbols, system: System, i: int) -> tuple[sp.Expr, sp.Expr]:
    """docs/model.md: r_i = Σ_{k≤i} l_k sin θk − (l_i/2) sin θi, z_i likewise with cos."""
    q, length = sym.q, sym.l
    r = sum(length[k] * sp.sin(q[k]) for k in range(1, i + 1)) - length[i] / 2 * sp.sin(q[i])
    z = sum(length[k] * sp.cos(q[k]) for k in range(1, i + 1)) - length[i] / 2 * sp.cos(q[i])
    return r, z


def time_derivative(expr: sp.Expr, sym: Symbols) -> sp.Expr:
    return sum(sp.diff(expr, q) * qd for q, qd in zip(sym.q, sym.qd, strict=True))


@pytest.mark.parametrize("case", CASES, ids=case_id)
def test_bodies_follow_the_model(case: tuple[str, int, str]) -> None:
    """Positions as in docs/model.md; velocity = d/dt position; T_i, V_i, D_i from them and sum to T, V, D."""
    eqs = equations(*case)
    system, sym = eqs.system, eqs.symbols
    printed = entries(*case, "md")
    q, qd, m = sym.q, sym.qd, sym.m
    name = case_id(case)

    def same(actual: sp.Expr, expected: sp.Expr, what: str) -> None:
        assert_identical(actual, expected, q, f"{name}: {what}")

    if system.is_rotary:
        same(printed["J_{0}"], m[0] * sym.l[0] ** 2 / 3, "J0")
    base = printed["J_{0}"] if system.is_rotary else m[0]
    same(printed["T_{0}"], base * qd[0] ** 2 / 2, "T0")
    same(printed["D_{0}"], sym.delta[0] * qd[0] ** 2 / 2, "D0")
    totals = {"T": printed["T_{0}"], "V": printed["V_{0}"], "D": printed["D_{0}"]}
    for i in range(1, system.links + 1):
        reach, height = model_position(sym, system, i)
        same(printed[f"z_{{{i}}}"], height, f"z{i}")
        if system.is_rotary:
            same(printed[f"r_{{{i}}}"], reach, f"r{i}")
            position = [
                sym.l[0] * sp.sin(q[0]) + printed[f"r_{{{i}}}"] * sp.cos(q[0]),
                sym.l[0] * sp.cos(q[0]) - printed[f"r_{{{i}}}"] * sp.sin(q[0]),
                printed[f"z_{{{i}}}"],
            ]
            parts = [printed[rf"v_{{{i}\parallel}}"], printed[rf"v_{{{i}\perp}}"], printed[f"v_{{{i}z}}"]]
            # The arm frame turns with θ0: its velocity components have the fixed frame's |v|² and
            # the vertical one is the same.
            same(parts[2], time_derivative(position[2], sym), f"v{i}z")
        else:
            same(printed[f"x_{{{i}}}"], q[0] + reach, f"x{i}")
            position = [printed[f"x_{{{i}}}"], printed[f"z_{{{i}}}"]]
            parts = [printed[rf"\dot{{x}}_{{{i}}}"], printed[rf"\dot{{z}}_{{{i}}}"]]
            for part, coordinate, axis in zip(parts, position, "xz", strict=True):
                same(part, time_derivative(coordinate, sym), f"d{axis}{i}/dt")
        speed2 = sum(time_derivative(c, sym) ** 2 for c in position)
        same(sum(p**2 for p in parts), speed2, f"|v{i}|²")
        spin = m[i] * sym.l[i] ** 2 / 12
        kinetic = m[i] * speed2 / 2 + spin * qd[i] ** 2 / 2
        if system.is_rotary and system.inertia == "full":
            kinetic += spin * (qd[0] * sp.sin(q[i])) ** 2 / 2
        same(printed[f"T_{{{i}}}"], kinetic, f"T{i}")
        same(printed[f"V_{{{i}}}"], m[i] * sym.g * printed[f"z_{{{i}}}"], f"V{i}")
        previous = qd[i - 1] if i >= 2 else 0
        same(printed[f"D_{{{i}}}"], sym.delta[i] * (qd[i] - previous) ** 2 / 2, f"D{i}")
        for key in totals:
            totals[key] += printed[f"{key}_{{{i}}}"]
    for key, total in totals.items():
        same(printed[key], total, f"{key} = Σ {key}_i")


def printed_matrices(case: tuple[str, int, str], doc: str) -> tuple[sp.Matrix, sp.Matrix, sp.Matrix]:
    printed = entries(*case, doc)
    dof = case[1] + 1
    mass = sp.Matrix(dof, dof, lambda j, k: printed[f"M_{{{min(j, k)}{max(j, k)}}}"])
    n_matrix = sp.Matrix(dof, dof, lambda j, k: printed[f"N_{{{j}{k}}}"])
    gravity = column([printed[f"P_{{{k}}}"] for k in range(dof)])
    return mass, n_matrix, gravity


@pytest.mark.parametrize("doc", DOCS)
@pytest.mark.parametrize(
    ("case", "paper"),
    [
        (("classical", 2, "pivot"), lambda sym: eq30(sym)),
        (("rotary", 1, "pivot"), lambda sym: eq31(sym, sp.Rational(1, 4))),
        (("rotary", 1, "full"), lambda sym: eq31(sym, sp.Rational(1, 3))),
    ],
    ids=["eq30", "eq31", "eq31-full"],
)
def test_printed_model_is_eqs_30_and_31(case: tuple[str, int, str], paper: object, doc: str) -> None:
    sym = equations(*case).symbols
    mass, n_matrix, gravity = printed_matrices(case, doc)
    paper_mass, paper_n, paper_gravity = paper(sym)  # type: ignore[operator]
    rates = column(sym.qd)
    for what, actual, expected in [
        ("M", mass, paper_mass),
        ("N θ̇", n_matrix * rates, paper_n * rates),
        ("P", gravity, paper_gravity),
    ]:
        for index in range(len(actual)):
            assert_identical(
                actual[index], expected[index], sym.q, f"{case_id(case)} .{doc}: {what}[{index}]"
            )


def test_classical_double_reads_as_eq30() -> None:
    """The form a person writes: factored groups, cos(θ1 − θ2), fractions (eq. 30's look)."""
    text = documents("classical", 2)[".md"]
    for piece in [
        r"M_{01} = \left(\frac{m_{1}}{2} + m_{2}\right) l_{1} \cos \theta_{1}",
        r"M_{11} = \left(\frac{m_{1}}{3} + m_{2}\right) l_{1}^{2}",
        r"M_{12} = \tfrac{1}{2} m_{2} l_{1} l_{2} \cos(\theta_{1} - \theta_{2})",
        r"P_{1} = - \left(\frac{m_{1}}{2} + m_{2}\right) g l_{1} \sin \theta_{1}",
        r"N_{11} = \delta_{1} + \delta_{2}",
    ]:
        assert piece in text


def test_rotary_single_reads_as_eq31() -> None:
    text = documents("rotary", 1)[".md"]
    assert r"\tfrac{1}{4} m_{1} l_{1}^{2} \sin^{2} \theta_{1}" in text  # M00's sin²θ1 term
    assert r"\sin 2\theta_{1}" in text  # sin θ1 cos θ1 as ½ sin 2θ1


def test_large_entries_are_capped_not_dumped() -> None:
    """Entries beyond the cap are stated by size; the document says so and stays small."""
    text = documents("rotary", 8)[".md"]
    assert "not expanded here" in text and "not expanded** here" in text
    assert len(text) < 200_000


# --------------------------------------------------------------------------- the files


def test_cli_writes_markdown_and_latex(tmp_path: Path) -> None:
    """Both files (next to the header when asked for), the same bytes on a second run."""
    args = ["--type", "rotary", "--links", "2", "--emit", "cpp,equations", "-o", str(tmp_path)]
    assert run(args) == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["rotary2.hpp", "rotary2.md", "rotary2.tex"]
    first = (tmp_path / "rotary2.md").read_bytes(), (tmp_path / "rotary2.tex").read_bytes()
    assert b"--emit cpp,equations" in first[0]
    assert run(args) == 0
    assert ((tmp_path / "rotary2.md").read_bytes(), (tmp_path / "rotary2.tex").read_bytes()) == first


def test_the_tex_compile_comment_names_no_wrong_file(tmp_path: Path) -> None:
    """A name with an underscore: the comment's compile line names no file (the name is escaped
    everywhere in the document, my\\_arm, which is not the file my_arm.tex), the title escapes it."""
    for options, name in (
        (["--type", "rotary", "--links", "1", "--name", "my_arm"], "my_arm"),
        (["--type", "fixed", "--links", "2", "--joints", "2", "--name", "my_chain"], "my_chain"),
    ):
        assert run([*options, "--emit", "equations", "-o", str(tmp_path)]) == 0
        lines = (tmp_path / f"{name}.tex").read_text().splitlines()
        command = next(line for line in lines if line.startswith("% Compile "))
        assert ".tex" not in command, command
        assert any(f"\\title{{Equations of motion of {tex_escape(name)}}}" in line for line in lines)


def pdflatex() -> str:
    found = shutil.which("pdflatex")
    if found is None:
        if os.environ.get("IPGEN_ALLOW_NO_LATEX") == "1":
            pytest.skip("pdflatex not installed (IPGEN_ALLOW_NO_LATEX=1)")
        pytest.fail(
            "pdflatex is missing: make test installs it (texlive-latex-base, texlive-latex-recommended)"
        )
    return found


def compile_tex(tex: str, directory: Path, stem: str = "doc") -> Path:
    (directory / f"{stem}.tex").write_text(tex)
    result = subprocess.run(
        [pdflatex(), "-interaction=nonstopmode", "-halt-on-error", "-no-shell-escape", f"{stem}.tex"],
        cwd=directory,
        capture_output=True,
        text=True,
        timeout=120,
    )
    log = (
        (directory / f"{stem}.log").read_text(errors="replace")
        if (directory / f"{stem}.log").exists()
        else ""
    )
    assert result.returncode == 0, f"pdflatex failed:\n{result.stdout[-3000:]}"
    assert "Overfull \\hbox" not in log or "in alignment" not in log
    return directory / f"{stem}.pdf"


@pytest.mark.parametrize("case", [("classical", 2, "pivot"), ("rotary", 2, "full"), ("rotary", 8, "pivot")])
def test_tex_compiles_with_pdflatex(case: tuple[str, int, str], tmp_path: Path) -> None:
    pdf = compile_tex(documents(*case)[".tex"], tmp_path)
    assert pdf.stat().st_size > 10_000


# --------------------------------------------------------------------------- escaping

_MD_SPECIALS = set("\\`*_[]<>|$~&#")
_TEX_SPECIALS = set("\\&%$#_{}~^<>|")


def markdown_unescape(text: str) -> str:
    return re.sub(r"\\(.)", r"\1", text)


@settings(max_examples=200, deadline=None)
@given(st.text())
def test_markdown_escape_is_literal(text: str) -> None:
    escaped = markdown_escape(text)
    assert "\n" not in escaped and "\r" not in escaped
    assert markdown_unescape(escaped) == text.replace("\n", " ").replace("\r", " ")
    unescaped_special = re.sub(r"\\.", "", escaped)
    assert not (set(unescaped_special) & _MD_SPECIALS)


@settings(max_examples=200, deadline=None)
@given(st.text())
def test_tex_escape_leaves_no_active_character(text: str) -> None:
    escaped = tex_escape(text)
    assert "\n" not in escaped
    # What is left after removing the escapes' own commands has no special character.
    bare = re.sub(r"\\text[a-z]+\{\}|\\[&%$#_{}]", "", escaped)
    assert not (set(bare) & _TEX_SPECIALS)


NASTY_NAMES = ["my_model", "a}b{c", r"x\input{/etc/hostname}", "50% $5 #1 &", "~^_\\", "`*[x](y)`"]


@pytest.mark.parametrize("name", NASTY_NAMES)
def test_name_is_escaped_in_both_documents(name: str, tmp_path: Path) -> None:
    """A model name reaches both documents only escaped: the .tex still compiles, and the
    Markdown shows it literally."""
    docs = documents("classical", 1, "pivot", name)
    assert f"# Equations of motion of {markdown_escape(name)}\n" in docs[".md"]
    assert name not in docs[".tex"] or not (set(name) & _TEX_SPECIALS)
    compile_tex(docs[".tex"], tmp_path)


@settings(max_examples=25, deadline=None)
@given(st.text(min_size=1, max_size=20))
def test_any_name_gives_escaped_documents(name: str) -> None:
    docs = render_equations(equations("classical", 1), HeaderRequest(name, f"ipgen --name {name}"))
    title = next(line for line in docs[".md"].split("\n") if line.startswith("# "))
    assert markdown_unescape(title.removeprefix("# Equations of motion of ")) == name.replace(
        "\n", " "
    ).replace("\r", " ")
    assert rf"\title{{Equations of motion of {tex_escape(name)}}}" in docs[".tex"]


def test_scene_path_is_escaped(tmp_path: Path) -> None:
    """A specialised scene's path is part of the command the documents print: percent-encoded
    (as in every generated file) and escaped, it compiles, and the fixed values are listed."""
    folder = tmp_path / "d %&$#{x}~^<|>"
    folder.mkdir()
    scene = (Path(__file__).resolve().parents[1] / "scenes" / "cdip_pulse.toml").read_text()
    (folder / "we_ird.toml").write_text(scene.replace("[system]", "[system]\nspecialise = true", 1))
    out = tmp_path / "out"
    assert run(["--scene", str(folder / "we_ird.toml"), "--emit", "equations", "-o", str(out)]) == 0
    markdown, tex = (out / "cdip.md").read_text(), (out / "cdip.tex").read_text()
    shown = quote_path(folder.as_posix())
    assert shown != folder.as_posix() and "%" in shown
    assert markdown_escape(shown) in markdown and tex_escape(shown) in tex
    assert "m1 = 0.275" in markdown
    compile_tex(tex, out, "cdip")


# --------------------------------------------------------------------------- as a person writes them


def _line(text: str, lhs: str) -> str:
    """The displayed right-hand side of `lhs` in a Markdown document (its continuation lines too)."""
    return displayed(text, "md")[lhs]


def test_kinetic_energies_are_written_as_a_person_would() -> None:
    """T_i in cos(θa − θb) and collected terms (the expanded components' squares printed
    1/24 + 1/8 cos² + 1/8 sin² for a rod's 1/6, and capped T_6 of a 6-link cart at 50 terms)."""
    double = documents("classical", 2)[".md"]
    assert r"\cos(\theta_{1} - \theta_{2})" in _line(double, "T_{2}")
    assert r"\sin \theta_{1}" not in _line(double, "T_{2}")
    single = _line(documents("rotary", 1)[".md"], "T_{1}")
    assert single.count(r"l_{1}^{2} \dot{\theta}_{1}^{2}") == 1
    assert r"\tfrac{1}{6} m_{1} l_{1}^{2} \dot{\theta}_{1}^{2}" in single
    assert r"\cos^{2}" not in single


@pytest.mark.parametrize(("kind", "links"), [("classical", 7), ("rotary", 5)])
def test_nothing_is_capped_up_to_the_sizes_the_docs_name(kind: str, links: int) -> None:
    """docs/generator.md: "Nothing is capped up to n = 7 (classical) and n = 5 (rotary)"."""
    assert "not expanded" not in documents(kind, links)[".md"]


BUILT_SCENE = """\
[system]
type = "rotary"
links = 1
name = "built"
emit = ["equations"]
[parameters]
m = [0.1, 0.05]
l = [0.1, 0.2]
delta = [0, 0]
J = [0.001, 0.002]
com = [0, 0.1]
tip = [0, 0.05]
[simulation]
t_end = 1.0
"""


def test_a_scene_with_links_as_built_prints_them(tmp_path: Path) -> None:
    """A scene's com, J and tip reach the documents (they printed the paper's rods: J0 = m0 l0²/3,
    M_01 with l1/2), and every entry reads back as the general derivation's."""
    scene = tmp_path / "built.toml"
    scene.write_text(BUILT_SCENE)
    assert run(["--scene", str(scene), "-o", str(tmp_path / "out")]) == 0
    text = (tmp_path / "out" / "built.md").read_text()
    assert "homogeneous rods" not in text and r"J_{0} = m_{0} l_{0}^{2}/3" not in text
    eqs = derive(System("rotary", 1, "pivot"))
    found = {lhs: parse(rhs, eqs.symbols) for lhs, rhs in displayed(text, "md").items()}
    wanted = expected_entries(eqs)
    assert not sorted(set(wanted) - set(found)), "not displayed"
    for lhs, value in wanted.items():
        assert_identical(found[lhs], value, eqs.symbols.q, f"built.md: {lhs}")
    assert r"\mathrm{com}_{1}" in _line(text, "M_{01}") and r"\mathrm{tip}_{1}" in _line(text, "M_{01}")


@pytest.mark.parametrize(
    ("kind", "sentence"),
    [("dc_motor", "with a DC motor"), ("acceleration", "acceleration (`[actuator] kind"), ("direct", None)],
)
def test_the_scene_s_drive_is_named(tmp_path: Path, kind: str, sentence: str | None) -> None:
    drive = {
        "dc_motor": 'kind = "dc_motor"\nRm = 8.4\nkt = 0.042\nkm = 0.042\n',
        "acceleration": 'kind = "acceleration"\n',
    }
    scene = tmp_path / "driven.toml"
    scene.write_text(BUILT_SCENE.replace("[simulation]", f"[actuator]\n{drive.get(kind, '')}[simulation]"))
    assert run(["--scene", str(scene), "-o", str(tmp_path / "out")]) == 0
    texts = [(tmp_path / "out" / f"built{suffix}").read_text() for suffix in (".md", ".tex")]
    for text in texts:
        if sentence is None:
            assert "DC motor" not in text and "commands the" not in text
        else:
            assert sentence.replace("`", "\\texttt{") in text or sentence in text
