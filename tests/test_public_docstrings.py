"""Every name of the public API (`ipgen.__all__`) has a numpydoc docstring with an example, and
the examples hold (run as doctests; those that compile a simulator are marked +SKIP)."""

from __future__ import annotations

import doctest
import importlib
import inspect
import sys

import pytest

import ipgen

PUBLIC = [name for name in ipgen.__all__ if name != "__version__"]


@pytest.mark.parametrize("name", PUBLIC)
def test_every_public_name_has_the_numpydoc_sections(name: str) -> None:
    obj = getattr(ipgen, name)
    doc = inspect.getdoc(obj) or ""
    sections = ["Examples"]
    if inspect.isfunction(obj):
        sections += ["Returns", "Raises"]
        if inspect.signature(obj).parameters:
            sections.append("Parameters")
    missing = [section for section in sections if f"{section}\n{'-' * len(section)}" not in doc]
    assert not missing, f"ipgen.{name}: its docstring has no {', '.join(missing)} section"


def _home_module(name: str) -> str:
    """The module that defines the public object `name` (where its docstring's examples live)."""
    return getattr(ipgen, name).__module__


@pytest.mark.parametrize("module", sorted({_home_module(name) for name in PUBLIC}))
def test_the_public_examples_hold(module: str) -> None:
    importlib.import_module(module)
    failures, tried = doctest.testmod(sys.modules[module], optionflags=doctest.ELLIPSIS)
    assert tried >= 1 and failures == 0
