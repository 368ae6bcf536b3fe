"""The headers' DC motor functions are `actuator.motor_terms` printed (codegen/motor.py), not a
second copy of the formula: compiled, the C header's `ipgen_NAME_motor_gain`, `_motor_damping`,
`_motor_inertia` and `_with_motor` and the C++ header's `DcMotor` and `with_motor` give, for a
motor's datasheet values, the bits of ipgen's own `Actuator.gain()`, `damping()` and `inertia()`
(motor_terms in Python floats) and agree with the fold worked out by hand in exact rationals
(docs/model.md, "A DC motor on the base"). The check can fail: a header printed from a wrong
formula, or from the right one grouped differently (the hand-written headers' eta_g*Kg*Kg*Jm),
is caught."""

from __future__ import annotations

import subprocess
from collections.abc import Callable, Mapping
from fractions import Fraction
from pathlib import Path
from typing import Any

import pytest
from c_models import c_command, require_cc
from motor_by_hand import ETA_G, ETA_M, JM, KG, KM, KT, RM, R

import ipgen.codegen.motor
import ipgen.model.actuator
from ipgen.codegen.c_header import render_c_header
from ipgen.codegen.header import HeaderRequest, render_header
from ipgen.codegen.printer import Formula, c_literal, print_formula
from ipgen.model.actuator import Actuator, motor_terms
from ipgen.model.derivation import derive
from ipgen.model.system import System

# Datasheet values: Quanser's SRV02 (tests/motor_by_hand.py) and a geared motor whose Kg and
# eta_g make eta_g*(Kg*Kg)*Jm and (eta_g*Kg)*Kg*Jm round differently in double, so the check
# sees the grouping of the formula too.
MOTORS: dict[str, dict[str, float]] = {
    "srv02": {"Rm": RM, "kt": KT, "km": KM, "Kg": KG, "eta_g": ETA_G, "eta_m": ETA_M, "Jm": JM},
    "geared": {"Rm": 1.9, "kt": 0.0234, "km": 0.0234, "Kg": 13.7, "eta_g": 0.9, "eta_m": 0.8, "Jm": 1.2e-6},
}
RADIUS = {"srv02": R, "geared": 0.0125}  # the pinion on a cart [m]
BASE = (0.57, 0.08, 0.0021)  # m[0] [kg], delta[0], links J[0] [kg m^2] before the fold
FIELDS = ("gain", "damping", "inertia", "m0", "delta0", "J0")
MOTOR_TERMS = motor_terms  # the formula as actuator.py states it (the tests below may patch it)

C_PROGRAM = """
#include <stdio.h>
#include "m.h"
int main(void) {
  ipgen_m_dc_motor motor = {MOTOR};
  ipgen_m_params p = {{(IPGEN_SCALAR)M0, 1}, {1, 1}, {(IPGEN_SCALAR)D0, 0}, (IPGEN_SCALAR)9.81};
  ipgen_m_links links;
  ipgen_m_rod_links(&p, &links);
  links.J[0] = (IPGEN_SCALAR)J0;
  ipgen_m_with_motor(&motor, &p, &links);
  printf("%a %a %a %a %a %a\\n", (double)ipgen_m_motor_gain(&motor), (double)ipgen_m_motor_damping(&motor),
         (double)ipgen_m_motor_inertia(&motor), (double)p.m[0], (double)p.delta[0], (double)links.J[0]);
  return 0;
}
"""

CPP_PROGRAM = """
#include <cstdio>
#include "m.hpp"
int main() {
  const ipgen::m::DcMotor motor{MOTOR};
  ipgen::m::Params<double> p{{M0, 1.0}, {1.0, 1.0}, {D0, 0.0}};
  p.J[0] = J0;
  const auto folded = ipgen::m::with_motor(p, motor);
  std::printf("%a %a %a %a %a %a\\n", motor.gain(), motor.damping(), motor.inertia(), folded.m[0],
              folded.delta[0], folded.J[0]);
}
"""


def constants(motor: str, kind: str) -> dict[str, float]:
    """The motor's constants in the struct's order (Rm, kt, km, Kg, eta_g, eta_m, Jm, then r on a cart)."""
    values = dict(MOTORS[motor])
    if kind == "classical":
        values["r"] = RADIUS[motor]
    return values


def by_hand(values: Mapping[str, float], kind: str) -> dict[str, Fraction]:
    """The fold in exact rationals, written out from docs/model.md (not through motor_terms):
    b = eta_g Kg eta_m kt / (Rm r), c = b Kg km / r, I = eta_g Kg^2 Jm / r^2 (r = 1 on an arm)."""
    x = {name: Fraction(repr(value)) for name, value in values.items()}
    r = x.get("r", Fraction(1))
    b = x["eta_g"] * x["Kg"] * x["eta_m"] * x["kt"] / (x["Rm"] * r)
    c = b * x["Kg"] * x["km"] / r
    inertia = x["eta_g"] * x["Kg"] ** 2 * x["Jm"] / r**2
    m0, delta0, j0 = (Fraction(repr(v)) for v in BASE)
    cart = kind == "classical"
    return {
        "gain": b,
        "damping": c,
        "inertia": inertia,
        "m0": m0 + inertia if cart else m0,
        "delta0": delta0 + c,
        "J0": j0 if cart else j0 + inertia,
    }


def in_floats(values: Mapping[str, float], kind: str) -> dict[str, float]:
    """What ipgen computes in Python floats: actuator.py's motor_terms (as imported here, before
    any test patches it) and the fold's one addition per entry."""
    gain, damping, inertia = MOTOR_TERMS(Actuator("dc_motor", **values).constants())
    m0, delta0, j0 = BASE
    cart = kind == "classical"
    return {
        "gain": gain,
        "damping": damping,
        "inertia": inertia,
        "m0": m0 + inertia if cart else m0,
        "delta0": delta0 + damping,
        "J0": j0 if cart else j0 + inertia,
    }


def header_values(
    kind: str, values: Mapping[str, float], language: str, folder: Path, scalar: str = "double"
) -> dict[str, float]:
    """The six numbers the compiled header gives for `values`: its motor functions and the base
    entries after with_motor (C: `scalar` as IPGEN_SCALAR; C++: DcMotor and with_motor<double>)."""
    from cxx import cxx_command

    system = System(kind, 1)  # type: ignore[arg-type]
    cast = "(IPGEN_SCALAR)" if language == "c" else ""
    program = (C_PROGRAM if language == "c" else CPP_PROGRAM).replace(
        "{MOTOR}", "{" + ", ".join(f"{cast}{v!r}" for v in values.values()) + "}"
    )
    for name, value in zip(("M0", "D0", "J0"), BASE, strict=True):
        program = program.replace(f"{name};", f"{value!r};").replace(f"{name},", f"{value!r},")
    folder.mkdir(parents=True, exist_ok=True)
    request = HeaderRequest("m", "test")
    if language == "c":
        (folder / "m.h").write_text(render_c_header(derive(system), request))
        (folder / "main.c").write_text(program)
        command = c_command(f"-I{folder}", str(folder / "main.c"), "-o", str(folder / "main"), scalar=scalar)
    else:
        (folder / "m.hpp").write_text(render_header(derive(system), request))
        (folder / "main.cpp").write_text(program)
        command = cxx_command(f"-I{folder}", str(folder / "main.cpp"), "-o", str(folder / "main"))
    subprocess.run(command, check=True)
    out = subprocess.run([str(folder / "main")], capture_output=True, text=True, check=True).stdout
    return dict(zip(FIELDS, (float.fromhex(word) for word in out.split()), strict=True))


def disagreements(kind: str, values: Mapping[str, float], printed: Mapping[str, float]) -> list[str]:
    """The fields where a double header's numbers are not ipgen's floats bit for bit, or are
    further than 4 ulp-sized steps (rel 1e-15) from the exact fold by hand."""
    floats, exact = in_floats(values, kind), by_hand(values, kind)
    wrong = []
    for name in FIELDS:
        close = abs(Fraction(printed[name]) - exact[name]) <= Fraction(1, 10**15) * abs(exact[name])
        if printed[name] != floats[name] or not close:
            wrong.append(name)
    return wrong


@pytest.mark.parametrize("motor", sorted(MOTORS))
@pytest.mark.parametrize("kind", ["rotary", "classical"])
def test_c_header_motor_is_motor_terms(kind: str, motor: str, tmp_path: Path) -> None:
    """C99 in double: ipgen's floats to the bit, the exact fold to rounding; in float: the exact
    fold to float's rounding."""
    require_cc()
    values = constants(motor, kind)
    assert disagreements(kind, values, header_values(kind, values, "c", tmp_path / "double")) == []
    single = header_values(kind, values, "c", tmp_path / "float", scalar="float")
    for name, exact in by_hand(values, kind).items():
        assert single[name] == pytest.approx(float(exact), rel=1e-6), name


@pytest.mark.parametrize("kind", ["rotary", "classical"])
def test_cpp_header_motor_is_motor_terms(kind: str, tmp_path: Path) -> None:
    """C++17: DcMotor (double) and with_motor<double>, both motors in one build each."""
    from cxx import require_toolchain

    require_toolchain()
    for motor in sorted(MOTORS):
        values = constants(motor, kind)
        printed = header_values(kind, values, "cpp", tmp_path / motor)
        assert disagreements(kind, values, printed) == [], motor


def _forgets_eta_m(c: Mapping[str, Any]) -> tuple[Any, Any, Any]:
    """motor_terms without the motor's efficiency: a wrong formula."""
    return MOTOR_TERMS({**c, "eta_m": 1})


def _old_grouping(c: Mapping[str, Any]) -> tuple[Any, Any, Any]:
    """motor_terms with the hand-written headers' grouping of the inertia, (eta_g Kg) Kg Jm: the
    same formula, rounded differently."""
    gain, damping, _ = MOTOR_TERMS(c)
    inertia = c["eta_g"] * c["Kg"] * c["Kg"] * c["Jm"]
    if c.get("r") is not None:
        inertia = inertia / (c["r"] * c["r"])
    return gain, damping, inertia


@pytest.mark.parametrize(
    ("wrong", "caught"),
    [(_forgets_eta_m, ["gain", "damping", "delta0"]), (_old_grouping, ["inertia"])],
    ids=["forgets-eta_m", "old-grouping"],
)
def test_the_check_catches_a_header_off_motor_terms(
    wrong: Callable[[Mapping[str, Any]], tuple[Any, Any, Any]],
    caught: list[str],
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The header follows whatever motor_terms says (there is no other copy of the formula), and
    the check above fails when that is not ipgen's fold: a formula without eta_m, and the right
    formula grouped as the hand-written headers had it (off by one bit on the geared motor; the
    cart's m0 + inertia happens to round to the same double)."""
    require_cc()
    _patch_the_formula(monkeypatch, wrong)
    values = constants("geared", "classical")
    assert disagreements("classical", values, header_values("classical", values, "c", tmp_path)) == caught


def test_printed_formulas_keep_python_grouping() -> None:
    """print_formula parenthesises exactly where C's left-to-right evaluation would regroup."""
    a, b, c = (Formula.leaf(name) for name in "abc")
    assert print_formula(a * b / c * a, c_literal) == "a*b/c*a"
    assert print_formula(a * (b / c), c_literal) == "a*(b/c)"
    assert print_formula(a / (b * c), c_literal) == "a/(b*c)"
    assert print_formula((a + b) * c + (a + c), c_literal) == "(a + b)*c + (a + c)"
    assert print_formula(3 * a / 2, c_literal) == "(IPGEN_SCALAR)3*a/(IPGEN_SCALAR)2"
    assert print_formula(a * (b * b) / (c * c), c_literal, readable=True) == "a b^2 / c^2"
    with pytest.raises(TypeError, match="write the product"):
        _ = a**2


def test_motor_functions_are_printed_from_motor_terms(monkeypatch: pytest.MonkeyPatch) -> None:
    """codegen.motor takes the formula from motor_terms, comments included."""
    printed = ipgen.codegen.motor.motor_functions(System("classical", 1), "c", "ipgen_m")
    assert printed.gain_formula == "eta_g Kg eta_m kt / Rm / r"
    assert printed.damping_formula == "b Kg km / r"
    assert printed.inertia_formula == "eta_g Kg^2 Jm / r^2"
    _patch_the_formula(monkeypatch, _forgets_eta_m)
    changed = ipgen.codegen.motor.motor_functions(System("classical", 1), "c", "ipgen_m")
    assert changed.gain_formula == "eta_g Kg 1 kt / Rm / r"
    assert changed.gain == "motor->eta_g*motor->Kg*(IPGEN_SCALAR)1*motor->kt/motor->Rm/motor->r"


def _patch_the_formula(monkeypatch: pytest.MonkeyPatch, terms: Callable[..., tuple[Any, Any, Any]]) -> None:
    """actuator.py's motor_terms replaced by `terms`, where fold_base and codegen.motor find it."""
    monkeypatch.setattr(ipgen.model.actuator, "motor_terms", terms)
    monkeypatch.setattr(ipgen.codegen.motor, "motor_terms", terms)
