"""What scene messages share: the file they name (`Reader`), values shown as written in
TOML (`show`), type names, choices, and numbers written so that they read back exactly.
"""

from __future__ import annotations

import json
import math
from decimal import Decimal
from pathlib import Path
from typing import NoReturn

from ipgen.common.limits import MESSAGE_PATH_CHARS
from ipgen.common.safetext import abbreviate, shown_path
from ipgen.errors import SceneError


def format_number(x: float) -> str:
    """Shortest text that reads back (strtod / float) as exactly x: 10.0 -> "10", 0.1 -> "0.1"."""
    if x == 0.0:
        return "-0" if math.copysign(1.0, x) < 0 else "0"
    if x.is_integer() and abs(x) < 1e16:
        return str(int(x))
    return repr(x)


class Reader:
    """Raises `SceneError`s that name the scene file."""

    def __init__(self, path: Path) -> None:
        self.path = path

    def fail(self, message: str) -> NoReturn:
        """Raise the message as one line; a very long word in it (a value echoed from the
        scene) is shortened in the middle, so every message stays readable."""
        text = f"{shown_path(self.path.as_posix())}: {message}"
        raise SceneError(" ".join(abbreviate(word, MESSAGE_PATH_CHARS) for word in text.split()))

    def bad(self, key: str, value: object, expected: str) -> NoReturn:
        self.fail(f"{key} = {show(value)}: {expected}")

    def warning(self, message: str) -> str:
        return f"{shown_path(self.path.as_posix())}: warning: {message}"


def show(value: object) -> str:
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
        text = "[" + ", ".join(show(item) for item in value) + "]"
    elif isinstance(value, dict):
        text = "{" + ", ".join(f"{k} = {show(v)}" for k, v in value.items()) + "}"
    elif isinstance(value, int) and value.bit_length() > 14_000:  # str() stops at 4300 digits
        text = hex(value)
    else:
        text = str(value)
    return abbreviate(text)


def _show_decimal(value: Decimal) -> str:
    if value.is_nan():
        return "nan"
    if value.is_infinite():
        return "-inf" if value < 0 else "inf"
    return str(value).lower()  # as written, up to exponent style: 1e5 -> 1e+5


def type_name(value: object) -> str:
    names = {bool: "a boolean", str: "a string", list: "an array", dict: "a table"}
    names.update({int: "an integer", Decimal: "a float"})
    kind = Decimal if isinstance(value, Decimal) else type(value)
    return names.get(kind, f"a {kind.__name__}")


def one_of(options: tuple[str, ...]) -> str:
    """'"a" or "b"', '"a", "b" or "c"'."""
    quoted = [f'"{option}"' for option in options]
    return quoted[0] if len(quoted) == 1 else ", ".join(quoted[:-1]) + " or " + quoted[-1]
