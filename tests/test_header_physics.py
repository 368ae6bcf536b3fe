"""Physics checks of the generated C++ headers, compiled with -Wall -Wextra -Wpedantic -Werror.

Each model's header is built into `tests/cpp/eval_model.cpp` (see conftest.py) and evaluated at
random states with random positive parameters (fixed seeds). Checked:
- M(q) equals the Hessian in θ̇ of the header's kinetic_energy (central second differences,
  exact for a quadratic; hence symmetric) and is positive definite (Cholesky, eigenvalues);
- every function equals the lambdified sympy equations (1e-12 relative);
- power balance: d(T + V)/dt along the motion given by forward_dynamics, by a central
  difference of the header's T and V, equals the input power u θ̇0 minus 2D;
- Ṁ − 2C skew-symmetric, Ṁ by a central difference of mass_matrix along θ̇ and
  C = N(q, θ̇) − N(q, 0);
- N θ̇ + P = bias, M θ̈ + bias = B u, D = ½ θ̇ᵀ N(q, 0) θ̇;
- Scalar = float compiles and agrees loosely with double.
"""

from __future__ import annotations

import subprocess
import zlib
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import cache
from pathlib import Path

import numpy as np
import pytest
import sympy as sp
from conftest import CppModels, check_built, model_name
from numeric import assert_close

from ipgen.model.derivation import derive
from ipgen.model.system import System

MODELS = [
    *(System("classical", n) for n in range(1, 6)),
    *(System("rotary", n, "pivot") for n in range(1, 6)),
    *(System("rotary", n, "full") for n in range(1, 4)),
]
STATES = 6
RELATIVE = 1e-12  # header vs lambdified sympy, relative to the quantity's largest entry
STEP = 1e-6  # central differences
DIFFERENCE_RELATIVE = 1e-6
FLOAT_RELATIVE = 1e-4  # float vs double, relative to the largest entry (times cond(M) for θ̈)

Quantities = dict[str, np.ndarray]
State = tuple[np.ndarray, np.ndarray, float]


@dataclass(frozen=True)
class Case:
    """Parameters and states of one model, drawn from a seed fixed by the model's name."""

    params: tuple[np.ndarray, np.ndarray, np.ndarray, float]  # m, l, delta, g
    q: np.ndarray  # (STATES, dof)
    qd: np.ndarray
    u: np.ndarray  # (STATES,)

    def states(self) -> list[State]:
        return [(self.q[k], self.qd[k], float(self.u[k])) for k in range(len(self.u))]


def make_case(system: System) -> Case:
    rng = np.random.default_rng(zlib.crc32(model_name(system).encode()))
    dof = system.dof
    params = (rng.uniform(0.1, 2.0, dof), rng.uniform(0.2, 1.5, dof), rng.uniform(0.0, 0.5, dof), 9.81)
    q = rng.uniform(-np.pi, np.pi, (STATES, dof))
    if not system.is_rotary:
        q[:, 0] = rng.uniform(-1.0, 1.0, STATES)  # cart position [m]
    qd = rng.uniform(-2.0, 2.0, (STATES, dof))
    u = rng.uniform(-2.0, 2.0, STATES)
    return Case(params, q, qd, u)


def run_driver(
    executable: Path, system: System, scalar: str, case: Case, states: Sequence[State]
) -> list[Quantities]:
    """Evaluate the header at `states` [(q, qd, u), ...]; one dict of quantities per state."""
    name = model_name(system)
    m, lengths, delta, g = case.params
    numbers = [*m, *lengths, *delta, g, len(states)]
    for q, qd, u in states:
        numbers += [*q, *qd, u]
    text = " ".join(repr(float(x)) if not isinstance(x, int) else str(x) for x in numbers)
    result = subprocess.run(
        [str(executable), name, scalar], input=text, capture_output=True, text=True, check=False
    )
    assert result.returncode == 0, f"{name} ({scalar}): driver failed: {result.stderr.strip()}"
    lines = result.stdout.splitlines()
    header = lines[0].split()
    expected_inertia = system.inertia if system.is_rotary else "-"
    assert header == ["model", name, system.type, expected_inertia, str(system.dof)], (
        f"{name}: the header's Model reports {header[1:]}, expected "
        f"{[name, system.type, expected_inertia, system.dof]}"
    )
    dof = system.dof
    shapes = {
        "M": (dof, dof),
        "N": (dof, dof),
        "bias": (dof,),
        "gravity": (dof,),
        "qdd": (dof,),
        "dqdd_dq": (dof, dof),
        "dqdd_dqd": (dof, dof),
        "dqdd_du": (dof,),
    }
    per_state = 11
    assert len(lines) == 1 + per_state * len(states), f"{name}: unexpected output\n{result.stdout}"
    results: list[Quantities] = []
    for k in range(len(states)):
        block: Quantities = {}
        for line in lines[1 + per_state * k : 1 + per_state * (k + 1)]:
            key, *values = line.split()
            block[key] = np.array([float(v) for v in values]).reshape(shapes.get(key, ()))
        results.append(block)
    return results


# --------------------------------------------------------------------------- sympy reference


@cache
def reference(system: System) -> Callable[[Case, int], Quantities]:
    """Lambdified eqs: (case, state index) -> the same quantities as the driver prints."""
    eqs = derive(system).rod()
    sym = eqs.symbols
    args = (sym.q, sym.qd, sym.u, sym.m, sym.l, sym.delta, sym.g)
    functions = {
        "M": eqs.mass_matrix,
        "bias": eqs.bias,
        "gravity": eqs.gravity,
        "N": eqs.n_matrix,
        "T": eqs.kinetic_energy,
        "V": eqs.potential_energy,
        "D": eqs.dissipation,
    }
    numeric = {key: sp.lambdify(args, value, "numpy") for key, value in functions.items()}

    def evaluate(case: Case, k: int) -> Quantities:
        m, lengths, delta, g = case.params
        values = (case.q[k], case.qd[k], case.u[k], m, lengths, delta, g)
        out: Quantities = {}
        for key, function in numeric.items():
            value = np.array(function(*values), dtype=float)
            out[key] = value.reshape(-1) if key in ("bias", "gravity") else value
        force = np.zeros(system.dof)
        force[0] = case.u[k]
        out["qdd"] = np.linalg.solve(out["M"], force - out["bias"])
        return out

    return evaluate


# --------------------------------------------------------------------------- evaluation


@dataclass(frozen=True)
class Evaluation:
    case: Case
    at: list[Quantities]  # at (q, qd, u)
    at_rest: list[Quantities]  # at (q, 0, u): N(q, 0) is the damping matrix
    ahead: list[Quantities]  # at (q + h qd, qd + h qdd, u)
    behind: list[Quantities]  # at (q − h qd, qd − h qdd, u)


class Evaluations:
    """Header outputs per model, computed once per module."""

    def __init__(self, models: CppModels) -> None:
        self.models = models
        self.cache: dict[System, Evaluation] = {}

    def __call__(self, system: System) -> Evaluation:
        if system not in self.cache:
            self.cache[system] = self._evaluate(system)
        return self.cache[system]

    def _evaluate(self, system: System) -> Evaluation:
        case = make_case(system)
        rest = np.zeros(system.dof)
        states = case.states()
        states += [(case.q[k], rest, case.u[k]) for k in range(STATES)]
        executable = self.models.program(system)
        first = run_driver(executable, system, "double", case, states)
        at, at_rest = first[:STATES], first[STATES:]
        shifted = []
        for sign in (1.0, -1.0):
            for k in range(STATES):
                h = sign * STEP
                shifted.append((case.q[k] + h * case.qd[k], case.qd[k] + h * at[k]["qdd"], case.u[k]))
        second = run_driver(executable, system, "double", case, shifted)
        return Evaluation(case, at, at_rest, second[:STATES], second[STATES:])


@pytest.fixture(scope="module")
def evaluations(cpp_models: CppModels) -> Evaluations:
    cpp_models.submit(MODELS)  # start every build now; tests wait only for their own
    return Evaluations(cpp_models)


def where(system: System, case: Case, k: int) -> str:
    return (
        f"{model_name(system)}, state {k}: q={np.array2string(case.q[k], precision=4)}, "
        f"qd={np.array2string(case.qd[k], precision=4)}, u={case.u[k]:.4f}"
    )


# --------------------------------------------------------------------------- tests

model_ids = [model_name(system) for system in MODELS]


HESSIAN_STEP = 0.5  # T is quadratic in θ̇: central second differences are exact for any step
HESSIAN_RELATIVE = 1e-12  # so only rounding remains


def kinetic_hessian_states(state: State) -> list[State]:
    """(q, θ̇ ± h eᵢ ± h eⱼ, u) for every i ≤ j, in the order `kinetic_hessian` reads them."""
    q, qd, u = state
    steps = HESSIAN_STEP * np.eye(len(qd))
    states = []
    for i in range(len(qd)):
        for j in range(i, len(qd)):
            for si, sj in ((1, 1), (1, -1), (-1, 1), (-1, -1)):
                states.append((q, qd + si * steps[i] + sj * steps[j], u))
    return states


def kinetic_hessian(values: list[Quantities], dof: int) -> np.ndarray:
    """∂²T/∂θ̇ᵢ∂θ̇ⱼ ≈ [T(++) − T(+−) − T(−+) + T(−−)] / 4h², from the header's kinetic_energy."""
    hessian = np.zeros((dof, dof))
    energies = iter(float(v["T"]) for v in values)
    for i in range(dof):
        for j in range(i, dof):
            pp, pm, mp, mm = (next(energies) for _ in range(4))
            hessian[i, j] = hessian[j, i] = (pp - pm - mp + mm) / (4 * HESSIAN_STEP**2)
    return hessian


@pytest.mark.parametrize("system", MODELS, ids=model_ids)
def test_mass_matrix_symmetric_positive_definite(evaluations: Evaluations, system: System) -> None:
    """M = ∂²T/∂θ̇² of the header's own kinetic_energy (so M is symmetric), and M ≻ 0.

    kinetic_energy is emitted as its own expanded polynomial, not from mass_matrix, so a wrong
    entry of the emitted M (either triangle) disagrees with the Hessian of T.
    """
    run = evaluations(system)
    dof = system.dof
    states = run.case.states()
    shifted = [s for state in states for s in kinetic_hessian_states(state)]
    values = run_driver(evaluations.models.program(system), system, "double", run.case, shifted)
    per_state = len(shifted) // len(states)
    for k, out in enumerate(run.at):
        mass = out["M"]
        hessian = kinetic_hessian(values[per_state * k : per_state * (k + 1)], dof)
        assert_close(mass, hessian, HESSIAN_RELATIVE, f"{where(system, run.case, k)}: M vs ∂²T/∂θ̇²")
        try:
            np.linalg.cholesky(mass)
        except np.linalg.LinAlgError:
            pytest.fail(f"{where(system, run.case, k)}: Cholesky of M fails\n{mass}")
        eigenvalues = np.linalg.eigvalsh(mass)
        assert eigenvalues.min() > 0, f"{where(system, run.case, k)}: eigenvalues of M {eigenvalues}"


@pytest.mark.parametrize("system", MODELS, ids=model_ids)
def test_matches_lambdified_equations(evaluations: Evaluations, system: System) -> None:
    run = evaluations(system)
    evaluate = reference(system)
    for k, out in enumerate(run.at):
        expected = evaluate(run.case, k)
        cond = np.linalg.cond(expected["M"])
        for key in ("M", "bias", "gravity", "N", "T", "V", "D"):
            assert_close(out[key], expected[key], RELATIVE, f"{where(system, run.case, k)}: {key}")
        # θ̈ from a different linear solver: rounding grows with the condition number of M.
        assert_close(
            out["qdd"], expected["qdd"], RELATIVE * max(1.0, cond / 100), f"{where(system, run.case, k)}: θ̈"
        )


@pytest.mark.parametrize("system", MODELS, ids=model_ids)
def test_power_balance(evaluations: Evaluations, system: System) -> None:
    """d(T + V)/dt = u θ̇0 − 2D along θ̈ = forward_dynamics (eq. 3 times θ̇)."""
    run = evaluations(system)
    for k, out in enumerate(run.at):
        qd, qdd, u = run.case.qd[k], out["qdd"], run.case.u[k]

        def energy(values: Quantities) -> float:
            return float(values["T"] + values["V"])

        rate = (energy(run.ahead[k]) - energy(run.behind[k])) / (2 * STEP)
        supplied = u * qd[0] - 2 * float(out["D"])
        # Size of the power flows, for the tolerance: kinetic, potential, input, dissipated.
        scale = abs(qd @ out["M"] @ qdd) + abs(out["gravity"] @ qd) + abs(u * qd[0]) + 2 * abs(out["D"])
        assert abs(rate - supplied) <= DIFFERENCE_RELATIVE * scale, (
            f"{where(system, run.case, k)}: d(T+V)/dt = {rate:.12g} (central difference), "
            f"u θ̇0 − 2D = {supplied:.12g}, difference {rate - supplied:.3e}, scale {scale:.3e}"
        )


@pytest.mark.parametrize("system", MODELS, ids=model_ids)
def test_mdot_minus_two_c_is_skew_symmetric(evaluations: Evaluations, system: System) -> None:
    run = evaluations(system)
    for k, out in enumerate(run.at):
        mdot = (run.ahead[k]["M"] - run.behind[k]["M"]) / (2 * STEP)  # M depends on q only
        coriolis = out["N"] - run.at_rest[k]["N"]
        skew = mdot - 2 * coriolis
        scale = float(np.max(np.abs(out["M"])) * np.max(np.abs(run.case.qd[k])) + np.max(np.abs(coriolis)))
        error = float(np.max(np.abs(skew + skew.T)))
        assert error <= DIFFERENCE_RELATIVE * scale, (
            f"{where(system, run.case, k)}: (Ṁ − 2C) + (Ṁ − 2C)ᵀ has max |entry| {error:.3e} "
            f"(scale {scale:.3e})\nṀ − 2C =\n{skew}"
        )


@pytest.mark.parametrize("system", MODELS, ids=model_ids)
def test_bias_decompositions(evaluations: Evaluations, system: System) -> None:
    """N θ̇ + P = bias; M θ̈ + bias = B u; D = ½ θ̇ᵀ N(q, 0) θ̇; N(q, 0) θ̇ is gravity-free."""
    run = evaluations(system)
    for k, out in enumerate(run.at):
        qd, u = run.case.qd[k], run.case.u[k]
        here = where(system, run.case, k)
        assert_close(out["N"] @ qd + out["gravity"], out["bias"], RELATIVE, f"{here}: N θ̇ + P vs bias")
        force = np.zeros(system.dof)
        force[0] = u
        residual = out["M"] @ out["qdd"] + out["bias"]
        scale = np.abs(out["M"]) @ np.abs(out["qdd"]) + np.abs(out["bias"]) + abs(u)
        assert np.all(np.abs(residual - force) <= RELATIVE * scale), (
            f"{here}: M θ̈ + bias = {residual}, expected B u = {force}"
        )
        damping = run.at_rest[k]["N"]
        assert_close(damping, damping.T, RELATIVE, f"{here}: N(q, 0) (damping) symmetric")
        assert_close(out["D"], 0.5 * qd @ damping @ qd, RELATIVE, f"{here}: D vs ½ θ̇ᵀ N(q, 0) θ̇")
        rest_bias = run.at_rest[k]["bias"]
        assert_close(rest_bias, out["gravity"], RELATIVE, f"{here}: bias(q, 0) vs P(q)")


@pytest.mark.parametrize("system", MODELS, ids=model_ids)
def test_float_scalar(evaluations: Evaluations, system: System) -> None:
    """Scalar = float: the same program, loose agreement with the double results."""
    run = evaluations(system)
    states = run.case.states()
    single = run_driver(evaluations.models.program(system), system, "float", run.case, states)
    for k, (low, out) in enumerate(zip(single, run.at, strict=True)):
        here = where(system, run.case, k)
        for key in ("M", "bias", "gravity", "N", "T", "V", "D"):
            assert_close(low[key], out[key], FLOAT_RELATIVE, f"{here}: float {key}")
        cond = np.linalg.cond(out["M"])
        assert_close(low["qdd"], out["qdd"], FLOAT_RELATIVE * max(1.0, cond / 100), f"{here}: float θ̈")


def test_one_model_build_macros(evaluations: Evaluations, cpp_models: CppModels) -> None:
    """The driver's one-model form (IPGEN_HEADER + IPGEN_NAMESPACE) gives identical output."""
    system = System("rotary", 1, "full")
    program = cpp_models.build_alone(system)
    check_built(system, program)
    run = evaluations(system)
    alone = run_driver(program.executable, system, "double", run.case, run.case.states())
    for k, (single, grouped) in enumerate(zip(alone, run.at, strict=True)):
        for key, value in grouped.items():
            assert np.array_equal(single[key], value), (
                f"{where(system, run.case, k)}: {key} alone {single[key]} vs in a group {value}"
            )


JACOBIAN_STEP = 1e-6  # central differences of forward_dynamics, relative to each variable's scale
JACOBIAN_RELATIVE = 1e-6


@pytest.mark.parametrize("system", MODELS, ids=model_ids)
def test_forward_dynamics_derivatives_match_central_differences(
    evaluations: Evaluations, cpp_models: CppModels, system: System
) -> None:
    """∂θ̈/∂θ, ∂θ̈/∂θ̇, ∂θ̈/∂u of forward_dynamics_derivatives vs central differences of θ̈."""
    run = evaluations(system)
    dof, case = system.dof, run.case
    shifted: list[State] = []
    for k in range(STATES):
        q, qd, u = case.q[k], case.qd[k], float(case.u[k])
        for sign in (1.0, -1.0):
            h = sign * JACOBIAN_STEP
            shifted += [(q + h * np.eye(dof)[i], qd, u) for i in range(dof)]
            shifted += [(q, qd + h * np.eye(dof)[i], u) for i in range(dof)]
            shifted.append((q, qd, u + h))
    out = run_driver(cpp_models.program(system), system, "double", case, shifted)
    per_sign = 2 * dof + 1
    for k in range(STATES):
        ahead = out[2 * per_sign * k : 2 * per_sign * k + per_sign]
        behind = out[2 * per_sign * k + per_sign : 2 * per_sign * (k + 1)]
        columns = [(a["qdd"] - b["qdd"]) / (2 * JACOBIAN_STEP) for a, b in zip(ahead, behind, strict=True)]
        here = where(system, case, k)
        exact = run.at[k]
        by_q = np.column_stack(columns[:dof])
        by_qd = np.column_stack(columns[dof : 2 * dof])
        assert_close(exact["dqdd_dq"], by_q, JACOBIAN_RELATIVE, f"{here}: ∂θ̈/∂θ")
        assert_close(exact["dqdd_dqd"], by_qd, JACOBIAN_RELATIVE, f"{here}: ∂θ̈/∂θ̇")
        assert_close(exact["dqdd_du"], columns[-1], JACOBIAN_RELATIVE, f"{here}: ∂θ̈/∂u")
