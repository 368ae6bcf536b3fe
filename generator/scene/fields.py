"""Reading one table of a scene: typed getters whose errors name the file and the dotted key.

Shared by the scene reader (`reader.py`) and the `[controller]` table (`controller.py`).
"""

from __future__ import annotations

import json
import math
from decimal import Decimal
from pathlib import Path
from typing import Any, NoReturn

from ipgen.common.safetext import abbreviate, shown_path
from ipgen.errors import SceneError


def format_number(x: float) -> str:
    """Shortest text that reads back (strtod / float) as exactly x: 10.0 -> "10", 0.1 -> "0.1"."""
    if x == 0.0:
        return "-0" if math.copysign(1.0, x) < 0 else "0"
    if x.is_integer() and abs(x) < 1e16:
        return str(int(x))
    return repr(x)


class _Reader:
    """Raises `SceneError`s that name the scene file."""

    def __init__(self, path: Path) -> None:
        self.path = path

    def fail(self, message: str) -> NoReturn:
        text = f"{shown_path(self.path.as_posix())}: {message}"
        raise SceneError(" ".join(text.split()))

    def bad(self, key: str, value: object, expected: str) -> NoReturn:
        self.fail(f"{key} = {_show(value)}: {expected}")

    def warning(self, message: str) -> str:
        return f"{shown_path(self.path.as_posix())}: warning: {message}"


def _show(value: object) -> str:
    """A value as it would be written in TOML, shortened to stay readable in one line."""
    if isinstance(value, bool):
        text = "true" if value else "false"
    elif isinstance(value, Decimal):
        text = _show_decimal(value)
    elif isinstance(value, float):
        text = format_number(value)
    elif isinstance(value, str):
        text = json.dumps(value)
    elif isinstance(value, list):
        text = "[" + ", ".join(_show(item) for item in value) + "]"
    elif isinstance(value, dict):
        text = "{" + ", ".join(f"{k} = {_show(v)}" for k, v in value.items()) + "}"
    else:
        text = str(value)
    return abbreviate(text)


def _show_decimal(value: Decimal) -> str:
    if value.is_nan():
        return "nan"
    if value.is_infinite():
        return "-inf" if value < 0 else "inf"
    return str(value).lower()  # as written, up to exponent style: 1e5 -> 1e+5


def _type_name(value: object) -> str:
    names = {bool: "a boolean", str: "a string", list: "an array", dict: "a table"}
    names.update({int: "an integer", Decimal: "a float"})
    return names.get(type(value), f"a {type(value).__name__}")


def _one_of(options: tuple[str, ...]) -> str:
    """'"a" or "b"', '"a", "b" or "c"'."""
    quoted = [f'"{option}"' for option in options]
    return quoted[0] if len(quoted) == 1 else ", ".join(quoted[:-1]) + " or " + quoted[-1]


class _Section:
    """One table of the document, with typed getters that report dotted keys."""

    def __init__(self, reader: _Reader, document: dict[str, Any], name: str) -> None:
        self.reader = reader
        self.name = name
        self.data: dict[str, Any] = document.get(name, {})

    def key(self, key: str) -> str:
        return f"{self.name}.{key}"

    def has(self, key: str) -> bool:
        return key in self.data

    def raw(self, key: str, expected: str) -> Any:
        if key not in self.data:
            self.reader.fail(f"missing required key '{self.key(key)}' ({expected})")
        return self.data[key]

    def bad(self, key: str, value: object, expected: str) -> NoReturn:
        """Report `key` (e.g. "m" or "m[2]"), showing its value as written if present."""
        self.reader.bad(self.key(key), self._written(key, value), expected)

    def _written(self, key: str, fallback: object) -> object:
        name, _, index = key.partition("[")
        value = self.data.get(name, fallback)
        if index and isinstance(value, list):
            position = int(index.rstrip("]"))
            return value[position] if position < len(value) else fallback
        return value

    def number(self, key: str, expected: str, default: float | None = None) -> float:
        return self.exact_number(key, expected, default)[0]

    def exact_number(self, key: str, expected: str, default: float | str | None = None) -> tuple[float, str]:
        """(float, decimal text as written); `expected` describes the value for messages."""
        if default is not None and key not in self.data:
            return float(default), str(default)
        return _to_number(self.reader, self.key(key), self.raw(key, expected))

    def integer(self, key: str, expected: str, default: int | None = None) -> int:
        if default is not None and key not in self.data:
            return default
        value = self.raw(key, expected)
        if isinstance(value, bool) or not isinstance(value, int):
            hint = " (write it without '.' or an exponent)" if isinstance(value, Decimal) else ""
            self.bad(key, value, f"expected an integer, got {_type_name(value)}{hint}")
        return value

    def choice(self, key: str, options: tuple[str, ...], default: str | None = None) -> str:
        expected = _one_of(options)
        if default is not None and key not in self.data:
            return default
        value = self.raw(key, expected)
        if value not in options or not isinstance(value, str):
            self.bad(key, value, f"expected {expected}")
        return value

    def boolean(self, key: str, default: bool) -> bool:
        value = self.data.get(key, default)
        if not isinstance(value, bool):
            self.bad(key, value, f"expected true or false, got {_type_name(value)}")
        return value

    def array(self, key: str, count: int, what: str) -> list[Any]:
        """A list of exactly `count` entries (links + 1)."""
        value = self.raw(key, f"an array of {count} {what}")
        if not isinstance(value, list):
            self.bad(
                key,
                value,
                f"expected an array of {count} {what}, got {_type_name(value)}",
            )
        if len(value) != count:
            links = count - 1
            layout = f"links + 1 = base + {links} link{'s' if links != 1 else ''}"
            entries = f"{len(value)} entr{'y' if len(value) == 1 else 'ies'}"
            self.reader.fail(f"{self.key(key)} has {entries}, expected {count} ({layout})")
        return value

    def numbers(self, key: str, count: int, default: float | None = None) -> list[tuple[float, str]]:
        """An array of `count` numbers as (float, decimal text) pairs."""
        if default is not None and key not in self.data:
            return [(float(default), str(default))] * count
        items = self.array(key, count, "numbers")
        return [_to_number(self.reader, f"{self.key(key)}[{i}]", v) for i, v in enumerate(items)]


def _to_number(reader: _Reader, key: str, value: Any) -> tuple[float, str]:
    """A finite TOML number (int or float, not bool) as (float, its decimal text)."""
    if isinstance(value, bool) or not isinstance(value, (int, Decimal)):
        reader.bad(key, value, f"expected a number, got {_type_name(value)}")
    if isinstance(value, Decimal) and not value.is_finite():
        reader.bad(key, value, "must be a finite number (inf and nan are not allowed)")
    try:
        as_float = float(value)
    except OverflowError:
        as_float = math.inf
    if not math.isfinite(as_float):
        reader.bad(key, value, "is too large for a double")
    return as_float, str(value)
