"""The kinds of value a scene key takes, for the declaration in `schema.py`.

Each kind (`Number`, `Integer`, `Choice`, `Flag`, `Text`, `PerLink`, `Names`, `Custom`) is a
pydantic annotation that gives both halves of a key's declaration:

- its validation: a TOML value (as `tomllib.loads(..., parse_float=Decimal)` gives it) is
  checked and converted, and every problem raises a `PydanticCustomError` that carries ipgen's
  one-line message (`reader.py` adds the file and the dotted key);
- its JSON Schema (`ipgen --scene-schema`): type, bounds, choices, for editors.

Numbers stay exact: a `Number` is an `Exact` pair (float, decimal text as written), so a
specialised header folds 0.1 as 1/10. Bounds are declared once (`Gt(0, "masses must be > 0 kg")`)
and give the check, its message and the schema's `exclusiveMinimum`. Messages may name
`{count}` (links + 1) and other entries of the validation context (see `reader.py`); the
context's "fields" are the keys of the same table validated so far (declaration order).
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from decimal import Decimal
from typing import Any, NamedTuple, NoReturn

from pydantic_core import PydanticCustomError, core_schema

from ipgen.scene.fields import _one_of, _type_name


class Exact(NamedTuple):
    """A number as a float and as its decimal text, exactly as written ("0.1", "1e-3", "9.81")."""

    value: float
    text: str


# ---------------------------------------------------------------------------- refusals


def refuse(expected: str, **shown: Any) -> NoReturn:
    """`<key> = <value>: <expected>` (the value at the error's location, or `shown["value"]`;
    `shown["key"]` names another key of the same table)."""
    raise PydanticCustomError("scene_value", "{expected}", {"expected": expected, **shown})


def refuse_key(message: str, **where: Any) -> NoReturn:
    """`<key><message>`, e.g. "parameters.m" + " has 2 entries, expected 3 (...)" (`where`: as
    for `refuse`, `key` and `index`)."""
    raise PydanticCustomError("scene_key", "{message}", {"message": message, **where})


def refuse_line(message: str) -> NoReturn:
    """A message that names its own keys."""
    raise PydanticCustomError("scene_line", "{message}", {"message": message})


# ---------------------------------------------------------------------------- bounds


_JSON_BOUND = {">": "exclusiveMinimum", ">=": "minimum", "<": "exclusiveMaximum", "<=": "maximum"}


@dataclass(frozen=True)
class Bound:
    """value <op> limit, else the message."""

    op: str
    limit: float
    message: str

    def holds(self, x: float) -> bool:
        return {
            ">": x > self.limit,
            ">=": x >= self.limit,
            "<": x < self.limit,
            "<=": x <= self.limit,
        }[self.op]


def Gt(limit: float, message: str) -> Bound:
    return Bound(">", limit, message)


def Ge(limit: float, message: str) -> Bound:
    return Bound(">=", limit, message)


def Lt(limit: float, message: str) -> Bound:
    return Bound("<", limit, message)


def Le(limit: float, message: str) -> Bound:
    return Bound("<=", limit, message)


# ---------------------------------------------------------------------------- kinds


class Kind:
    """A pydantic annotation: `check` validates, `json` is the JSON Schema, `what` describes
    the value for "missing required key" messages."""

    what: str = ""

    def check(self, value: Any, context: dict[str, Any]) -> Any:
        raise NotImplementedError

    def json(self) -> dict[str, Any]:
        raise NotImplementedError

    def expected(self, context: dict[str, Any]) -> str:
        return self.what.format(**context)

    def __get_pydantic_core_schema__(self, source: Any, handler: Any) -> core_schema.CoreSchema:
        return core_schema.with_info_plain_validator_function(
            lambda value, info: self.check(value, {**(info.context or {}), "fields": info.data or {}})
        )

    def __get_pydantic_json_schema__(self, schema: Any, handler: Any) -> dict[str, Any]:
        return self.json()


def exact_number(
    value: Any, *, finite: str = "must be a finite number (inf and nan are not allowed)"
) -> Exact:
    """A finite TOML number (int or float, not bool) as an `Exact`."""
    if isinstance(value, bool) or not isinstance(value, (int, Decimal, float)):
        refuse(f"expected a number, got {_type_name(value)}")
    if isinstance(value, Decimal) and not value.is_finite():
        refuse(finite)
    try:
        as_float = float(value)
    except OverflowError:
        as_float = math.inf
    if not math.isfinite(as_float):
        refuse("is too large for a double" if not isinstance(value, float) else finite)
    return Exact(as_float, repr(value) if isinstance(value, float) else str(value))


@dataclass(frozen=True)
class Number(Kind):
    """A finite number (TOML integer or float), kept exact, within its bounds."""

    what: str = ""
    bounds: tuple[Bound, ...] = ()

    def check(self, value: Any, context: dict[str, Any]) -> Exact:
        number = exact_number(value)
        for bound in self.bounds:
            if not bound.holds(number.value):
                refuse(bound.message.format(**context))
        return number

    def json(self) -> dict[str, Any]:
        schema: dict[str, Any] = {"type": "number"}
        for bound in self.bounds:
            schema[_JSON_BOUND[bound.op]] = bound.limit
        return schema


@dataclass(frozen=True)
class Integer(Kind):
    """A TOML integer (not a float, not a bool), within its bounds."""

    what: str = ""
    bounds: tuple[Bound, ...] = ()

    def check(self, value: Any, context: dict[str, Any]) -> int:
        if isinstance(value, bool) or not isinstance(value, int):
            hint = " (write it without '.' or an exponent)" if isinstance(value, Decimal) else ""
            refuse(f"expected an integer, got {_type_name(value)}{hint}")
        for bound in self.bounds:
            if not bound.holds(value):
                refuse(bound.message.format(**context))
        return value

    def json(self) -> dict[str, Any]:
        schema: dict[str, Any] = {"type": "integer"}
        for bound in self.bounds:
            schema[_JSON_BOUND[bound.op]] = bound.limit
        return schema


@dataclass(frozen=True)
class Choice(Kind):
    """One of a few strings."""

    options: tuple[str, ...] = ()

    def expected(self, context: dict[str, Any]) -> str:
        return _one_of(self.options)

    def check(self, value: Any, context: dict[str, Any]) -> str:
        if not isinstance(value, str) or value not in self.options:
            refuse(f"expected {_one_of(self.options)}")
        return value

    def json(self) -> dict[str, Any]:
        return {"type": "string", "enum": list(self.options)}


@dataclass(frozen=True)
class Flag(Kind):
    """true or false."""

    def check(self, value: Any, context: dict[str, Any]) -> bool:
        if not isinstance(value, bool):
            refuse(f"expected true or false, got {_type_name(value)}")
        return value

    def json(self) -> dict[str, Any]:
        return {"type": "boolean"}


@dataclass(frozen=True)
class Text(Kind):
    """A string that `problem` accepts (None) or explains (a phrase; the message adds `fix`)."""

    problem: Callable[[str], str | None] = lambda text: None
    fix: str = ""
    pattern: str | None = None  # for the JSON Schema only (editors); `problem` is the rule
    max_length: int | None = None

    def check(self, value: Any, context: dict[str, Any]) -> str:
        if not isinstance(value, str):
            refuse(f"expected a string, got {_type_name(value)}")
        problem = self.problem(value)
        if problem:
            refuse(f"{problem}; {self.fix}")
        return value

    def json(self) -> dict[str, Any]:
        schema: dict[str, Any] = {"type": "string"}
        if self.pattern is not None:
            schema["pattern"] = self.pattern
        if self.max_length is not None:
            schema["maxLength"] = self.max_length
        return schema


@dataclass(frozen=True)
class PerLink(Kind):
    """An array of links + 1 entries (index 0 the base, 1..n the links), each an `item`."""

    item: Number = field(default_factory=Number)

    def expected(self, context: dict[str, Any]) -> str:
        return f"an array of {context['count']} numbers"

    def check(self, value: Any, context: dict[str, Any]) -> tuple[Exact, ...]:
        count = context["count"]
        if not isinstance(value, list):
            refuse(f"expected an array of {count} numbers, got {_type_name(value)}")
        check_count(value, count, f"links + 1 = base + {count - 1} link{'s' if count != 2 else ''}")
        return tuple(at(i, self.item.check, item, context) for i, item in enumerate(value))

    def json(self) -> dict[str, Any]:
        return {"type": "array", "items": self.item.json(), "minItems": 2}


@dataclass(frozen=True)
class Custom(Kind):
    """A value checked by ipgen's own function `validate(value, context)`, with a hand-written
    JSON Schema (e.g. an array of names, or a string or an array)."""

    validate: Callable[[Any, dict[str, Any]], Any] = lambda value, context: value
    schema: dict[str, Any] = field(default_factory=dict)

    def check(self, value: Any, context: dict[str, Any]) -> Any:
        return self.validate(value, context)

    def json(self) -> dict[str, Any]:
        return json.loads(json.dumps(self.schema))  # a copy: pydantic may edit it


def check_count(value: list[Any], count: int, layout: str) -> None:
    """An array of exactly `count` entries, else "<key> has N entries, expected count (layout)"."""
    if len(value) != count:
        entries = f"{len(value)} entr{'y' if len(value) == 1 else 'ies'}"
        refuse_key(f" has {entries}, expected {count} ({layout})")


def at(index: int, check: Callable[[Any, dict[str, Any]], Any], value: Any, context: dict[str, Any]) -> Any:
    """`check(value)` for entry `index` of an array: its errors name `key[index]`."""
    try:
        return check(value, context)
    except PydanticCustomError as error:
        context_ = dict(error.context or {})
        context_["index"] = (index, *context_.get("index", ()))
        context_.setdefault("value", value)
        raise PydanticCustomError(error.type, error.message_template, context_) from None
