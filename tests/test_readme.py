"""The README's examples (and the C++ LQR example of docs/control.md it points to) compile cleanly
and do what they say."""

from __future__ import annotations

import re
import shlex
import subprocess
from pathlib import Path

import numpy as np
import pytest
from cxx import EIGEN_INCLUDE, WARNINGS, cxx_command, require_toolchain

import ipgen
from ipgen.model.system import System
from ipgen.pipeline.generate import generate_header

ROOT = Path(__file__).resolve().parents[1]

CHECK = r"""
#include <cmath>
#include <cstdio>
int main() {
  const m::Params<double> p{{0.3, 0.275, 0.275}, {0.0, 0.5, 0.5}, {0.3, 0.1, 0.1}};
  m::Vector<double> q(0.1, 0.4, -0.7), qd(-0.3, 1.5, 2.0);
  for (double a : {-2.0, 0.0, 3.5}) {
    const double u = force_for_cart_acceleration(q, qd, a);
    const double achieved = m::forward_dynamics(q, qd, u, p)(0);
    if (std::abs(achieved - a) > 1e-9) { std::printf("a=%g achieved %.17g\n", a, achieved); return 1; }
  }
  return 0;
}
"""


def test_readme_controller_example(tmp_path: Path) -> None:
    require_toolchain()
    readme = (ROOT / "docs" / "generator.md").read_text()  # moved there from the README
    blocks = re.findall(r"```cpp\n(.*?)```", readme, flags=re.S)
    example = next(b for b in blocks if "force_for_cart_acceleration" in b)
    generate_header(System("classical", 2), "cdip", tmp_path / "out")
    source = tmp_path / "example.cpp"
    source.write_text(example + CHECK)
    binary = tmp_path / "example"
    build = subprocess.run(
        cxx_command(f"-I{tmp_path}", str(source), "-o", str(binary)), capture_output=True, text=True
    )
    assert build.returncode == 0, build.stderr
    run = subprocess.run([str(binary)], capture_output=True, text=True)
    assert run.returncode == 0, run.stdout


CONTROL_CHECK = r"""
#include <cmath>
#include <cstdio>
int main() {
  const m::Params<double> p{{0.5, 0.275, 0.275}, {0.6, 0.5, 0.5}, {0.3, 0.011458, 0.011458}};
  m::StateVector<double> K;
  K << GAIN;
  const m::Vector<double> q(0.1, -0.2, 0.3), qd(0.5, 1.0, -1.5);
  const double expected = -(K.head<3>().dot(q) + K.tail<3>().dot(qd));
  if (std::abs(lqr_torque(q, qd, K) - expected) > 1e-12) return 1;
  if (!stabilises(p, K)) { std::puts("the LQR gain should stabilise"); return 1; }
  if (stabilises(p, m::StateVector<double>::Zero())) return 2;  // u = 0 cannot stabilise upright
  return 0;
}
"""


def lqr_example() -> str:
    """The C++ LQR example of docs/control.md (the README links to it)."""
    page = (ROOT / "docs" / "control.md").read_text()
    return next(b for b in re.findall(r"```cpp\n(.*?)```", page, flags=re.S) if "lqr_torque" in b)


def test_readme_python_control_example() -> None:
    readme = (ROOT / "README.md").read_text()
    block = next(b for b in re.findall(r"```python\n(.*?)```", readme, flags=re.S) if "ipgen.lqr" in b)
    namespace: dict = {}
    exec(block, namespace)
    assert namespace["A"].shape == (6, 6) and namespace["B"].shape == (6, 1)
    assert namespace["K"].shape == (1, 6) and namespace["K_mixed"].shape == (1, 6)
    # the Pendulum calls are the keyword calls (same numbers), and the preset is the scene's rig
    m, l, delta = [0.5, 0.275, 0.275], [0.6, 0.5, 0.5], [0.3, 0.011458, 0.011458]  # noqa: E741
    assert np.array_equal(namespace["K"], ipgen.lqr("rotary", 2, m, l, delta, Q=np.ones(6), R=1.0))
    from ipgen.experiment.scene import load_scene

    scene = load_scene(ROOT / "scenes" / "rigs" / "qube_servo2.toml")  # the same weights
    assert scene.controller is not None
    assert np.array_equal(namespace["K_qube"].ravel(), np.asarray(scene.controller.gain))


def readme_command(program: str) -> list[str]:
    """The README's one-line compile command (a ``` block of one line starting with `program`)."""
    readme = (ROOT / "README.md").read_text()
    lines = [
        body.strip()
        for language, body in re.findall(r"^```(\w*)\n(.*?)^```$", readme, flags=re.S | re.M)
        if not language and body.startswith(program + " ")
    ]
    assert len(lines) == 1 and "\n" not in lines[0], f"expected one {program} line in README.md"
    return shlex.split(lines[0])


@pytest.mark.user_program  # a whole program at -O2: 11-14 s of compiling (make test-slow)
def test_readme_cxx_compile_line_builds_the_lqr_example(tmp_path: Path) -> None:
    """The README's g++ line, verbatim, is complete: it builds a program with docs/control.md's LQR
    example, which compiles without warnings (the warning flags appended to the line) and whose
    gain stabilises the upright rdip."""
    import ipgen

    require_toolchain()
    command = readme_command("g++")
    assert "-I/usr/include/eigen3" in command
    example = lqr_example()
    generate_header(System("rotary", 2), "rdip", tmp_path / "out")
    gain = ipgen.lqr(
        "rotary", 2, [0.5, 0.275, 0.275], [0.6, 0.5, 0.5], [0.3, 0.011458, 0.011458], [1] * 6, 1.0
    )[0]
    program = CONTROL_CHECK.replace("GAIN", ", ".join(map(repr, gain.tolist())))
    (tmp_path / command[command.index("-o") - 1]).write_text(example + program)
    # Warnings as errors for the example's own code: Eigen, on the line's -I path, is named a system
    # directory too (GCC then ignores the -I), since at the line's -O2 GCC 12 warns inside Eigen
    # (-Wmaybe-uninitialized in TriangularMatrixVector.h).
    checked = [*command, *WARNINGS, "-isystem", str(EIGEN_INCLUDE)]
    build = subprocess.run(checked, cwd=tmp_path, capture_output=True, text=True)
    assert build.returncode == 0, build.stderr
    run = subprocess.run([str(tmp_path / command[command.index("-o") + 1])], capture_output=True, text=True)
    assert run.returncode == 0, run.stdout


def github_anchor(heading: str) -> str:
    """The anchor GitHub gives a Markdown heading: lower case, punctuation dropped, - for spaces."""
    return re.sub(r"[^\w\- ]", "", heading.strip().lower()).replace(" ", "-")


def test_readme_is_a_short_guide_and_its_links_resolve() -> None:
    """The README stays a user guide (the details live in docs/), and every relative link of the
    README, docs/ and cpp/README.md names a file that exists and, with #, one of its headings."""
    # 300 (issue 49; 350 had grown with the sweeps and gym sections and the examples as complete
    # programs that run verbatim, tests/test_readme_verbatim.py): reference detail lives in docs/
    readme = (ROOT / "README.md").read_text()
    assert len(readme.splitlines()) <= 300
    # the two commands of the checkout on the first screen (issue 49: they were at line 37)
    first_screen = "\n".join(readme.splitlines()[:24])
    assert "`make demo`" in first_screen and "`make test`" in first_screen
    documents = [ROOT / "README.md", ROOT / "cpp" / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]
    for document in documents:
        text = re.sub(r"^```.*?^```$", "", document.read_text(), flags=re.S | re.M)  # not in code
        for target in re.findall(r"\]\(([^)\s]+)\)|src=\"([^\"]+)\"", text):
            link = target[0] or target[1]
            if link.startswith(("http://", "https://", "mailto:")):
                continue
            path, _, anchor = link.partition("#")
            resolved = (document.parent / path).resolve() if path else document
            assert resolved.exists(), f"{document.relative_to(ROOT)}: {link} does not exist"
            if anchor and resolved.suffix == ".md":
                headings = re.findall(r"^#+ (.*)$", resolved.read_text(), flags=re.M)
                anchors = {github_anchor(h) for h in headings}
                assert anchor in anchors, f"{document.relative_to(ROOT)}: no heading for #{anchor} in {path}"


def test_the_rigs_page_does_not_deny_a_shipped_preset() -> None:
    """Issue 49: docs/rigs.md said "no QUBE swing-up preset is shipped" above a table listing
    scenes/rigs/qube_servo2_swingup.toml."""
    text = " ".join((ROOT / "docs" / "rigs.md").read_text().split())
    rigs = {"qube_servo2": "QUBE", "ip02_sip": "IP02", "srv02_dbip": "SRV02"}
    rigs |= {"acrobot": "acrobot", "pendubot": "pendubot"}  # RealAIGym's leaderboard systems
    for path in sorted((ROOT / "scenes" / "rigs").glob("*_swingup.toml")):
        rig = next(name for stem, name in rigs.items() if path.stem.startswith(stem))
        assert not re.search(rf"no {rig}\S* swing-up preset", text, flags=re.I), path.name
        assert path.name in text  # and the page names it
