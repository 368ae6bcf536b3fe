"""Scene-specialised headers: same numbers as the general header, and only what was asked for.

For every shipped scene, the header specialised to it (every parameter folded) and the general
header are compiled into one program and evaluated at random states with the scene's
parameters: forward_dynamics and its derivatives agree to 1e-12 relative. Functions a
specialisation does not emit are absent (a call does not compile), `--fix` folds exact
rationals, and check_folded names a Params entry that disagrees with a folded value.
"""

from __future__ import annotations

import dataclasses
import subprocess
from fractions import Fraction
from pathlib import Path

import numpy as np
import pytest
from cxx import cxx_command, require_toolchain
from shipped_scenes import shipped_scene

from ipgen.command.cli import run
from ipgen.experiment.scene import load_scene
from ipgen.experiment.specialisation import from_scene
from ipgen.model.specialise import ENERGY_FUNCTIONS, Specialisation
from ipgen.model.system import System
from ipgen.pipeline.generate import generate_header

ROOT = Path(__file__).resolve().parents[1]
SCENES = sorted((ROOT / "scenes").glob("*.toml"))
STATES = 8
RELATIVE = 1e-12

COMPARE = r"""
#include <cmath>
#include <cstdio>
#include <iostream>
#include "general.hpp"
#include "special.hpp"
namespace G = ipgen::general;
namespace S = ipgen::special;
#ifdef ENERGY  // a second specialisation of the same scene, with the energy functions
#include "special_energy.hpp"
namespace E = ipgen::special_energy;
#endif

template <class A, class B>
double difference(const A& a, const B& b) {  // max |a - b| / max |b|; NaN if any entry is NaN
  const double scale = b.cwiseAbs().template maxCoeff<Eigen::PropagateNaN>();
  return (a - b).cwiseAbs().template maxCoeff<Eigen::PropagateNaN>() / (scale > 0 ? scale : 1.0);
}

void raise_to(double& worst, double value) {  // std::max would drop a NaN value
  if (!std::isnan(worst) && !(value <= worst)) worst = value;
}

int main() {
  G::Params<double> gp;
  for (auto* group : {&gp.m, &gp.l, &gp.delta}) for (double& x : *group) std::cin >> x;
  std::cin >> gp.g;
  S::Params<double> sp{gp.m, gp.l, gp.delta, gp.g};
  if (S::check_folded(sp) != nullptr) { std::printf("folded mismatch %s\n", S::check_folded(sp)); return 1; }
#ifdef ENERGY
  E::Params<double> ep{gp.m, gp.l, gp.delta, gp.g};
  if (E::check_folded(ep) != nullptr) { std::printf("folded mismatch %s\n", E::check_folded(ep)); return 1; }
#endif
  double worst = 0;
  G::Vector<double> q, qd;
  double u;
  while (std::cin >> u) {
    for (int i = 0; i < G::kDof; ++i) std::cin >> q(i);
    for (int i = 0; i < G::kDof; ++i) std::cin >> qd(i);
    raise_to(worst, difference(S::forward_dynamics(q, qd, u, sp), G::forward_dynamics(q, qd, u, gp)));
    const auto ds = S::forward_dynamics_derivatives(q, qd, u, sp);
    const auto dg = G::forward_dynamics_derivatives(q, qd, u, gp);
    raise_to(worst, difference(ds.dqdd_dq, dg.dqdd_dq));
    raise_to(worst, difference(ds.dqdd_dqd, dg.dqdd_dqd));
    raise_to(worst, difference(ds.dqdd_du, dg.dqdd_du));
#ifdef ENERGY
    raise_to(worst, difference(E::forward_dynamics(q, qd, u, ep), G::forward_dynamics(q, qd, u, gp)));
    const auto de = E::forward_dynamics_derivatives(q, qd, u, ep);
    raise_to(worst, difference(de.dqdd_dq, dg.dqdd_dq));
    raise_to(worst, difference(de.dqdd_dqd, dg.dqdd_dqd));
    raise_to(worst, difference(de.dqdd_du, dg.dqdd_du));
    Eigen::Vector3d es(E::kinetic_energy(q, qd, ep), E::potential_energy(q, ep), E::dissipation(qd, ep));
    Eigen::Vector3d eg(G::kinetic_energy(q, qd, gp), G::potential_energy(q, gp), G::dissipation(qd, gp));
    raise_to(worst, difference(es, eg));
#endif
  }
  if (!std::cin.eof()) { std::printf("unreadable input\n"); return 1; }  // not a silent partial read
  std::printf("%.3e\n", worst);
  return 0;
}
"""


def compile_program(
    directory: Path, source: str, defines: list[str] | None = None
) -> subprocess.CompletedProcess:
    require_toolchain()
    path = directory / "program.cpp"
    path.write_text(source)
    command = cxx_command(*(defines or []), f"-I{directory}", str(path), "-o", str(directory / "program"))
    return subprocess.run(command, capture_output=True, text=True)


@pytest.mark.parametrize("scene_path", SCENES, ids=[p.stem for p in SCENES])
def test_specialised_header_agrees_with_general(tmp_path: Path, scene_path: Path) -> None:
    """Two specialisations of each scene, the simulator's (no energy functions) and the energy
    ledger's (scene.energy = true), in one program with the general header."""
    scene = shipped_scene(scene_path)
    system = System(scene.type, scene.links, scene.inertia)  # type: ignore[arg-type]
    generate_header(system, "general", tmp_path)
    for name, energy in (("special", False), ("special_energy", True)):
        spec = from_scene(dataclasses.replace(scene, energy=energy))
        assert {key for key, _ in spec.fixed} >= {"m0", "m1", "delta1", "g"}
        generate_header(system, name, tmp_path, spec=spec)
        special = (tmp_path / f"{name}.hpp").read_text()
        assert "SPECIALISED for scene" in special and "folded" in special
        assert ("kinetic_energy(" in special) == energy
    build = compile_program(tmp_path, COMPARE, ["-DENERGY"])
    assert build.returncode == 0, build.stderr[:4000]

    rng = np.random.default_rng(len(scene.stem))
    numbers = [*scene.m, *scene.l, *scene.delta, scene.g]
    for _ in range(STATES):
        numbers += [rng.uniform(-1, 1), *rng.uniform(-3, 3, system.dof), *rng.uniform(-2, 2, system.dof)]
    result = subprocess.run(
        [str(tmp_path / "program")],
        input=" ".join(repr(float(x)) for x in numbers),
        capture_output=True,
        text=True,
    )
    assert result.returncode == 0, result.stdout + result.stderr
    assert float(result.stdout) <= RELATIVE, f"{scene.stem}: specialised vs general differ by {result.stdout}"


def test_pruned_function_does_not_compile(tmp_path: Path) -> None:
    scene = load_scene(ROOT / "scenes" / "cdip_pulse.toml")
    system = System(scene.type, scene.links)
    generate_header(system, "special", tmp_path, spec=from_scene(scene))
    source = '#include "special.hpp"\nint main() {\n  ipgen::special::Params<double> p{};\n'
    source += "  ipgen::special::Vector<double> q = ipgen::special::Vector<double>::Zero();\n"
    calls = {
        "mass_matrix": "mass_matrix(q, p)",
        "bias": "bias(q, q, p)",
        "kinetic_energy": "kinetic_energy(q, q, p)",
    }
    for function, call in calls.items():
        build = compile_program(tmp_path, f"{source}  (void)ipgen::special::{call};\n}}\n")
        assert build.returncode != 0, f"{function} should be absent from the specialised header"
        assert function in build.stderr
    build = compile_program(
        tmp_path, f"{source}  (void)ipgen::special::forward_dynamics(q, q, 0.0, p);\n}}\n"
    )
    assert build.returncode == 0, build.stderr[:2000]
    assert set(ENERGY_FUNCTIONS).isdisjoint(from_scene(scene).outputs)


def test_fix_folds_exact_rationals_and_check_folded_names_a_mismatch(tmp_path: Path) -> None:
    args = ["--type", "classical", "--links", "2", "--name", "m", "--fix", "m1=0.275,delta2=0,g=9.81"]
    assert run([*args, "--outputs", "forward_dynamics,kinetic_energy", "-o", str(tmp_path)]) == 0
    text = (tmp_path / "m.hpp").read_text()
    assert "m1 = 0.275 (11/40) folded" in text and "delta2 = 0 pruned" in text
    assert "--fix m1=0.275,delta2=0,g=9.81" in text
    body = text[text.index("forward_dynamics(const") :]
    assert "p.m[1]" not in body and "p.g" not in body and "delta2" not in body.split("kinetic_energy")[0]
    assert "Scalar(11)" in body or "Scalar(40)" in body  # 0.275 = 11/40, folded exactly
    check = (
        '#include "m.hpp"\n#include <cstring>\nint main() {\n'
        "  ipgen::m::Params<double> p{{0.3, 0.275, 0.275}, {0, 0.5, 0.5}, {0.3, 0.1, 0.0}, 9.81};\n"
        "  if (ipgen::m::check_folded(p) != nullptr) return 1;\n"
        "  p.m[1] = 0.3;\n"
        '  return std::strcmp(ipgen::m::check_folded(p), "m1") == 0 ? 0 : 2;\n}\n'
    )
    build = compile_program(tmp_path, check)
    assert build.returncode == 0, build.stderr[:2000]
    assert subprocess.run([str(tmp_path / "program")]).returncode == 0


def test_general_header_declares_itself_general(tmp_path: Path) -> None:
    assert run(["--type", "rotary", "--links", "1", "-o", str(tmp_path)]) == 0
    text = (tmp_path / "rotary1.hpp").read_text()
    assert "inline constexpr bool kSpecialised = false;" in text and "SPECIALISED" not in text


def test_scene_with_specialise_true_writes_a_specialised_header(tmp_path: Path) -> None:
    source = (ROOT / "scenes" / "rsip_pulse.toml").read_text()
    source = source.replace("[system]", "[system]\nspecialise = true", 1)
    source = source.replace("[parameters]", '[parameters]\nfree = ["m0"]', 1)
    scene_path = tmp_path / "rsip_special.toml"
    scene_path.write_text(source)
    assert run(["--scene", str(scene_path), "-o", str(tmp_path / "out")]) == 0
    text = (tmp_path / "out" / "rsip.hpp").read_text()
    assert f"ipgen --scene {scene_path.as_posix()} -o <dir>" in text
    assert "m1 = 0.275 (11/40) folded" in text and "m0 =" not in text.split("Model:")[0]
    assert "const Scalar m0 = p.m[0];" in text  # free: still read from Params


def test_fix_with_many_digits_compiles_and_agrees(tmp_path: Path) -> None:
    """Folded values with 30 significant digits (the most --fix accepts) multiply up to
    rationals beyond 64-bit integers: the header prints those as the nearest double, compiles
    without warnings and agrees with the general header."""
    system = System("classical", 2)
    digits = {"m0": "0.123456789012345678901234567891", "m1": "1.98765432109876543210987654321",
              "l1": "0.333333333333333333333333333331", "l2": "0.7"}  # fmt: skip
    spec = Specialisation(fixed=tuple((name, Fraction(value)) for name, value in digits.items()))
    generate_header(system, "general", tmp_path)
    generate_header(system, "special", tmp_path, spec=spec)
    build = compile_program(tmp_path, COMPARE)
    assert build.returncode == 0, build.stderr[:4000]
    rng = np.random.default_rng(7)
    free = {"m2": 0.2, "l0": 0.0, "delta0": 0.1, "delta1": 0.1, "delta2": 0.1}
    params = free | {name: float(Fraction(value)) for name, value in digits.items()}
    numbers = [*(params[f"{group}{i}"] for group in ("m", "l", "delta") for i in range(3)), 9.81]
    for _ in range(STATES):
        numbers += [rng.uniform(-1, 1), *rng.uniform(-3, 3, system.dof), *rng.uniform(-2, 2, system.dof)]
    result = subprocess.run(
        [str(tmp_path / "program")],
        input=" ".join(repr(float(x)) for x in numbers),  # numpy 2's repr is "np.float64(…)"
        capture_output=True,
        text=True,
    )
    assert result.returncode == 0, result.stdout + result.stderr
    assert float(result.stdout) <= RELATIVE, f"specialised vs general differ by {result.stdout}"
