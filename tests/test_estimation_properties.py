"""Bad arguments to ipgen.kalman, the sensors and the estimator designs: each class of bad input
(non-finite or non-positive periods, negative or NaN resolutions and noise, covariances of the
wrong shape, asymmetric, indefinite or NaN, bad measured indices, kinds, cutoffs) is one
`EstimationError` (an `ipgen.Error`) with a one-line message, never another exception."""

from __future__ import annotations

import itertools
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


@settings(max_examples=150, deadline=None)
@given(
    measured=st.lists(
        st.one_of(st.integers(0, 3), st.integers(0, 3), st.integers(-3, 5), st.booleans(), st.floats(-1, 3)),
        max_size=4,
    ),
    dof=st.integers(1, 4),
)
def test_measured_is_refused_exactly_when_it_names_no_coordinates(measured, dof) -> None:
    """Any list: taken when it lists coordinate indices 0..dof-1 increasing without repeats (at
    least one), else one line naming `measured` (an audit found this class tested on six fixed
    lists only)."""
    valid = (
        len(measured) > 0
        and all(type(index) is int and 0 <= index < dof for index in measured)
        and all(a < b for a, b in itertools.pairwise(measured))
    )
    if valid:
        assert Sensors.of(dof, measured, 2048).measured == tuple(measured)
        return
    with pytest.raises(EstimationError, match="measured") as info:
        Sensors.of(dof, measured, 2048)
    _one_line(info.value)


@SETTINGS
@given(measured=st.one_of(st.just([1, 0]), st.just([2]), st.just([True]), st.just("01"), st.just(7)))
def test_bad_measured_in_kalman(measured) -> None:
    with pytest.raises(EstimationError, match="measured") as info:
        ipgen.kalman(RSIP, 1e-3, 1e-6, 1e-6, measured=measured)
    _one_line(info.value)


# How a drawn covariance is spoilt, and what the refusal must name.
SPOILT = {
    "asymmetric": "must be symmetric",
    "indefinite": "must be positive",
    "nan": "must be finite",
    "size": "expected",
}


@SETTINGS
@given(
    size=st.integers(1, 4),
    seed=st.integers(0, 2**32 - 1),
    scale=st.floats(-6, 6).map(lambda e: 10.0**e),
    spoil=st.sampled_from([None, *SPOILT]),
    definite=st.booleans(),
)
def test_a_covariance_is_refused_exactly_when_spoilt(size, seed, scale, spoil, definite) -> None:
    """A random positive definite matrix, at any scale, is taken as it is; spoilt (made
    asymmetric, indefinite, NaN or the wrong size, each by a margin far beyond rounding) it is
    refused in one line saying how."""
    from ipgen.estimation.checks import covariance_matrix

    rng = np.random.default_rng(seed)
    factor = rng.normal(size=(size, size))
    matrix = scale * (factor @ factor.T + 0.1 * np.eye(size))
    expected_size = size
    if spoil == "asymmetric" and size > 1:
        matrix[0, -1] += 0.5 * scale
    elif spoil == "indefinite":
        matrix -= (float(np.max(np.linalg.eigvalsh(matrix))) + 0.5 * scale) * np.eye(size)
    elif spoil == "nan":
        matrix[-1, 0] = math.nan
    elif spoil == "size":
        expected_size = size + 1
    else:
        spoil = None  # (a 1 × 1 matrix cannot be asymmetric)
    if spoil is None:
        taken = covariance_matrix("Qn", matrix, expected_size, "test", definite=definite)
        np.testing.assert_array_equal(taken, 0.5 * (matrix + matrix.T))
        return
    with pytest.raises(EstimationError, match=SPOILT[spoil]) as info:
        covariance_matrix("Qn", matrix, expected_size, "test", definite=definite)
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
