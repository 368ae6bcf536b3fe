"""Bad swing-up input (hypothesis): every class ends in one line from an `ipgen.Error` subclass,
raised before any solve, naming the field and what to use instead; an infeasible plan names
what to relax."""

from __future__ import annotations

import math

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

pytest.importorskip("casadi")

from ipgen import Error
from ipgen.control.casadi_model import plant
from ipgen.control.energy import energy_swingup
from ipgen.control.swingup import trajectory_swingup
from ipgen.control.trajectory import PlanError, plan_swingup
from ipgen.control.tvlqr import track

SETTINGS = settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
RSIP = plant("rotary", 1, [0.5, 0.275], [0.6, 0.5], [0.3, 0.011458])
CDIP = plant("classical", 2, [0.3, 0.275, 0.275], [0.0, 0.5, 0.5], [0.3, 0.1, 0.1])

not_positive = st.one_of(
    st.floats(max_value=0.0, allow_nan=False),
    st.just(math.nan),
    st.just(math.inf),
    st.just(-math.inf),
    st.text(max_size=5),
    st.none(),
)


def one_line(error: Exception) -> str:
    message = str(error)
    assert isinstance(error, Error), type(error)
    assert message and "\n" not in message and "Traceback" not in message
    return message


@SETTINGS
@given(value=not_positive, field=st.sampled_from(["duration", "u_max", "x_max"]))
def test_bad_limits_and_duration_are_one_line_errors(value: object, field: str) -> None:
    arguments: dict[str, object] = {"duration": 2.0, "u_max": 5.0, "x_max": 1.0}
    if field == "x_max" and value is None:
        return  # no travel limit is allowed
    arguments[field] = value
    with pytest.raises(PlanError) as caught:
        plan_swingup(RSIP, **arguments)  # type: ignore[arg-type]
    assert field in one_line(caught.value)


@SETTINGS
@given(
    start=st.one_of(
        st.lists(st.floats(allow_nan=False, allow_infinity=False, width=32), max_size=8).filter(
            lambda v: len(v) != 4
        ),
        st.lists(st.sampled_from([math.nan, math.inf, 0.0]), min_size=4, max_size=4).filter(
            lambda v: any(not math.isfinite(x) for x in v)
        ),
    )
)
def test_bad_start_is_a_one_line_error(start: list[float]) -> None:
    with pytest.raises(PlanError) as caught:
        plan_swingup(RSIP, duration=2.0, u_max=5.0, start=start)
    assert "start" in one_line(caught.value)


@SETTINGS
@given(angle=st.floats(min_value=0.1, max_value=6.0), rate=st.floats(min_value=0.1, max_value=10))
def test_a_target_that_is_not_upright_at_rest_is_refused(angle: float, rate: float) -> None:
    for target in ([0.0, angle, 0.0, 0.0], [0.0, 0.0, 0.0, rate]):
        with pytest.raises(PlanError) as caught:
            plan_swingup(RSIP, duration=2.0, u_max=5.0, target=target)
        assert "target" in one_line(caught.value)


@SETTINGS
@given(start_base=st.floats(min_value=1.01, max_value=100.0))
def test_a_start_outside_the_travel_limit_is_refused(start_base: float) -> None:
    with pytest.raises(PlanError) as caught:
        plan_swingup(CDIP, duration=3.0, u_max=50.0, x_max=1.0, start=[start_base, math.pi, math.pi, 0, 0, 0])
    assert "x_max" in one_line(caught.value)


@SETTINGS
@given(intervals=st.one_of(st.integers(max_value=3), st.integers(min_value=2001), st.floats(), st.booleans()))
def test_bad_intervals_are_refused(intervals: object) -> None:
    with pytest.raises(PlanError) as caught:
        plan_swingup(RSIP, duration=2.0, u_max=5.0, intervals=intervals)  # type: ignore[arg-type]
    assert "intervals" in one_line(caught.value)


@pytest.fixture(scope="module")
def rsip_plan():
    return plan_swingup(RSIP, duration=2.0, u_max=5.0)


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(
    period=st.one_of(
        not_positive,
        st.floats(min_value=0.003, max_value=0.5).filter(lambda h: abs(2.0 / h - round(2.0 / h)) > 1e-3),
    )
)
def test_bad_period_is_refused(rsip_plan, period: object) -> None:
    with pytest.raises(PlanError) as caught:
        track(rsip_plan, period)  # type: ignore[arg-type]
    assert "period" in one_line(caught.value)


@SETTINGS
@given(margin=st.one_of(not_positive, st.floats(min_value=1.0001, max_value=1e6)))
def test_bad_margin_is_refused(margin: object) -> None:
    with pytest.raises(PlanError) as caught:
        trajectory_swingup(RSIP, duration=2.0, u_max=5.0, margin=margin)  # type: ignore[arg-type]
    assert "margin" in one_line(caught.value)


@SETTINGS
@given(value=not_positive, field=st.sampled_from(["u_max", "period", "catch_angle", "catch_rate"]))
def test_bad_energy_controller_input_is_refused(value: object, field: str) -> None:
    arguments: dict[str, object] = {"u_max": 5.0, field: value}
    with pytest.raises(PlanError) as caught:
        energy_swingup(RSIP, **arguments)  # type: ignore[arg-type]
    assert field in one_line(caught.value)


def test_energy_control_is_for_single_links() -> None:
    with pytest.raises(PlanError) as caught:
        energy_swingup(CDIP, u_max=20.0)
    assert "trajectory" in one_line(caught.value)


@SETTINGS
@given(
    mass=st.one_of(st.floats(max_value=0.0), st.just(math.nan)),
    index=st.integers(min_value=0, max_value=1),
)
def test_bad_plant_parameters_are_refused(mass: float, index: int) -> None:
    m = [0.5, 0.275]
    m[index] = mass
    with pytest.raises(Error) as caught:
        plant("rotary", 1, m, [0.6, 0.5], [0.3, 0.01])
    one_line(caught.value)


@pytest.mark.parametrize(
    ("system", "arguments", "names"),
    [
        (CDIP, {"duration": 1.0, "u_max": 0.5, "x_max": 0.2}, "relax u_max, x_max"),
        (RSIP, {"duration": 0.3, "u_max": 1.0}, "relax u_max or"),
    ],
)
def test_an_infeasible_plan_names_what_to_relax(system, arguments: dict, names: str) -> None:
    with pytest.raises(PlanError) as caught:
        plan_swingup(system, **arguments)
    message = one_line(caught.value)
    assert "no swing-up plan found" in message and names in message and "duration" in message
