"""The simulator's key table and value rules are generated from CFG_KEYS and the scene schema
(ipgen.pipeline.cfg_rules -> cpp/include/ipsim/cfg_rules.hpp), and the simulator's check refuses
exactly the numbers the scene schema refuses (jsonschema as the reference validator; the schema
itself is held to ipgen's pydantic checks by tests/test_scene_schema.py)."""

from __future__ import annotations

import math
import subprocess
import typing
from pathlib import Path

import pytest
from cxx import CXX
from hypothesis import given, settings
from hypothesis import strategies as st
from jsonschema import Draft4Validator

from ipgen.experiment.config import CFG_KEYS
from ipgen.pipeline.cfg_rules import HEADER, SOURCES, header_text, rules
from ipgen.pipeline.scene_schema import json_schema
from ipgen.scene.schema import SceneDocument

ROOT = Path(__file__).resolve().parent.parent

PROGRAM = r"""
#include <cstdio>
#include <cstring>
#include "ipsim/cfg_rules.hpp"
// Reads `key value` lines; prints 1 (admitted) or 0 per line, -1 for a key without a rule.
int main() {
  char key[128];
  double value;
  while (std::scanf("%127s %lf", key, &value) == 2) {
    int verdict = -1;
    for (const auto& rule : ipsim::cfg::kRules) {
      if (std::strcmp(rule.key, key) == 0) verdict = ipsim::cfg::admits(rule, value) ? 1 : 0;
    }
    std::printf("%d\n", verdict);
  }
  return 0;
}
"""


def test_the_header_is_generated_from_the_current_schema() -> None:
    assert HEADER.read_text(encoding="utf-8") == header_text(), "run: python -m ipgen.pipeline.cfg_rules"


def test_every_rule_is_a_config_key_and_every_source_a_scene_key() -> None:
    assert set(SOURCES) <= set(CFG_KEYS)
    for table, name in SOURCES.values():
        assert name in _table_model(table).model_fields, (table, name)


def _table_model(table: str) -> type:
    annotation = SceneDocument.model_fields[table].annotation
    return next(a for a in typing.get_args(annotation) or (annotation,) if a is not type(None))


SCHEMA = json_schema()


def _scene_admits(table: str, name: str, value: float) -> bool:
    """Whether the scene schema (docs/scene.schema.json, which tests/test_scene_schema.py holds to
    what ipgen refuses) takes `value` for [table] name, alone or as the one number of a list;
    jsonschema's Draft 4 validator is the reference."""
    ref = SCHEMA["properties"][table]["$ref"].rsplit("/", 1)[-1]
    prop = SCHEMA["definitions"][ref]["properties"][name]
    if not math.isfinite(value):
        return False  # TOML's nan and inf: every scene number is finite (fields.Real)
    number = int(value) if value.is_integer() else value  # the .cfg writes whole numbers as integers
    validator = Draft4Validator(prop)
    return validator.is_valid(number) or any(validator.is_valid([number] * k) for k in (1, 2))  # minItems


@pytest.fixture(scope="module")
def checker(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("cfg_rules")
    source = folder / "check.cpp"
    source.write_text(PROGRAM)
    program = folder / "check"
    subprocess.run(
        [CXX, "-std=c++17", "-Wall", "-Wextra", "-Wpedantic", "-Werror",
         f"-I{ROOT / 'cpp' / 'include'}", str(source), "-o", str(program)],
        check=True,
    )  # fmt: skip
    return program


def _cpp_admits(checker: Path, pairs: list[tuple[str, float]]) -> list[int]:
    text = "".join(f"{key} {value!r}\n" for key, value in pairs)
    result = subprocess.run([str(checker)], input=text, capture_output=True, text=True, check=True)
    return [int(line) for line in result.stdout.split()]


# Numbers at and around every bound a rule states, where off-by-one rules would differ.
RULED = {b for rule in rules() for r in rule.ranges for b in (r.minimum, r.maximum)}
BOUNDS = sorted(RULED - {-math.inf, math.inf})
BELOW = [math.nextafter(b, -math.inf) for b in BOUNDS]
ABOVE = [math.nextafter(b, math.inf) for b in BOUNDS]
NEAR = BOUNDS + BELOW + ABOVE + [b - 0.5 for b in BOUNDS] + [b + 0.5 for b in BOUNDS]
VALUES = st.one_of(
    st.sampled_from(NEAR),
    st.floats(allow_nan=True, allow_infinity=True),
    st.integers(-(2**64), 2**64).map(float),
)


@settings(max_examples=25, deadline=None)
@given(values=st.lists(VALUES, min_size=len(SOURCES), max_size=len(SOURCES)))
def test_the_simulator_refuses_exactly_what_a_scene_refuses(checker: Path, values: list[float]) -> None:
    keys = list(SOURCES)
    verdicts = _cpp_admits(checker, list(zip(keys, values, strict=True)))
    for key, value, verdict in zip(keys, values, verdicts, strict=True):
        table, name = SOURCES[key]
        assert verdict == int(_scene_admits(table, name, value)), (key, value)


def test_every_bound_is_checked_on_both_sides(checker: Path) -> None:
    """Deterministic: each key at each bound and one step either side (hypothesis may miss one)."""
    pairs = [(key, value) for key in SOURCES for value in NEAR]
    verdicts = _cpp_admits(checker, pairs)
    for (key, value), verdict in zip(pairs, verdicts, strict=True):
        assert verdict == int(_scene_admits(*SOURCES[key], value)), (key, value)
