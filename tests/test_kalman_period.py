"""A steady-state Kalman filter of a pendulum with both angles measured and process noise on every state
always exists; where scipy cannot compute it, the sampling period is to blame (the model grows by
e^(λ T) over a sample), and the refusal says so. An audit found a 100 s period, or a 10 nm link at
10 ms, refused with "measure more coordinates or give every mode process noise", both already so."""

from __future__ import annotations

import numpy as np
from hypothesis import event, given, settings
from hypothesis import strategies as st

import ipgen
from ipgen.estimation.pendulum import EstimationError


@settings(max_examples=40, deadline=None)
@given(
    kind=st.sampled_from(["classical", "rotary"]),
    length=st.floats(-8, 1).map(lambda e: 10.0**e),
    period=st.floats(-3, 2).map(lambda e: 10.0**e),
)
def test_a_fully_measured_filter_is_refused_only_for_its_period(
    kind: str, length: float, period: float
) -> None:
    p = ipgen.Pendulum(
        kind, 1, m=[1.0, 0.1], l=[length if kind == "rotary" else 0.0, length], delta=[0.0, 0.0]
    )
    try:
        estimator = ipgen.kalman(p, period, 1e-3, 1e-4, measured=[0, 1])
    except EstimationError as error:
        event("refused")
        assert "sample faster" in str(error), str(error)
        return
    event("designed")
    poles = np.linalg.eigvals(estimator.A - estimator.A @ estimator.M @ estimator.C)
    assert np.max(np.abs(poles)) < 1
