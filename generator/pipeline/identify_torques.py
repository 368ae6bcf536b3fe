"""`ipgen identify` of a fixed-pivot scene: the base parameters fitted to measured joint torques
(`identification.torque`) on the `--data` recordings, validated on the `--validate` ones.

Writes into OUT, all or nothing:

    <stem>_identify.txt   the report: filtering, base parameters (what the data can identify),
                          estimates with 95 % intervals beside the scene's values, and per
                          recording the RMS torque error of the fit and of the scene's values
    <stem>_identify.csv   the same RMS table, one row per recording and model
    <stem>_identify.png   measured against predicted torques on each validation recording
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ipgen.common.files import (
    MARKER,
    check_replaceable,
    prepare_directory,
    removed_if_left_empty,
    write_files,
)
from ipgen.common.version import __version__
from ipgen.identification.recording import DEFAULT_CUTOFF, FILTER_ORDER, Filtered, filtered, read_recording
from ipgen.identification.torque import (
    DEFAULT_METHOD,
    TorqueFit,
    TorqueFitError,
    fit_torques,
    reference_torques,
    regressor,
    rms,
)
from ipgen.model.fixed import FixedPendulum

__all__ = ["TorqueIdentified", "identify_torques"]

PNG_KIND = "PNG image"
FIT_WORDS = {
    "sequential": "least squares tip first (the last joint's equation for the outer link's "
    "parameters, then inwards with those fixed)",
    "joint": "weighted least squares on all joints' equations together (1/σ of each joint's residual)",
}


@dataclass(frozen=True)
class Score:
    """RMS torque errors [N m] per joint of one model on one recording (against the filtered and
    the raw measured torque)."""

    recording: str
    role: str  # "fit" or "validate"
    model: str  # "identified" or "scene"
    filtered: np.ndarray
    raw: np.ndarray
    samples: int


@dataclass(frozen=True)
class TorqueIdentified:
    """The fit, the scores and the files written (none without an output folder)."""

    fit: TorqueFit
    scores: tuple[Score, ...]
    report: str
    files: tuple[Path, ...]

    def pooled(self, role: str, model: str) -> np.ndarray | None:
        """RMS per joint over every sample of the recordings of `role` ("fit", "validate") for
        `model` ("identified", "scene"); None if there are none."""
        return _pooled(self.scores, role, model)


def _score(fit: TorqueFit, scene: FixedPendulum, data: Filtered, role: str) -> list[Score]:
    ours, theirs = fit.predict(data), reference_torques(fit.regressor, scene, data)
    scores = []
    for model, predicted in (("identified", ours), ("scene", theirs)):
        scores.append(
            Score(data.name, role, model, rms(predicted, data.tau), rms(predicted, data.tau_raw), len(data.t))
        )
    return scores


def _pooled(scores: Sequence[Score], role: str, model: str) -> np.ndarray | None:
    chosen = [s for s in scores if s.role == role and s.model == model]
    if not chosen:
        return None
    counts = np.array([s.samples for s in chosen], dtype=float)
    squares = np.array([s.filtered**2 for s in chosen])
    return np.sqrt(counts @ squares / counts.sum())


def _report(
    fit: TorqueFit, scene: FixedPendulum, stem: str, scores: Sequence[Score], cutoff: float, seconds: float
) -> str:
    base = fit.base
    reference = fit.reference(scene)
    m = scene.inputs
    joints = ", ".join(f"joint {j}" for j in scene.joints)
    lines = [
        f"# {MARKER} {__version__} identify: {stem}, base parameters fitted to measured joint torques",
        "",
        "Filtering: angles and torques on a uniform grid, zero-phase Butterworth low-pass of order "
        f"{FILTER_ORDER} at {cutoff:g} Hz (scipy filtfilt); rates and accelerations central differences",
        "of the filtered angles. Model: ipgen's fixed-pivot equations in the scene's coordinates;",
        "lengths, g, gear ratios and the Coulomb law's rate known.",
        f"Fit: {FIT_WORDS[fit.method]}"
        + ("; a constant offset of each measured torque fitted too." if fit.offset else "."),
        f"{fit.samples} samples, {len(base.kept)} base parameters; {seconds:.2f} s.",
        "Not identifiable alone (absorbed in the combinations): "
        + (", ".join(base.unidentifiable()) or "none"),
        "95 % intervals count one sample in every "
        f"{fit.stride} as independent (the low-pass correlates neighbours).",
        "",
        f"{'base parameter':<40} {'estimate':>12} {'95 % interval':>27} {'scene':>12}",
    ]
    for label, value, (low, high), prior in zip(
        fit.labels(), fit.estimate, fit.interval, reference, strict=True
    ):
        lines.append(f"{label:<40} {value:>12.6g} [{low:>12.6g}, {high:>12.6g}] {prior:>12.6g}")
    lines += _unphysical(fit)
    lines += [
        "",
        f"RMS torque error [N m] ({joints}; against the filtered measured torque, raw in brackets):",
    ]
    for score in scores:
        values = "  ".join(f"{score.filtered[k]:.4f} ({score.raw[k]:.4f})" for k in range(m))
        lines.append(f"  {score.role:<8} {score.model:<10} {score.recording:<48} {values}")
    for role in ("fit", "validate"):
        ours, theirs = _pooled(scores, role, "identified"), _pooled(scores, role, "scene")
        if ours is not None and theirs is not None:
            lines.append(
                f"  {role} recordings pooled: identified {np.array2string(ours, precision=4)}, "
                f"scene {np.array2string(theirs, precision=4)}"
            )
    return "\n".join(lines) + "\n"


def _check_distinct(data: Sequence[str | Path], validate: Sequence[str | Path]) -> None:
    """TorqueFitError for a recording given twice: twice in the fit counts its samples twice (the
    intervals narrow for nothing), and one in the fit and the validation is not held out."""
    seen: dict[Path, str] = {}
    for role, paths_ in (("--data", data), ("--validate", validate)):
        for path in paths_:
            resolved = Path(path).resolve()
            if resolved in seen:
                raise TorqueFitError(
                    f"{Path(path).name}: given as {seen[resolved]} and as {role}: a recording counts once, "
                    "and one held out for validation must not be fitted; give each file once"
                )
            seen[resolved] = role


def _unphysical(fit: TorqueFit) -> list[str]:
    """A warning per base parameter that physics keeps ≥ 0 (`BaseParameters.sign_definite`) but
    whose whole 95 % interval lies below 0: the data or their columns are not what the scene says."""
    found = [
        f"warning: {label} = {value:.6g} is negative, with its whole 95 % interval, but is a sum of "
        "inertias, masses or friction coefficients: check that the torque columns are the driven joints' "
        "(tau_measJ joint J's; tau1.. in the order of [actuator] joints) and the angles' coordinates"
        for label, value, (_, high), definite in zip(
            fit.labels(), fit.estimate, fit.interval, fit.base.sign_definite(), strict=False
        )
        if definite and high < 0
    ]
    return ["", *found] if found else []


def _csv(scores: Sequence[Score], inputs: int) -> str:
    header = ["recording", "role", "model", *(f"rms_tau{k}" for k in range(1, inputs + 1))]
    header += [f"rms_raw_tau{k}" for k in range(1, inputs + 1)]
    rows = [f"# {MARKER} {__version__} identify", ",".join(header)]
    for s in scores:
        rows.append(",".join([s.recording, s.role, s.model, *(f"{v:.6g}" for v in (*s.filtered, *s.raw))]))
    return "\n".join(rows) + "\n"


def _png(fit: TorqueFit, scene: FixedPendulum, recordings: Sequence[Filtered], title: str) -> bytes:
    import io

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    m = scene.inputs
    fig, axes = plt.subplots(len(recordings), m, figsize=(6 * m, 2.6 * len(recordings) + 0.8), squeeze=False)
    for row, data in enumerate(recordings):
        ours, theirs = fit.predict(data), reference_torques(fit.regressor, scene, data)
        for k in range(m):
            ax = axes[row, k]
            ax.plot(data.t, data.tau_raw[:, k], color="0.75", lw=0.5, label="measured (raw)")
            ax.plot(data.t, data.tau[:, k], color="k", lw=1.2, label="measured (filtered)")
            ax.plot(
                data.t,
                ours[:, k],
                color="tab:blue",
                lw=1,
                label=f"identified ({rms(ours, data.tau)[k]:.3f} N m)",
            )
            ax.plot(
                data.t,
                theirs[:, k],
                color="tab:orange",
                lw=1,
                ls="--",
                label=f"scene ({rms(theirs, data.tau)[k]:.3f} N m)",
            )
            low, high = np.percentile(data.tau[:, k], [0.5, 99.5])
            pad = 0.4 * (high - low) + 0.05
            ax.set_ylim(low - pad, high + pad)
            ax.set_title(f"{data.name}: joint {scene.joints[k]}", fontsize=9)
            ax.set_ylabel("torque [N m]")
            ax.legend(fontsize=7, loc="upper left")
            ax.grid(alpha=0.3)
        axes[row, 0].set_xlabel("t [s]")
    fig.suptitle(
        title + "\n(RMS against the filtered measured torque; raw spikes clipped from view)", fontsize=10
    )
    fig.tight_layout()
    buffer = io.BytesIO()
    fig.savefig(buffer, dpi=64, format="png", metadata={"Software": f"{MARKER} (ipgen identify)"})
    plt.close(fig)
    return buffer.getvalue()


def identify_torques(
    scene: FixedPendulum,
    stem: str,
    data: Sequence[str | Path],
    validate: Sequence[str | Path] = (),
    output: str | Path | None = None,
    *,
    cutoff: float = DEFAULT_CUTOFF,
    method: str = DEFAULT_METHOD,
    offset: bool = True,
    force: bool = False,
    keep: Sequence[Path] = (),
) -> TorqueIdentified:
    """Fit `scene`'s base parameters to the recordings `data`, score the fit and the scene's own
    values on `data` and `validate`, and with `output` write the report, the CSV and the PNG.

    Parameters
    ----------
    scene : FixedPendulum
        The chain (its structure, known lengths, gear ratios, Coulomb law, and the values the
        fit is compared with).
    stem : str
        The name of the output files (the scene's stem).
    data, validate : sequence of path
        Recordings to fit on and to validate on (CSV or CSV.gz; `identification.recording`).
    output : path, optional
        Folder for <stem>_identify.txt, .csv and .png.
    cutoff : float
        The low-pass's cutoff [Hz].
    method : {"sequential", "joint"}
        The fit (`identification.torque.fit_torques`): tip first, one equation at a time (the
        default), or all equations together, weighted.
    offset : bool
        Fit a constant offset of each measured torque (the default).

    Returns
    -------
    TorqueIdentified

    Raises
    ------
    Error
        One line: a recording that cannot be read, data that cannot identify the parameters.
    """
    _check_distinct(data, validate)
    paths = {}
    if output is not None:
        paths = {kind: Path(output) / f"{stem}_identify.{kind}" for kind in ("txt", "csv", "png")}
        for kind, path in paths.items():
            check_replaceable(path, force, PNG_KIND if kind == "png" else "text file", keep=list(keep))
    clock = time.perf_counter()
    reg = regressor(scene)

    def read(paths_: Sequence[str | Path]) -> list[Filtered]:
        return [filtered(read_recording(p, scene.links, scene.inputs, scene.joints), cutoff) for p in paths_]

    fitting, checking = read(data), read(validate)
    step = float(np.median(np.diff(fitting[0].t))) if fitting else 0.002
    stride = max(1, round(1 / (2 * cutoff * step)))
    fit = fit_torques(reg, fitting, stride=stride, method=method, offset=offset)
    seconds = time.perf_counter() - clock
    scores: list[Score] = []
    for role, recordings in (("fit", fitting), ("validate", checking)):
        for recording in recordings:
            scores += _score(fit, scene, recording, role)
    report = _report(fit, scene, stem, scores, cutoff, seconds)
    if not paths:
        return TorqueIdentified(fit, tuple(scores), report, ())
    which = "validation" if checking else "fit"  # drawn: the validation recordings, else the fit's
    title = f"ipgen identify: {stem},\nmeasured against predicted torques on the {which} recordings"
    png = _png(fit, scene, checking or fitting, title)
    with removed_if_left_empty():
        prepare_directory(Path(output))  # type: ignore[arg-type]
        write_files(
            [(paths["txt"], report), (paths["csv"], _csv(scores, scene.inputs)), (paths["png"], png)],
            force=force,
            keep=list(keep),
        )
    return TorqueIdentified(fit, tuple(scores), report, tuple(paths.values()))
