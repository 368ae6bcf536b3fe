"""A scene's text with some parameters replaced: what `ipgen identify` writes as the updated scene.

The original file is kept line by line (its comments, tables and order); only the value of each
updated key (`m = [...]` in [parameters], `kt = ...` in [actuator]) is replaced, a key the table
lacks is added after the table's last key, and a missing table is appended. The result is
checked by parsing it again: every updated key must read back as the number written, else a
`SceneError` says the layout could not be updated (nothing is written then).
"""

from __future__ import annotations

import re
import tomllib
from collections.abc import Mapping, Sequence

from ipgen.errors import SceneError

__all__ = ["format_value", "updated_scene_text"]

_TABLE = re.compile(r"^\s*\[\s*([A-Za-z0-9_.-]+)\s*\]\s*(#.*)?$")


def format_value(value: float | Sequence[float]) -> str:
    """A number (shortest repr that reads back exactly) or a list of them, as TOML."""
    if isinstance(value, int | float):
        return repr(float(value))
    return "[" + ", ".join(repr(float(v)) for v in value) + "]"


def _value_end(lines: list[str], start: int, column: int) -> tuple[int, str]:
    """(last line index of the value starting at lines[start][column:], that line's comment)."""
    depth = 0
    index = start
    position = column
    while index < len(lines):
        line = lines[index]
        for k in range(position, len(line)):
            char = line[k]
            if char == "#":
                if depth == 0:
                    return index, line[k:]
                break  # a comment inside a multi-line array: go on with the next line
            if char in "[{":
                depth += 1
            elif char in "]}":
                depth -= 1
        if depth <= 0:
            return index, ""
        index += 1
        position = 0
    raise SceneError("the scene's TOML has an unterminated array: it cannot be updated")


def updated_scene_text(
    text: str, updates: Mapping[tuple[str, str], float | Sequence[float]], header: str
) -> str:
    """`text` with each (table, key) of `updates` set to its value, `header` (comment lines,
    each starting with '#') put first. Raises SceneError if the result does not read back."""
    lines = text.splitlines()
    for (table, key), value in updates.items():
        lines = _set(lines, table, key, format_value(value))
    result = "\n".join([*header.splitlines(), *lines]) + "\n"
    try:
        document = tomllib.loads(result)
    except tomllib.TOMLDecodeError as e:
        raise SceneError(f"the updated scene does not parse ({e}): its layout could not be updated") from None
    for (table, key), value in updates.items():
        read = document.get(table, {}).get(key)
        expected = [float(v) for v in value] if not isinstance(value, int | float) else float(value)
        if read != expected:
            raise SceneError(f"could not update {table}.{key} in the scene (an unusual TOML layout)")
    return result


def _set(lines: list[str], table: str, key: str, value: str) -> list[str]:
    start = None
    end = len(lines)
    for i, line in enumerate(lines):
        match = _TABLE.match(line)
        if match is None:
            continue
        if start is not None:
            end = i
            break
        if match.group(1) == table:
            start = i
    if start is None:
        return [*lines, "", f"[{table}]", f"{key} = {value}"]
    pattern = re.compile(rf"^(\s*{re.escape(key)}\s*=\s*)")
    assignment = re.compile(r"^\s*[A-Za-z0-9_\"'.-]+\s*=\s*")
    last_key = start
    i = start + 1
    while i < end:
        match = pattern.match(lines[i])
        if match:
            stop, comment = _value_end(lines, i, match.end())
            new = f"{match.group(1)}{value}" + (f"  {comment}" if comment else "")
            return [*lines[:i], new, *lines[stop + 1 :]]
        other = assignment.match(lines[i])
        if other:
            i, _ = _value_end(lines, i, other.end())
            last_key = i
        i += 1
    # absent: after the table's last key (its value's last line)
    return [*lines[: last_key + 1], f"{key} = {value}", *lines[last_key + 1 :]]
