"""Validation of the links as built (model/links.py, --fix, ipgen.linearize / ipgen.lqr):
hypothesis properties over each class of value, and the rules docs/model.md states:

- non-finite com, J, J_axial or tip: refused;
- negative J, J_axial or tip (and J0): refused; com may be any finite number (a CoG beyond the
  pivot, on the counterweight side, or past the far end), accepted;
- J_axial > 2 J (no axisymmetric body has that): refused; a link without inertia about its
  pivot (J = com = 0, nothing beyond): refused;
- every refusal is one line naming the parameter.
"""

from __future__ import annotations

import math
from fractions import Fraction

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import ipgen
from ipgen.control.linear import ControlError
from ipgen.model.links import LinkError, resolve_links
from ipgen.model.specialise import SpecialisationError, parse_fix
from ipgen.model.system import System

SYSTEM = System("rotary", 2, "full")
M, L, DELTA = [0.2, 0.1, 0.15], [0.3, 0.5, 0.4], [0.01, 0.001, 0.002]
EXAMPLES = settings(max_examples=60, deadline=None)
finite = st.floats(min_value=-1e3, max_value=1e3, allow_nan=False, allow_infinity=False)
non_finite = st.sampled_from([math.nan, math.inf, -math.inf])
negative = st.floats(min_value=-1e3, max_value=-1e-9, allow_nan=False)
index = st.integers(min_value=1, max_value=2)


def rods() -> dict[str, list[float]]:
    return {
        "com": [0.0, L[1] / 2, L[2] / 2],
        "J": [M[0] * L[0] ** 2 / 3, M[1] * L[1] ** 2 / 12, M[2] * L[2] ** 2 / 12],
        "J_axial": [0.0, 0.0, 0.0],
        "tip": [0.0, 0.0, 0.0],
    }


def one_line(message: str, name: str) -> None:
    assert "\n" not in message and name in message, message


@given(group=st.sampled_from(["com", "J", "J_axial", "tip"]), i=index, value=non_finite)
@EXAMPLES
def test_non_finite_is_refused(group: str, i: int, value: float) -> None:
    values = rods()
    values[group][i] = value
    with pytest.raises(LinkError) as refused:
        resolve_links(SYSTEM, M, L, values)
    one_line(str(refused.value), f"{group}[{i}]")


@given(
    group=st.sampled_from(["J", "J_axial", "tip"]), i=st.integers(min_value=0, max_value=2), value=negative
)
@EXAMPLES
def test_negative_inertia_or_mass_is_refused(group: str, i: int, value: float) -> None:
    if i == 0 and group != "J":
        return  # index 0 of J_axial and tip is unused
    values = rods()
    values[group][i] = value
    with pytest.raises(ControlError) as refused:
        ipgen.linearize("rotary", 2, M, L, DELTA, inertia="full", **values)
    one_line(str(refused.value), f"{group}[{i}]")


@given(com=st.lists(finite, min_size=2, max_size=2))
@EXAMPLES
def test_any_finite_com_is_accepted(com: list[float]) -> None:
    """A CoG anywhere along the link's line (beyond the pivot or the far end) is a real body."""
    values = rods()
    values["com"] = [0.0, *com]
    resolve_links(SYSTEM, M, L, values)  # no error (J > 0: inertia about the pivot)


@given(
    i=index, across=st.floats(min_value=1e-6, max_value=1.0), excess=st.floats(min_value=1e-6, max_value=10.0)
)
@EXAMPLES
def test_axial_above_twice_across_is_refused(i: int, across: float, excess: float) -> None:
    values = rods()
    values["J"][i] = across
    values["J_axial"][i] = 2 * across * (1 + excess)
    with pytest.raises(LinkError) as refused:
        resolve_links(SYSTEM, M, L, values)
    one_line(str(refused.value), f"J_axial[{i}]")
    values["J_axial"][i] = 2 * across  # a thin disc: allowed
    resolve_links(SYSTEM, M, L, values)


def test_link_without_pivot_inertia_is_refused() -> None:
    values = rods()
    values["J"][2], values["com"][2] = 0.0, 0.0
    with pytest.raises(LinkError, match="link 2 has no inertia"):
        resolve_links(SYSTEM, M, L, values)


def test_wrong_length_is_refused() -> None:
    with pytest.raises(ControlError, match="tip has 2 entries, expected 3"):
        ipgen.linearize("rotary", 2, M, L, DELTA, tip=[0.0, 0.1])


def test_keywords_default_to_the_rods() -> None:
    """linearize/lqr with com, J, J_axial, tip at the rod values equal the calls without them."""
    a0, b0 = ipgen.linearize("rotary", 2, M, L, DELTA, inertia="full")
    a1, b1 = ipgen.linearize("rotary", 2, M, L, DELTA, inertia="full", **rods())
    assert np.allclose(a0, a1, rtol=1e-13) and np.allclose(b0, b1, rtol=1e-13)
    k0 = ipgen.lqr("classical", 1, M[:2], L[:2], DELTA[:2], Q=[1, 1, 1, 1], R=1)
    k1 = ipgen.lqr("classical", 1, M[:2], L[:2], DELTA[:2], Q=[1, 1, 1, 1], R=1, com=[0, 0.25], tip=[0, 0])
    assert np.allclose(k0, k1, rtol=1e-10)
    k2 = ipgen.lqr("classical", 1, M[:2], L[:2], DELTA[:2], Q=[1, 1, 1, 1], R=1, tip=[0, 0.05])
    assert not np.allclose(k0, k2, rtol=1e-3)  # a tip mass changes the gain


# --------------------------------------------------------------------------- --fix


@given(
    name=st.sampled_from(["J1", "J2", "J0", "J_axial1", "tip2"]),
    value=st.fractions(max_value=Fraction(-1, 10**6)),
)
@EXAMPLES
def test_fix_refuses_negative(name: str, value: object) -> None:
    with pytest.raises(SpecialisationError) as refused:
        parse_fix(SYSTEM, f"{name}={value}")
    one_line(str(refused.value), name)


@given(value=st.decimals(min_value=-10, max_value=10, places=4, allow_nan=False))
@EXAMPLES
def test_fix_accepts_any_com(value: object) -> None:
    assert parse_fix(SYSTEM, f"com1={value}") == (("com1", Fraction(str(value))),)


@given(
    across=st.decimals(min_value=0, max_value=1, places=4, allow_nan=False),
    excess=st.decimals(min_value="0.0001", max_value=5, places=4, allow_nan=False),
)
@EXAMPLES
def test_fix_refuses_axial_above_twice_across(across: object, excess: object) -> None:
    with pytest.raises(SpecialisationError) as refused:
        parse_fix(SYSTEM, f"J1={across},J_axial1={2 * across + excess}")
    one_line(str(refused.value), "J_axial1")


@pytest.mark.parametrize(
    ("system", "name", "reason"),
    [
        (System("classical", 1), "J0", "a cart has no inertia J0"),
        (System("rotary", 1, "pivot"), "J_axial1", "inertia full"),
        (System("classical", 2), "J_axial1", "inertia full"),
        (System("rotary", 1), "com0", "unknown parameter"),
        (System("rotary", 1), "tip2", "unknown parameter"),
    ],
)
def test_fix_refuses_unused_or_unknown(system: System, name: str, reason: str) -> None:
    with pytest.raises(SpecialisationError, match=reason):
        parse_fix(system, f"{name}=0.1")
