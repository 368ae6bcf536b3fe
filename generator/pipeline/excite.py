"""`ipgen excite`'s work as a library function (`ipgen.excitation`): the identification experiment
a user should run.

The design is the library's (`ipgen.control.excitation.design`: the excitation about hanging
that keeps the rig within its limits, predicted by the linear model), the experiment scene's
text the scene layer's (`pipeline.excitation_scene.scene_text`); this module writes the file
(validated first; an existing one replaced only with `force`, the input scene never).
docs/excitation.md is the user's guide; command/excite.py the command.
"""

from __future__ import annotations

import tempfile
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING

from ipgen.common.safetext import shown_path
from ipgen.control.excitation import (
    DEFAULT_MARGIN,
    DEFAULT_PERIODS,
    DEFAULT_SWING,
    Design,
    ExcitationError,
)
from ipgen.control.excitation import design as excitation_design

if TYPE_CHECKING:
    from ipgen.experiment.scene import Scene

__all__ = ["Design", "ExcitationError", "excitation"]


def excitation(
    scene: str | Path,
    output: str | Path | None = None,
    *,
    u_max: float | None = None,
    travel: float | None = None,
    signal: str = "multisine",
    f_min: float | None = None,
    f_max: float | None = None,
    period: float | None = None,
    periods: int = DEFAULT_PERIODS,
    duration: float | None = None,
    sweep: str = "logarithmic",
    margin: float = DEFAULT_MARGIN,
    swing: float = DEFAULT_SWING,
    sample: float | None = None,
    force: bool = False,
) -> Design:
    """Design an excitation for the rig of `scene` and, given `output`, write the experiment scene.

    The amplitude is the largest (3 significant digits) whose excursions, predicted by the
    linear model about hanging, stay within (1 − `margin`) of `travel` and `swing`, and at most
    `u_max`. docs/excitation.md is the guide.

    Parameters
    ----------
    scene : str or Path
        The rig's scene file (TOML).
    output : str or Path, optional
        The experiment scene to write (a new .toml file; an existing one only with `force`, the
        rig's own scene never). Without it the design is only returned.
    u_max : float, optional
        The largest |u| allowed [N, N m, or V with a dc_motor]; required but for a free decay.
    travel : float, optional
        The base's limit |θ0| [m or rad] (default: the scene's [limits] travel).
    signal : {"multisine", "chirp", "free-decay"}, optional
        multisine: every harmonic of 1/`period` in [f_min, f_max], run for `periods` periods;
        chirp: f_min to f_max over `duration` s; free-decay: no input, link 1 released from
        rest at (1 − `margin`) · `swing` off hanging or less, for `duration` s.
    f_min, f_max : float, optional
        The band [Hz] (default: a fifth of the hanging pendulum's lowest natural frequency up
        to five times its highest).
    period : float, optional
        The multisine's period [s] (default max(10, 2/f_min)).
    periods : int, optional
        Multisine periods run.
    duration : float, optional
        The chirp's or free decay's length [s].
    sweep : {"logarithmic", "linear"}, optional
        The chirp's sweep.
    margin : float, optional
        The fraction of each limit kept free, in [0, 1).
    swing : float, optional
        The links' largest swing [rad].
    sample : float, optional
        The output interval [s] (default 1/(20 f_max), rounded).
    force : bool, optional
        Replace an existing experiment scene.

    Returns
    -------
    Design
        The excitation (`.amplitude`, `.limited_by`, the predicted `.base` and `.swing`,
        `.written`: the scene written or None) and `.report()`, the paragraph `ipgen excite`
        prints.

    Raises
    ------
    ExcitationError
        Bad limits or options, or an output that may not be written (one line).
    SceneError
        The rig's scene is not a valid scene (one line).

    Examples
    --------
    >>> import ipgen
    >>> from ipgen.common.presets import preset_path
    >>> design = ipgen.excitation(preset_path("qube_servo2"), u_max=10, travel=1.0)
    >>> design.limited_by, design.amplitude  # the arm's travel binds: 0.839 V, not 10 V
    ('travel', 0.839)
    """
    from ipgen.experiment.scene import load_scene

    rig = load_scene(scene)
    if output is not None:
        _check_output(rig, Path(output), force)  # before any work
    design = excitation_design(
        rig, u_max=u_max, travel=travel, signal=signal, f_min=f_min, f_max=f_max, period=period,
        periods=periods, duration=duration, sweep=sweep, margin=margin, swing=swing, sample=sample,
    )  # fmt: skip
    if output is not None:
        design = replace(design, written=_write(rig, Path(output), design, force))
    return design


def _check_output(rig: Scene, output: Path, force: bool) -> None:
    """An ExcitationError unless `output` is a .toml path that may be written: a new file, or an
    existing one with `force` — never the rig's own scene."""
    from ipgen.common.files import OutputError, check_replaceable

    if output.suffix != ".toml":
        raise ExcitationError(f"-o {shown_path(output)}: name a .toml scene file")
    try:  # the output-path policy's checks of the path itself (a directory, too long, ...)
        check_replaceable(output, True, keep=[rig.path])
    except OutputError as exc:
        raise ExcitationError(str(exc)) from None
    if output.exists() and not force:  # stricter than the policy: an experiment is a new file
        raise ExcitationError(f"{shown_path(output)} exists: choose another -o or pass --force")


def _write(rig: Scene, output: Path, design: Design, force: bool) -> Path:
    from ipgen.common.files import OutputError, write_file
    from ipgen.experiment.scene import load_scene
    from ipgen.pipeline.excitation_scene import scene_text

    _check_output(rig, output, force)  # again: a file may have appeared while the design ran
    text = scene_text(rig, design)
    with tempfile.TemporaryDirectory(prefix="ipgen-excite.") as folder:
        trial = Path(folder) / output.name
        trial.write_text(text, encoding="utf-8")
        load_scene(trial)  # the experiment must be a valid scene before it is written
    try:
        write_file(output, text, force=True)  # checked above
    except OutputError as exc:
        raise ExcitationError(str(exc)) from None
    return output
