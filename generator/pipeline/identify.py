"""`ipgen identify --scene S.toml --data D.csv --free m1,delta0 -o OUT/`: fit a scene to measurements.

Reads the scene (the prior: every parameter's value, the drive, the input) and the data (the
simulator's CSV format, in the scene's coordinates; converted to ipgen's in `canonical`, the one
place that knows the rig's convention), fits the free parameters (identify/fit.py) and writes
into OUT, all or nothing:

    <stem>_identified.toml  the scene with the estimates in (a new file: never the input)
    <stem>_identify.txt     the report: estimates, standard errors, 95 % intervals, correlations,
                            identifiability, residuals
    <stem>_identify.png     measured against simulated angles
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ipgen.common.files import check_replaceable, prepare_directory, removed_if_left_empty, write_files
from ipgen.common.presets import scene_source
from ipgen.common.safetext import quote_path, shown_path
from ipgen.common.version import __version__
from ipgen.experiment.scene import Scene, load_scene
from ipgen.identification.data import DataError, Measurements, read_measurements
from ipgen.identification.fit import report_text
from ipgen.identification.model import IdentifyError, Setup
from ipgen.model.actuator import MOTOR_CONSTANTS
from ipgen.model.coordinates import Coordinates
from ipgen.plots.run import PNG

if TYPE_CHECKING:
    import numpy as np

    from ipgen.identification.fit import Fit

__all__ = ["Identified", "canonical", "check_recording", "identify", "report_text", "setup_from_scene"]


@dataclass(frozen=True)
class Identified:
    """The fit and the files written (none without an output folder)."""

    fit: Fit
    scene: Scene
    files: tuple[Path, ...]
    report: str


def setup_from_scene(scene: Scene, free: Sequence[str] = ()) -> Setup:
    """The prior of a fit: every parameter's value from `scene` (`Setup.from_pendulum`)."""
    return Setup.from_pendulum(scene.pendulum, free)


def canonical(scene: Scene, data: Measurements) -> Measurements:
    """The measurements in ipgen's coordinates (`Measurements.canonical` with the scene's)."""
    return data.canonical(scene.coordinates)


def input_function(scene: Scene) -> Callable[[np.ndarray], np.ndarray] | None:
    """u(t) from the scene's [input], vectorised; None for a feedback law (the data must have u)."""
    import numpy as np

    if scene.controller is not None or scene.swingup is not None:
        return None
    spec = scene.input

    def u(t: np.ndarray) -> np.ndarray:
        return np.array([spec.value(float(x)) for x in np.asarray(t)])

    return u


def _convention(coordinates: Coordinates, keys: Sequence[str]) -> str:
    return ", ".join(f"{key} = {getattr(coordinates, key)}" for key in keys)


def check_recording(scene: Scene, data: Path) -> None:
    """A `DataError` when the resolved scene beside the CSV (`<stem>.cfg`, which `ipgen run`
    writes) says the recording is of another system than `scene`: another type, number of links
    or convention of the angles. Nothing to check without one (a rig's own recording)."""
    from ipgen.plots.run import coordinates_beside, scene_beside

    beside = scene_beside(data)
    if beside is None:
        return
    kind, lengths = beside
    cfg = shown_path(data.with_suffix(".cfg"))
    fix = "identify it with the scene of the rig that recorded it (--scene or --preset)"
    if kind != scene.type or len(lengths) != scene.links + 1:
        links = len(lengths) if kind == "fixed" else len(lengths) - 1  # a fixed chain has no base
        plural = "s" if links > 1 else ""
        raise DataError(
            f"{shown_path(data)} is a recording of a {kind} pendulum with {links} link{plural} ({cfg} beside "
            f"it says so), the scene a {scene.type} one with {scene.links}: {fix}"
        )
    recorded = coordinates_beside(data)
    differ = [
        key
        for key in ("angles", "zero", "positive")
        if getattr(recorded, key) != getattr(scene.coordinates, key)
    ]
    if differ:
        raise DataError(
            f"{shown_path(data)} has its angles in {_convention(recorded, differ)} ({cfg} beside it says "
            f"so), the scene in {_convention(scene.coordinates, differ)}: give the scene's [system] the "
            f"recording's, or {fix}"
        )


def _updates(fit: Fit, setup: Setup, scene: Scene) -> dict[tuple[str, str], Any]:
    """(table, key) → value of every scene key a free parameter changes."""
    values = fit.values()
    dof = scene.links + 1
    updates: dict[tuple[str, str], Any] = {}
    for name in fit.free:
        group = name.rstrip("0123456789")
        if name in MOTOR_CONSTANTS:
            updates["actuator", name] = values[name]
        elif name == "g":
            updates["parameters", "g"] = values["g"]
        else:
            entries = []
            for i in range(dof):
                key = f"{group}{i}"
                entries.append(values.get(key, 0.0))
            if group == "l" and scene.type == "classical":
                entries[0] = 0.0
            updates["parameters", group] = entries
    return updates


def _check_updated(text: str, stem: str) -> None:
    """IdentifyError unless `text` is a valid scene (read back by `load_scene`)."""
    import tempfile

    from ipgen.errors import SceneError

    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / f"{stem}.toml"
        path.write_text(text, encoding="utf-8")
        try:
            load_scene(path)
        except SceneError as e:
            problem = str(e).split(": ", 1)[-1]
            raise IdentifyError(
                f"the estimates make no valid scene ({problem}): "
                "fix more parameters or record a richer experiment"
            ) from None


def _paths(scene: Scene, directory: Path) -> dict[str, Path]:
    stem = scene.stem
    return {
        "toml": directory / f"{stem}_identified.toml",
        "txt": directory / f"{stem}_identify.txt",
        "png": directory / f"{stem}_identify.png",
    }


def identify(
    scene: str | Path,
    data: str | Path,
    free: str | Sequence[str],
    output: str | Path | None = None,
    *,
    force: bool = False,
    output_error: bool = True,
    progress: Callable[[str], None] | None = None,
) -> Identified:
    """Fit the `free` parameters of `scene` to the CSV `data`; with `output`, write the updated
    scene, the report and the PNG there (module docstring). Raises an `Error` (one line)."""
    import time

    from ipgen.identification.fit import identify_measurements

    scene_path, data_path = Path(scene), Path(data)
    names = [n.strip() for n in free.split(",")] if isinstance(free, str) else list(free)
    loaded = load_scene(scene_path)
    paths = _paths(loaded, Path(output)) if output is not None else {}
    inputs = [scene_path, data_path]  # never written, not even with --force
    if paths:  # the output-path policy (common.files), before the fit; never the scene itself
        check_replaceable(paths["toml"], force, keep=inputs)
        check_replaceable(paths["txt"], force, keep=inputs)
        check_replaceable(paths["png"], force, PNG, keep=inputs)
    setup = setup_from_scene(loaded, names)
    check_recording(loaded, data_path)
    measurements = canonical(loaded, read_measurements(data_path, loaded.links + 1))
    clock = time.perf_counter()
    fit = identify_measurements(
        setup,
        measurements,
        names,
        input_fn=input_function(loaded),
        output_error=output_error,
        progress=progress,
    )
    fit.seconds["total"] = time.perf_counter() - clock
    text = report_text(fit, scene_path, data_path)
    if not paths:
        return Identified(fit=fit, scene=loaded, files=(), report=text)
    from ipgen.common.toml_edit import updated_scene_text
    from ipgen.plots.identify import identify_png

    source = scene_source(Path(scene_path))  # "preset NAME" for a preset, else the path as given
    header = "\n".join(
        [
            f"# Generated by ipgen {__version__} identify: the scene {source} with the",
            f"# parameters fitted to {quote_path(str(data_path))} (estimate ± standard error):",
            *(
                f"#   {n} = {fit.estimate[n]:.6g}"
                + (f" ± {fit.stderr[n]:.2g}" if math.isfinite(fit.stderr[n]) else " (not determined)")
                for n in fit.free
            ),
        ]
    )
    original = scene_path.read_text(encoding="utf-8")
    updated = updated_scene_text(original, _updates(fit, setup, loaded), header)
    _check_updated(updated, loaded.stem)
    png = identify_png(
        fit, loaded.type, f"ipgen identify: {loaded.stem}, free {', '.join(fit.free)}", loaded.coordinates
    )
    with removed_if_left_empty():
        prepare_directory(Path(output))  # type: ignore[arg-type]
        write_files(
            [(paths["toml"], updated), (paths["txt"], text), (paths["png"], png)], force=force, keep=inputs
        )
    return Identified(fit=fit, scene=loaded, files=tuple(paths.values()), report=text)
