"""User-controlled text made safe: short and one-line for messages, inert in generated files.

`abbreviate` keeps an echoed value on one line and at most `MESSAGE_VALUE_CHARS` characters;
`quote_path` turns a path into text that cannot end a comment or start a new line in any file
ipgen writes (C and C++ `//` and `/* */` comments, the resolved scene's `#` comments);
`comment_safe` guards any other text printed into a C or C++ comment (both headers use it).
"""

from __future__ import annotations

import urllib.parse

from ipgen.common.limits import MESSAGE_PATH_CHARS, MESSAGE_VALUE_CHARS

# Characters a quoted path keeps as they are; everything else (control characters, spaces,
# backslashes, '*', '?', '#', quotes, non-ASCII) is percent-encoded (%0A, %5C, ...).
_PATH_SAFE = "/._-+~:=,@"


def abbreviate(text: str, limit: int = MESSAGE_VALUE_CHARS) -> str:
    """`text` on one line (control characters escaped) and at most `limit` characters: the
    middle of a longer text is replaced by "...", so both ends stay visible."""
    shown = "".join(ch if ch.isprintable() else repr(ch)[1:-1] for ch in text)
    if len(shown) <= limit:
        return shown
    head = (limit - 3) * 2 // 3
    return f"{shown[:head]}...{shown[len(shown) - (limit - 3 - head) :]}"


def shown_path(path: object) -> str:
    """A path for a message: `abbreviate`d to `MESSAGE_PATH_CHARS`."""
    return abbreviate(str(path), MESSAGE_PATH_CHARS)


def quote_path(path: str) -> str:
    """`path` percent-encoded except for letters, digits and `/._-+~:=,@`: safe inside any
    comment of a generated file, and unchanged for ordinary paths (scenes/cdip_pulse.toml)."""
    return urllib.parse.quote(path, safe=_PATH_SAFE, errors="surrogateescape")


def comment_safe(text: str) -> str:
    """`text` made safe inside a C block comment on one line: unprintable characters (newlines
    included) and backslashes written as \\xNN (\\uNNNN), `*/` and `/*` broken up, and `??` (a trigraph
    start in C99) written as `?\\x3f`, so that nothing a user typed can end the comment, splice
    lines or start another one."""
    out: list[str] = []
    for char in text:
        if char == "\\" or not char.isprintable():
            code = ord(char)
            out.append(
                f"\\x{code:02x}" if code < 0x100 else f"\\u{code:04x}" if code < 0x10000 else f"\\U{code:08x}"
            )
        elif char == "?" and out and out[-1] == "?":
            out.append("\\x3f")
        elif char == "/" and out and out[-1] == "*":
            out.append("\\x2f")
        elif char == "*" and out and out[-1] == "/":
            out.append("\\x2a")
        else:
            out.append(char)
    return "".join(out)
