"""`ipgen excite SCENE.toml -o EXPERIMENT.toml`: the identification experiment a user should run.

This module reads the options and prints the report; the work is `ipgen.pipeline.excite`
(`ipgen.excitation`). docs/excitation.md is the user's guide.
"""

from __future__ import annotations

from pathlib import Path

import click

from ipgen.command.paths import NonEmptyPath
from ipgen.command.scene_choice import chosen_scene, preset_option
from ipgen.control.excitation import (
    DEFAULT_CHIRP_DURATION,
    DEFAULT_MARGIN,
    DEFAULT_PERIODS,
    DEFAULT_SWING,
    SIGNALS,
)
from ipgen.pipeline.excite import excitation

__all__ = ["command"]


# ---------------------------------------------------------------------------- the command

EXCITE_HELP = """Design the identification experiment for a rig: an excitation about the hanging
equilibrium that keeps the rig within its limits, written as a new scene to run with ipgen run
(or on the rig).

\b
The amplitude is the largest whose motion, predicted by the linear model about hanging over the
whole run, keeps the base within (1 - margin) of --travel and the links within (1 - margin) of
--swing, and at most --u-max. The experiment scene carries [limits] travel: the simulator stops
a run whose base leaves it (exit status 4). Without -o the design is only reported.

\b
Examples:
  ipgen excite --preset qube_servo2 --u-max 10 --travel 1 -o qube_identify.toml
  ipgen excite rig.toml --u-max 5 --travel 0.4 --signal chirp --f-min 0.2 --f-max 5 --duration 60
  ipgen excite --preset qube_servo2 --signal free-decay --travel 1 --duration 30 -o decay.toml
"""


@click.command(
    "excite",
    help=EXCITE_HELP,
    context_settings={"help_option_names": ["-h", "--help"], "max_content_width": 100},
)
@click.argument("scene", type=NonEmptyPath(), metavar="[SCENE.toml]", required=False)
@preset_option
@click.option(
    "-o", "--output", type=NonEmptyPath(), default=None, metavar="EXPERIMENT.toml",
    help="The experiment scene to write (a new file; an existing one only with --force).",
)  # fmt: skip
@click.option(
    "--u-max",
    type=float,
    default=None,
    help="Largest |u| allowed [N, N m, or V with a dc_motor]; required but for a free decay.",
)
@click.option(
    "--travel", type=float, default=None,
    help="The base's limit |θ0| [m on a cart, rad on an arm] [default: the scene's [limits] travel].",
)  # fmt: skip
@click.option("--signal", type=click.Choice(SIGNALS), default="multisine", show_default=True)
@click.option("--f-min", type=float, default=None, help="Band's low end [Hz] [default: from the model].")
@click.option("--f-max", type=float, default=None, help="Band's high end [Hz] [default: from the model].")
@click.option("--period", type=float, default=None, help="Multisine period [s] [default: max(10, 2/f_min)].")
@click.option(
    "--periods", type=int, default=DEFAULT_PERIODS, show_default=True, help="Multisine periods run."
)
@click.option(
    "--duration",
    type=float,
    default=None,
    help=f"Chirp or free-decay length [s] [default: {DEFAULT_CHIRP_DURATION:g}].",
)
@click.option(
    "--sweep", type=click.Choice(("linear", "logarithmic")), default="logarithmic", show_default=True
)
@click.option(
    "--margin",
    type=float,
    default=DEFAULT_MARGIN,
    show_default=True,
    help="Fraction of each limit kept free.",
)
@click.option(
    "--swing", type=float, default=DEFAULT_SWING, show_default=True, help="Links' largest swing [rad]."
)
@click.option(
    "--sample", type=float, default=None, help="Output interval [s] [default: 1/(20 f_max), rounded]."
)
@click.option("--force", is_flag=True, help="Replace an existing experiment scene.")
def command(scene: Path | None, preset: str | None, output: Path | None, **options: object) -> None:
    scene = chosen_scene(scene, preset, "ipgen excite --preset qube_servo2 --u-max 10 --travel 1 -o x.toml")
    design = excitation(scene, output, **options)  # type: ignore[arg-type]
    if design.written is not None:
        click.echo(f"wrote {design.written}")
    else:
        click.echo("(no -o: nothing written)")
    click.echo(design.report())
