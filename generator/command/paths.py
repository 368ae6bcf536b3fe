"""The type of every path the `ipgen` command takes: a click.Path that refuses an empty one.

An empty path is bad input, not "the current folder": `--cache-dir ''` would build simulators
into a `simulators/` folder beside the user's files, `-o ''` write into the current folder.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import click


class NonEmptyPath(click.Path):
    """click.Path (as `Path` unless `path_type` says otherwise) refusing "" (or blanks) with a
    one-line usage error that names the option: `-o '' is empty: ...`."""

    def __init__(self, **kwargs: Any) -> None:
        kwargs.setdefault("path_type", Path)
        super().__init__(**kwargs)

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> Any:
        if isinstance(value, str) and not value.strip():  # job.plan's rule for the generator's -o
            if isinstance(param, click.Option) and param.opts:
                name = param.opts[0]
            else:
                name = param.human_readable_name if param is not None else "a path"
            raise click.UsageError(
                f"{name} {value!r} is empty: name a file or folder, e.g. out/ (or . for this one)", ctx
            )
        return super().convert(value, param, ctx)
