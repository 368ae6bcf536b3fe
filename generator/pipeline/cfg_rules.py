"""The simulator's key table and value rules (cpp/include/ipsim/cfg_rules.hpp), generated from the
one statement of each: `CFG_KEYS` (the resolved config's keys) and the scene schema's bounds
(`json_schema`, from `scene.schema`), so that the simulator refuses exactly the values a scene
refuses.

    python -m ipgen.pipeline.cfg_rules        # rewrites cpp/include/ipsim/cfg_rules.hpp

A config key takes a scene key's rule when the config holds that scene value unchanged or scaled
by a positive factor (a motor's gain, a folded rotor: the bounds still hold); keys the scene does
not state directly (gains, plans, matrices) have none. tests/test_cfg_rules.py checks that the
header is current and that the simulator's check and the scene's refuse the same values.
"""

from __future__ import annotations

import math
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ipgen.experiment.config import CFG_KEYS

# config key -> (scene table, key): the scene value the config key holds.
SOURCES: dict[str, tuple[str, str]] = {
    "m": ("parameters", "m"),
    "delta": ("parameters", "delta"),
    "g": ("parameters", "g"),
    "J": ("parameters", "J"),
    "J_axial": ("parameters", "J_axial"),
    "tip": ("parameters", "tip"),
    "coulomb": ("parameters", "coulomb"),
    **{f"controller.model.{key}": ("parameters", key) for key in ("m", "delta", "g", "J", "J_axial", "tip")},
    "coulomb_speed": ("parameters", "coulomb_speed"),
    "actuator.lag": ("actuator", "lag"),
    "limits.travel": ("limits", "travel"),
    "t_end": ("simulation", "t_end"),
    "sample": ("simulation", "sample"),
    "rtol": ("simulation", "rtol"),
    "atol": ("simulation", "atol"),
    "step": ("simulation", "step"),
    "max_steps": ("simulation", "max_steps"),
    "controller.saturation": ("controller", "saturation"),
    "controller.period": ("controller", "period"),
    "controller.horizon": ("controller", "horizon"),
    "controller.substeps": ("controller", "substeps"),
    "controller.r": ("controller", "r"),
    "controller.u_max": ("controller", "u_max"),
    "controller.iterations": ("controller", "iterations"),
    "controller.qp_iterations": ("controller", "qp_iterations"),
    "controller.barrier": ("controller", "barrier"),
    "swingup.u_max": ("swingup", "u_max"),
    "swingup.period": ("swingup", "period"),
    "swingup.hold": ("swingup", "hold"),
    "swingup.gain_energy": ("swingup", "gain_energy"),
    "swingup.gain_position": ("swingup", "gain_position"),
    "swingup.gain_velocity": ("swingup", "gain_velocity"),
    "swingup.accel_max": ("swingup", "accel_max"),
    "swingup.catch_angle": ("swingup", "catch_angle"),
    "swingup.catch_rate": ("swingup", "catch_rate"),
    "swingup.release_angle": ("swingup", "release_angle"),
    "swingup.energy_step": ("swingup", "energy_step"),
    "swingup.catch_deficit": ("swingup", "catch_deficit"),
    "swingup.catch_base": ("swingup", "catch_base"),
    "sensors.measured": ("sensors", "measured"),
    "sensors.resolution": ("sensors", "resolution"),
    "sensors.noise": ("sensors", "noise"),
    "sensors.zero": ("sensors", "zero"),
    "sensors.seed": ("sensors", "seed"),
    "estimator.cutoff": ("estimator", "cutoff"),
    "estimator.gain_spread": ("estimator", "gain_spread"),
    "estimator.gain_drift": ("estimator", "gain_drift"),
    "estimator.lag": ("estimator", "lag"),
    "estimator.noise_memory": ("estimator", "noise_memory"),
}

HEADER = Path(__file__).resolve().parents[2] / "cpp" / "include" / "ipsim" / "cfg_rules.hpp"


@dataclass(frozen=True)
class Range:
    """One allowed interval of a rule (an `enum` of one number is [v, v])."""

    minimum: float = -math.inf
    exclusive_minimum: bool = False
    maximum: float = math.inf
    exclusive_maximum: bool = False
    integer: bool = False

    def admits(self, value: float) -> bool:
        """Whether `value` (finite) lies in the range."""
        above = value > self.minimum if self.exclusive_minimum else value >= self.minimum
        below = value < self.maximum if self.exclusive_maximum else value <= self.maximum
        return above and below and (not self.integer or float(value).is_integer())


@dataclass(frozen=True)
class Rule:
    """A config key's rule: each number of its value finite and in one of `ranges`."""

    key: str
    source: str  # "[table] key", for the message
    ranges: tuple[Range, ...]

    def admits(self, value: float) -> bool:
        """Whether one number of the key's value is allowed."""
        return math.isfinite(value) and any(r.admits(value) for r in self.ranges)

    def says(self) -> str:
        """The rule in words, as the simulator's message ends."""
        return " or ".join(_words(r) for r in self.ranges)


def _words(r: Range) -> str:
    if r.minimum == r.maximum:
        return f"{_number(r.minimum)}"
    parts = []
    if r.minimum > -math.inf:
        parts.append(f"{'>' if r.exclusive_minimum else '>='} {_number(r.minimum)}")
    if r.maximum < math.inf:
        parts.append(f"{'<' if r.exclusive_maximum else '<='} {_number(r.maximum)}")
    text = " and ".join(parts) if parts else "finite"
    return f"a whole number {text}" if r.integer else text


def _number(value: float) -> str:
    return str(int(value)) if float(value).is_integer() and abs(value) < 1e15 else f"{value:g}"


def _ranges(schema: dict[str, Any]) -> tuple[Range, ...]:
    """The number ranges a property's schema allows (its items' for an array, every branch of a oneOf)."""
    if "oneOf" in schema:
        return tuple(r for branch in schema["oneOf"] for r in _ranges(branch))
    if schema.get("type") == "array":
        return _ranges(schema["items"])
    if "enum" in schema:
        return tuple(Range(float(v), False, float(v), False) for v in schema["enum"])
    if schema.get("type") not in ("number", "integer"):
        raise ValueError(f"no number rule in {schema!r}")
    minimum = float(schema.get("minimum", -math.inf))
    maximum = float(schema.get("maximum", math.inf))
    return (
        Range(
            minimum,
            bool(schema.get("exclusiveMinimum", False)),
            maximum,
            bool(schema.get("exclusiveMaximum", False)),
            schema.get("type") == "integer",
        ),
    )


def rules() -> tuple[Rule, ...]:
    """Every config key's rule, in `CFG_KEYS`' order, from the scene schema."""
    from ipgen.pipeline.scene_schema import json_schema

    schema = json_schema()
    tables = {name: prop.get("$ref", "").rsplit("/", 1)[-1] for name, prop in schema["properties"].items()}
    found = []
    for key in CFG_KEYS:
        if key not in SOURCES:
            continue
        table, name = SOURCES[key]
        prop = schema["definitions"][tables[table]]["properties"][name]
        ranges = tuple(dict.fromkeys(_ranges(prop)))  # a scalar's and its array's ranges are the same
        found.append(Rule(key, f"[{table}] {name}", ranges))
    return tuple(found)


def _cpp_number(value: float) -> str:
    if math.isinf(value):
        return "kInf" if value > 0 else "-kInf"
    return repr(float(value))


def header_text() -> str:
    """cpp/include/ipsim/cfg_rules.hpp's text; deterministic."""
    lines = [
        "// cfg_rules.hpp: the resolved config's keys and the rules of their numbers. Generated by",
        "// `python -m ipgen.pipeline.cfg_rules` from ipgen's CFG_KEYS (experiment/config.py) and its",
        "// scene schema (scene/schema.py): do not edit. scene.hpp refuses an unknown key and a number",
        "// outside its key's ranges, so the simulator refuses what a scene refuses.",
        "#pragma once",
        "",
        "#include <cmath>",
        "#include <limits>",
        "",
        "namespace ipsim::cfg {",
        "",
        "inline constexpr double kInf = std::numeric_limits<double>::infinity();",
        "",
        "/// One allowed interval; a number is allowed when it is finite and in one of its rule's ranges.",
        "struct Range {",
        "  double minimum;",
        "  bool exclusive_minimum;",
        "  double maximum;",
        "  bool exclusive_maximum;",
        "  bool integer;",
        "};",
        "",
        "/// A key with a rule: the scene key it comes from and what the rule says, for the message.",
        "struct Rule {",
        "  const char* key;",
        "  const char* source;",
        "  const char* says;",
        "  int first, count;  ///< its ranges in kRanges",
        "};",
        "",
        "/// Every key of a resolved config (CFG_KEYS).",
        "inline constexpr const char* kKeys[] = {",
    ]
    lines += [f'    "{key}",' for key in CFG_KEYS]
    lines += ["};", "", "inline constexpr Range kRanges[] = {"]
    table = rules()
    index = 0
    spans = []
    for rule in table:
        spans.append((rule, index, len(rule.ranges)))
        for r in rule.ranges:
            fields = (
                _cpp_number(r.minimum),
                str(r.exclusive_minimum).lower(),
                _cpp_number(r.maximum),
                str(r.exclusive_maximum).lower(),
                str(r.integer).lower(),
            )
            lines.append(f"    {{{', '.join(fields)}}},  // {rule.key}")
            index += 1
    lines += ["};", "", "inline constexpr Rule kRules[] = {"]
    for rule, first, count in spans:
        lines.append(f'    {{"{rule.key}", "{rule.source}", "{rule.says()}", {first}, {count}}},')
    lines += [
        "};",
        "",
        "/// Whether `value` is allowed as one number of `rule`'s key: finite and in one of its ranges.",
        "inline bool admits(const Rule& rule, double value) {",
        "  if (!std::isfinite(value)) return false;",
        "  for (int i = rule.first; i < rule.first + rule.count; ++i) {",
        "    const Range& r = kRanges[i];",
        "    const bool above = r.exclusive_minimum ? value > r.minimum : value >= r.minimum;",
        "    const bool below = r.exclusive_maximum ? value < r.maximum : value <= r.maximum;",
        "    const bool whole = !r.integer || std::floor(value) == value;",
        "    if (above && below && whole) return true;",
        "  }",
        "  return false;",
        "}",
        "",
        "}  // namespace ipsim::cfg",
        "",
    ]
    return "\n".join(lines)


def main() -> int:
    """Rewrite the header (atomically); 0."""
    text = header_text()
    temporary = HEADER.with_suffix(".hpp.tmp")
    temporary.write_text(text, encoding="utf-8")
    temporary.replace(HEADER)
    print(f"wrote {HEADER}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
