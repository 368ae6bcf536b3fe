"""ipgen.mpc and cpp/include/ipgen_mpc.h: the constrained nonlinear MPC (docs/mpc.md).

- Converged mode against CasADi + IPOPT on the same optimal-control problem (tests/mpc_reference.py:
  the same RK4 discretisation built independently from the exact model's CasADi expressions,
  the same weights, terminal weight and bounds), first input within 1e-6 at 20 seeded random
  states, for the QUBE-Servo 2 preset (rotary1, DC motor, ±10 V, arm travel ±1 rad), the same
  with soft state bounds, and the cart double pendulum (classical2, rail ±1 m, ±10 N), with the
  exact Hessian and with Gauss-Newton's; the bounds must be active (the soft ones violated) in
  some of them.
- A reference per stage (ipgen_mpc_track, a plan to track) in the converged mode against IPOPT
  with the same reference, from states off a plan, both started from the plan's rows; a bad
  reference (any shape or value) is a step or one line.
- The RK4 sensitivities of the C code against CasADi's Jacobians of the same RK4 and central
  differences of the C map.
- The real-time iteration in closed loop with the exact model integrated by scipy (solve_ivp):
  |u| within its bound at every sample, the base within its travel (up to RTI_TRAVEL: the
  linearisation error of one iteration), upright at the end from a tilted start.
- The header compiles without a warning as C99 (double and float) and as C++17.
- Float against double along a closed loop: within FLOAT_INPUT (stated in docs/mpc.md).
"""

from __future__ import annotations

import ctypes
import subprocess
from collections.abc import Callable
from functools import cache
from pathlib import Path

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st
from mpc_reference import IpoptReference, flow

import ipgen
from ipgen.control.linear import vector_field
from ipgen.control.mpc import LAYOUT_ENTRIES, Mpc, MpcError, library, mpc

pytest.importorskip("casadi")

ROOT = Path(__file__).resolve().parent.parent
INCLUDE = ROOT / "cpp" / "include"
AGREEMENT = 1e-6  # the first input, converged mode against IPOPT [V or N]
RTI_TRAVEL = 1e-5  # how far past its bound the base may be at a sample under RTI [rad or m]
FLOAT_INPUT = 1e-3  # |u_float - u_double| along a closed loop, relative to u_max


def qube(**options: object) -> Mpc:
    """The QUBE-Servo 2 preset: u in volts (the motor folded in), ±10 V, the arm within ±1 rad."""
    p = ipgen.Pendulum.preset("qube_servo2")
    return mpc(p, u_max=10.0, travel=1.0, Q=[1, 10, 0.1, 0.1], R=0.1, **options)  # type: ignore[arg-type]


@cache
def cdip_pendulum() -> ipgen.Pendulum:
    """The pendulum of scenes/cdip_swingup.toml, read once per process: loading the scene designs
    its swing-up plan (about 0.5 s), which the MPCs below do not use; a Pendulum is frozen."""
    return ipgen.Pendulum.from_scene(ROOT / "scenes" / "cdip_swingup.toml")


def cdip(**options: object) -> Mpc:
    """The cart double pendulum of scenes/cdip_swingup.toml: rail ±1 m, ±10 N, 20 ms samples."""
    p = cdip_pendulum()
    return mpc(
        p, u_max=10.0, travel=1.0, period=0.02, substeps=2, Q=[1, 10, 10, 0.1, 0.1, 0.1], R=1.0,
        **options,  # type: ignore[arg-type]
    )  # fmt: skip


def cdip_fast(**options: object) -> Mpc:
    """The cart double pendulum with ±20 N and a heavier weight on the state: what the real-time
    iteration holds from a start far along the rail (±10 N and cdip's weights lose the links
    there: the basin of a bounded force is small on this chain, docs/control.md)."""
    p = cdip_pendulum()
    return mpc(
        p, u_max=20.0, travel=1.0, period=0.02, substeps=2, Q=[10, 10, 10, 0.1, 0.1, 0.1], R=0.1,
        **options,  # type: ignore[arg-type]
    )  # fmt: skip


# (controller, lower and upper corner of the random states)
def qube_soft(**options: object) -> Mpc:
    """The QUBE with soft bounds besides the hard ones: the arm beyond ±0.7 rad and the link's rate
    beyond ±8 rad/s cost s + 100 s²."""
    return qube(soft_bounds={0: (-0.7, 0.7), 3: (-8.0, 8.0)}, soft_penalty=(1.0, 100.0), **options)


CASES = {
    "qube": (qube, [-0.9, -0.3, -1, -1], [0.9, 0.3, 1, 1]),
    "qube-soft": (qube_soft, [-0.9, -0.3, -1, -1], [0.9, 0.3, 1, 1]),
    "cdip": (cdip, [-0.6, -0.02, -0.02, -0.3, -0.1, -0.1], [0.6, 0.02, 0.02, 0.3, 0.1, 0.1]),
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_the_converged_mode_equals_ipopt(case: str) -> None:
    make, lo, hi = CASES[case]
    # the exact Hessian by default; 200 SQP iterations: the few states that reach the budget
    # (docs/mpc.md) have their first input right long before
    controller = make(mode="converged", sqp_iterations=200)
    gauss_newton = make(mode="converged", hessian="gauss-newton", sqp_iterations=200)
    reference = IpoptReference(controller)
    rng = np.random.default_rng(47)
    u_active = travel_active = soft_violated = 0
    for _ in range(20):
        x = rng.uniform(lo, hi)
        u = controller.solve(x)
        # "SQP budget reached": Gauss-Newton's linear rate at a degenerate active set (docs/mpc.md)
        assert controller.info is not None and controller.info.status in ("ok", "SQP budget reached"), x
        u_ref, inputs = reference.solve(x)
        assert abs(u - u_ref) <= AGREEMENT, (x, u, u_ref)
        if controller.info.status == "ok":  # converged: the C cost of the solution is IPOPT's optimum
            assert abs(controller.cost() - reference.objective) <= 1e-8 * max(1.0, reference.objective)
        if not controller.soft:  # Gauss-Newton's Hessian too (the soft case: the exact one only)
            assert abs(gauss_newton.solve(x) - u_ref) <= AGREEMENT, (x, gauss_newton.info)
        states = reference.states
        u_active += bool(np.any(np.abs(inputs) > controller.u_max - 1e-6))
        travel_active += bool(np.max(np.abs(states[0])) > 1.0 - 1e-6)
        soft_violated += any(np.any(np.abs(states[i, 1:]) > hi + 1e-6) for i, _, hi in controller.soft)
    assert u_active >= 3 and travel_active >= 1, (u_active, travel_active)  # the bounds were exercised
    assert soft_violated >= 3 if controller.soft else soft_violated == 0, soft_violated


def rollout(controller: Mpc, x0: np.ndarray, inputs: np.ndarray) -> np.ndarray:
    """The states x_0..x_N of the controller's own RK4 map from x0 under `inputs` (a plan's)."""
    states = [np.asarray(x0, float)]
    for u in inputs:
        states.append(controller.rk4(states[-1], float(u))[0])
    return np.array(states)


@pytest.mark.parametrize("case", ["qube", "cdip"])
def test_tracking_a_reference_per_stage_equals_ipopt(case: str) -> None:
    """ipgen_mpc_track: the reference a plan gives (x_ref_k, u_ref_k per stage) in the converged
    mode against IPOPT with the same reference, from states off the plan; the bounds active."""
    make, lo, hi = CASES[case]
    controller = make(mode="converged", sqp_iterations=200)
    reference = IpoptReference(controller)
    rng = np.random.default_rng(4747)
    N, u_max = controller.N, controller.u_max
    u_active = 0
    for _ in range(6):
        times = np.arange(N) * controller.period
        plan_x = np.full((N + 1, controller.nx), np.inf)
        while np.max(np.abs(plan_x[:, 0])) > 0.9:  # a plan within the base's travel, as planned ones are
            start = rng.uniform(lo, hi) / 2
            phase = rng.uniform(0, 2 * np.pi)
            plan_u = u_max * 0.98 * np.sin(2 * np.pi * times / (N * controller.period) + phase)
            plan_x = rollout(controller, start, plan_u)
        x = plan_x[0] + rng.uniform(lo, hi) / 2  # off the plan (near it: one local minimum)
        x[0] = np.clip(x[0], -0.95, 0.95)  # the base within its travel
        u = controller.solve(x, (plan_x, plan_u))
        assert controller.info is not None and controller.info.status in ("ok", "SQP budget reached"), x
        u_ipopt, inputs = reference.solve(x, (plan_x, plan_u))
        assert abs(u - u_ipopt) <= AGREEMENT, (x, u, u_ipopt)
        if controller.info.status == "ok":
            scale = max(1.0, reference.objective)
            assert abs(controller.cost((plan_x, plan_u)) - reference.objective) <= 1e-8 * scale
        u_active += bool(np.any(np.abs(inputs) > u_max - 1e-6))
        # the constant reference's solution differs: the reference per stage was used
        assert abs(controller.solve(x) - u) > 1e-3
    assert u_active >= 1, u_active  # the input bound mattered


# The QUBE design's N = 30 and nx = 4: the shapes a reference's states and inputs may have (None:
# absent), right ((31, 4), (124,); (30,), (30, 1)) and wrong (transposed, one short, one more axis).
REFERENCE_SHAPES = st.sampled_from(
    [None, (), (31, 4), (124,), (4, 31), (30, 4), (30,), (30, 1), (31,), (1, 30)]
)
REFERENCE_VALUES = st.sampled_from([0.0, 1.0, -2.5, np.nan, np.inf, -np.inf, "abc"])


@settings(max_examples=80, deadline=None)
@given(REFERENCE_SHAPES, REFERENCE_SHAPES, REFERENCE_VALUES, REFERENCE_VALUES, st.booleans())
@example((31, 4), (30,), 0.5, 1.0, True)  # a plan's rows: a step
@example((124,), (30, 1), 0.5, 1.0, True)  # flat: a step
@example((4, 31), (30,), 0.5, 1.0, True)  # transposed: refused
@example((31, 4), (30,), 0.5, np.nan, True)  # not finite: refused
def test_any_reference_steps_or_is_refused_in_one_line(
    states: tuple[int, ...] | None,
    inputs: tuple[int, ...] | None,
    x_value: object,
    u_value: object,
    pair: bool,
) -> None:
    """A reference per stage of any shape and value (or not a pair at all): a step within the
    input's bounds when it is N+1 rows of nx states (or their nx (N+1) entries, row by row) and
    N finite inputs (or N × 1), or None; else one line naming the reference."""
    controller = _refusals_qube()
    N, nx = controller.N, controller.nx
    assert (N, nx) == (30, 4)  # REFERENCE_SHAPES' sizes

    def array(shape: tuple[int, ...] | None, value: object) -> object:
        return None if shape is None else np.full(shape, value, dtype=object)

    xs, us = array(states, x_value), array(inputs, u_value)
    reference = (xs, us) if pair else xs
    numbers = all(isinstance(v, float) and np.isfinite(v) for v in (x_value, u_value))
    good = reference is None or (  # None: the constant reference
        pair and states in ((31, 4), (124,)) and inputs in ((30,), (30, 1)) and numbers
    )
    try:
        u = controller.step(np.zeros(nx), reference)
    except MpcError as caught:
        assert not good, caught
        assert "\n" not in str(caught) and "reference" in str(caught), caught
        return
    assert good and -controller.u_max <= u <= controller.u_max


_QUBE: list[Mpc] = []


def _refusals_qube() -> Mpc:
    """One QUBE design shared by the examples above (building it once per example would be slow)."""
    if not _QUBE:
        _QUBE.append(qube())
    return _QUBE[0]


@pytest.mark.parametrize("case", sorted(CASES))
def test_the_rk4_sensitivities_equal_casadi_and_differences(case: str) -> None:
    import casadi as ca

    controller = CASES[case][0]()
    F = flow(controller)
    x_sym, u_sym = ca.SX.sym("x", controller.nx), ca.SX.sym("u")
    image = F(x_sym, u_sym)
    jacobians = ca.Function(
        "J", [x_sym, u_sym], [image, ca.jacobian(image, x_sym), ca.jacobian(image, u_sym)]
    )
    rng = np.random.default_rng(3)
    for _ in range(5):
        x, u = rng.uniform(-1, 1, controller.nx), float(rng.uniform(-5, 5))
        xn, a, b = controller.rk4(x, u)
        xn_ref, a_ref, b_ref = (np.asarray(v, float) for v in jacobians(x, u))
        scale = max(1.0, np.abs(a_ref).max())
        assert np.abs(xn - xn_ref.reshape(-1)).max() <= 1e-13 * scale
        assert np.abs(a - a_ref).max() <= 1e-13 * scale
        assert np.abs(b - b_ref).max() <= 1e-13 * max(1.0, np.abs(b_ref).max())
        h = 1e-6  # central differences of the C map itself
        columns = [
            (controller.rk4(x + h * e, u)[0] - controller.rk4(x - h * e, u)[0]) / (2 * h)
            for e in np.eye(controller.nx)
        ]
        assert np.abs(np.array(columns).T - a).max() <= 1e-7 * scale
        du = (controller.rk4(x, u + h)[0] - controller.rk4(x, u - h)[0]) / (2 * h)
        assert np.abs(du - b[:, 0]).max() <= 1e-7 * max(1.0, np.abs(b).max())


def closed_loop(controllers: list[Mpc], x0: list[float], seconds: float) -> tuple[np.ndarray, np.ndarray]:
    """The first controller's RTI loop on the exact model (scipy's solve_ivp between samples, u
    held), ipgen's coordinates; the others see the same states. Returns the states at the
    samples and the inputs (samples × controllers)."""
    from scipy.integrate import solve_ivp

    lead = controllers[0]
    field = vector_field(lead.pendulum.replace(positive="clockwise"))  # the C model's coordinates
    x = np.asarray(x0, dtype=float)
    states, inputs = [x], []
    for _ in range(round(seconds / lead.period)):
        u = [c.step(x) for c in controllers]
        inputs.append(u)
        drive = u[0]
        step = solve_ivp(
            lambda _, s, v=drive: field.f(s, v), (0.0, lead.period), x, "DOP853", rtol=1e-10, atol=1e-12
        )
        x = step.y[:, -1]
        states.append(x)
    return np.array(states), np.array(inputs)


@pytest.mark.parametrize(
    ("make", "x0", "reaches"),
    [
        (qube, [0.5, 0.15, 1.0, 0.0], ("u", "travel")),
        (cdip_fast, [0.5, 0.02, -0.02, 0.3, 0.0, 0.0], ("u",)),
        (cdip_fast, [0.7, 0.0, 0.0, 0.4, 0.0, 0.0], ("travel",)),
    ],
    ids=["qube", "cdip-force", "cdip-rail"],
)
def test_the_real_time_iteration_keeps_the_bounds_and_stabilises(
    make: Callable[..., Mpc], x0: list[float], reaches: tuple[str, ...]
) -> None:
    controller = make()
    states, inputs = closed_loop([controller], x0, 3.0)
    assert np.all(np.abs(inputs) <= controller.u_max)
    assert np.max(np.abs(states[:, 0])) <= 1.0 + RTI_TRAVEL
    if "u" in reaches:  # the bounds were reached, so they mattered
        assert np.max(np.abs(inputs)) >= controller.u_max - 1e-6
    if "travel" in reaches:
        assert np.max(np.abs(states[:, 0])) >= 1.0 - 1e-3
    assert np.max(np.abs(states[-1])) <= 5e-2, states[-1]  # upright, near rest


def test_float_follows_double_along_a_closed_loop() -> None:
    double, single = qube(), qube(precision="float")
    _, inputs = closed_loop([double, single], [0.5, 0.15, 1.0, 0.0], 2.0)  # both bounds reached
    assert np.max(np.abs(inputs[:, 1] - inputs[:, 0])) <= FLOAT_INPUT * double.u_max


DRIVER = r"""
#include <stdio.h>
#include "ipgen_mpc.h"
/* A double integrator x' = (v, u): enough to instantiate every function of the header. */
static int model(void *context, const ipgen_mpc_real x[], const ipgen_mpc_real u[], ipgen_mpc_real f[],
                 ipgen_mpc_real A[], ipgen_mpc_real B[]) {
  (void)context;
  f[0] = x[1];
  f[1] = u[0];
  if (A != 0 && B != 0) {
    A[0] = (ipgen_mpc_real)0; A[1] = (ipgen_mpc_real)1; A[2] = (ipgen_mpc_real)0; A[3] = (ipgen_mpc_real)0;
    B[0] = (ipgen_mpc_real)0; B[1] = (ipgen_mpc_real)1;
  }
  return 0;
}
#define HORIZON 20
int main(void) {
  static ipgen_mpc_real work[IPGEN_MPC_WORK(2, 1, HORIZON, 1, 1) + IPGEN_MPC_WORK_HESSIAN(2, 1, HORIZON)];
  const ipgen_mpc_real Q[4] = {1, 0, 0, 1}, R[1] = {1}, x_ref[2] = {0, 0}, u_ref[1] = {0};
  const ipgen_mpc_real u_min[1] = {-1}, u_max[1] = {1}, lo[1] = {-2}, hi[1] = {2};
  const ipgen_mpc_real v_lo[1] = {-1}, v_hi[1] = {1};
  const ipgen_mpc_real linear[1] = {0}, quadratic[1] = {100};
  const int position[1] = {0}, speed[1] = {1};
  ipgen_mpc_settings s;
  ipgen_mpc_info info;
  ipgen_mpc_real x[2] = {1.5, 0.5}, u[1];
  int k;
  s.nx = 2; s.nu = 1; s.N = HORIZON; s.period = (ipgen_mpc_real)0.1; s.substeps = 1;
  s.dynamics = model; s.context = 0;
  s.Q = Q; s.R = R; s.P = Q; s.x_ref = x_ref; s.u_ref = u_ref; s.u_min = u_min; s.u_max = u_max;
  s.hard_count = 1; s.hard_index = position; s.hard_min = lo; s.hard_max = hi;
  s.soft_count = 1; s.soft_index = speed; s.soft_min = v_lo; s.soft_max = v_hi; s.soft_linear = linear;
  s.soft_quadratic = quadratic; s.sqp_iterations = 1; s.sqp_tolerance = 0; s.qp_iterations = 20;
  s.qp_tolerance = (ipgen_mpc_real)1e-6; s.shift = 1; s.line_search = 0; s.cold_iterations = 5;
  s.exact_hessian = 1; /* used by the cold start's iterations 2..5 */
  if (ipgen_mpc_work_size(&s) != (long)(sizeof work / sizeof work[0])) return 2;
  ipgen_mpc_reset(work);
  for (k = 0; k < 150; ++k) {
    if (ipgen_mpc_step(&s, x, u, work, &info) != IPGEN_MPC_OK) return 3;
    if (u[0] < u_min[0] || u[0] > u_max[0]) return 4;
    x[0] += (ipgen_mpc_real)0.1 * x[1] + (ipgen_mpc_real)0.005 * u[0];
    x[1] += (ipgen_mpc_real)0.1 * u[0];
  }
  printf("%g %g %g\n", (double)x[0], (double)x[1], (double)ipgen_mpc_cost(&s, work));
  return 0;
}
"""

COMPILERS = {
    "c99-double": ["gcc", "-std=c99", "-x", "c"],
    "c99-float": [
        "gcc",
        "-std=c99",
        "-DIPGEN_MPC_REAL=float",
        "-Wdouble-promotion",
        "-Wconversion",
        "-x",
        "c",
    ],
    "c++17": ["g++", "-std=c++17", "-x", "c++"],
}


@pytest.mark.parametrize("variant", sorted(COMPILERS))
def test_the_header_compiles_without_warnings_and_runs(tmp_path: Path, variant: str) -> None:
    """C99 in double and float and C++17, -Wall -Wextra -Wpedantic -Werror; the toy loop's
    ipgen_mpc_step keeps u within its bound and brings the double integrator to rest."""
    source = tmp_path / "driver.txt"
    source.write_text(DRIVER)
    program = tmp_path / "driver"
    command = [*COMPILERS[variant], "-O1", "-Wall", "-Wextra", "-Wpedantic", "-Werror", f"-I{INCLUDE}"]
    done = subprocess.run([*command, str(source), "-o", str(program), "-lm"], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    ran = subprocess.run([str(program)], capture_output=True, text=True, timeout=60)
    assert ran.returncode == 0, ran.returncode
    position, speed, _ = (float(v) for v in ran.stdout.split())
    assert abs(position) < 1e-2 and abs(speed) < 1e-2


LOOP = ROOT / "tests" / "c" / "mpc_qube_loop.c"


def c_loop(controller: Mpc, x0: list[float], scalar: str, folder: Path) -> tuple[np.ndarray, float]:
    """tests/c/mpc_qube_loop.c on the QUBE's generated C header (`--emit c`) in `scalar`: the
    closed loop's rows (x_k, u_k, status) and the mean time of a C step [s]."""
    from ipgen.pipeline.generate import generate

    p = controller.pendulum
    if not (folder / "qube.h").exists():
        generate(p.system, "qube", folder, force=True, emit=("c",))
    flags = ["-DIPGEN_SCALAR=float", "-DIPGEN_MPC_REAL=float", "-Wdouble-promotion", "-Wconversion"]
    program = folder / f"loop_{scalar}"
    command = [
        "gcc",
        "-std=c99",
        "-O2",
        "-Wall",
        "-Wextra",
        "-Wpedantic",
        "-Werror",
        *(flags if scalar == "float" else []),
    ]
    done = subprocess.run(
        [*command, f"-I{folder}", f"-I{INCLUDE}", str(LOOP), "-o", str(program), "-lm"],
        capture_output=True,
        text=True,
    )
    assert done.returncode == 0, done.stderr
    v = p.folded().params()
    design = [
        *controller.Q.ravel(),
        controller.R[0, 0],
        *controller.P.ravel(),
        controller.u_max,
        1.0,
        controller.period,
    ]
    numbers = [
        *v["m"],
        *v["l"],
        *v["delta"],
        v["g"],
        *v["com"],
        *v["J"],
        *v["J_axial"],
        *v["tip"],
        p.gain,
        *design,
        *x0,
    ]
    text = " ".join(repr(float(n)) for n in numbers)  # type: ignore[arg-type]
    ran = subprocess.run([str(program)], input=text, capture_output=True, text=True, timeout=120)
    assert ran.returncode == 0, ran.returncode
    lines = ran.stdout.split("\n")
    rows = np.array([[float(t) for t in line.split()] for line in lines[:-2]])
    return rows, float(lines[-2]) * 1e-9


@pytest.mark.parametrize("scalar", ["double", "float"])
def test_the_c_header_loop_equals_the_python_step(tmp_path: Path, scalar: str) -> None:
    """The step as a firmware runs it (the generated C header's model, static memory, IPGEN_SCALAR =
    IPGEN_MPC_REAL) in a closed loop, against ipgen.mpc's step fed the same states: equal to 1e-9
    of u_max in double, within FLOAT_INPUT in float (the model in float too)."""
    rows, _ = c_loop(qube(), [0.5, 0.15, 1.0, 0.0], scalar, tmp_path)
    python = qube()
    inputs = np.array([python.step(x) for x in rows[:, :4]])
    assert np.all(rows[:, 5] == 0)  # IPGEN_MPC_OK at every sample
    bound = 1e-9 if scalar == "double" else FLOAT_INPUT
    assert np.max(np.abs(inputs - rows[:, 4])) <= bound * python.u_max
    assert np.max(np.abs(rows[:, 4])) >= python.u_max - 1e-3  # the bound was reached
    assert np.max(np.abs(rows[-1, :4])) <= 0.2  # on its way to upright and rest (1.5 s)


def test_the_workspace_is_what_the_macro_says_and_the_layout_matches() -> None:
    controller = cdip()
    lib = library("double")
    parts = ctypes.create_string_buffer(64 * ctypes.sizeof(ctypes.c_void_p))  # ipgen_mpc_layout's pointers
    used = lib.ipgen_mpc_carve(ctypes.byref(controller._settings), controller.work.ctypes.data, parts)
    assert used == controller.work.size
    written = (ctypes.c_long * LAYOUT_ENTRIES)()
    assert lib.ipgen_mpc_model_layout(ctypes.addressof(written)) == LAYOUT_ENTRIES


def test_bad_designs_are_refused_in_one_line() -> None:
    p = ipgen.Pendulum.preset("qube_servo2")
    for options, words in (
        ({"u_max": 10.0, "horizon": 0}, "horizon"),
        ({"u_max": 10.0, "u_min": 11.0}, "u bounds"),
        ({"u_max": 10.0, "bounds": {7: (-1, 1)}}, "state index"),
        ({"u_max": 10.0, "soft_bounds": {0: (1, -1)}}, "soft_bounds"),
        ({"u_max": 10.0, "mode": "fast"}, "mode"),
        ({"u_max": 10.0, "travel": -1.0}, "travel"),
    ):
        with pytest.raises(MpcError, match=words):
            mpc(p, **options)  # type: ignore[arg-type]


def test_an_infeasible_hard_bound_is_reported_and_a_soft_one_is_not() -> None:
    """The arm already past its hard travel: no prediction meets the bound, the QP diverges and the
    step says so (keeping its guess, u within its bound); the same travel as a soft bound with a
    large linear penalty (exact while feasible) solves, and brings the arm back."""
    x = [1.05, 0.0, 0.0, 0.0]
    hard = qube()
    u = hard.step(x)
    assert hard.info is not None and hard.info.status == "QP infeasible"
    assert abs(u) <= hard.u_max
    p = ipgen.Pendulum.preset("qube_servo2")
    soft = mpc(
        p, u_max=10.0, soft_bounds={0: (-1.0, 1.0)}, soft_penalty=(1e3, 1.0), Q=[1, 10, 0.1, 0.1], R=0.1
    )
    u = soft.step(x)
    assert soft.info is not None and soft.info.status == "ok"
    assert u < 0  # toward the bound's inside


def test_the_example_of_docs_mpc_runs() -> None:
    """docs/mpc.md's Python example, as written."""
    import re

    text = (ROOT / "docs" / "mpc.md").read_text()
    example = re.search(r"```python\n(.*?)```", text, re.S)
    assert example is not None
    namespace: dict[str, object] = {}
    exec(compile(example.group(1), "docs/mpc.md", "exec"), namespace)  # the docs' own code
    assert abs(float(namespace["u"])) <= 10.0  # type: ignore[arg-type]
