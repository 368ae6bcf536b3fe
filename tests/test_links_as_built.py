"""Links as built (issue 21; docs/model.md "Links as built"): com, J, J_axial, tip and J0.

- the general equations obey the power balance dE/dt = u θ̇0 − 2D along their own motion, for
  random links as built (the Kane comparison is tests/test_independent.py);
- with the rod defaults they are the paper's model: the same numbers as the equations of the
  commit before the links as built (GOLDEN, written by the command in its docstring);
- the per-link combinations keep the generated code's cost: operation counts against that
  commit's (and folding the new parameters to rod values gives exactly its count).
"""

from __future__ import annotations

import json
import re
import subprocess
from fractions import Fraction
from functools import cache
from pathlib import Path

import numpy as np
import pytest
import sympy as sp
from test_independent import GENERAL_CASES, random_general_case

from ipgen.codegen.functions import count_operations
from ipgen.codegen.header import function_bodies, poly_keys
from ipgen.model.derivation import derive
from ipgen.model.specialise import Specialisation, specialise
from ipgen.model.system import System

RELATIVE = 1e-10


@cache
def power_functions(kind: str, links: int, inertia: str) -> tuple:
    """(M, bias, dE/dq, dT/dqd, D) of the general equations as numeric functions."""
    eqs = derive(System(kind, links, inertia))  # type: ignore[arg-type]
    sym = eqs.symbols
    arguments = (sym.q, sym.qd, sym.u, (sym.m, sym.l, sym.delta, sym.g, sym.com, sym.J, sym.J_axial, sym.tip))
    energy = eqs.kinetic_energy + eqs.potential_energy
    by_angle = sp.Matrix([energy.diff(q) for q in sym.q])
    by_rate = sp.Matrix([eqs.kinetic_energy.diff(qd) for qd in sym.qd])
    return tuple(
        sp.lambdify(arguments, expr, "numpy")
        for expr in (eqs.mass_matrix, eqs.bias, by_angle, by_rate, eqs.dissipation)
    )


@pytest.mark.parametrize("case", GENERAL_CASES, ids=lambda c: f"{c[0]}{c[1]}-{c[2]}")
def test_power_balance(case: tuple[str, int, str]) -> None:
    """dE/dt = ∂E/∂θ θ̇ + ∂T/∂θ̇ θ̈ with θ̈ = M⁻¹(B u − bias) equals the input's power u θ̇0
    minus the damping's 2D: the bias is consistent with the energies."""
    kind, links, inertia = case
    mass, bias, by_angle, by_rate, dissipation = power_functions(kind, links, inertia)
    rng = np.random.default_rng(2100 + links)
    for _ in range(3):
        args = random_general_case(rng, links + 1)
        _, rates, u, _ = args
        force = -np.ravel(bias(*args))
        force[0] += u
        acceleration = np.linalg.solve(np.asarray(mass(*args), dtype=float), force)
        rate = float(np.ravel(by_angle(*args)) @ rates + np.ravel(by_rate(*args)) @ acceleration)
        expected = u * rates[0] - 2 * float(dissipation(*args))
        scale = abs(u * rates[0]) + 2 * abs(float(dissipation(*args))) + 1.0
        assert abs(rate - expected) <= RELATIVE * scale, f"{case}: dE/dt {rate} != {expected}"


GOLDEN = Path(__file__).parent / "data" / "rod_golden.json"


def test_rod_defaults_reproduce_the_paper_model() -> None:
    """The rod view (com = l/2, J = m l²/12, J0 = m0 l0²/3, no tips) gives the numbers of the
    commit before the links as built (tests/data/rod_golden.json, `python -m bench.general_links
    --golden`), and so does the general view with those values given explicitly."""
    cases = json.loads(GOLDEN.read_text())["cases"]
    assert cases
    for case in cases:
        kind, links, inertia = case["system"]
        rod, general = _views(kind, links, inertia)
        m, lengths, _, _ = case["params"]
        size = links + 1
        com = [x / 2 for x in lengths]
        inertia_cog = [mi * li * li / 12 for mi, li in zip(m, lengths, strict=True)]
        inertia_cog[0] = m[0] * lengths[0] ** 2 / 3 if kind == "rotary" else 0.0
        explicit = (*case["params"], com, inertia_cog, [0.0] * size, [0.0] * size)
        for name, index in (("M", 0), ("bias", 1), ("T", 2), ("V", 3)):
            expected = np.asarray(case[name], dtype=float)
            for label, values in (
                ("rod view", rod[index](case["q"], case["qd"], case["params"])),
                ("general view", general[index](case["q"], case["qd"], explicit)),
            ):
                got = np.asarray(values, dtype=float)
                assert np.allclose(got, expected, rtol=1e-12, atol=1e-12), (
                    f"{kind}{links} {inertia} {name} ({label})"
                )


@cache
def _views(kind: str, links: int, inertia: str) -> tuple[list, list]:
    eqs = derive(System(kind, links, inertia))  # type: ignore[arg-type]
    rod = eqs.rod()
    sym = eqs.symbols
    exprs = (eqs.mass_matrix, eqs.bias, eqs.kinetic_energy, eqs.potential_energy)
    rod_exprs = (rod.mass_matrix, rod.bias, rod.kinetic_energy, rod.potential_energy)
    basic = (sym.q, sym.qd, (sym.m, sym.l, sym.delta, sym.g))
    full = (sym.q, sym.qd, (sym.m, sym.l, sym.delta, sym.g, sym.com, sym.J, sym.J_axial, sym.tip))
    return (
        [sp.lambdify(basic, e, "numpy") for e in rod_exprs],
        [sp.lambdify(full, e, "numpy") for e in exprs],
    )


# forward_dynamics operations of the rod headers of the commit before the links as built
# (67de603), general and with every m and l folded (docs/bench/general_links.md, the same counts).
ROD_OPERATIONS = {
    ("classical", 2, "pivot"): (47, 33),
    ("classical", 3, "pivot"): (94, 70),
    ("classical", 5, "pivot"): (240, 180),
    ("rotary", 2, "pivot"): (89, 68),
    ("rotary", 3, "pivot"): (168, 135),
    ("rotary", 5, "pivot"): (378, 322),
    ("rotary", 2, "full"): (111, 86),
    ("rotary", 3, "full"): (200, 161),
}


def _rod_fold(kind: str, links: int, inertia: str) -> dict[str, Fraction]:
    """m and l at fixed values, and com, J, J_axial, tip, J0 at the rods' values for them (the
    same m and l as bench/general_links.py folds)."""
    fixed = {f"m{i}": Fraction(3, 10 + i) for i in range(links + 1)}
    fixed |= {f"l{i}": Fraction(1, 2 + i) for i in range(links + 1) if i or kind == "rotary"}
    for i in range(1, links + 1):
        fixed[f"com{i}"] = fixed[f"l{i}"] / 2
        fixed[f"J{i}"] = fixed[f"m{i}"] * fixed[f"l{i}"] ** 2 / 12
        fixed[f"tip{i}"] = Fraction(0)
        if kind == "rotary" and inertia == "full":
            fixed[f"J_axial{i}"] = Fraction(0)
    if kind == "rotary":
        fixed["J0"] = fixed["m0"] * fixed["l0"] ** 2 / 3
    return fixed


@pytest.mark.parametrize("case", list(ROD_OPERATIONS), ids=lambda c: f"{c[0]}{c[1]}-{c[2]}")
def test_operation_counts(case: tuple[str, int, str]) -> None:
    """Folding the new parameters to the rod values gives the same count as this generator's
    rod equations with the same m and l folded (classical: exactly; rotary: no more, its Q = Σ m r²
    form is cheaper), and no more than the rod headers of the commit before the links as built
    (fewer since the damping is written as joint torques); the general header, with com and J
    given, at most 10 % above those rod headers (docs/bench/general_links.md)."""
    kind, links, inertia = case
    general_rods, folded_rods = ROD_OPERATIONS[case]
    eqs = derive(System(kind, links, inertia))  # type: ignore[arg-type]
    fixed = _rod_fold(kind, links, inertia)
    spec = Specialisation(fixed=tuple(fixed.items()), outputs=("forward_dynamics",))
    folded = function_bodies(specialise(eqs, spec, poly_keys(spec.outputs)), spec.outputs)["forward_dynamics"]
    rod_spec = Specialisation(
        fixed=tuple((k, v) for k, v in fixed.items() if k[0] in "ml"), outputs=("forward_dynamics",)
    )
    rod = function_bodies(specialise(eqs.rod(), rod_spec, poly_keys(rod_spec.outputs)), rod_spec.outputs)
    if kind == "classical":
        assert folded.operations == rod["forward_dynamics"].operations
    else:
        assert folded.operations <= rod["forward_dynamics"].operations
    assert folded.operations <= folded_rods
    general = function_bodies(eqs, ("forward_dynamics",))["forward_dynamics"]
    given = sum(
        count_operations(re.sub(r" = (.*?) \? (.*?) : (.*);", r" = \2;", line))
        for line in [*general.prelude, *general.temporaries, *general.outputs]
    )
    assert given <= 1.10 * general_rods


# --------------------------------------------------------------------------- generated code

CPP_PROGRAM = """
#include <cstdio>
#include "model.hpp"
namespace m = ipgen::model;
int main() {
  const m::Params<double> rod{{M}, {L}, {D}};  // the existing style: m, l, delta only
  m::Params<double> assigned{};                 // and member by member
  assigned.m = rod.m; assigned.l = rod.l; assigned.delta = rod.delta;
  m::Params<double> built = rod;                // the links as built
  built.com = {COM}; built.J = {J}; built.J_axial = {AX}; built.tip = {TIP};
  const m::Vector<double> q{Q}, qd{QD};
  const m::Params<double> resolved = m::with_rod_links(rod);  // the rods' com and J, given
  for (int i = 1; i < m::kDof; ++i) {
    if (!m::detail::given(resolved.com[i]) || !m::detail::given(resolved.J[i])) return 1;
  }
  if (m::with_rod_links(built).com != built.com || m::with_rod_links(built).J != built.J) return 2;
  const m::Params<double>* all[] = {&rod, &assigned, &built, &resolved};
  for (const auto* p : all) {
    const auto qdd = m::forward_dynamics<double>(q, qd, 0.3, *p);
    for (int i = 0; i < m::kDof; ++i) std::printf("%.17g ", qdd(i));
    std::printf("\\n");
  }
}
"""

C_PROGRAM = """
#include <stdio.h>
#include "model.h"
int main(void) {
  const ipgen_model_params rod = {{M}, {L}, {D}, 9.81};  /* the existing style */
  const ipgen_model_links built = {{COM}, {J}, {AX}, {TIP}};
  ipgen_model_links rods;
  const IPGEN_SCALAR q[] = {Q}, qd[] = {QD};
  IPGEN_SCALAR qdd[IPGEN_MODEL_DOF];
  int i;
  ipgen_model_rod_links(&rod, &rods);
  if (ipgen_model_forward_dynamics(q, qd, 0.3, &rod, qdd)) return 1;
  for (i = 0; i < IPGEN_MODEL_DOF; ++i) printf("%.17g ", qdd[i]);
  printf("\\n");
  if (ipgen_model_forward_dynamics_built(q, qd, 0.3, &rod, &rods, qdd)) return 1;
  for (i = 0; i < IPGEN_MODEL_DOF; ++i) printf("%.17g ", qdd[i]);
  printf("\\n");
  if (ipgen_model_forward_dynamics_built(q, qd, 0.3, &rod, &built, qdd)) return 1;
  for (i = 0; i < IPGEN_MODEL_DOF; ++i) printf("%.17g ", qdd[i]);
  printf("\\n");
  return 0;
}
"""


def _fill(program: str, values: dict[str, list[float]]) -> str:
    for key, numbers in values.items():
        program = program.replace("{" + key + "}", "{" + ", ".join(repr(float(x)) for x in numbers) + "}")
    return program


@pytest.mark.parametrize(
    "case", [("classical", 2, "pivot"), ("rotary", 2, "full")], ids=["classical2", "rotary2-full"]
)
@pytest.mark.parametrize("language", ["cpp", "c"])
def test_generated_code_keeps_existing_initialisation(
    tmp_path: Path, case: tuple[str, int, str], language: str
) -> None:
    """Params initialised with m, l, delta only (C++ aggregate or member by member; C positional
    with g) compiles under -Wall -Wextra -Wpedantic -Werror and means the rods; com, J, J_axial,
    tip given (C++ members; C: the links struct and *_built) give the links as built; C++
    with_rod_links gives the rods with every com and J set and keeps given entries. All against
    the sympy equations (rod view and general view)."""
    from c_models import c_command, compile_c, require_cc
    from cxx import cxx_command, require_toolchain

    kind, links, inertia = case
    size = links + 1
    rng = np.random.default_rng(77)
    angles, rates, _, params = random_general_case(rng, size)
    m, lengths, delta, _, com, inertia_cog, axial, tip = params
    values = {"M": m, "L": lengths, "D": delta, "COM": com, "J": inertia_cog, "AX": axial, "TIP": tip,
              "Q": angles, "QD": rates}  # fmt: skip
    system = System(kind, links, inertia)  # type: ignore[arg-type]
    eqs = derive(system)
    from ipgen.codegen.c_header import render_c_header
    from ipgen.codegen.header import HeaderRequest, render_header

    if language == "cpp":
        require_toolchain()
        (tmp_path / "model.hpp").write_text(render_header(eqs, HeaderRequest("model", "test")))
        (tmp_path / "main.cpp").write_text(_fill(CPP_PROGRAM, values))
        command = cxx_command(f"-I{tmp_path}", str(tmp_path / "main.cpp"), "-o", str(tmp_path / "main"))
    else:
        require_cc()
        (tmp_path / "model.h").write_text(render_c_header(eqs, HeaderRequest("model", "test")))
        (tmp_path / "main.c").write_text(_fill(C_PROGRAM, values))
        command = c_command(f"-I{tmp_path}", str(tmp_path / "main.c"), "-o", str(tmp_path / "main"))
    error = compile_c(command)
    assert error is None, error
    run = subprocess.run([str(tmp_path / "main")], capture_output=True, text=True, check=True)
    rows = [np.array([float(x) for x in line.split()]) for line in run.stdout.splitlines()]
    sym = eqs.symbols
    rod_values = (m, lengths, delta, 9.81)
    general_values = (m, lengths, delta, 9.81, com, inertia_cog, axial, tip)

    def accelerations(view: object, parameter_values: tuple, symbols: tuple) -> np.ndarray:
        arguments = (sym.q, sym.qd, symbols)
        mass = np.asarray(sp.lambdify(arguments, view.mass_matrix)(angles, rates, parameter_values), float)  # type: ignore[attr-defined]
        bias = np.ravel(sp.lambdify(arguments, view.bias)(angles, rates, parameter_values))  # type: ignore[attr-defined]
        force = -bias
        force[0] += 0.3
        return np.linalg.solve(mass, force)

    rod = accelerations(eqs.rod(), rod_values, (sym.m, sym.l, sym.delta, sym.g))
    general = accelerations(
        eqs, general_values, (sym.m, sym.l, sym.delta, sym.g, sym.com, sym.J, sym.J_axial, sym.tip)
    )
    expected_rows = [rod, rod, general] + ([rod] if language == "cpp" else [])
    names = ["rods", "rods (2)", "links as built"] + (["with_rod_links(rods)"] if language == "cpp" else [])
    assert len(rows) == len(expected_rows)
    for row, expected, what in zip(rows, expected_rows, names, strict=True):
        assert np.allclose(row, expected, rtol=1e-9, atol=1e-9), f"{language} {what}: {row} != {expected}"
