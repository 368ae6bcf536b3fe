"""Bad arguments to `ipgen.mpc` and its step: each is one line (`MpcError`, a `ControlError`), never
a numpy or ctypes traceback, a crash, a huge allocation or a controller that silently never steps;
what is accepted steps. The combinations the C step refuses (frozen or shifted sensitivities
with the exact Hessian; travel with a bound on the base) are refused when the MPC is built."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import ipgen
from ipgen.control.linear import ControlError
from ipgen.control.mpc import MpcError

QUBE = ipgen.Pendulum.preset("qube_servo2")
X = [0.1, 0.05, 0.0, 0.0]
ARGUMENTS = (
    "horizon", "period", "Q", "R", "P", "u_max", "u_min", "travel", "bounds", "soft_bounds", "soft_penalty",
    "reference", "substeps", "sqp_iterations", "qp_iterations", "cold_iterations", "sqp_tolerance",
    "qp_tolerance", "barrier", "mode", "precision", "hessian", "sensitivities",
)  # fmt: skip
ODD = st.one_of(
    st.booleans(), st.text(max_size=4),
    st.sampled_from([math.nan, math.inf, -math.inf, 2**40, 2**31, 1.5, 1j]),
    st.floats(-1e3, -1e-9), st.lists(st.one_of(st.floats(allow_nan=True), st.text(max_size=2)), max_size=3),
    st.dictionaries(st.one_of(st.integers(-2, 9), st.text(max_size=2)), st.floats(), max_size=2),
    st.lists(st.lists(st.floats(-1, 1), max_size=3), max_size=2), st.just(np.int64(3)), st.just(1e300),
)  # fmt: skip


@settings(max_examples=150, deadline=None)
@given(name=st.sampled_from(ARGUMENTS), value=ODD)
def test_any_argument_is_taken_and_steps_or_is_one_line(name: str, value: object) -> None:
    """An argument of any type or value: refused in one line, or taken and the MPC steps to a
    finite input within its bounds."""
    try:
        controller = ipgen.mpc(QUBE, **({"u_max": 10.0} | {name: value}))
    except ControlError as error:
        assert "\n" not in str(error) and len(str(error)) < 400, str(error)
        return
    u = controller.step(X)
    assert math.isfinite(u) and controller.u_min - 1e-9 <= u <= controller.u_max + 1e-9


@pytest.mark.parametrize(
    ("kwargs", "words"),
    [
        ({"sensitivities": "frozen", "hessian": "exact"}, "hessian 'exact'"),
        ({"sensitivities": "shifted", "hessian": "exact"}, "hessian 'exact'"),
        ({"travel": 1.0, "bounds": {0: (-0.5, 0.5)}}, "travel and bounds[0]"),
        ({"soft_bounds": {0: (-0.9, 0.9)}, "soft_penalty": (1e12, 1.0)}, "soft_penalty"),
        ({"P": [1.0, 2.0, 3.0]}, "P "),
        ({"horizon": 1001}, "horizon"),
        ({"horizon": np.int64(30)}, None),  # numpy's integers are integers
        ({"bounds": {np.int64(1): (-1.0, 1.0)}}, None),
    ],
)
def test_combinations_the_step_cannot_take_are_refused(kwargs: dict, words: str | None) -> None:
    """Frozen or shifted sensitivities with the exact Hessian (the C step answered "bad settings" at
    every sample), travel with a bound on the base (travel replaced it), a soft penalty the QP
    breaks down at, P's errors naming P, a horizon above a scene's 1000: one line each; numpy's
    integers are taken as integers."""
    if words is None:
        assert math.isfinite(ipgen.mpc(QUBE, u_max=10.0, **kwargs).step(X))
        return
    with pytest.raises(MpcError, match=None) as refused:
        ipgen.mpc(QUBE, u_max=10.0, **kwargs)
    assert words in str(refused.value) and "\n" not in str(refused.value)


@pytest.mark.parametrize(
    "x", [[math.nan, 0, 0, 0], [0, 0, math.inf, 0], [[0.1, 0.0], [0.0, 0.0]], ["a", 0, 0, 0]]
)
def test_a_bad_state_is_one_line(x: object) -> None:
    """A non-finite, non-numeric or matrix-shaped state: one line from step, solve and rk4 (a warm
    NaN step returned the warm start's input before)."""
    controller = ipgen.mpc(QUBE, u_max=10.0)
    controller.step(X)  # warm
    for call in (controller.step, controller.solve, lambda s: controller.rk4(s, 0.0)):
        with pytest.raises(MpcError) as refused:
            call(x)
        assert "\n" not in str(refused.value) and "x" in str(refused.value)


@pytest.mark.parametrize("entry", ["Q", "P", "x_ref", "u_max", "period", "hard_max"])
def test_the_c_check_refuses_a_non_finite_setting(entry: str) -> None:
    """ipgen_mpc_check (what a C caller runs once before its steps) refuses a setting that is not
    finite (it promised a finite period and bounds and checked neither: an infinite period passed
    and the step reported a model failure)."""
    import ctypes

    controller = ipgen.mpc(QUBE, u_max=10.0, travel=1.0)
    check = controller._lib.ipgen_mpc_check
    settings = controller._settings
    assert check(ctypes.byref(settings)) == 0
    if entry == "period":
        settings.period = math.inf
    else:
        array = controller._arrays[entry]
        array[0] = math.inf
    assert check(ctypes.byref(settings)) != 0


REST_ANGLES = st.integers(-3, 3).map(lambda k: k * math.pi)


@settings(max_examples=40, deadline=None)
@given(
    base=st.floats(-1.0, 1.0),
    link=st.one_of(REST_ANGLES, st.floats(-7.0, 7.0)),
    rate=st.one_of(st.just(0.0), st.floats(-5.0, 5.0)),
    full=st.booleans(),
)
def test_a_constant_reference_is_a_rest_or_one_line(
    base: float, link: float, rate: float, full: bool
) -> None:
    """A constant reference is a rest of the model with u_ref = 0 (the terminal LQR's point): the
    base anywhere, the link upright or hanging (a multiple of π), rates 0. Anything else is refused
    in one line naming the entry; a rest is taken."""
    reference = [base, link, 0.0, rate] if full else [base, link]
    rest = abs(math.remainder(link, math.pi)) <= 1e-9 and (rate == 0.0 or not full)
    try:
        controller = ipgen.mpc(QUBE, u_max=10.0, reference=reference)
    except MpcError as error:
        assert not rest, f"a rest refused: {error}"
        assert "\n" not in str(error) and "x_ref[" in str(error), str(error)
        return
    assert rest, f"{reference} is no rest and was taken"
    assert np.array_equal(controller.x_ref, np.array([base, link, 0.0, 0.0]))


def test_a_fixed_chains_reference_is_a_rest() -> None:
    """A fixed chain has no base: every angle of its reference is a link's."""
    acrobot = ipgen.FixedPendulum.preset("acrobot_swingup")
    assert ipgen.mpc(acrobot, u_max=5.0, reference=[math.pi, 0.0]).x_ref[0] == math.pi
    with pytest.raises(MpcError, match=r"x_ref\[0\] = 0.5"):
        ipgen.mpc(acrobot, u_max=5.0, reference=[0.5, 0.0])


@settings(max_examples=60, deadline=None)
@given(
    index=st.integers(0, 3),
    lo=st.floats(-3.0, 3.0),
    width=st.floats(0.01, 3.0),
    arm=st.floats(-3.0, 3.0),
)
def test_a_reference_outside_a_hard_bound_is_one_line(
    index: int, lo: float, width: float, arm: float
) -> None:
    """A hard bound that excludes the reference's state (before, the MPC was built and every QP
    near the reference was infeasible: a run drove the arm past its travel): refused in one line
    naming the state and the bound; a bound that holds it is taken and steps."""
    reference = [arm, 0.0]
    state = [arm, 0.0, 0.0, 0.0][index]
    bounds = {index: (lo, lo + width)}
    if lo <= state <= lo + width:
        assert math.isfinite(ipgen.mpc(QUBE, u_max=10.0, bounds=bounds, reference=reference).step(X))
        return
    with pytest.raises(MpcError) as refused:
        ipgen.mpc(QUBE, u_max=10.0, bounds=bounds, reference=reference)
    assert f"state {index} = " in str(refused.value) and "hard bound" in str(refused.value)
    assert "\n" not in str(refused.value)


@pytest.mark.parametrize(
    ("kwargs", "words"),
    [
        ({"travel": 1.0, "reference": [5.0, 0.0]}, "state 0 = 5 is outside its hard bound [-1, 1]"),
        ({"u_min": 5.0}, "exclude 0"),
        ({"u_min": -10.0, "u_max": -1.0}, "exclude 0"),
        ({"reference": "sideways"}, "reference 'sideways'"),
        ({"period": 1e6}, "beyond 1000 s"),
        ({"period": 1e-300}, "period 1e-300"),
    ],
)
def test_what_no_mpc_can_meet_is_an_mpc_error(kwargs: dict, words: str) -> None:
    """A reference outside the MPC's own bounds, u bounds without the rest's input 0, a word that is
    no reference (before a ControlError naming "equilibrium"), a prediction beyond 1000 s or a period
    below a microsecond (before, a Riccati message that named neither): an MpcError naming it."""
    with pytest.raises(MpcError) as refused:
        ipgen.mpc(QUBE, **({"u_max": 10.0} | kwargs))
    assert words in str(refused.value) and "\n" not in str(refused.value)


@pytest.mark.parametrize("reference", [(None, None), (1.0, 2.0), (None, [0.0] * 30)])
def test_a_plan_that_is_no_plan_is_named_as_given(reference: tuple) -> None:
    """step(x, reference=(None, None)) said "got () and ()"; now it shows what was passed."""
    controller = ipgen.mpc(QUBE, u_max=10.0)
    with pytest.raises(MpcError) as refused:
        controller.step(X, reference=reference)
    assert "a plan's 31 × 4 states" in str(refused.value) and "()" not in str(refused.value)
