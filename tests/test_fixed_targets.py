"""`ipgen --type fixed --emit equations, fmu, fmu3`: a fixed chain's documents and FMUs.

- every displayed entry of the Markdown and of the LaTeX (M, N, P, T, V, D, the rotors, τ = B u)
  is read back (tests/latex_reader.py) and compared at random points with sympy.physics.mechanics'
  model of the chain (tests/fixed_reference.py, which shares nothing with ipgen's derivation):
  M, N θ̇ + P = −forcing(u = 0), τ = forcing(u) − forcing(0), T = ½ θ̇ᵀ M θ̇, P = ∂V/∂θ,
  ∂D/∂θ̇ = the damping torques; for the pendubot, the acrobot and both joints driven;
- the .tex compiles with pdflatex;
- the FMUs (FMI 2.0: pendubot and both joints; FMI 3.0: acrobot) pass FMPy's validation; their
  derivatives equal ipgen's numeric model (`FixedModel`, no Coulomb friction) at random states,
  inputs and parameters, rotors included; their directional derivatives with respect to each
  input equal M⁻¹ B; FMPy's CVODE run with m input signals follows scipy's integration of the
  model;
- the bad inputs get one line; a fixed scene's FMU is refused in one line.
"""

from __future__ import annotations

from functools import cache
from pathlib import Path

import numpy as np
import pytest
import sympy as sp
from c_models import require_cc
from fixed_reference import mechanics_model
from latex_reader import displayed, parse
from test_equations_doc import compile_tex

from ipgen.codegen.equations import render_fixed_equations
from ipgen.command.cli import run
from ipgen.errors import Error
from ipgen.model.fixed import FixedPendulum
from ipgen.model.fixed_numeric import FixedModel
from ipgen.model.fixed_poly import fixed_poly_equations
from ipgen.pipeline.fixed_generate import generate_fixed

CHAINS = [(2, (1,)), (2, (2,)), (2, (1, 2)), (3, (1, 3))]


def _chain_id(chain: tuple[int, tuple[int, ...]]) -> str:
    return f"n{chain[0]}-joints{'_'.join(map(str, chain[1]))}"


@cache
def _documents(links: int, joints: tuple[int, ...]) -> dict[str, str]:
    return render_fixed_equations("chain", "ipgen --type fixed", joints, links)


@cache
def _reference(links: int, joints: tuple[int, ...]):
    return mechanics_model(links, joints, np.eye(links), 0.0, True)


def _values(rng: np.random.Generator, links: int, inputs: int) -> dict[str, float]:
    values = {"g": 9.81}
    for i in range(1, links + 1):
        m, length = rng.uniform(0.2, 1.5), rng.uniform(0.2, 0.8)
        values |= {f"m{i}": m, f"l{i}": length, f"com{i}": rng.uniform(0.05, length)}
        values |= {f"J{i}": rng.uniform(0.001, 0.05), f"delta{i}": rng.uniform(0.0, 0.2)}
    for k in range(1, inputs + 1):
        values |= {f"Ir{k}": rng.uniform(0.0, 0.01), f"gr{k}": rng.choice([-6.0, 1.0, 3.0])}
    return values


def _numeric(expr: sp.Expr, values: dict[str, float]) -> float:
    return float(expr.xreplace({s: sp.Float(values[s.name]) for s in expr.free_symbols}))


@pytest.mark.parametrize("doc", ["md", "tex"])
@pytest.mark.parametrize("chain", CHAINS, ids=_chain_id)
def test_printed_equations_are_the_mechanics_model(chain: tuple[int, tuple[int, ...]], doc: str) -> None:
    links, joints = chain
    sym = fixed_poly_equations(links).symbols  # the cart's numbering: link i is theta_i
    entries = {
        lhs: parse(rhs, sym) for lhs, rhs in displayed(_documents(links, joints)[f".{doc}"], doc).items()
    }
    mass_ref, forcing_ref = _reference(links, joints)
    rng = np.random.default_rng(links * 10 + len(joints))
    name = "," if links > 10 else ""  # M_{12}, or M_{1,12} once an index has two digits
    for _ in range(3):
        values = _values(rng, links, len(joints))
        q, qd = rng.uniform(-np.pi, np.pi, links), rng.uniform(-2, 2, links)
        u = rng.uniform(-1, 1, len(joints))
        point = dict(values)
        point |= {f"theta{i + 1}": q[i] for i in range(links)} | {
            f"dtheta{i + 1}": qd[i] for i in range(links)
        }
        point |= {f"u{k + 1}": u[k] for k in range(len(joints))}
        mass = np.array(
            [
                [_numeric(entries[f"M_{{{min(j, k)}{name}{max(j, k)}}}"], point) for k in range(1, links + 1)]
                for j in range(1, links + 1)
            ]
        )
        np.testing.assert_allclose(mass, mass_ref(q, values), rtol=1e-12, atol=1e-12)
        n_theta = np.array(
            [
                sum(_numeric(entries[f"N_{{{j}{name}{k}}}"], point) * qd[k - 1] for k in range(1, links + 1))
                for j in range(1, links + 1)
            ]
        )
        gravity = np.array([_numeric(entries[f"P_{{{j}}}"], point) for j in range(1, links + 1)])
        at_rest = forcing_ref(q, qd, np.zeros(len(joints)), values)
        np.testing.assert_allclose(n_theta + gravity, -at_rest, rtol=1e-10, atol=1e-12)
        torques = np.array([_numeric(entries[rf"\tau_{{{j}}}"], point) for j in range(1, links + 1)])
        np.testing.assert_allclose(torques, forcing_ref(q, qd, u, values) - at_rest, atol=1e-12)
        kinetic = 0.5 * qd @ mass_ref(q, values) @ qd
        assert _numeric(entries["T"], point) == pytest.approx(kinetic, rel=1e-12)
        rotors = sum(_numeric(entries[rf"T_{{\mathrm{{r}},{k}}}"], point) for k in range(1, len(joints) + 1))
        bodies = sum(_numeric(entries[f"T_{{{i}}}"], point) for i in range(1, links + 1))
        assert bodies + rotors == pytest.approx(kinetic, rel=1e-12)
    # P = ∂V/∂θ and ∂D/∂θ̇ = δ_j on the joints' relative rates, symbolically
    for j in range(1, links + 1):
        assert sp.expand(sp.diff(entries["V"], sym.q[j]) - entries[f"P_{{{j}}}"]) == 0
    rates = [sym.qd[j] - (sym.qd[j - 1] if j >= 2 else 0) for j in range(1, links + 1)]
    rayleigh = sum(sym.delta[j] * rates[j - 1] ** 2 for j in range(1, links + 1)) / 2
    assert sp.expand(entries["D"] - rayleigh) == 0


def test_documents_state_the_chain_and_its_coordinates() -> None:
    markdown = _documents(2, (2,))[".md"]
    assert "on a fixed pivot" in markdown and "a motor drives joint 2" in markdown
    assert "**absolute** angle of link $i$ from the upright vertical, clockwise positive" in markdown
    assert r"\mathbf{B} = \begin{pmatrix} -1 \\ 1 \end{pmatrix}" in markdown
    assert "M_{00}" not in markdown and "P_{0}" not in markdown


def test_tex_compiles_with_pdflatex(tmp_path: Path) -> None:
    pdf = compile_tex(_documents(3, (1, 3))[".tex"], tmp_path)
    assert pdf.stat().st_size > 10_000


# --------------------------------------------------------------------------- FMUs

fmpy = pytest.importorskip("fmpy")


@pytest.fixture(scope="module")
def fmus(tmp_path_factory: pytest.TempPathFactory) -> dict[tuple[int, ...], Path]:
    """Three FMUs of the double pendulum: pendubot and both joints (FMI 2.0), acrobot (FMI 3.0)."""
    require_cc()
    folder = tmp_path_factory.mktemp("fixed_fmus")
    built = {}
    for joints, target, name in (
        ((1,), "fmu", "pendubot"),
        ((1, 2), "fmu", "both"),
        ((2,), "fmu3", "acrobot"),
    ):
        (written,) = generate_fixed(2, ",".join(map(str, joints)), folder / name, name, target)
        built[joints] = written.path
    return built


def _loaded(path: Path, folder: Path):
    from fmu_models import Loaded

    return Loaded(path, fmpy.extract(str(path), str(folder)))


def _pendulum(values: dict[str, float], joints: tuple[int, ...]) -> FixedPendulum:
    n = 2
    return FixedPendulum(
        n,
        m=[values[f"m{i}"] for i in range(1, n + 1)],
        l=[values[f"l{i}"] for i in range(1, n + 1)],
        delta=[values[f"delta{i}"] for i in range(1, n + 1)],
        g=values["g"],
        com=[values[f"com{i}"] for i in range(1, n + 1)],
        J=[values[f"J{i}"] for i in range(1, n + 1)],
        joints=joints,
        Ir=[values[f"Ir{k}"] for k in range(1, len(joints) + 1)],
        gr=[values[f"gr{k}"] for k in range(1, len(joints) + 1)],
    )


@pytest.mark.parametrize("joints", [(1,), (1, 2), (2,)], ids=["pendubot", "both", "acrobot"])
def test_fmu_is_valid_and_its_derivatives_are_the_model(
    fmus: dict[tuple[int, ...], Path], joints: tuple[int, ...], tmp_path: Path
) -> None:
    from fmpy.validation import validate_fmu

    path = fmus[joints]
    assert validate_fmu(str(path)) == []
    fmu = _loaded(path, tmp_path / "unzipped")
    assert [v.name for v in fmu.description.modelVariables if v.causality == "input"] == [
        f"u{k}" for k in range(1, len(joints) + 1)
    ]
    rng = np.random.default_rng(len(joints) + joints[0])
    try:
        for _ in range(4):
            values = _values(rng, 2, len(joints))
            q, qd, u = rng.uniform(-3, 3, 2), rng.uniform(-2, 2, 2), rng.uniform(-1, 1, len(joints))
            fmu.set(values)
            fmu.set({"theta1": q[0], "theta2": q[1], "dtheta1": qd[0], "dtheta2": qd[1]})
            fmu.set({f"u{k + 1}": u[k] for k in range(len(joints))})
            model = FixedModel(_pendulum(values, joints))
            expected = model.forward_dynamics(q, qd, u, coulomb=False)
            np.testing.assert_allclose(fmu.derivatives(), [*qd, *expected], rtol=1e-10, atol=1e-12)
            mass = model.mass_matrix(q)
            energy = fmu.get(["kinetic_energy"])[0]
            assert energy == pytest.approx(0.5 * qd @ mass @ qd, rel=1e-12)
            _, input_gain = model.linearize(q, qd, u)
            for k in range(len(joints)):
                column = fmu.directional(["ddtheta1", "ddtheta2"], [f"u{k + 1}"], [1.0])
                np.testing.assert_allclose(column, input_gain[2:, k], rtol=1e-9, atol=1e-12)
            slope = fmu.directional(["kinetic_energy"], ["dtheta1", "dtheta2"], [1.0, 0.0])
            assert slope[0] == pytest.approx((mass @ qd)[0], rel=1e-10)
    finally:
        fmu.close()


def test_fmu_refuses_bad_values_in_one_logged_line(fmus: dict[tuple[int, ...], Path], tmp_path: Path) -> None:
    from fmpy.fmi1 import FMICallException

    fmu = _loaded(fmus[(1, 2)], tmp_path / "unzipped")
    try:
        for name, value, expected in (
            ("gr2", 0.0, "gr2 = 0 is invalid: it must be finite and != 0"),
            ("Ir1", -1.0, "Ir1 = -1 is invalid: it must be >= 0"),
            ("u2", float("inf"), "u2 = inf is not a finite number"),
        ):
            with pytest.raises(FMICallException):
                fmu.set({name: value})
            assert expected in fmu.messages[-1], fmu.messages
        with pytest.raises(FMICallException):
            fmu.directional(["ddtheta1"], ["g"], [1.0])
        assert "a known must be a state (theta, dtheta) or an input" in fmu.messages[-1]
        fmu.set({"J2": -0.001, "gr1": -6.0})  # identified values may have them (DFKI's)
        assert fmu.get(["J2", "gr1"]).tolist() == [-0.001, -6.0]
    finally:
        fmu.close()


@pytest.mark.parametrize("joints", [(1, 2), (2,)], ids=["both", "acrobot"])
def test_fmpy_simulation_follows_the_model(
    fmus: dict[tuple[int, ...], Path], joints: tuple[int, ...]
) -> None:
    from scipy.integrate import solve_ivp

    values = _values(np.random.default_rng(7), 2, len(joints))
    inputs = len(joints)
    steps = [(0.0, 0.3), (0.5, 0.3), (0.5, -0.2), (2.0, -0.2)]  # (t, torque): a step at 0.5 s
    signal = np.array(
        [(t, *[level * (k + 1) for k in range(inputs)]) for t, level in steps],
        dtype=[("time", float), *[(f"u{k + 1}", float) for k in range(inputs)]],
    )
    start = {**values, "theta1": 0.4, "theta2": -0.3}
    result = fmpy.simulate_fmu(
        str(fmus[joints]),
        solver="CVode",
        relative_tolerance=1e-10,
        stop_time=2.0,
        output_interval=0.01,
        input=signal,
        start_values=start,
        output=["theta1", "theta2"],
    )
    model = FixedModel(_pendulum(values, joints))

    def torque(t: float) -> np.ndarray:
        level = 0.3 if t < 0.5 else -0.2
        return np.array([level * (k + 1) for k in range(inputs)])

    def rate(t: float, x: np.ndarray) -> np.ndarray:
        return np.concatenate([x[2:], model.forward_dynamics(x[:2], x[2:], torque(t), coulomb=False)])

    early = solve_ivp(rate, (0.0, 0.5), [0.4, -0.3, 0.0, 0.0], rtol=1e-11, atol=1e-12, dense_output=True)
    later = solve_ivp(rate, (0.5, 2.0), early.y[:, -1], rtol=1e-11, atol=1e-12, dense_output=True)
    times = result["time"]
    expected = np.array([early.sol(t) if t <= 0.5 else later.sol(t) for t in times])
    assert np.max(np.abs(result["theta1"] - expected[:, 0])) < 1e-6
    assert np.max(np.abs(result["theta2"] - expected[:, 1])) < 1e-6


# --------------------------------------------------------------------------- refusals


def test_bad_options_get_one_line(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    assert run(["--type", "fixed", "--links", "2", "--emit", "fmu,fmu3", "-o", str(tmp_path)]) == 2
    assert (
        run(["--type", "fixed", "--links", "2", "--angles", "relative", "--emit", "fmu", "-o", str(tmp_path)])
        == 2
    )
    scene = Path(__file__).resolve().parent.parent / "scenes" / "rigs" / "dfki_c0.toml"
    assert run(["--scene", str(scene), "--emit", "fmu", "-o", str(tmp_path)]) == 2
    errors = [line for line in capsys.readouterr().err.splitlines() if line]
    assert len(errors) == 3 and all(line.startswith("ipgen: error: ") for line in errors)
    assert "fmu and fmu3 both write NAME.fmu" in errors[0]
    assert "--angles with --type fixed" in errors[1]
    assert "fixed" in errors[2]
    assert not any(tmp_path.iterdir())
    with pytest.raises(Error, match=r"unknown target 'bogus'"):
        generate_fixed(2, "1", tmp_path, None, "bogus")
