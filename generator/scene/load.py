"""Reading a scene file into a validated `schema.SceneDocument`, every problem one line.

`load_document` reads the file (at most `limits.MAX_SCENE_BYTES`, its shape checked by
`common.toml_shape` before parsing), parses it with numbers kept exact (`Decimal`), and validates the
whole document in one pydantic call. `_message` is the one place where pydantic's errors
become ipgen's messages: the file, the dotted key, the value as written and what was expected.
"""

from __future__ import annotations

import decimal
import difflib
import functools
import re
import tomllib
from decimal import Decimal
from pathlib import Path
from typing import Any, NoReturn, get_args

from ipgen.common import limits
from ipgen.common.safetext import abbreviate
from ipgen.common.toml_shape import shape_problem
from ipgen.model.system import PARAMETER_GROUPS
from ipgen.scene import schema
from ipgen.scene.fields import Reader, one_of, type_name
from ipgen.scene.values import Says


def load_document(path: Path) -> tuple[Reader, schema.SceneDocument]:
    """The scene at `path`, validated; raises `SceneError` (one line) on any problem."""
    reader, document = parse_document(path)
    return reader, validate_document(reader, document)


def parse_document(path: Path) -> tuple[Reader, dict[str, Any]]:
    """The scene file's TOML document (numbers as exact `Decimal`s), not yet validated: what
    `validate_document` checks, possibly after a sweep changed some values."""
    reader = Reader(path)
    if not schema.STEM.match(path.stem):
        reader.fail(
            f"scene file name '{abbreviate(path.stem)}' must be letters, digits, '_', '.', '+' or '-' "
            "(it names the output files)"
        )
    if len(path.stem) > limits.MAX_STEM_LENGTH:
        reader.fail(
            f"scene file name is {len(path.stem)} characters long: use at most {limits.MAX_STEM_LENGTH} "
            "(it names the output files)"
        )
    return reader, _parse_toml(reader, _read_text(reader))


FIXED_NOT_YET = "not yet supported for fixed-pivot models"


def validate_document(reader: Reader, document: dict[str, Any]) -> schema.SceneDocument:
    """`document` validated against the scene format; `SceneError` (one line) naming `reader`'s file.
    A fixed-pivot scene (`[system] type = "fixed"`, read by `scene.fixed` and the commands that
    take it: ipgen --scene -o, run, sweep, identify) is refused here: what validates a cart's or
    an arm's scene does not take it."""
    system = document.get("system")
    if isinstance(system, dict) and system.get("type") == "fixed":
        reader.fail(
            f'[system] type = "fixed": this command is {FIXED_NOT_YET} (these read it: ipgen --scene FILE '
            "-o DIR or --describe, ipgen run, sweep, identify and ipgen.FixedPendulum.from_scene)"
        )
    return _validate(reader, document)


def _read_text(reader: Reader) -> str:
    try:
        if reader.path.stat().st_size > limits.MAX_SCENE_BYTES:
            reader.fail(
                f"is {reader.path.stat().st_size} bytes, more than a scene needs "
                f"(at most {limits.MAX_SCENE_BYTES} bytes): is it the right file?"
            )
        data = reader.path.read_bytes()
    except FileNotFoundError:
        reader.fail("no such file")
    except IsADirectoryError:
        reader.fail("is a directory, expected a TOML scene file")
    except OSError as exc:
        reader.fail(f"cannot read file: {exc.strerror or exc}")
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        reader.fail(f"not UTF-8 text (bad byte at offset {exc.start})")


class _Beyond(Decimal):
    """A TOML float whose exponent no Decimal holds (1e9999999999999999999): the largest Decimal
    of its sign, refused as too large for a double like 1e400, shown as written."""

    text: str

    def __str__(self) -> str:
        return self.text


def _decimal(text: str) -> Decimal:
    try:
        return Decimal(text)
    except decimal.InvalidOperation:  # an exponent beyond ±MAX_EMAX
        sign = "-" if text.startswith("-") else ""
        if "-" in text.lower().split("e", 1)[-1]:
            return Decimal(sign + "0")  # below every double: 0, as 1e-400 is
        beyond = _Beyond(f"{sign}1e{decimal.MAX_EMAX}")
        beyond.text = text
        return beyond


def _parse_toml(reader: Reader, text: str) -> dict[str, Any]:
    """Parse TOML keeping floats as Decimal, i.e. exactly as written; refuse, before parsing,
    nesting deeper than a scene can need and very long dotted keys (`common.toml_shape`)."""
    problem = shape_problem(text)
    if problem:
        reader.fail(f"line {problem.line}: {problem.message}")
    try:
        return tomllib.loads(text, parse_float=_decimal)
    except tomllib.TOMLDecodeError as exc:
        reader.fail(f"malformed TOML: {abbreviate(_named(str(exc), text), 120)}")
    except RecursionError:  # not expected after shape_problem: one line all the same
        reader.fail(f"nested too deeply to parse (at most {limits.MAX_SCENE_NESTING} levels)")
    except ValueError:  # Python reads at most 4300 decimal digits into an integer
        found = re.search(r"(?<![\d.])\d{4301,}", text)  # a run of digits from its start
        where = f"line {text.count(chr(10), 0, found.start()) + 1}: " if found else ""
        limit = "a scene's numbers fit a double (at most 1.8e308)"
        reader.fail(f"{where}an integer of more than 4300 digits: {limit}")


def _named(message: str, text: str) -> str:
    """tomllib's message, with the key named where it only says a value cannot be overwritten (a
    key or table given twice): `rtol` is given twice (at line 34): remove one."""
    found = re.fullmatch(r"Cannot (?:overwrite a value|declare .*?) \(at line (\d+), column \d+\)", message)
    if not found:
        return message
    number = int(found.group(1))
    lines = text.splitlines()
    line = lines[number - 1].strip() if 0 < number <= len(lines) else ""
    key = line.split("=", 1)[0].strip() if "=" in line and not line.startswith("[") else line
    return f"{abbreviate(key, 60)} is given twice (line {number}): remove one" if key else message


# ---------------------------------------------------------------------------- validation


def _validate(reader: Reader, document: dict[str, Any]) -> schema.SceneDocument:
    """The document validated in one call, the tables in the order of `SceneDocument` sharing
    one context (`Table.context`); the first problem as one line."""
    from pydantic import ValidationError

    context: dict[str, Any] = {}
    try:
        return _adapter().validate_python(document, context=context)
    except ValidationError as error:
        refuse(reader, document, error.errors(include_url=False), context)


@functools.cache
def _adapter() -> Any:
    """The pydantic validator of a scene (built once)."""
    from pydantic import TypeAdapter

    return TypeAdapter(schema.SceneDocument)


def refuse(reader: Reader, document: dict[str, Any], errors: list[Any], context: dict[str, Any]) -> NoReturn:
    """The first problem: an unknown table or key, or a table that is not one, first (in the
    file's order: a typo explains a missing key), else the first of pydantic's `errors`."""
    given = document.get("input")
    if isinstance(given, dict) and "kind" not in given:  # no model to find [input]'s unknown keys
        unknown = [key for key in given if key not in schema.TABLES["input"]]
        errors = [{"type": "extra_forbidden", "loc": ("input", key)} for key in unknown] + errors
    order = {name: i for i, name in enumerate(document)}
    structural = [error for error in errors if _structural(error, document)]
    if structural:
        first = min(structural, key=lambda e: (order.get(e["loc"][0], -1), _key_order(e, document)))
        _unknown(reader, first, document)
    table = errors[0]["loc"][0]  # in it, a key of another input kind first
    extra = (e for e in errors if e["loc"][0] == table and e["type"] == "extra_forbidden")
    reader.fail(_message(next(extra, errors[0]), document, context))


def _structural(error: dict[str, Any], document: dict[str, Any]) -> bool:
    loc = error["loc"]
    if len(loc) == 1 and loc[0] in schema.TABLES and not isinstance(document.get(loc[0], {}), dict):
        return True  # system = 5: not a table
    if error["type"] != "extra_forbidden":
        return False
    if len(loc) == 1:
        return True  # an unknown table
    return loc[-1] not in schema.TABLES[loc[0]]  # [input]: known to another kind is not unknown


def _key_order(error: dict[str, Any], document: dict[str, Any]) -> int:
    table = document.get(error["loc"][0])
    return list(table).index(error["loc"][-1]) if isinstance(table, dict) and len(error["loc"]) > 1 else -1


def _unknown(reader: Reader, error: dict[str, Any], document: dict[str, Any]) -> NoReturn:
    loc = error["loc"]
    name = loc[0]
    if len(loc) == 1 and name in schema.TABLES:
        reader.bad(name, document[name], f"expected a table: [{name}] on a line of its own")
    if len(loc) == 1:
        what = "table" if isinstance(document[name], dict) else "key"
        reader.fail(f"unknown {what} '{abbreviate(name)}'{_hint(name, tuple(schema.TABLES), '')}")
    key = loc[-1]
    reader.fail(f"unknown key '{name}.{abbreviate(key)}'{_hint(key, schema.TABLES[name], name)}")


def _hint(key: str, allowed: tuple[str, ...], table: str) -> str:
    """' (did you mean ...?)' or where the key belongs, for an unknown key."""
    homes = [name for name, keys in schema.TABLES.items() if key in keys and name != table]
    if homes:
        return f" (it belongs in [{homes[0]}])"
    array = key.rstrip("0123456789")
    if table == "parameters" and array in PARAMETER_GROUPS:
        return f" (parameters are arrays: {array} = [base, link 1, ...])"
    close = difflib.get_close_matches(key, allowed, n=1)
    if close:
        return f" (did you mean '{close[0]}'?)"
    return f" (expected one of: {', '.join(allowed)})"


def _message(error: dict[str, Any], document: dict[str, Any], context: dict[str, Any]) -> str:
    """One pydantic error as ipgen's words: `<dotted key> = <value as written>: <expected>`."""
    kind, loc, ctx = error["type"], list(error["loc"]), dict(error.get("ctx") or {})
    table = loc.pop(0)
    model = schema.SceneDocument.model_fields[table].annotation
    if table == "input":
        data = document.get("input") or {}
        if kind in ("union_tag_not_found", "union_tag_invalid", "model_attributes_type"):
            if not isinstance(data, dict) or "kind" not in data:
                return f"missing required key 'input.kind' (one of: {', '.join(schema.INPUTS)})"
            return _bad("input.kind", data["kind"], f"expected {one_of(tuple(schema.INPUTS))}")
        model = schema.INPUTS[loc.pop(0)]  # the kind's model: loc = [kind, key, ...]
    model = next(
        a for a in (*get_args(model), model) if isinstance(a, type) and issubclass(a, schema.BaseModel)
    )
    key = ctx.get("key") or next((part for part in loc if isinstance(part, str)), "")
    indices = [part for part in loc if isinstance(part, int)] + list(ctx.get("index", ()))
    dotted = f"{table}.{key}" + "".join(f"[{i}]" for i in indices)
    value = ctx.get("value", error["input"])
    field = model.model_fields.get(key)
    says = _says(field)
    if kind == "scene_key":
        return dotted + ctx["message"]
    if kind == "scene_line":
        return ctx["message"]
    if kind == "missing":
        return f"missing required key '{dotted}' ({_what(field, says, context)})"
    if kind == "extra_forbidden":
        kind_name = document["input"]["kind"]
        takes = ", ".join(schema.INPUT_KEYS[kind_name]) or "no other keys"
        return f"{dotted} is not used by a '{kind_name}' input ({kind_name} takes {takes})"
    expected = {
        "scene_value": ctx.get("expected", ""),
        "number_type": f"expected a number, got {type_name(value)}",
        "double_range": "is too large for a double",
        "finite_number": "must be a finite number (inf and nan are not allowed)",
        "int_type": f"expected an integer, got {type_name(value)}"
        + (" (write it without '.' or an exponent)" if isinstance(value, Decimal) else ""),
        "bool_type": f"expected true or false, got {type_name(value)}",
        "string_type": f"expected a string, got {type_name(value)}",
        "literal_error": f"expected {ctx.get('expected', '').replace(chr(39), chr(34))}",
        "tuple_type": f"expected an array of {context.get('count', 2)} numbers, got {type_name(value)}",
    }.get(kind)
    if expected is None and kind in ("greater_than", "greater_than_equal", "less_than", "less_than_equal"):
        expected = says.bound.format(**context)
    if expected is None:  # not expected: every kind a scene can meet is above
        expected = abbreviate(error["msg"])
    return _bad(dotted, value, expected)


def _bad(key: str, value: object, expected: str) -> str:
    from ipgen.scene.fields import show

    return f"{key} = {show(value)}: {expected}"


def _says(field: Any) -> Says:
    """ipgen's words for a field: its `Says`, or the one inside an optional value."""
    if field is None:
        return Says()
    found = [item for item in field.metadata if isinstance(item, Says)]
    stack = [field.annotation]
    while stack and not found:
        annotation = stack.pop()
        found = [item for item in getattr(annotation, "__metadata__", ()) if isinstance(item, Says)]
        stack += get_args(annotation)
    return found[0] if found else Says()


def _what(field: Any, says: Says, context: dict[str, Any]) -> str:
    """What a missing key is: its `Says.what`, or its choices."""
    if says.what:
        return says.what.format(**context)
    choices = [arg for arg in get_args(field.annotation) if isinstance(arg, str)]
    return one_of(tuple(choices)) if choices else ""
