"""The C99 header (`--emit c`): compiles cleanly in double and float, equals the C++ header.

Checked, for classical and rotary (pivot) n = 1..5:
- NAME.h compiles with gcc -std=c99 -Wall -Wextra -Wpedantic -Werror, and in float mode also
  with -Wdouble-promotion -Wconversion (tests/c_models.py; the evaluation driver is the
  compile check, one build per header and precision);
- in double, every quantity equals the C++ header's (tests/cpp/eval_model.cpp) to 1e-13
  relative at random states, and linearize's A, B are [[0, I], [∂θ̈/∂θ, ∂θ̈/∂θ̇]], [0; ∂θ̈/∂u];
- in float, every entry is within the a-priori bound of tests/float_bound.py of the double one;
- a mass matrix that is not positive definite (a zero link mass) makes forward_dynamics,
  its derivatives and linearize return non-zero;
- a specialised header (folded parameters, scene outputs) compiles and agrees with the general one;
- the controller ipgen_NAME_control equals −K (x − x_eq), saturated;
- what a user typed (a scene path) cannot break out of the header's comments.
"""

from __future__ import annotations

import math
import os
import subprocess
from fractions import Fraction
from functools import cache
from pathlib import Path

import numpy as np
import pytest
from c_models import CC, CModels, c_command, compile_c, require_cc, run_c
from conftest import CppModels, model_name
from float_bound import float_bounds, parameter_values
from hypothesis import given
from hypothesis import strategies as st
from numeric import assert_close
from test_header_physics import MODELS as HEADER_MODELS
from test_header_physics import make_case, run_driver

from ipgen.codegen.c_header import render_c_header
from ipgen.codegen.header import HeaderRequest
from ipgen.common.safetext import comment_safe
from ipgen.control.controller import Controller
from ipgen.model.derivation import derive
from ipgen.model.specialise import Specialisation
from ipgen.model.system import System

MODELS = [
    *(System("classical", n) for n in range(1, 6)),
    *(System("rotary", n, "pivot") for n in range(1, 6)),
]
IDS = [model_name(s) for s in MODELS]
DOUBLE_RELATIVE = 1e-13
CPP_KEYS = ("M", "bias", "gravity", "N", "qdd", "T", "V", "D", "dqdd_dq", "dqdd_dqd", "dqdd_du")


@pytest.fixture(scope="module")
def c_models(tmp_path_factory: pytest.TempPathFactory) -> CModels:
    require_cc()
    models = CModels(tmp_path_factory.mktemp("c_models"), jobs=max(1, os.cpu_count() or 1))
    models.submit(MODELS)
    yield models
    models.close()


@cache
def equations(system: System):
    return derive(system)


def c_results(c_models: CModels, system: System, scalar: str) -> list[dict[str, np.ndarray]]:
    case = make_case(system)
    return run_c(c_models.program(system, scalar), case.params, case.states())


@pytest.mark.parametrize("system", MODELS, ids=IDS)
def test_double_equals_cpp_header(c_models: CModels, cpp_models: CppModels, system: System) -> None:
    # test_header_physics's models, a superset of MODELS: the same groups (programs) as it compiles,
    # so the two files share them in the run's cache, whichever runs first and on whichever worker.
    cpp_models.submit(HEADER_MODELS)
    case = make_case(system)
    c = c_results(c_models, system, "double")
    cpp = run_driver(cpp_models.program(system), system, "double", case, case.states())
    n = system.dof
    for k, (ours, theirs) in enumerate(zip(c, cpp, strict=True)):
        assert ours["status"][0] == 0, f"{model_name(system)} state {k}: forward dynamics failed"
        for key in CPP_KEYS:
            assert_close(
                ours[key],
                theirs[key].reshape(-1),
                DOUBLE_RELATIVE,
                f"{model_name(system)} {key} state {k}",
                ("C", "C++"),
            )
        a = np.zeros((2 * n, 2 * n))
        a[:n, n:] = np.eye(n)
        a[n:, :n] = theirs["dqdd_dq"]
        a[n:, n:] = theirs["dqdd_dqd"]
        assert_close(
            ours["A"], a.reshape(-1), DOUBLE_RELATIVE, f"{model_name(system)} A state {k}", ("C", "C++")
        )
        b = np.concatenate([np.zeros(n), theirs["dqdd_du"].reshape(-1)])
        assert_close(ours["B"], b, DOUBLE_RELATIVE, f"{model_name(system)} B state {k}", ("C", "C++"))


@pytest.mark.parametrize("system", MODELS, ids=IDS)
def test_float_within_derived_bound(c_models: CModels, system: System) -> None:
    case = make_case(system)
    double = c_results(c_models, system, "double")
    single = c_results(c_models, system, "float")
    eqs = equations(system)
    params = parameter_values(system.dof, case.params)
    differs = any(np.any(s["qdd"] != d["qdd"]) for s, d in zip(single, double, strict=True))
    assert differs, f"{model_name(system)}: the float build computes exactly what the double one does"
    for k, (exact, computed) in enumerate(zip(double, single, strict=True)):
        bounds = float_bounds(eqs, params, case.qd[k], float(case.u[k]), exact)
        for key, bound in bounds.items():
            error = np.abs(computed[key] - exact[key])
            worst = int(np.argmax(error - bound))
            assert np.all(error <= bound), (
                f"{model_name(system)} {key} state {k}: float error {error[worst]:.3e} at entry {worst} "
                f"exceeds the derived bound {bound[worst]:.3e} (double value {exact[key][worst]:.6g})"
            )


@pytest.mark.parametrize("system", [System("classical", 1), System("rotary", 3, "pivot")], ids=model_name)
@pytest.mark.parametrize("scalar", ["double", "float"])
def test_not_positive_definite_returns_nonzero(c_models: CModels, system: System, scalar: str) -> None:
    case = make_case(system)
    m, lengths, delta, g = case.params
    m = m.copy()
    m[-1] = 0.0  # a massless last link: its row and column of M vanish
    results = run_c(c_models.program(system, scalar), (m, lengths, delta, g), case.states()[:2])
    for block in results:
        assert block["status"][0] == 7, "forward_dynamics, its derivatives and linearize must all fail"
    good = run_c(c_models.program(system, scalar), case.params, case.states()[:2])
    assert all(block["status"][0] == 0 for block in good)


SPECIAL = """
#include <stdio.h>
#include "general.h"
#include "special.h"
int main(void) {
  const IPGEN_SCALAR q[] = {QS}, qd[] = {QDS};
  const ipgen_general_params p = {{MS}, {LS}, {DS}, (IPGEN_SCALAR)9.81};
  ipgen_special_params ps;
  IPGEN_SCALAR a[IPGEN_GENERAL_DOF], b[IPGEN_SPECIAL_DOF];
  int i;
  for (i = 0; i < IPGEN_GENERAL_DOF; ++i) {
    ps.m[i] = p.m[i]; ps.l[i] = p.l[i]; ps.delta[i] = p.delta[i];
  }
  ps.g = p.g;
  if (ipgen_special_check_folded(&ps) != 0) return 3;
  ps.m[0] = (IPGEN_SCALAR)1;
  if (ipgen_special_check_folded(&ps) == 0) return 4;
  ps.m[0] = p.m[0];
  if (ipgen_general_forward_dynamics(q, qd, (IPGEN_SCALAR)0, &p, a)) return 5;
  if (ipgen_special_forward_dynamics(q, qd, (IPGEN_SCALAR)0.5, &ps, b)) return 6; /* u pruned */
  for (i = 0; i < IPGEN_GENERAL_DOF; ++i) printf("%.17g %.17g\\n", (double)a[i], (double)b[i]);
  printf("%.17g %.17g\\n", (double)ipgen_general_kinetic_energy(q, qd, &p),
         (double)ipgen_special_kinetic_energy(q, qd, &ps));
  return 0;
}
"""


def _c_list(values: list[float]) -> str:
    return ", ".join(f"(IPGEN_SCALAR){v!r}" for v in values)


SHORT = {"m0": "0.3", "m1": "0.275", "l1": "0.5", "delta2": "0"}
# Many digits: the folded rationals' numerators and denominators outgrow 64-bit integers.
LONG = {"m0": "0.123456789123", "m1": "0.987654321987", "m2": "0.7777777777771", "l1": "0.333333333331",
        "l2": "0.1234567891", "delta2": "0"}  # fmt: skip


@pytest.mark.parametrize("values", [SHORT, LONG], ids=["short", "long"])
@pytest.mark.parametrize("scalar", ["double", "float"])
def test_specialised_header(tmp_path: Path, scalar: str, values: dict[str, str]) -> None:
    require_cc()
    system = System("classical", 2)
    eqs = equations(system)
    fixed = tuple((name, Fraction(value)) for name, value in values.items())
    spec = Specialisation(fixed=fixed, outputs=("forward_dynamics", "kinetic_energy"), zero_input=True)
    (tmp_path / "general.h").write_text(render_c_header(eqs, HeaderRequest("general", "ipgen (test)")))
    special = render_c_header(eqs, HeaderRequest("special", "ipgen (test)", spec))
    assert "ipgen_special_mass_matrix" not in special and "SPECIALISED" in special
    assert "input path pruned" in special
    (tmp_path / "special.h").write_text(special)
    source = SPECIAL
    for key, values in (
        ("QS", [0.1, 0.4, -0.7]),
        ("QDS", [-0.3, 1.5, 2.0]),
        ("MS", [float(values.get(f"m{i}", 0.4)) for i in range(3)]),
        ("LS", [float(values.get(f"l{i}", v)) for i, v in enumerate((0.0, 0.5, 0.6))]),
        ("DS", [float(values.get(f"delta{i}", 0.1)) for i in range(3)]),
    ):
        source = source.replace(key, _c_list(values))
    (tmp_path / "main.c").write_text(source)
    error = compile_c(
        c_command(f"-I{tmp_path}", str(tmp_path / "main.c"), "-o", str(tmp_path / "main"), scalar=scalar)
    )
    assert error is None, error
    run = subprocess.run([str(tmp_path / "main")], capture_output=True, text=True, check=False)
    assert run.returncode == 0, f"exit {run.returncode}"
    pairs = np.array([[float(x) for x in line.split()] for line in run.stdout.splitlines()])
    tolerance = 1e-14 if scalar == "double" else 1e-5
    assert_close(pairs[:, 1], pairs[:, 0], tolerance, "specialised vs general", ("special", "general"))


CONTROL = """
#include <stdio.h>
#include "ctl.h"
int main(void) {
  IPGEN_SCALAR q[IPGEN_CTL_DOF], qd[IPGEN_CTL_DOF];
  double x;
  int i;
  for (;;) {
    for (i = 0; i < 2 * IPGEN_CTL_DOF; ++i) {
      if (scanf("%lf", &x) != 1) return 0;
      if (i < IPGEN_CTL_DOF) q[i] = (IPGEN_SCALAR)x; else qd[i - IPGEN_CTL_DOF] = (IPGEN_SCALAR)x;
    }
    printf("%.17g\\n", (double)ipgen_ctl_control(q, qd));
  }
}
"""


@pytest.mark.parametrize("saturation", [None, 3.0])
@pytest.mark.parametrize("scalar", ["double", "float"])
def test_controller(tmp_path: Path, saturation: float | None, scalar: str) -> None:
    require_cc()
    system = System("rotary", 1)
    gain = (-1.5, 31.25, 0.0, 4.5)  # a zero gain: its term is left out
    equilibrium = (0.25, 0.0, 0.0, 0.0)
    controller = Controller("lqr", gain, equilibrium, saturation, 0.001)
    header = render_c_header(equations(system), HeaderRequest("ctl", "ipgen (test)", controller=controller))
    assert "ipgen_ctl_control" in header
    (tmp_path / "ctl.h").write_text(header)
    (tmp_path / "main.c").write_text(CONTROL)
    error = compile_c(
        c_command(f"-I{tmp_path}", str(tmp_path / "main.c"), "-o", str(tmp_path / "main"), scalar=scalar)
    )
    assert error is None, error
    rng = np.random.default_rng(15)
    states = rng.uniform(-0.5, 0.5, (20, 4))
    text = "\n".join(" ".join(repr(float(v)) for v in row) for row in states)
    text += "\n0 nan 0 0"  # a state that is not a number: NaN out, also through the clip (documented)
    run = subprocess.run([str(tmp_path / "main")], input=text, capture_output=True, text=True, check=True)
    *values, last = [float(v) for v in run.stdout.split()]
    assert math.isnan(last)
    assert (saturation is not None) == ("not a number gives NaN" in header)
    got = np.array(values)
    expected = -(states - np.array(equilibrium)) @ np.array(gain)
    if saturation is not None:
        expected = np.clip(expected, -saturation, saturation)
        assert np.any(np.abs(expected) == saturation), "the test states must reach the saturation"
    assert_close(got, expected, 1e-14 if scalar == "double" else 1e-6, "control u", ("C", "numpy"))


def test_controller_rejects_bad_gain() -> None:
    from ipgen.codegen.c_header import ControllerError

    bad = Controller("lqr", (1.0, float("nan"), 0.0, 0.0), (0.0,) * 4)
    with pytest.raises(ControllerError, match=r"gain K\[1\]"):
        render_c_header(equations(System("rotary", 1)), HeaderRequest("ctl", "ipgen (test)", controller=bad))
    short = Controller("lqr", (1.0, 2.0), (0.0,) * 4)
    with pytest.raises(ControllerError, match="has 2 entries, expected 4"):
        render_c_header(
            equations(System("rotary", 1)), HeaderRequest("ctl", "ipgen (test)", controller=short)
        )


@given(st.text())
def test_comment_safe_cannot_end_or_splice_a_comment(text: str) -> None:
    safe = comment_safe(text)
    assert "*/" not in safe and "/*" not in safe and "??" not in safe
    assert "\n" not in safe and "\r" not in safe and not safe.endswith("\\")
    assert all(ch.isprintable() for ch in safe)


def test_hostile_scene_path_stays_in_the_comment(tmp_path: Path) -> None:
    require_cc()
    hostile = "x*/ int broken = 1; /*\n#error injected\\\n??/\nend"
    spec = Specialisation(scene=hostile)
    request = HeaderRequest("hostile", f"ipgen --scene {hostile} -o <dir>", spec)
    header = render_c_header(equations(System("classical", 1)), request)
    (tmp_path / "hostile.h").write_text(header)
    (tmp_path / "main.c").write_text('#include "hostile.h"\nint main(void) { return 0; }\n')
    error = compile_c(c_command(f"-I{tmp_path}", str(tmp_path / "main.c"), "-o", str(tmp_path / "main")))
    assert error is None, error
    assert (
        "broken"
        not in subprocess.run(
            [CC, "-std=c99", "-E", "-P", str(tmp_path / "main.c"), f"-I{tmp_path}"],
            capture_output=True,
            text=True,
            check=True,
        ).stdout
    )


finite_or_not = st.floats(allow_nan=True, allow_infinity=True, width=64)


@given(
    gain=st.lists(finite_or_not, min_size=0, max_size=6),
    equilibrium=st.lists(finite_or_not, min_size=4, max_size=4),
    saturation=st.one_of(st.none(), finite_or_not),
)
def test_controller_values_are_printed_exactly_or_refused(
    gain: list[float], equilibrium: list[float], saturation: float | None
) -> None:
    """Any controller either raises ControllerError (one line) or prints every gain as a C constant
    that reads back as the same double; never a `nan`/`inf` token in the header."""
    import math
    import re

    from ipgen.codegen.c_header import ControllerError, control_context

    controller = Controller("lqr", tuple(gain), tuple(equilibrium), saturation)
    try:
        context = control_context(controller, dof=2)
    except ControllerError as error:
        assert "\n" not in str(error)
        return
    assert len(gain) == 4 and all(math.isfinite(v) for v in [*gain, *equilibrium])
    printed = [float(t.gain.removeprefix("(IPGEN_SCALAR)")) for t in context["terms"]]  # type: ignore[attr-defined]
    assert printed == [abs(k) for k in gain if k != 0]
    for text in (context["offset"], context["saturation"]):
        assert not re.search(r"nan|inf", str(text))
