"""A command's scene: a file the user names, or a preset shipped with ipgen (`--preset NAME`)."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import TypeVar

import click

from ipgen.pipeline.job import OptionsError

F = TypeVar("F", bound=Callable[..., object])


def preset_option(function: F) -> F:
    """`--preset NAME`: one of the scenes `ipgen presets` lists, instead of a scene file."""
    return click.option(
        "--preset",
        default=None,
        metavar="NAME",
        help="A preset scene shipped with ipgen instead of a file (ipgen presets lists them).",
    )(function)  # type: ignore[return-value]


def chosen_scene(scene: Path | None, preset: str | None, example: str) -> Path:
    """The scene file: `scene`, or the preset's file; exactly one of them must be given."""
    if scene is not None and preset is not None:
        raise OptionsError(f"give a scene file or --preset, not both, e.g. {example}")
    if preset is not None:
        from ipgen.common.presets import preset_path

        return preset_path(preset)
    if scene is None:
        raise OptionsError(
            f"missing the scene: a file or --preset NAME (ipgen presets lists them), e.g. {example}"
        )
    return scene
