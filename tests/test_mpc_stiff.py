"""The MPC refuses a prediction whose RK4 step is unstable for a stiff mode of the model (an audit
found heavy damping on a light cart, λ ≈ −976 s⁻¹ at 10 ms, accepted: every QP broke down and the
loop diverged, with advice that did not name the cause). Checked against the C code's own
prediction, not the eigenvalue test that refuses: about the hanging rest, where no mode of the
model grows, a design that is accepted predicts no growth either, and the substeps a refusal
names are accepted."""

from __future__ import annotations

import re

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import ipgen
from ipgen.control.mpc import MpcError


def _grows(design: ipgen.control.mpc.Mpc, samples: int = 60) -> bool:
    """Whether the prediction, with u held at 0 from a small kick of every rate about the rest,
    grows past ten times the kick (a mode RK4 makes unstable grows by |R(h λ)| > 1 each step)."""
    kick = 1e-6
    x = design.x_ref.copy()
    dof = len(x) // 2
    x[dof:] += kick
    for _ in range(samples):
        x, _, _ = design.rk4(x, 0.0)
        if not np.all(np.isfinite(x)) or np.max(np.abs(x - design.x_ref)) > 10 * kick * (1 + samples):
            return True
    return False


@settings(max_examples=25, deadline=None)
@given(
    damping=st.floats(-1, 5).map(lambda e: 10.0**e),
    period=st.sampled_from([0.002, 0.005, 0.01, 0.02]),
    substeps=st.integers(1, 4),
)
def test_an_accepted_prediction_does_not_grow_at_a_rest(damping: float, period: float, substeps: int) -> None:
    p = ipgen.Pendulum("classical", 1, m=[1.0, 0.1], l=[0.0, 0.5], delta=[damping, 0.0])
    options = {"u_max": 1000.0, "period": period, "horizon": 5, "reference": "hanging"}
    try:
        design = ipgen.mpc(p, substeps=substeps, **options)
    except MpcError as error:
        found = re.search(r"give substeps = (\d+)", str(error))
        if found is None:
            assert "even 100 substeps are not enough: a shorter period" in str(error)
            return
        design = ipgen.mpc(p, substeps=int(found.group(1)), **options)
        assert design.substeps > substeps
    assert not _grows(design)


def test_the_stiff_cart_the_audit_found_is_refused_with_the_fix() -> None:
    p = ipgen.Pendulum("classical", 1, m=[1.0, 0.1], l=[0.0, 0.5], delta=[1000.0, 0.0])
    with pytest.raises(MpcError, match=r"substeps 1: .* unstable .* give substeps = 4"):
        ipgen.mpc(p, u_max=1000.0, period=0.01, horizon=30)
    assert not _grows(ipgen.mpc(p, u_max=1000.0, period=0.01, horizon=30, substeps=4, reference="hanging"))


def test_a_reference_within_the_rest_tolerance_designs_without_a_warning() -> None:
    """The stability check linearises at the reference, which the MPC took as a rest within its
    tolerance (1e-9 rad): linearize's "not an equilibrium" warning was noise there."""
    import warnings

    from ipgen.control.linear import EquilibriumWarning

    p = ipgen.Pendulum("classical", 1, m=[1.0, 0.1], l=[0.0, 0.005], delta=[0.0, 0.0])  # g/l large
    with warnings.catch_warnings():
        warnings.simplefilter("error", EquilibriumWarning)
        ipgen.mpc(p, u_max=10.0, horizon=5, reference=[0.0, 1e-9])
