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


# Public names whose examples are all skipped in the doctests: sweep compiles a simulator,
# identify fits a recording the user has (rig.csv).
SKIPPED_EXAMPLES = {"identify", "sweep"}


@pytest.mark.parametrize("name", PUBLIC)
def test_every_public_name_has_an_example_that_runs(name: str) -> None:
    """At least one example with an expected output and not marked +SKIP (the module's doctests
    below run it and compare)."""
    tests = doctest.DocTestFinder(recurse=False).find(getattr(ipgen, name), name)
    runnable = [
        example
        for test in tests
        for example in test.examples
        if example.want and not example.options.get(doctest.OPTIONFLAGS_BY_NAME["SKIP"], False)
    ]
    if name in SKIPPED_EXAMPLES:
        assert not runnable, f"ipgen.{name}'s example runs now: drop it from SKIPPED_EXAMPLES"
    else:
        assert runnable, f"ipgen.{name}: its docstring has no example that runs"


def _home_module(name: str) -> str:
    """The module that defines the public object `name` (where its docstring's examples live)."""
    return getattr(ipgen, name).__module__


@pytest.mark.parametrize("module", sorted({_home_module(name) for name in PUBLIC}))
def test_the_public_examples_hold(module: str) -> None:
    importlib.import_module(module)
    failures, tried = doctest.testmod(sys.modules[module], optionflags=doctest.ELLIPSIS)
    assert tried >= 1 and failures == 0
