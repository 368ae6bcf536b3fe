"""Bad arguments at the model layer's entry points (`ipgen.Actuator`, `Pendulum`, `FixedPendulum`,
`derive`, `linearize`, `lqr` of a fixed chain): each an `ipgen.Error` of one line, never a raw
TypeError, KeyError or numpy error, and never taken in a meaning the user did not give (text or
booleans as numbers, a set's order as the links', an inertia the pendulum does not have)."""

from __future__ import annotations

import math
from decimal import Decimal

import numpy as np
import pytest
import sympy as sp
from hypothesis import given, settings
from hypothesis import strategies as st

import ipgen
from ipgen.model.system import UnknownParameter

ROTARY = {"m": [0.1, 0.03], "l": [0.1, 0.2], "delta": [0.0, 0.0]}
MOTOR = {"Rm": 8.4, "kt": 0.042, "km": 0.042}
NOT_NUMBERS = st.one_of(
    st.text(max_size=4), st.binary(max_size=3), st.booleans(), st.just(1j), st.just([1.0]),
    st.just(10**400), st.just({}), st.lists(st.floats(), max_size=2),
)  # fmt: skip


def _one_line(error: BaseException) -> str:
    text = str(error)
    assert isinstance(error, ipgen.Error) and "\n" not in text and len(text) < 400, repr(error)
    return text


@settings(max_examples=60, deadline=None)
@given(name=st.sampled_from(sorted(MOTOR)), value=NOT_NUMBERS, as_dict=st.booleans())
def test_a_motor_constant_that_is_not_a_number_is_one_line(name: str, value: object, as_dict: bool) -> None:
    """Text, bytes, booleans, complex numbers, lists and integers beyond a double as a dc_motor's
    constant, in an Actuator or in the dict form (before: a raw TypeError or OverflowError, and the
    dict form read "8.4" and True as numbers)."""
    constants = MOTOR | {name: value}
    actuator = {"kind": "dc_motor", **constants} if as_dict else ipgen.Actuator("dc_motor", **constants)
    with pytest.raises(ipgen.Error) as refused:
        ipgen.Pendulum("rotary", 1, **ROTARY, actuator=actuator)
    assert f"actuator {name} = " in _one_line(refused.value)


def test_a_motor_constant_of_any_real_type_is_taken_alike() -> None:
    """numpy's floats and Decimal, in the dict form and in `ipgen.Actuator`, are numbers: the same
    pendulum as plain floats (an Actuator of Decimals raised a TypeError in its gain, and in
    derive, linearize and lqr)."""
    plain = ipgen.Pendulum("rotary", 1, **ROTARY, actuator=ipgen.Actuator("dc_motor", **MOTOR))
    numpy = {k: np.float64(v) for k, v in MOTOR.items()}
    decimals = {k: Decimal(str(v)) for k, v in MOTOR.items()}
    for actuator in (
        ipgen.Actuator("dc_motor", **numpy),
        {"kind": "dc_motor", **numpy},
        {"kind": "dc_motor", **decimals},
        ipgen.Actuator("dc_motor", **decimals),
    ):
        other = ipgen.Pendulum("rotary", 1, **ROTARY, actuator=actuator)
        assert other.actuator.gain() == plain.actuator.gain()
        assert np.array_equal(ipgen.linearize(other)[1], ipgen.linearize(plain)[1])
    motor = ipgen.Actuator("dc_motor", **decimals)
    assert ipgen.derive("rotary", 1, actuator=motor).mass_matrix == ipgen.derive(
        "rotary", 1, actuator=ipgen.Actuator("dc_motor", **MOTOR)
    ).mass_matrix


@settings(max_examples=40, deadline=None)
@given(value=NOT_NUMBERS | st.just("1") | st.just([[1.0, 2.0], [3.0]]))
def test_a_fixed_chains_lqr_weight_r_of_any_type_is_one_line(value: object) -> None:
    """`ipgen.lqr(FixedPendulum, R=...)` with text (also "1"), a ragged or empty value: a
    ControlError naming R (before, numpy's ValueError or TypeError, and "1" was taken as 1)."""
    chain = ipgen.FixedPendulum.preset("dfki_c1")
    try:
        ipgen.lqr(chain, Q=[1.0, 1.0, 0.1, 0.1], R=value)
    except ipgen.Error as error:
        assert "R" in _one_line(error)
        return
    # only a list of numbers may be weights; text, bytes, booleans, complex, {} and 10**400 never
    assert isinstance(value, list) and value != [[1.0, 2.0], [3.0]], value


def test_derive_of_a_pendulum_takes_no_inertia() -> None:
    """derive(p, inertia="full") with a pivot pendulum returned the pivot equations without a word;
    now refused, as links and actuator are; derive(type, links) keeps "pivot" as its default."""
    pendulum = ipgen.Pendulum("rotary", 1, m=[0.5, 0.275], l=[0.6, 0.5], delta=[0, 0])
    for inertia in ("full", "pivot"):
        with pytest.raises(ipgen.Error) as refused:
            ipgen.derive(pendulum, inertia=inertia)
        assert "inertia" in _one_line(refused.value)
    assert ipgen.derive("rotary", 1).system.inertia == "pivot"
    assert ipgen.derive(pendulum).mass_matrix == ipgen.derive("rotary", 1, "pivot").mass_matrix
    with pytest.raises(ipgen.Error):
        ipgen.derive(ipgen.FixedPendulum.preset("dfki_c0"), inertia="full")


@pytest.mark.parametrize("name", ["mass1", "m2", "coulomb1", 1, None, "J_axial9", "m0"])
def test_an_unknown_parameter_is_an_ipgen_error_and_a_key_error(name: object) -> None:
    for model in (
        ipgen.Pendulum("rotary", 1, **ROTARY),
        ipgen.FixedPendulum(1, m=[1.0], l=[1.0], delta=[0.0]),
    ):
        if (name, isinstance(model, ipgen.Pendulum)) in (("m0", True), ("coulomb1", False)):
            continue  # the base's mass; a fixed chain's Coulomb friction
        with pytest.raises(UnknownParameter) as refused:
            model.value(name)  # type: ignore[arg-type]
        assert isinstance(refused.value, KeyError)
        _one_line(refused.value)


def test_a_rods_inertia_that_overflows_is_refused() -> None:
    with pytest.raises(ipgen.Error) as refused:
        ipgen.FixedPendulum(1, m=[1e300], l=[1e10], delta=[0.0])
    assert "overflows" in _one_line(refused.value)


@pytest.mark.parametrize(
    ("args", "words"),
    [((["0", "0"],), "q must be 2 numbers"), ((None, [True, False]), "qd must be 2 numbers")],
)
def test_linearize_takes_no_text_or_booleans_as_states(args: tuple, words: str) -> None:
    pendulum = ipgen.Pendulum("classical", 1, m=[1.0, 0.1], l=[0, 0.5], delta=[0, 0])
    with pytest.raises(ipgen.Error) as refused:
        ipgen.linearize(pendulum, *args)
    assert words in _one_line(refused.value)
    chain = ipgen.FixedPendulum(2, m=[1.0, 1.0], l=[1.0, 1.0], delta=[0, 0])
    with pytest.raises(ipgen.Error):
        ipgen.linearize(chain, None, None, "1")


def test_a_set_is_not_a_list_of_numbers() -> None:
    """{5.0, 0.1} has no order: before, the cart's mass became 0.1 and the link's 5."""
    with pytest.raises(ipgen.Error):
        ipgen.Pendulum("classical", 1, m={5.0, 0.1}, l=[0, 0.5], delta=[0, 0])
    with pytest.raises(ipgen.Error):
        ipgen.FixedPendulum(2, m={1.0, 2.0}, l=[1.0, 1.0], delta=[0, 0])
    with pytest.raises(ipgen.Error):
        ipgen.FixedPendulum(2, m=[1.0, 2.0], l=[1.0, 1.0], delta=[0, 0], joints={2, 1})


def test_a_fixed_chain_takes_decimals_as_a_pendulum_does() -> None:
    exact = ipgen.FixedPendulum(1, m=[Decimal("0.5")], l=[Decimal("0.2")], delta=[Decimal("0")])
    plain = ipgen.FixedPendulum(1, m=[0.5], l=[0.2], delta=[0.0])
    assert exact.numbers() == plain.numbers()


@pytest.mark.parametrize("bad", [None, 5, b"x", 1.5])
def test_entry_points_name_what_they_take(bad: object) -> None:
    for call in (ipgen.FixedPendulum.preset, ipgen.Pendulum.from_scene, ipgen.FixedPendulum.from_scene):
        with pytest.raises(ipgen.Error):
            call(bad)  # type: ignore[arg-type]


@pytest.mark.parametrize(
    "links",
    [{"tip": [-3.0, 0.0]}, {"J": [-5.0, 0.002]}, {"J_axial": [-5.0, 0.0]}],
)
def test_the_bases_entries_of_the_links_as_built_are_checked_too(links: dict) -> None:
    """Index 0 of tip and J_axial (and a cart's J) enter no equation, but a negative mass or
    inertia there is nonsense, as docs/links.md says: refused as for the links."""
    kind, inertia = ("rotary", "full") if "J_axial" in links else ("classical", "pivot")
    with pytest.raises(ipgen.Error) as refused:
        ipgen.Pendulum(kind, 1, m=[1.0, 0.1], l=[0.1, 0.5], delta=[0, 0], inertia=inertia, **links)
    assert "cannot be negative" in _one_line(refused.value)
    assert math.isfinite(ipgen.Pendulum(kind, 1, m=[1.0, 0.1], l=[0.1, 0.5], delta=[0, 0]).value("m0"))


@pytest.mark.parametrize(
    ("call", "words"),
    [
        (lambda p, c: ipgen.linearize(p, qq=1), "ipgen.linearize() got an unexpected keyword argument 'qq'"),
        (lambda p, c: ipgen.lqr(p, [1, 1, 1, 1], 1, None, 5), "ipgen.lqr() takes from 3 to 4"),
        (lambda p, c: ipgen.lqr(c), "ipgen.lqr() missing 2 required positional arguments: 'Q' and 'R'"),
        (lambda p, c: ipgen.linearize(c, 1, 2, 3, 4), "ipgen.linearize() takes from 1 to 4"),
        (lambda p, c: ipgen.linearize(None), "ipgen.linearize() missing 4 required positional arguments"),
    ],
)
def test_arguments_fitting_no_form_name_the_public_function(call: object, words: str) -> None:
    """A misspelt keyword or a wrong count named the private form (`_linearize()`, `lqr_fixed()`);
    now ipgen's, as an ipgen.Error that is still a TypeError."""
    pendulum = ipgen.Pendulum("classical", 1, m=[1.0, 0.1], l=[0, 0.5], delta=[0, 0])
    with pytest.raises(TypeError) as refused:
        call(pendulum, ipgen.FixedPendulum.preset("dfki_c1"))  # type: ignore[operator]
    assert words in _one_line(refused.value)


def test_numpys_integers_count_links_and_name_joints() -> None:
    """links = np.int64(1) and joints = np.array([1, 2]) were refused ("np.int64(1) is not a joint
    number"); now taken as the Python integers they are, and stored as such."""
    plain = ipgen.Pendulum("rotary", 1, **ROTARY)
    numpy = ipgen.Pendulum("rotary", np.int64(1), **ROTARY)
    assert numpy == plain and type(numpy.links) is int
    chain = ipgen.FixedPendulum(
        np.int64(2), m=[1.0, 1.0], l=[1.0, 1.0], delta=[0, 0], joints=np.array([1, 2])
    )
    assert chain.joints == (1, 2) and all(type(j) is int for j in chain.joints) and type(chain.links) is int


def test_derive_of_a_pendulum_with_links_as_built_describes_them() -> None:
    """derive(p) of a Pendulum that sets com, J or tip gives the general views (M11 = J1 + m1 com1²
    + tip1 l1²), equal to derive(..., general=True); it gave the rods' (m1 l1²/3), which are not
    p's. A Pendulum of rods keeps the rods' views."""
    built = ipgen.Pendulum("rotary", 1, **ROTARY, tip=[0.0, 0.05])
    views = ipgen.derive(built)
    s = views.symbols
    pivot = s.J[1] + s.m[1] * s.com[1] ** 2 + s.tip[1] * s.l[1] ** 2
    assert sp.expand(views.mass_matrix[1, 1] - pivot) == 0
    assert views.mass_matrix == ipgen.derive("rotary", 1, general=True).mass_matrix
    rods = ipgen.Pendulum("rotary", 1, **ROTARY)
    assert ipgen.derive(rods).mass_matrix == ipgen.derive("rotary", 1).mass_matrix


@settings(max_examples=30, deadline=None)
@given(links=st.integers(41, 10**6), fixed=st.booleans())
def test_a_chain_beyond_the_simulators_capacity_is_one_line(links: int, fixed: bool) -> None:
    """More links than the numeric tools take (40 on a cart or arm, 41 on a fixed pivot): one
    ipgen.Error naming the limit, before any derivation (1000 links ran out of memory, or FLINT
    aborted the process)."""
    if fixed and links == 41:
        return  # a fixed chain of 41 links is within the capacity: the next test
    n = links + (0 if fixed else 1)
    with pytest.raises(ipgen.Error) as refused:
        if fixed:
            ipgen.FixedPendulum(links, m=[0.5] * n, l=[0.2] * n, delta=[0.0] * n, joints=[1])
        else:
            ipgen.linearize("rotary", links, m=[0.2] * n, l=[0.3] * n, delta=[0.01] * n)
    message = _one_line(refused.value)
    limit = 41 if fixed else 40
    assert f"links = {links}: a " in message and f"at most {limit} links" in message, message


def test_the_capacity_itself_is_taken_and_derive_of_many_links_needs_force() -> None:
    """40 links on an arm and 41 on a fixed pivot are Pendulums (constructing one derives nothing);
    derive of more than 30 links needs force=True, as the command needs --force."""
    assert ipgen.Pendulum("rotary", 40, m=[0.2] * 41, l=[0.3] * 41, delta=[0.01] * 41).links == 40
    assert ipgen.FixedPendulum(41, m=[0.5] * 41, l=[0.2] * 41, delta=[0.0] * 41, joints=[1]).links == 41
    with pytest.raises(ipgen.Error, match=r"derive\('rotary', 31\) of 31 links is large: .*pass force=True"):
        ipgen.derive("rotary", 31)
    for p in (
        ipgen.Pendulum("rotary", 35, m=[0.2] * 36, l=[0.3] * 36, delta=[0.01] * 36),
        ipgen.FixedPendulum(35, m=[0.5] * 35, l=[0.2] * 35, delta=[0.0] * 35, joints=[1]),
    ):
        with pytest.raises(ipgen.Error, match=r"derive\(p\) of 35 links is large: .*pass force=True"):
            ipgen.derive(p)
