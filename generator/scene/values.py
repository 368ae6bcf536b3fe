"""The kinds of value a scene key takes, as pydantic annotations for `schema.py`.

A scene is parsed with `tomllib.loads(..., parse_float=Decimal)`, so a TOML number is an `int`
or a `Decimal` exactly as written (0.1 stays 1/10 for a specialised header). The kinds:

- `Real(gt=…, ge=…, lt=…, le=…, says=…, what=…)`: a finite number, validated to a `Decimal` by
  pydantic's own `Decimal` with its bounds and `allow_inf_nan=False`; before that, one check
  that the value is a TOML number (not a string or a boolean, which pydantic's lax `Decimal`
  would convert) and fits a double;
- `PerLink(item)`: a `tuple` of links + 1 items (the count comes from the validation context);
- `Literal[...]` (choices), `Annotated[int, Field(strict=True, ge=1)]`, `Annotated[bool,
  Field(strict=True)]`, `Annotated[str, Field(strict=True)]`: pydantic's own.

`Says` carries ipgen's words for a key: the message when a bound fails and what the key is (for
"missing required key"); `load.py` turns pydantic's error types into the one-line messages in
one place. ipgen's own rules raise `refuse` (`<key> = <value>: <expected>`), `refuse_key`
(`<key><message>`) or `refuse_line` (a message that names its own keys).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from decimal import Decimal
from functools import partial
from typing import Annotated, Any, NamedTuple, NoReturn, get_args

from pydantic import BeforeValidator, Field, ValidationInfo
from pydantic_core import PydanticCustomError

from ipgen.common.arrays import float_or_inf


class Says(NamedTuple):
    """ipgen's words for a key: `bound` when one of its bounds fails (may name `{u_unit}`,
    `{count}` and other entries of the validation context), `what` it is for a missing key."""

    bound: str = ""
    what: str = ""


def refuse(expected: str, **shown: Any) -> NoReturn:
    """`<key> = <value>: <expected>` (the value at the error's location, or `shown["value"]`;
    `shown["key"]` names another key of the same table, `shown["index"]` an entry)."""
    raise PydanticCustomError("scene_value", "{expected}", {"expected": expected, **shown})


def refuse_key(message: str, **where: Any) -> NoReturn:
    """`<key><message>`, e.g. "parameters.m" + " has 2 entries, expected 3 (...)"."""
    raise PydanticCustomError("scene_key", "{message}", {"message": message, **where})


def refuse_line(message: str) -> NoReturn:
    """A message that names its own keys."""
    raise PydanticCustomError("scene_line", "{message}", {"message": message})


def context_of(info: ValidationInfo, *keys: str) -> dict[str, Any] | None:
    """The validation context, or None while a table before this one failed to give `keys`
    (its error is the one reported: the rules that need them are skipped)."""
    context = info.context if info.context is not None else {}
    return context if all(key in context for key in keys) else None


# ---------------------------------------------------------------------------- numbers


def toml_number(value: Any, gt: float | None = None, lt: float | None = None) -> Any:
    """A TOML integer or float (not a boolean, not a string) whose value fits a double; inf and
    nan are left to pydantic's `allow_inf_nan=False`. The strict bounds `gt` and `lt` hold for the
    double too (1e-400 > 0, but its double is 0; 0.99999999999999999999 < 1, but its double is 1:
    the simulator reads the double)."""
    if isinstance(value, bool) or not isinstance(value, int | Decimal):
        raise PydanticCustomError("number_type", "expected a number")
    if isinstance(value, Decimal) and not value.is_finite():
        return value
    as_float = float_or_inf(value)  # inf: an integer beyond 1.8e308
    if not math.isfinite(as_float):
        raise PydanticCustomError("double_range", "is too large for a double")
    if gt is not None and not as_float > gt:
        raise PydanticCustomError("greater_than", "Input should be greater than {gt}", {"gt": gt})
    if lt is not None and not as_float < lt:
        raise PydanticCustomError("less_than", "Input should be less than {lt}", {"lt": lt})
    return value


def Real(
    *,
    gt: float | None = None,
    ge: float | None = None,
    lt: float | None = None,
    le: float | None = None,
    says: str = "",
    what: str = "",
) -> Any:
    """A finite number kept exact (`Decimal`), within pydantic's bounds (`says` when one fails)."""
    return Annotated[
        Decimal,
        Field(gt=gt, ge=ge, lt=lt, le=le, allow_inf_nan=False),
        BeforeValidator(partial(toml_number, gt=gt, lt=lt)),
        Says(says, what),
    ]


def says_of(annotation: Any) -> Says:
    """The `Says` of an annotation built by `Real` (or an empty one)."""
    return next((item for item in get_args(annotation)[1:] if isinstance(item, Says)), Says())


def PerLink(item: Any) -> Any:
    """An array of links + 1 entries (index 0 the base, 1..n the links), each an `item`."""
    return Annotated[
        tuple[item, ...],
        BeforeValidator(_per_link_count),
        Field(json_schema_extra={"minItems": 2}),
        says_of(item)._replace(what="an array of {count} numbers"),
    ]


def _per_link_count(value: Any, info: ValidationInfo) -> Any:
    context = context_of(info, "count")
    if isinstance(value, list) and context is not None:
        count = context["count"]
        check_count(value, count, f"links + 1 = base + {count - 1} link{'s' if count != 2 else ''}")
    return value


def check_count(value: list[Any], count: int, layout: str) -> None:
    """An array of exactly `count` entries, else "<key> has N entries, expected count (layout)"."""
    if len(value) != count:
        entries = f"{len(value)} entr{'y' if len(value) == 1 else 'ies'}"
        from ipgen.common.safetext import abbreviate  # a huge `links` stays one short line

        refuse_key(f" has {entries}, expected {abbreviate(str(count), 24)} ({abbreviate(layout, 60)})")


def at(index: int, check: Callable[[Any, dict[str, Any]], Any], value: Any, context: dict[str, Any]) -> Any:
    """`check(value, context)` for entry `index` of an array: its errors name `key[index]`."""
    try:
        return check(value, context)
    except PydanticCustomError as error:
        context_ = dict(error.context or {})
        context_["index"] = (index, *context_.get("index", ()))
        context_.setdefault("value", value)
        raise PydanticCustomError(error.type, error.message_template, context_) from None


def number(value: Any, context: dict[str, Any] | None = None) -> float:
    """An entry of an array that is not a per-link array (weights, angles) as a float."""
    if isinstance(value, bool) or not isinstance(value, int | Decimal):
        from ipgen.scene.fields import type_name

        refuse(f"expected a number, got {type_name(value)}")
    as_float = float_or_inf(value)
    if not math.isfinite(as_float):
        refuse("must be a finite number")
    return as_float


def keyed(key: str, value: Any) -> Decimal:
    """A number checked in a table's rule (e.g. [simulation] step, by method): errors name `key`."""
    from ipgen.scene.fields import type_name

    if isinstance(value, Decimal) and not value.is_finite():
        refuse("must be a finite number (inf and nan are not allowed)", key=key, value=value)
    try:
        return Decimal(toml_number(value))
    except PydanticCustomError as error:
        wrong_type = error.type == "number_type"
        refuse(
            f"expected a number, got {type_name(value)}" if wrong_type else str(error), key=key, value=value
        )
