"""Headers in the rig's coordinates (`--angles`, `--zero`, `--positive`; a scene's [system] keys).

Each generated function in the rig's coordinates (C++ and C, double) is evaluated at a general
state and checked against things it is not built from: the Python map (model/coordinates.py)
for to_canonical and the rates; the kinetic energy ½ q̇ᵀ M_q q̇ of the rig's mass matrix against
the canonical energy at the mapped state (energies do not depend on the coordinates); the rig's
gravity vector against central differences of the rig's potential energy; M_q q̈ + b_q = e0 u
and N_q q̇ + P_q = b_q; and A, B of `linearize` against ipgen's Python linearisation in the same
convention (A_q = T A T⁻¹, a numerical path of its own). The defaults write what they always
wrote (the scene test in test_scene_coordinates.py and the golden headers check that).
"""

from __future__ import annotations

import subprocess
import warnings
from pathlib import Path

import numpy as np
import pytest
from c_models import c_command, compile_c, require_cc
from cxx import cxx_command, require_toolchain
from hypothesis import given, settings
from hypothesis import strategies as st

import ipgen
from ipgen.control.linear import EquilibriumWarning
from ipgen.model.coordinates import ANGLES, POSITIVE, ZEROS, Coordinates
from ipgen.pipeline.job import OptionsError, plan

CASES = [
    ("rotary", 2, Coordinates("relative", "hanging", "counterclockwise")),
    ("classical", 2, Coordinates("absolute", "hanging", "clockwise")),
    ("rotary", 1, Coordinates("absolute", "upright", "counterclockwise")),
    ("classical", 3, Coordinates("relative", "upright", "clockwise")),
]
M = [0.5, 0.275, 0.2, 0.15]
L = [0.6, 0.5, 0.4, 0.3]
DELTA = [0.3, 0.011, 0.013, 0.007]
U = 0.37


def _state(dof: int) -> tuple[np.ndarray, np.ndarray]:
    q = np.array([0.1, 0.4, -0.7, 2.1][:dof])
    qd = np.array([0.3, -0.5, 0.9, -0.2][:dof])
    return q, qd


def _vector(values: np.ndarray | list[float]) -> str:
    return ", ".join(repr(float(v)) for v in values)


CPP_DRIVER = """#include <cstdio>
#include "{name}.hpp"
using namespace ipgen::{name};
template <class T> void show(const char* label, const T& x) {{
  std::printf("%s", label);
  for (int i = 0; i < x.size(); ++i) std::printf(" %.17g", x.data()[i]);  // column-major
  std::printf("\\n");
}}
int main() {{
  Params<double> p{{{{{m}}}, {{{l}}}, {{{delta}}}, 9.81}};
  Vector<double> q, qd;
  q << {q};
  qd << {qd};
  const double u = {u};
  const double h = 1e-6;
  show("theta", to_canonical(q));
  show("thetad", rates_to_canonical(qd));
  show("back", from_canonical(to_canonical(q)));
  show("backd", rates_from_canonical(rates_to_canonical(qd)));
  show("M", mass_matrix(q, p));
  show("Mc", canonical::mass_matrix(to_canonical(q), p));
  show("b", bias(q, qd, p));
  show("P", gravity(q, p));
  show("N", n_matrix(q, qd, p));
  show("qdd", forward_dynamics(q, qd, u, p));
  const auto lin = linearize(q, qd, u, p);
  show("A", lin.A);
  show("B", lin.B);
  show("Ac", Model::linearize(to_canonical(q), rates_to_canonical(qd), u, p).A);  // ipsim's view
  double tau = 0;  // an acceleration-driven base: u is the base's acceleration here
  show("qdda", forward_dynamics_acceleration(q, qd, u, p, &tau));
  show("qddac", canonical::forward_dynamics_acceleration(to_canonical(q), rates_to_canonical(qd), u, p));
  show("Aa", linearize_acceleration(q, qd, u, p).A);
  show("Ba", linearize_acceleration(q, qd, u, p).B);
  show("Aac", canonical::linearize_acceleration(to_canonical(q), rates_to_canonical(qd), u, p).A);
  Eigen::Matrix<double, 1, 1> t;
  t << tau;
  show("tau", t);
  Eigen::Matrix<double, 3, 1> e;
  e << kinetic_energy(q, qd, p), canonical::kinetic_energy(to_canonical(q), rates_to_canonical(qd), p),
      dissipation(qd, p);
  show("energies", e);
  Vector<double> dv;
  for (int i = 0; i < kDof; ++i) {{
    Vector<double> up = q, down = q;
    up(i) += h;
    down(i) -= h;
    dv(i) = (potential_energy(up, p) - potential_energy(down, p)) / (2 * h);
  }}
  show("dV", dv);
  Eigen::Matrix<double, 1, 1> d;
  d << canonical::dissipation(rates_to_canonical(qd), p);
  show("Dc", d);
}}
"""

C_DRIVER = """#include <stdio.h>
#include "{name}.h"
#define D {dof}
static void show(const char* label, const double* x, int n) {{
  int i;
  printf("%s", label);
  for (i = 0; i < n; ++i) printf(" %.17g", x[i]);  /* row-major */
  printf("\\n");
}}
int main(void) {{
  ipgen_{name}_params p = {{{{{m}}}, {{{l}}}, {{{delta}}}, 9.81}};
  double q[D] = {{{q}}}, qd[D] = {{{qd}}}, theta[D], thetad[D], back[D], backd[D];
  double M[D * D], Mc[D * D], b[D], P[D], N[D * D], qdd[D], A[4 * D * D], B[2 * D], e[3], dv[D], dc[1];
  const double u = {u}, h = 1e-6;
  int i;
  ipgen_{name}_to_canonical(q, theta);
  ipgen_{name}_rates_to_canonical(qd, thetad);
  ipgen_{name}_from_canonical(theta, back);
  ipgen_{name}_rates_from_canonical(thetad, backd);
  ipgen_{name}_mass_matrix(q, &p, M);
  ipgen_{name}_mass_matrix_canonical(theta, &p, Mc);
  ipgen_{name}_bias(q, qd, &p, b);
  ipgen_{name}_gravity(q, &p, P);
  ipgen_{name}_n_matrix(q, qd, &p, N);
  if (ipgen_{name}_forward_dynamics(q, qd, u, &p, qdd) != 0) return 1;
  if (ipgen_{name}_linearize(q, qd, u, &p, A, B) != 0) return 1;
  e[0] = ipgen_{name}_kinetic_energy(q, qd, &p);
  e[1] = ipgen_{name}_kinetic_energy_canonical(theta, thetad, &p);
  e[2] = ipgen_{name}_dissipation(qd, &p);
  for (i = 0; i < D; ++i) {{
    double up[D], down[D];
    int k;
    for (k = 0; k < D; ++k) up[k] = down[k] = q[k];
    up[i] += h;
    down[i] -= h;
    dv[i] = (ipgen_{name}_potential_energy(up, &p) - ipgen_{name}_potential_energy(down, &p)) / (2 * h);
  }}
  dc[0] = ipgen_{name}_dissipation_canonical(thetad, &p);
  show("theta", theta, D); show("thetad", thetad, D); show("back", back, D); show("backd", backd, D);
  show("M", M, D * D); show("Mc", Mc, D * D); show("b", b, D); show("P", P, D); show("N", N, D * D);
  show("qdd", qdd, D); show("A", A, 4 * D * D); show("B", B, 2 * D); show("energies", e, 3);
  show("dV", dv, D); show("Dc", dc, 1);
  return 0;
}}
"""


def _values(output: str, dof: int, language: str) -> dict[str, np.ndarray]:
    found = {}
    for line in output.splitlines():
        label, *numbers = line.split()
        found[label] = np.array([float(v) for v in numbers])
    for label in ("M", "Mc", "N", "A", "Ac", "Aa", "Aac"):
        if label not in found:
            continue
        size = 2 * dof if label.startswith("A") else dof
        matrix = found[label].reshape(size, size)
        found[label] = matrix.T if language == "cpp" else matrix  # Eigen is column-major
    return found


@pytest.mark.parametrize("language", ["cpp", "c"])
@pytest.mark.parametrize(("kind", "links", "frame"), CASES, ids=lambda v: getattr(v, "angles", v))
def test_functions_in_the_rig_s_coordinates(
    tmp_path: Path, language: str, kind: str, links: int, frame: Coordinates
) -> None:
    if language == "cpp":
        require_toolchain()
    else:
        require_cc()
    dof = links + 1
    name = f"{kind[0]}{links}_rig"
    ipgen.write_header(
        tmp_path, kind, links, name=name, emit=language, angles=frame.angles, zero=frame.zero,
        positive=frame.positive,
    )  # fmt: skip
    q, qd = _state(dof)
    m, l, delta = M[:dof], L[:dof], DELTA[:dof]  # noqa: E741
    if kind == "classical":
        l = [0.0, *l[1:]]  # noqa: E741
    fields = {"name": name, "dof": dof, "m": _vector(m), "l": _vector(l), "delta": _vector(delta)}
    source = (CPP_DRIVER if language == "cpp" else C_DRIVER).format(
        **fields, q=_vector(q), qd=_vector(qd), u=repr(U)
    )
    driver = tmp_path / f"driver.{language}"
    driver.write_text(source)
    program = tmp_path / "driver"
    if language == "cpp":
        command = cxx_command(f"-I{tmp_path}", str(driver), "-o", str(program))
    else:
        command = c_command(f"-I{tmp_path}", str(driver), "-o", str(program))
    problem = compile_c(command)
    assert problem is None, problem
    got = _values(
        subprocess.run([str(program)], capture_output=True, text=True, check=True).stdout, dof, language
    )

    # the map, against the Python one
    p, _ = frame.matrices(links)
    x_canonical = frame.to_canonical(np.concatenate([q, qd]), links)
    assert np.allclose(got["theta"], x_canonical[:dof], rtol=1e-15, atol=1e-15)
    assert np.allclose(got["thetad"], x_canonical[dof:], rtol=1e-15, atol=1e-15)
    assert np.allclose(got["back"], q, atol=1e-15) and np.allclose(got["backd"], qd, atol=1e-15)
    r = np.linalg.inv(p[:dof, :dof])  # θ̇ = R q̇
    assert np.allclose(got["M"], r.T @ got["Mc"] @ r, rtol=1e-13, atol=1e-15)

    # energies: the rig's mass matrix gives the same kinetic energy; T, D as in ipgen's
    kinetic, kinetic_canonical, dissipation = got["energies"]
    assert kinetic == pytest.approx(0.5 * qd @ got["M"] @ qd, rel=1e-13)
    assert kinetic == pytest.approx(kinetic_canonical, rel=1e-14)
    assert dissipation == pytest.approx(got["Dc"][0], rel=1e-14)
    assert np.allclose(got["P"], got["dV"], rtol=1e-7, atol=1e-8)  # P_q = dV/dq in q itself

    # the equations of motion and N in the rig's coordinates
    assert np.allclose(got["M"] @ got["qdd"] + got["b"], np.eye(dof)[0] * U, rtol=1e-12, atol=1e-12)
    assert np.allclose(got["N"] @ qd + got["P"], got["b"], rtol=1e-12, atol=1e-12)

    # the linearisation against ipgen's Python one in the same convention (numerical, independent)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", EquilibriumWarning)  # a general state: checks more
        a, b = ipgen.linearize(
            kind, links, m, l, delta, q=q, qd=qd, u=U, angles=frame.angles, zero=frame.zero,
            positive=frame.positive,
        )  # fmt: skip
    assert np.allclose(got["A"], a, rtol=1e-9, atol=1e-9)
    assert np.allclose(got["B"], b.ravel(), rtol=1e-9, atol=1e-12)
    if "Ac" in got:  # Model (what ipsim integrates) is ipgen's: A_q = T A T⁻¹, T = diag(R⁻¹, R⁻¹)
        assert np.allclose(got["A"], p @ got["Ac"] @ np.linalg.inv(p), rtol=1e-12, atol=1e-12)
    if "qdda" in got:  # C++: an acceleration-driven base, u = a (they did not compile in a rig's frame)
        qdda = got["qdda"]
        assert qdda[0] == pytest.approx(U)  # the base's acceleration, the same in both frames
        residual = got["M"] @ qdda + got["b"]  # the links' equations hold; the base's needs tau
        assert np.allclose(residual[1:], 0.0, atol=1e-11) and residual[0] == pytest.approx(got["tau"][0])
        assert np.allclose(r @ qdda, got["qddac"], rtol=1e-12, atol=1e-12)  # θ̈ = R q̈
        assert np.allclose(got["Aa"], p @ got["Aac"] @ np.linalg.inv(p), rtol=1e-12, atol=1e-12)
        assert got["Ba"][dof] == pytest.approx(1.0) and np.allclose(got["Ba"][:dof], 0.0)


def test_the_scene_s_header_is_in_its_coordinates(tmp_path: Path) -> None:
    """The QUBE-Servo 2 preset (Quanser's counter-clockwise α) writes headers in that convention,
    with the regenerate command and the C controller in it too."""
    root = Path(__file__).resolve().parents[1]
    ipgen.write_header(tmp_path, scene=root / "scenes" / "rigs" / "qube_servo2.toml")
    cpp = (tmp_path / "qube_servo2.hpp").read_text()
    c = (tmp_path / "qube_servo2.h").read_text()
    assert "THE RIG'S COORDINATES" in cpp and "namespace canonical {" in cpp
    assert "angles absolute, zero upright, positive counterclockwise" in cpp
    assert "ipgen_qube_servo2_mass_matrix_canonical(" in c and "ipgen_qube_servo2_to_canonical(" in c
    assert "return ::ipgen::qube_servo2::canonical::forward_dynamics(q, qd, u, p);" in cpp  # Model


@pytest.mark.parametrize(
    ("options", "message"),
    [
        ({"angles": "joint"}, "--angles 'joint': expected absolute or relative"),
        ({"zero": "down"}, "--zero 'down': expected upright or hanging"),
        ({"positive": 1}, "--positive '1': expected clockwise or counterclockwise"),
        ({"zero": "hanging", "emit": "fmu"}, "--emit fmu in the rig's coordinates is not supported yet"),
    ],
)
def test_bad_coordinates_are_one_line(tmp_path: Path, options: dict, message: str) -> None:
    with pytest.raises(ipgen.Error, match=message) as caught:
        ipgen.write_header(tmp_path / "out", "rotary", 1, **options)
    assert "\n" not in str(caught.value) and not (tmp_path / "out").exists()


def test_a_scene_says_its_own_coordinates(tmp_path: Path) -> None:
    root = Path(__file__).resolve().parents[1]
    with pytest.raises(ipgen.Error, match="--scene says the coordinates in its"):
        ipgen.write_header(
            tmp_path, scene=root / "scenes" / "rigs" / "qube_servo2.toml", positive="clockwise"
        )


def test_the_command_takes_the_options(tmp_path: Path) -> None:
    from ipgen.command.cli import run

    status = run(["--type", "rotary", "--links", "1", "--positive", "counterclockwise", "-o", str(tmp_path)])
    assert status == 0
    header = (tmp_path / "rotary1.hpp").read_text()
    assert "--positive counterclockwise -o <dir>" in header  # the regenerate command says it
    assert run(["--type", "rotary", "--links", "1", "--zero", "sideways", "-o", str(tmp_path / "x")]) == 2


# Any value of the three options: a job in that convention, or one line naming the option.
OPTION_VALUES = st.one_of(
    st.none(),
    st.sampled_from([*ANGLES, *ZEROS, *POSITIVE, "Relative", "ccw", ""]),
    st.text(max_size=20),
    st.integers(-2, 2),
    st.lists(st.sampled_from(ANGLES), max_size=2),
)


@settings(max_examples=80, deadline=None)
@given(OPTION_VALUES, OPTION_VALUES, OPTION_VALUES)
def test_any_coordinate_options_plan_or_fail_in_one_line(
    angles: object, zero: object, positive: object
) -> None:
    options = {"angles": angles, "zero": zero, "positive": positive}
    try:
        job = plan("out", system_type="rotary", links=2, **options)
    except OptionsError as exc:
        message = str(exc)
        assert "\n" not in message and message.startswith("--"), message
        wrong = message.split()[0][2:]
        assert wrong in options and options[wrong] is not None, message
        allowed = {"angles": ANGLES, "zero": ZEROS, "positive": POSITIVE}[wrong]
        assert options[wrong] not in allowed and "expected " + " or ".join(allowed) in message
        return
    for key, value in options.items():
        assert getattr(job.coordinates, key) == (value if value is not None else getattr(Coordinates(), key))
