"""The pre-parse check of a TOML text's shape (a scene's): nesting depth and dotted-key length,
in linear time.

tomllib recurses once per nested array or inline table (a RecursionError past ~1,000 levels)
and spends memory quadratic in the number of parts of a dotted key (2.4 GB for 20,000 parts),
so a scene is refused before parsing when it nests deeper than `limits.MAX_SCENE_NESTING` or
has a dotted key of more than `limits.MAX_DOTTED_KEY_PARTS` parts.

The check is one pass over the text that lexes it the way TOML does (strings, multi-line
strings, literal strings and comments are skipped; brackets and braces are counted; runs of
`part.part.part` are counted), so it costs time linear in the text's length whatever the
text is. Each regular expression below is anchored at the current position (`match`, never
`search` from every position) and uses possessive quantifiers, so no match can backtrack: the
position only moves forward. Before, one `search` for dotted keys tried every start inside a
long bare word or string and backtracked over its rest: quadratic (a 100,000-character word
took minutes).
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from ipgen.common import limits

# Characters a bare key part is made of (TOML 1.0), and the blanks that may surround a '.'.
_BARE = re.compile(r"[A-Za-z0-9_-]++")
_BLANKS = re.compile(r"[ \t]++")
# Everything up to the next character that needs a decision (anything else only ends a run of
# dotted key parts, and is handled here in bulk).
_PLAIN = re.compile(r"[^\[\]{}\"'#.A-Za-z0-9_\- \t]++")
# The bodies of the four string forms, up to (not including) their closing quote(s).
_BASIC_BODY = re.compile(r'(?:[^"\\\n]++|\\.)*+')  # '\\' + newline is not allowed on one line
_MULTILINE_BASIC_BODY = re.compile(r'(?:[^"\\]++|\\.|"(?!""))*+', re.DOTALL)
_LITERAL_BODY = re.compile(r"[^'\n]*+")


@dataclass(frozen=True)
class ShapeProblem:
    """Why a scene text is refused before parsing: the 1-based line and the message."""

    line: int
    message: str


def shape_problem(text: str) -> ShapeProblem | None:
    """The first place where `text` nests too deep or has too long a dotted key, or None."""
    scanner = _Scanner(text)
    return scanner.run()


class _Scanner:
    """One pass over a TOML text; `parts` counts the `part.` pairs of the current dotted run."""

    def __init__(self, text: str) -> None:
        self.text = text
        self.depth = 0
        self.parts = 0  # completed "part ." pairs in the current run
        self.has_part = False  # a part was read since the last '.' of the run

    def run(self) -> ShapeProblem | None:
        text, end, pos = self.text, len(self.text), 0
        while pos < end:
            char = text[pos]
            bare = _BARE.match(text, pos)
            if bare:
                self._part()
                pos = bare.end()
            elif char in "[{":
                self.depth += 1
                if self.depth > limits.MAX_SCENE_NESTING:
                    return self._problem(
                        pos,
                        f"arrays or tables nested more than {limits.MAX_SCENE_NESTING} deep; "
                        "a scene needs two levels at most",
                    )
                self._end_run()
                pos += 1
            elif char in "]}":
                self.depth = max(self.depth - 1, 0)
                self._end_run()
                pos += 1
            elif char == ".":
                if self.has_part:
                    self.parts += 1
                    self.has_part = False
                    if self.parts >= limits.MAX_DOTTED_KEY_PARTS:
                        return self._problem(
                            pos,
                            f"a dotted key of more than {limits.MAX_DOTTED_KEY_PARTS} parts; "
                            "scene keys have two (table.key)",
                        )
                else:
                    self._end_run()
                pos += 1
            elif char == '"' or char == "'":
                pos = self._string(pos)
            elif char == "#":
                newline = text.find("\n", pos)
                pos = end if newline < 0 else newline
            elif char in " \t":
                pos = _BLANKS.match(text, pos).end()  # type: ignore[union-attr]
            else:
                self._end_run()
                pos = max(_PLAIN.match(text, pos).end(), pos + 1)  # type: ignore[union-attr]
        return None

    def _string(self, pos: int) -> int:
        """Skip the string starting at `pos`; it counts as one key part. Returns the position
        after it (an unterminated string ends at its line's end: tomllib refuses it)."""
        text = self.text
        quote = text[pos]
        if text.startswith(quote * 3, pos):
            if quote == '"':
                body = _MULTILINE_BASIC_BODY.match(text, pos + 3).end()  # type: ignore[union-attr]
            else:
                close = text.find("'''", pos + 3)
                body = len(text) if close < 0 else close
            after = body
            while after < len(text) and text[after] == quote and after - body < 5:
                after += 1  # the closing three, and up to two quotes that end the content
            self._end_run()  # multi-line strings are values, never keys
            return after
        pattern = _BASIC_BODY if quote == '"' else _LITERAL_BODY
        body = pattern.match(text, pos + 1).end()  # type: ignore[union-attr]
        self._part()
        return body + 1 if body < len(text) and text[body] == quote else body

    def _part(self) -> None:
        """A bare or quoted key part: continues the run after a '.', else starts a new run."""
        if self.has_part:
            self.parts = 0  # two parts without a '.' between them: a new run starts here
        self.has_part = True

    def _end_run(self) -> None:
        self.parts = 0
        self.has_part = False

    def _problem(self, pos: int, message: str) -> ShapeProblem:
        return ShapeProblem(self.text.count("\n", 0, pos) + 1, message)
