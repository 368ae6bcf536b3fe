"""The type of every path the `ipgen` command takes: a click.Path that refuses an empty one.

An empty path is bad input, not "the current folder": `--cache-dir ''` would build simulators
into a `simulators/` folder beside the user's files, `-o ''` write into the current folder.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import click


class NonEmptyPath(click.Path):
    """click.Path (as `Path` unless `path_type` says otherwise) refusing "" with a one-line usage
    error that names the option."""

    def __init__(self, **kwargs: Any) -> None:
        kwargs.setdefault("path_type", Path)
        super().__init__(**kwargs)

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> Any:
        if isinstance(value, str) and not value.strip():
            self.fail("an empty path: give a file or folder name (e.g. out/)", param, ctx)
        return super().convert(value, param, ctx)
