"""Bad arguments to ipgen.kalman, the sensors and the estimator designs: each class of bad input
(non-finite or non-positive periods, negative or NaN resolutions and noise, covariances of the
wrong shape, asymmetric, indefinite or NaN, bad measured indices, kinds, cutoffs) is one
`EstimationError` (an `ipgen.Error`) with a one-line message, never another exception."""

from __future__ import annotations

import math

import numpy as np
import pytest
from estimation_cases import RSIP
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import ipgen
from ipgen.estimation import EstimationError, Sensors, design

SETTINGS = settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
BAD_NUMBERS = st.sampled_from([math.nan, math.inf, -math.inf, -1.0, -1e-300, 0.0])


def _one_line(exc: BaseException) -> None:
    message = str(exc)
    assert isinstance(exc, ipgen.Error)
    assert message and "\n" not in message and len(message) < 300, message


@SETTINGS
@given(period=st.one_of(BAD_NUMBERS, st.just("1ms"), st.none()))
def test_bad_period(period) -> None:
    with pytest.raises(EstimationError) as info:
        ipgen.kalman(RSIP, period, 1e-6, 1e-6)
    _one_line(info.value)


@SETTINGS
@given(
    resolution=st.one_of(
        BAD_NUMBERS.filter(lambda v: v != 0.0), st.just("2048"), st.lists(st.just(10.0), max_size=1)
    ),
)
def test_bad_resolution(resolution) -> None:
    with pytest.raises(EstimationError) as info:
        Sensors.of(2, None, resolution)
    _one_line(info.value)


@SETTINGS
@given(
    noise=st.one_of(BAD_NUMBERS.filter(lambda v: v != 0.0), st.lists(st.just(0.1), min_size=3, max_size=4))
)
def test_bad_noise(noise) -> None:
    with pytest.raises(EstimationError) as info:
        Sensors.of(2, [0, 1], 2048, noise)
    _one_line(info.value)


@SETTINGS
@given(
    measured=st.one_of(
        st.just([]), st.just([1, 0]), st.just([0, 0]), st.just([2]), st.just([-1]), st.just([True])
    )
)
def test_bad_measured(measured) -> None:
    with pytest.raises(EstimationError) as info:
        ipgen.kalman(RSIP, 1e-3, 1e-6, 1e-6, measured=measured)
    _one_line(info.value)


def _bad_covariances(size: int) -> st.SearchStrategy:
    asymmetric = np.eye(size)
    asymmetric[0, 1] = 1.0
    indefinite = np.eye(size)
    indefinite[0, 0] = -1.0
    nan = np.eye(size)
    nan[1, 1] = math.nan
    return st.sampled_from(
        [
            np.eye(size + 1),
            np.ones(size + 1),
            asymmetric,
            indefinite,
            nan,
            "big",
            [[1.0, 2.0]],
            -1.0,
            math.nan,
        ]
    )


@SETTINGS
@given(qn=_bad_covariances(4))
def test_bad_process_noise(qn) -> None:
    with pytest.raises(EstimationError) as info:
        ipgen.kalman(RSIP, 1e-3, qn, 1e-6)
    _one_line(info.value)


@SETTINGS
@given(rn=st.one_of(_bad_covariances(2), st.just(0.0), st.just(np.zeros((2, 2)))))
def test_bad_measurement_noise(rn) -> None:
    with pytest.raises(EstimationError) as info:
        ipgen.kalman(RSIP, 1e-3, 1e-6, rn)
    _one_line(info.value)


@SETTINGS
@given(
    case=st.sampled_from(
        [
            {"kind": "particle"},
            {"kind": "filter", "cutoff": 0.0},
            {"kind": "filter", "cutoff": math.nan},
            {"kind": "kalman", "cutoff": 50.0},
            {"kind": "difference", "process_noise": 1.0},
            {"kind": "filter", "measured": [1]},
            {"kind": "ekf", "measurement_noise": -1.0},
            {"kind": "kalman", "equilibrium": [0.0, 0.5]},
            {"kind": "kalman", "equilibrium": "sideways"},
        ]
    )
)
def test_bad_designs(case) -> None:
    case = dict(case)
    sensors = Sensors.of(2, case.pop("measured", None), 2048)
    kind = case.pop("kind")
    with pytest.raises(EstimationError) as info:
        design(RSIP, kind, 1e-3, sensors, **case)
    _one_line(info.value)


@SETTINGS
@given(
    pendulum=st.sampled_from(
        [{**RSIP, "m": [0.5]}, {**RSIP, "mass": 1}, {**RSIP, "type": "gantry"}, [1, 2], None]
    )
)
def test_bad_pendulum(pendulum) -> None:
    with pytest.raises(EstimationError) as info:
        ipgen.kalman(pendulum, 1e-3, 1e-6, 1e-6)
    _one_line(info.value)


ODD = st.one_of(
    st.text(max_size=3), st.none(), st.integers(-3, 3), st.floats(allow_nan=True, allow_infinity=True),
    st.lists(st.one_of(st.integers(-1, 3), st.text(max_size=1)), max_size=3), st.just(np.int64(1)),
    st.just(b"1"), st.just({"a": 1}),
)  # fmt: skip


@settings(max_examples=120, deadline=None)
@given(
    where=st.sampled_from(
        ["kalman.equilibrium", "kalman.measured", "filter.cutoff", "filter.dof", "difference.dof"]
    ),
    value=ODD,
)
def test_any_argument_of_an_estimator_is_taken_or_one_line(where: str, value: object) -> None:
    """The estimators' and ipgen.kalman's arguments of any type: an ipgen.Error in one line, or
    taken (text, None or a negative size raised numpy's or Python's ValueError / TypeError)."""
    from ipgen.estimation import DerivativeFilter, Difference

    qube = ipgen.Pendulum.preset("qube_servo2")
    calls = {
        "kalman.equilibrium": lambda: ipgen.kalman(qube, 1e-3, 1e-6 * np.eye(4), 1e-6, equilibrium=value),
        "kalman.measured": lambda: ipgen.kalman(qube, 1e-3, 1e-6 * np.eye(4), 1e-6, measured=value),
        "filter.cutoff": lambda: DerivativeFilter(1e-3, 2, value),
        "filter.dof": lambda: DerivativeFilter(1e-3, value),
        "difference.dof": lambda: Difference(1e-3, value),
    }
    try:
        calls[where]()
    except ipgen.Error as error:
        assert "\n" not in str(error) and len(str(error)) < 300
