"""cpp/README.md: the plain g++ command line builds a program with the feedback example, and what
the README says about the callback's time holds (it goes backwards across evaluations)."""

from __future__ import annotations

import re
import shlex
import subprocess
from pathlib import Path

import pytest
from cxx import require_toolchain

from ipgen.model.system import System
from ipgen.pipeline.generate import generate_header

ROOT = Path(__file__).resolve().parents[1]

PROGRAM = """#include <cstdio>
#include <vector>

#include "cdip.hpp"
#include "ipsim/ipsim.hpp"

int main() {
  using Model = ipgen::cdip::Model;
  const ipsim::ParamsOf<Model> p{{0.3, 0.275, 0.275}, {0.0, 0.5, 0.5}, {0.3, 0.1, 0.1}};
  ipsim::Settings<Model> s;
  s.theta(1) = 0.3;
  Eigen::VectorXd K = Eigen::VectorXd::Zero(2 * Model::kDof);
  K(0) = 0.5;  // a weak push back towards the cart's origin
%(snippet)s
  const ipsim::Result r = ipsim::simulate<Model>(p, s);
  std::vector<double> times;
  ipsim::Settings<Model> recorded = s;
  recorded.input = ipsim::Input::from_feedback([&](double t, const Eigen::VectorXd& x) {
    times.push_back(t);
    return -K.dot(x);
  });
  const ipsim::Result again = ipsim::simulate<Model>(p, recorded);
  int backwards = 0;
  for (std::size_t i = 1; i < times.size(); ++i) backwards += times[i] < times[i - 1];
  std::printf("%%.17g %%.17g %%d %%ld %%.0e\\n", r.states(r.states.rows() - 1, 1),
              again.states(again.states.rows() - 1, 1), backwards, again.stats.error_test_failures, s.rtol);
}
"""


def cpp_readme() -> str:
    return (ROOT / "cpp" / "README.md").read_text()


@pytest.mark.user_program  # a whole ipsim program: 17-20 s of compiling (make test-slow)
def test_plain_gxx_command_builds_the_feedback_example(tmp_path: Path) -> None:
    require_toolchain()
    text = cpp_readme()
    snippet = next(b for b in re.findall(r"```cpp\n(.*?)```", text, flags=re.S) if "from_feedback(" in b)
    command = re.search(r"^```\n(g\+\+ .*?)^```", text, flags=re.S | re.M)
    assert command is not None, "cpp/README.md has no ``` block starting with g++"
    generate_header(System("classical", 2), "cdip", tmp_path / "out")
    (tmp_path / "cpp").mkdir()
    (tmp_path / "cpp" / "include").symlink_to(ROOT / "cpp" / "include")
    (tmp_path / "main.cpp").write_text(PROGRAM % {"snippet": snippet})
    arguments = shlex.split(command.group(1).replace("\\\n", " "))
    build = subprocess.run(arguments, cwd=tmp_path, capture_output=True, text=True)
    assert build.returncode == 0, build.stderr[-3000:]
    run = subprocess.run([str(tmp_path / "main")], capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    first, second, backwards, failures, rtol = run.stdout.split()
    assert first == second  # the recording changes nothing
    assert rtol == "1e-10"  # the documented default, equal to a scene's
    # Steps rejected by the error test are retried from an earlier time.
    assert int(failures) > 0 and int(backwards) > 0
