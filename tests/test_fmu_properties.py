"""Bad input for the FMU targets, as property tests: what the user types reaches the FMU only
as the FMI version choice (`--emit fmu` / `fmu3`, or a scene's `emit`), the model name and the
command text quoted in the generated files' comments."""

from __future__ import annotations

import functools
import re
import xml.etree.ElementTree as ET

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ipgen.codegen.emit import TARGETS, EmitError, parse_emit
from ipgen.codegen.fmu import FmuError, render_sources
from ipgen.codegen.header import HeaderRequest
from ipgen.common.naming import name_problem
from ipgen.model.derivation import Equations, derive
from ipgen.model.system import System

NAMES = list(TARGETS)


@functools.cache
def _equations() -> Equations:
    return derive(System("classical", 1))


# Pairs of targets that write the same file (NAME.fmu; NAME.h): one of each pair at a time.
OVERLAPPING = [
    {a, b} for a in TARGETS for b in TARGETS if a < b and set(TARGETS[a].suffixes) & set(TARGETS[b].suffixes)
]


@given(st.lists(st.one_of(st.sampled_from(NAMES), st.text(max_size=12)), max_size=5))
@settings(max_examples=200, deadline=None)
def test_emit_accepts_known_targets_and_one_fmi_version(values: list[str]) -> None:
    """Every list of names is either accepted (known names, at most one FMU version) or refused
    with one line that names the valid choice."""
    wanted = {v.strip() for v in values if v.strip()}
    try:
        chosen = parse_emit(values)
    except EmitError as e:
        message = str(e)
        assert "\n" not in message and len(message) < 300
        overlap = any(pair <= wanted for pair in OVERLAPPING)  # two targets writing one file
        assert not wanted or any(v not in TARGETS for v in wanted) or overlap, message
        if overlap and all(v in TARGETS for v in wanted):
            assert "choose one" in message
        return
    assert set(chosen) == wanted and not any(pair <= set(chosen) for pair in OVERLAPPING)


_IDENTIFIER = st.from_regex(r"[A-Za-z][A-Za-z0-9_]{0,20}", fullmatch=True).filter(
    lambda n: name_problem(n) is None
)


@pytest.mark.parametrize("version", [2, 3])
@given(name=_IDENTIFIER, command=st.text(max_size=60))
@settings(max_examples=25, deadline=None)
def test_fmu_files_stay_well_formed_for_any_name_and_command(name: str, command: str, version: int) -> None:
    """For any valid model name and any command text, the model description is well-formed XML
    naming the model, and the command cannot leave the C sources' comments."""
    files = render_sources(_equations(), HeaderRequest(name, command), version)
    root = ET.fromstring(files["modelDescription.xml"].encode())
    assert root.get("modelName") == name
    exchange = root.find("ModelExchange")
    assert exchange is not None and exchange.get("modelIdentifier") == name
    glue = files[f"sources/{name}_fmu.c"]
    # the first comment closes once, after the command: nothing typed ends it early
    first = glue.index("*/")
    assert "Do not edit" in glue[:first] and "#include" in glue[first:]
    assert re.search(r"/\*.*\*/", glue[: first + 2], re.S)
    if version == 3:
        ET.fromstring(files["sources/buildDescription.xml"].encode())


@pytest.mark.parametrize(
    "name", ["fmi2Functions", "fmi2TypesPlatform", "fmi3PlatformTypes", "fmi3FunctionTypes"]
)
def test_a_model_named_like_an_fmi_header_is_refused(name: str) -> None:
    with pytest.raises(FmuError, match="choose another --name"):
        render_sources(_equations(), HeaderRequest(name, "ipgen"), 2)
