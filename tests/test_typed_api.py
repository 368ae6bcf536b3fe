"""The public API's types as help(), inspect and type checkers read them: `Pendulum(actuator=...)`
takes an Actuator, a mapping or None and reads back an Actuator; `ipgen.linearize` and `ipgen.lqr`
show their parameters (they showed *args, **kwargs) and give each form as a `typing.overload`."""

from __future__ import annotations

import copy
import dataclasses
import inspect
import pickle
import pydoc
import re
import typing
from collections.abc import Callable, Mapping
from typing import Any

import pytest

import ipgen
from ipgen.control import api, fixed_linear, linear
from ipgen.model.actuator import DIRECT, Actuator

ROD = {"m": [0.095, 0.024], "l": [0.085, 0.129], "delta": [0.0015, 0.0005]}
MOTOR: dict[str, Any] = {"kind": "dc_motor", "Rm": 8.4, "kt": 0.042, "km": 0.042}


def test_the_constructor_says_it_takes_an_actuator_a_mapping_or_none() -> None:
    """The annotation was `Actuator`, refusing (for a type checker) the dict and None it takes."""
    parameter = inspect.signature(ipgen.Pendulum).parameters["actuator"]
    assert parameter.kind is inspect.Parameter.KEYWORD_ONLY and parameter.default == DIRECT
    hint = typing.get_type_hints(ipgen.Pendulum.__init__)["actuator"]
    assert set(typing.get_args(hint)) == {Actuator, Mapping[str, object], type(None)}


@pytest.mark.parametrize("given", [None, MOTOR, Actuator(**MOTOR)])
def test_the_actuator_read_back_is_an_actuator_and_the_pendulum_is_as_before(given: object) -> None:
    """Reading, equality, hashing, replace, copies and pickles as when the field was a plain one:
    the Actuator lives in the instance's __dict__ under "actuator" (what an older pickle holds)."""
    p = ipgen.Pendulum("rotary", 1, **ROD, actuator=given)  # type: ignore[arg-type]
    drive = p.actuator
    assert isinstance(drive, Actuator) and drive.kind == ("direct" if given is None else "dc_motor")
    assert vars(p)["actuator"] is drive and list(vars(p)) == [f.name for f in dataclasses.fields(p)]
    assert ipgen.Pendulum.actuator is DIRECT  # the class attribute: the default
    assert object.__new__(ipgen.Pendulum).actuator is DIRECT  # an instance without __init__: too
    for other in (pickle.loads(pickle.dumps(p)), copy.deepcopy(p), p.replace(actuator=given)):
        assert other == p and hash(other) == hash(p) and isinstance(other.actuator, Actuator)
    assert dataclasses.replace(p, actuator=None).actuator is DIRECT
    assert p.replace(actuator=MOTOR).actuator == Actuator(**MOTOR)
    with pytest.raises(dataclasses.FrozenInstanceError):
        p.actuator = DIRECT  # type: ignore[misc]
    with pytest.raises(ipgen.Error, match="actuator must be"):
        ipgen.Pendulum("rotary", 1, **ROD, actuator="dc_motor")  # type: ignore[arg-type]


def _form(function: Any, drop: tuple[str, ...] = ()) -> list[tuple[str, object, object]]:
    """(name, kind, default) of each parameter: what a call binds, the annotations aside."""
    return [
        (p.name, p.kind, p.default)
        for p in inspect.signature(function).parameters.values()
        if p.name not in drop
    ]


LINEAR_FORMS = {
    # public function: the private functions its overloads call, in the overloads' order
    api.linearize: [linear._linearize, fixed_linear.linearize_fixed, linear._linearize_keywords],
    api.lqr: [linear._lqr, fixed_linear.lqr_fixed, linear._lqr_keywords],
    linear.linearize: [linear._linearize, linear._linearize_keywords],
    linear.lqr: [linear._lqr, linear._lqr_keywords],
}


@pytest.mark.parametrize("function", list(LINEAR_FORMS), ids=lambda f: f"{f.__module__}.{f.__name__}")
def test_linearize_and_lqr_have_an_overload_per_form_matching_the_form(function: Callable) -> None:
    """Each overload binds as the private form that the call reaches does (so the signatures
    type checkers read are the ones the calls meet), the Pendulum's first."""
    overloads = typing.get_overloads(function)
    forms = LINEAR_FORMS[function]
    assert len(overloads) == len(forms)
    for overload, form in zip(overloads, forms, strict=True):
        assert _form(overload) == _form(form, drop=("stacklevel",)), form.__name__
    first = [inspect.signature(overload).parameters for overload in overloads]
    assert [next(iter(p.values())).annotation for p in first] == (
        ["Pendulum", "FixedPendulum", "str"] if function.__module__ == api.__name__ else ["Pendulum", "str"]
    )


def test_help_and_inspect_show_linearizes_and_lqrs_parameters() -> None:
    """They showed (*args, **kwargs); now the Pendulum's form, as the Parameters section lists."""
    assert list(inspect.signature(ipgen.linearize).parameters) == ["p", "q", "qd", "u"]
    assert list(inspect.signature(ipgen.lqr).parameters) == ["p", "Q", "R", "equilibrium"]
    assert inspect.signature(ipgen.linearize).parameters["u"].default == 0.0
    for name in ("linearize", "lqr"):
        function = getattr(ipgen, name)
        assert inspect.signature(function) == inspect.signature(getattr(linear, name))
        assert function.__doc__ == getattr(linear, name).__doc__
        shown = pydoc.render_doc(function, renderer=pydoc.plaintext)  # type: ignore[attr-defined]
        assert f"\n{name}(p: 'Pendulum', " in shown
        section = shown[shown.index("Parameters\n") : shown.index("Returns\n")]
        headers = re.findall(r"^    (\w[\w, ]*) :", section, flags=re.M)  # "q, qd : ..." names two
        documented = [name for header in headers for name in header.split(", ")]
        assert documented == list(inspect.signature(function).parameters)
