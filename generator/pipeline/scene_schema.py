"""The scene format as a JSON Schema for editors (`ipgen --scene-schema`, shipped as
docs/scene.schema.json), from the one declaration of `scene.schema`: draft 4, the draft Taplo (and
so Even Better TOML) implements, its keywords in a canonical order so that any pydantic version
writes the same text.
"""

from __future__ import annotations

from decimal import Decimal
from typing import Any

from pydantic.json_schema import GenerateJsonSchema
from pydantic_core import core_schema

from ipgen.scene.schema import SceneDocument


class SceneJsonSchema(GenerateJsonSchema):
    """A scene number is a JSON number (pydantic writes a Decimal as a number or a string), its
    default written as one; an optional key is its value's schema (TOML has no null)."""

    def decimal_schema(self, schema: core_schema.DecimalSchema) -> dict[str, Any]:
        bounds = {
            key: _json_number(schema[key]) for key in ("gt", "ge", "lt", "le") if schema.get(key) is not None
        }  # type: ignore[literal-required]
        return self.float_schema(core_schema.float_schema(**bounds))

    def nullable_schema(self, schema: core_schema.NullableSchema) -> dict[str, Any]:
        return self.generate_inner(schema["schema"])

    def encode_default(self, dft: Any) -> Any:
        return float(dft) if isinstance(dft, Decimal) else super().encode_default(dft)


def _json_number(value: Any) -> int | float:
    return int(value) if float(value).is_integer() else float(value)


def json_schema() -> dict[str, Any]:
    """The JSON Schema of scene files, for editors: draft 4, the draft Taplo (and so Even Better
    TOML) implements; newer validators read it too."""
    schema = SceneDocument.model_json_schema(
        ref_template="#/definitions/{model}", schema_generator=SceneJsonSchema
    )
    schema["definitions"] = schema.pop("$defs")
    # An empty [input] table is no input, like none at all.
    schema["properties"]["input"]["oneOf"].append(
        {"type": "object", "maxProperties": 0, "description": "an empty table: no input"}
    )
    _draft4(schema)
    return {
        "$schema": "http://json-schema.org/draft-04/schema#",
        **schema,
        "description": (
            "An ipgen scene: one experiment of an n-link inverted pendulum (TOML, SI units). "
            "Arrays of the parameters and the initial state have links + 1 entries: index 0 the "
            "base (cart or arm), 1..n the links. ipgen checks more than this schema can say "
            "(array lengths, relations between keys); docs/scenes.md is the reference."
        ),
    }


def _draft4(node: Any) -> None:
    """Say in draft 4 what pydantic writes in draft 2020-12: exclusive bounds as booleans,
    `const` as a one-value `enum`; drop OpenAPI's `discriminator` and null defaults."""
    if isinstance(node, list):
        for item in node:
            _draft4(item)
        return
    if not isinstance(node, dict):
        return
    for bound, inclusive in (("exclusiveMinimum", "minimum"), ("exclusiveMaximum", "maximum")):
        limit = node.get(bound)
        if isinstance(limit, (int, float)) and not isinstance(limit, bool):
            tighter = max if bound == "exclusiveMinimum" else min
            if inclusive in node and tighter(node[inclusive], limit) == node[inclusive] != limit:
                del node[bound]  # the inclusive bound is the tighter one (rtol >= 1e-15 > 0)
            else:
                node[inclusive], node[bound] = limit, True
    if "const" in node:
        value = node.pop("const")
        node["enum"] = [value]
        if isinstance(value, str):
            node.setdefault("type", "string")
    if len(node.get("allOf", ())) == 1 and list(node["allOf"][0]) == ["$ref"]:
        node["$ref"] = node.pop("allOf")[0]["$ref"]  # older pydantic: the same as a plain $ref
    node.pop("discriminator", None)
    if "default" in node and node["default"] is None:
        del node["default"]
    for value in node.values():
        _draft4(value)


def json_schema_text() -> str:
    """`json_schema()` as the text `ipgen --scene-schema` prints and docs/scene.schema.json holds."""
    import json

    return json.dumps(_canonical(json_schema()), indent=2, ensure_ascii=False) + "\n"


def _canonical(node: Any, names: bool = False) -> Any:
    """The keywords of each schema in sorted order (the same text from any pydantic version);
    the members of `properties` and `definitions` in declaration order."""
    if isinstance(node, list):
        return [_canonical(item) for item in node]
    if not isinstance(node, dict):
        return node
    if names:
        return {name: _canonical(value) for name, value in node.items()}
    return {
        key: _canonical(node[key], names=key in ("properties", "definitions"))
        for key in sorted(node, key=lambda key: (key != "$schema", key))
    }
