"""`ipgen excite SCENE.toml -o EXPERIMENT.toml`: the identification experiment a user should run.

From a rig's scene (its parameters and actuator) and the rig's limits — the largest |u| the drive
may get and the base's travel — this designs an excitation about the hanging equilibrium: a
multisine (default) or a chirp in a frequency band, its amplitude the largest whose predicted
motion keeps the base within (1 − margin) of its travel and the links within (1 − margin) of
`swing` of hanging (so that the linear prediction holds), and never above u_max. The prediction
is the linear model (`ipgen.linearize` about hanging, with the scene's actuator) simulated over
the whole experiment from rest (transients and the base's drift included), and for a multisine
also its periodic steady state from the frequency response at every line; the larger of the two
counts. Coulomb friction, if the scene has it, is left out (it only slows the base).

The experiment is written as a new scene: the input scene's text (its comments kept) without its
[initial], [input], [limits], [controller], [swingup] and [simulation] tables, then those written
anew: hanging at rest, the excitation, [limits] travel (the simulator stops a run that leaves it,
exit status 4) and the run's length. It is validated before it is written; an existing file is
replaced only with `force`, the input scene never. docs/excitation.md is the user's guide.
"""

from __future__ import annotations

import math
import re
import tempfile
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING

import click

from ipgen.common.safetext import abbreviate, quote_path, shown_path
from ipgen.errors import Error

if TYPE_CHECKING:
    import numpy as np

    from ipgen.scene.reader import Scene

SIGNALS: tuple[str, ...] = ("multisine", "chirp")
DEFAULT_MARGIN = 0.3
DEFAULT_SWING = 0.5  # rad: the links' largest predicted swing about hanging
DEFAULT_PERIODS = 4
DEFAULT_CHIRP_DURATION = 40.0  # s
# The tables an experiment scene writes anew (the others are kept as the rig's scene has them).
REPLACED_TABLES: tuple[str, ...] = ("initial", "input", "limits", "controller", "swingup", "simulation")
_HEADER = re.compile(r"^\s*\[\s*([A-Za-z0-9_-]+)\s*\]\s*(#.*)?$")


class ExcitationError(Error):
    """The excitation cannot be designed or written; the message says why and what to change."""


@dataclass(frozen=True)
class Design:
    """An excitation and what the linear model predicts it does."""

    signal: str  # multisine | chirp
    amplitude: float  # peak |u| [N, N m or V]
    limited_by: str  # u_max | travel | swing
    f_min: float  # the band [Hz] (a chirp's f0, f1)
    f_max: float
    period: float | None  # multisine
    lines: int  # multisine: number of lines; chirp: 0
    crest_factor: float  # peak / RMS of u
    duration: float  # the run's t_end [s]
    sample: float  # [s]
    sweep: str | None  # chirp
    base: float  # predicted max |θ0 − θ0(0)| at the amplitude [m or rad]
    swing: float  # predicted max |θi − π| [rad]
    u_max: float
    travel: float
    swing_limit: float
    margin: float
    gain_band: tuple[float, float]  # min and max |θ0/u| over the band (frequency response)
    natural: tuple[float, ...] = ()  # the hanging model's natural frequencies [Hz]
    u_unit: str = "N"  # N, N m or V (a dc_motor)
    base_unit: str = "m"  # m (cart) or rad (arm)
    written: Path | None = None  # the experiment scene, when one was written

    def report(self) -> str:
        """A paragraph: the signal, the amplitude and why, and the predicted excursions."""
        unit = self._units
        band = f"{self.f_min:g}–{self.f_max:g} Hz"
        what = (
            f"multisine, {self.lines} lines in {band} (period {self.period:g} s, Schroeder phases, "
            f"crest factor {self.crest_factor:.3g})"
            if self.signal == "multisine"
            else f"{self.sweep} chirp {band} over {self.duration:g} s"
        )
        reason = {
            "u_max": f"the drive's limit u_max = {self.u_max:g} {unit[0]}",
            "travel": f"the travel: (1 − {self.margin:g}) × {self.travel:g} {unit[1]}",
            "swing": f"the links' swing: (1 − {self.margin:g}) × {self.swing_limit:g} rad",
        }[self.limited_by]
        natural = ", ".join(f"{f:.3g}" for f in self.natural) or "none"
        return (
            f"{what}; amplitude {self.amplitude:g} {unit[0]}, limited by {reason}. Predicted by the linear "
            f"model about hanging: base within ±{self.base:.3g} {unit[1]} (travel {self.travel:g}), links "
            f"within ±{self.swing:.3g} rad of hanging; |θ0/u| from {self.gain_band[0]:.3g} to "
            f"{self.gain_band[1]:.3g} {unit[1]}/{unit[0]} over the band; the hanging pendulum's natural "
            f"frequencies {natural} Hz. Run length {self.duration:g} s, sampled every {self.sample:g} s."
        )

    @property
    def _units(self) -> tuple[str, str]:
        return self.u_unit, self.base_unit


def excitation(
    scene: str | Path,
    output: str | Path | None = None,
    *,
    u_max: float,
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

    `u_max` is the largest |u| allowed (N, N m, or V with a dc_motor), `travel` the base's limit
    |θ0| (m or rad; default: the scene's [limits] travel). `signal` is "multisine" (every
    harmonic of 1/`period` in [f_min, f_max], run for `periods` periods) or "chirp" (f_min to
    f_max over `duration` s, `sweep` "linear" or "logarithmic"). The band defaults to a fifth of
    the hanging pendulum's lowest natural frequency up to five times its highest. The amplitude
    is the largest (3 significant digits) whose predicted excursions stay within (1 − `margin`)
    of `travel` and `swing` [rad], at most u_max. Raises `ExcitationError` (or `SceneError` for
    the scene) with a one-line message.
    """
    from ipgen.scene.reader import load_scene

    rig = load_scene(scene)
    if output is not None:
        _check_output(rig, Path(output), force)  # before any work
    travel = _check_limits(rig, u_max, travel, margin, swing)
    if signal not in SIGNALS:
        raise ExcitationError(f"signal {abbreviate(str(signal))!r}: expected one of {', '.join(SIGNALS)}")
    a, b = _hanging_model(rig)
    natural = _natural_frequencies(a, rig.links)
    f_lo, f_hi = _band(f_min, f_max, natural, signal, sweep)
    if signal == "multisine":
        period = period if period is not None else max(10.0, float(math.ceil(2.0 / f_lo)))
        _positive("period", period, "s")
        if not (isinstance(periods, int) and 1 <= periods <= 1000):
            raise ExcitationError(f"periods = {periods!r}: expected a whole number from 1 to 1000")
        t_end = periods * period
    else:
        duration = DEFAULT_CHIRP_DURATION if duration is None else duration
        _positive("duration", duration, "s")
        if sweep not in ("linear", "logarithmic"):
            raise ExcitationError(f"sweep {abbreviate(str(sweep))!r}: expected linear or logarithmic")
        t_end = duration
    sample = sample if sample is not None else min(rig.sample, _nice(1.0 / (20.0 * f_hi)))
    _positive("sample", sample, "s")
    if t_end / sample > 1e7:
        raise ExcitationError(
            f"{t_end:g} s sampled every {sample:g} s is more than 1e7 samples: raise sample"
        )
    design = _predict(rig, a, b, signal, f_lo, f_hi, period, t_end, sweep, travel, u_max, margin, swing)
    design = replace(
        design,
        sample=sample,
        natural=natural,
        u_unit="V" if rig.actuator.is_motor else ("N" if rig.type == "classical" else "N m"),
        base_unit="m" if rig.type == "classical" else "rad",
    )
    if output is not None:
        design = replace(design, written=_write(rig, Path(output), design, force))
    return design


def _check_limits(rig: Scene, u_max: float, travel: float | None, margin: float, swing: float) -> float:
    travel = travel if travel is not None else rig.travel
    if travel is None:
        raise ExcitationError(
            "no travel limit: pass --travel (m on a cart, rad on an arm) or give the scene [limits] travel"
        )
    _positive("u_max", u_max, "(the largest |u|)")
    _positive("travel", travel, "(m on a cart, rad on an arm)")
    _positive("swing", swing, "rad")
    if not (isinstance(margin, (int, float)) and 0.0 <= margin < 1.0):
        raise ExcitationError(f"margin = {margin!r}: expected a fraction in [0, 1), e.g. 0.3")
    return float(travel)


def _positive(name: str, value: object, unit: str) -> None:
    if (
        isinstance(value, bool)
        or not isinstance(value, (int, float))
        or not (math.isfinite(value) and value > 0)
    ):
        raise ExcitationError(f"{name} = {abbreviate(repr(value))}: expected a finite number > 0 {unit}")


def _nice(x: float) -> float:
    """x rounded down to 1, 2 or 5 times a power of ten (a sample time that reads well)."""
    exponent = math.floor(math.log10(x))
    for mantissa in (5.0, 2.0, 1.0):
        if mantissa * 10.0**exponent <= x:
            return float(f"{mantissa * 10.0**exponent:.3g}")
    return float(f"{10.0**exponent:.3g}")


def _hanging_model(rig: Scene) -> tuple[np.ndarray, np.ndarray]:
    """(A, B) of the rig about hanging at rest (canonical coordinates; B per unit of u)."""
    from ipgen.control.linear import ControlError, linearize

    links = rig.links
    try:
        return linearize(
            rig.type,
            links,
            rig.m,
            rig.l,
            rig.delta,
            rig.g,
            rig.inertia,
            q=[0.0] + [math.pi] * links,
            **rig.link_values(),
            actuator=rig.actuator,
        )
    except ControlError as exc:
        raise ExcitationError(f"no linear model about hanging: {exc}") from None


def _natural_frequencies(a: np.ndarray, links: int) -> tuple[float, ...]:
    """The oscillatory modes' frequencies |λ| / 2π [Hz] of the hanging model, ascending."""
    import numpy as np

    eigenvalues = np.linalg.eigvals(np.asarray(a))
    modes = sorted({round(abs(ev) / (2.0 * math.pi), 9) for ev in eigenvalues if abs(ev.imag) > 1e-9})
    return tuple(float(f) for f in modes)


def _band(
    f_min: float | None, f_max: float | None, natural: tuple[float, ...], signal: str, sweep: str
) -> tuple[float, float]:
    default = (_nice(natural[0] / 5.0), float(f"{5.0 * natural[-1]:.2g}")) if natural else (0.1, 10.0)
    lo = default[0] if f_min is None else f_min
    hi = default[1] if f_max is None else f_max
    for name, value in (("f_min", lo), ("f_max", hi)):
        if (
            isinstance(value, bool)
            or not isinstance(value, (int, float))
            or not math.isfinite(value)
            or value < 0
        ):
            raise ExcitationError(f"{name} = {abbreviate(repr(value))}: expected a finite frequency >= 0 Hz")
    if not hi > lo:
        raise ExcitationError(f"f_max = {hi:g} Hz must be > f_min = {lo:g} Hz")
    if lo == 0 and (signal == "multisine" or sweep == "logarithmic"):
        raise ExcitationError(
            "f_min = 0 Hz: a multisine or a logarithmic chirp starts above 0 Hz; give f_min > 0"
        )
    return float(lo), float(hi)


def _predict(
    rig: Scene,
    a: np.ndarray,
    b: np.ndarray,
    signal: str,
    f_lo: float,
    f_hi: float,
    period: float | None,
    t_end: float,
    sweep: str,
    travel: float,
    u_max: float,
    margin: float,
    swing: float,
) -> Design:
    import numpy as np

    from ipgen.control import excitation as predict
    from ipgen.control import signals

    a_, b_ = np.asarray(a), np.asarray(b)
    dof = rig.links + 1
    lines = None
    if signal == "multisine":
        assert period is not None
        try:
            lines = signals.multisine(f_lo, f_hi, period)
        except ValueError as exc:
            raise ExcitationError(f"multisine: {exc}") from None
    try:
        t = predict.grid(t_end, f_hi)
    except ValueError as exc:
        raise ExcitationError(str(exc)) from None
    if lines is not None:
        u = signals.multisine_values(t, 1.0, lines)
    else:
        u = signals.chirp_values(t, 1.0, f_lo, f_hi, t_end, 0.0, sweep)
    x = predict.response(a_, b_, u, t)
    base = float(np.max(np.abs(x[:, 0])))
    links_swing = float(np.max(np.abs(x[:, 1:dof]))) if dof > 1 else 0.0
    if lines is not None:
        steady = predict.steady_peaks(a_, b_, lines)
        base = max(base, float(steady[0]))
        links_swing = max(links_swing, float(np.max(steady[1:dof])) if dof > 1 else 0.0)
    band = np.geomspace(max(f_lo, 1e-3), f_hi, 200) if f_lo > 0 else np.linspace(1e-3, f_hi, 200)
    gain = np.abs(predict.frequency_response(a_, b_, band)[:, 0])
    try:
        scaled = predict.scale_to_limits(
            base,
            links_swing,
            rig.theta[0],
            predict.Limits(u_max, travel, swing, margin),
        )
    except ValueError as exc:
        raise ExcitationError(str(exc)) from None
    rms = float(np.sqrt(np.mean(u**2)))
    return Design(
        signal=signal,
        amplitude=scaled.amplitude,
        limited_by=scaled.limited_by,
        f_min=f_lo,
        f_max=f_hi,
        period=period if signal == "multisine" else None,
        lines=len(lines.frequencies) if lines is not None else 0,
        crest_factor=lines.crest_factor if lines is not None else (1.0 / rms if rms > 0 else math.inf),
        duration=t_end,
        sample=0.0,
        sweep=sweep if signal == "chirp" else None,
        base=scaled.base,
        swing=scaled.swing,
        u_max=u_max,
        travel=travel,
        swing_limit=swing,
        margin=margin,
        gain_band=(float(np.min(gain)), float(np.max(gain))),
    )


# ---------------------------------------------------------------------------- the scene


def _kept_text(rig: Scene) -> str:
    """The rig scene's text without the tables the experiment writes anew."""
    import tomllib

    text = rig.path.read_text(encoding="utf-8")
    document = tomllib.loads(text)
    kept: list[str] = []
    dropping = False
    seen: set[str] = set()
    for line in text.splitlines():
        header = _HEADER.match(line)
        if header:
            dropping = header.group(1) in REPLACED_TABLES
            seen.add(header.group(1))
        if not dropping:
            kept.append(line)
    hidden = [name for name in REPLACED_TABLES if name in document and name not in seen]
    if hidden:
        raise ExcitationError(
            f"the scene writes [{hidden[0]}] as dotted keys or inline: write it as a [{hidden[0]}] table "
            "on a line of its own, so that the experiment can replace it"
        )
    while kept and not kept[-1].strip():
        kept.pop()
    return "\n".join(kept) + "\n"


def _format(x: float) -> str:
    from ipgen.scene.fields import format_number

    return format_number(float(x))


def _line(text: str, comment: str) -> str:
    """`text`, then `# comment` from column 31 (as the preset scenes align them)."""
    return f"{text:<29} # {comment}"


def _hanging(rig: Scene) -> list[float]:
    """The hanging state's angles in the rig's own coordinates, each in (−π, π], as its [initial]
    is written (ipgen's: every link at π; 0 with zero = "hanging"; relative: the links above 1 at 0)."""
    import numpy as np

    dof = rig.links + 1
    canonical = np.zeros(2 * dof)
    canonical[1:dof] = math.pi
    user = rig.coordinates.to_user(canonical, rig.links)[:dof]
    wrapped = [float(x) % (2 * math.pi) for x in user[1:]]
    return [float(user[0]), *(x - 2 * math.pi if x > math.pi else x + 0.0 for x in wrapped)]


def scene_text(rig: Scene, design: Design) -> str:
    """The experiment scene: a generated header, the rig's own tables, then the new ones."""
    links = rig.links
    source = quote_path(rig.path.as_posix())
    theta = ", ".join(_format(angle) for angle in _hanging(rig))
    zeros = ", ".join(["0"] * (links + 1))
    unit, base_unit = design._units
    peak = f"peak |u| [{unit}], limited by {design.limited_by}"
    if design.signal == "multisine":
        table = [
            _line("[input]", "the excitation (docs/excitation.md)"),
            'kind = "multisine"',
            _line(f"amplitude = {_format(design.amplitude)}", peak),
            _line(f"f_min = {_format(design.f_min)}", "Hz"),
            _line(f"f_max = {_format(design.f_max)}", "Hz"),
            _line(f"period = {_format(design.period or 0.0)}", f"s: {design.lines} lines, Schroeder phases"),
        ]
    else:
        table = [
            _line("[input]", "the excitation (docs/excitation.md)"),
            'kind = "chirp"',
            _line(f"amplitude = {_format(design.amplitude)}", peak),
            _line(f"f0 = {_format(design.f_min)}", "Hz"),
            _line(f"f1 = {_format(design.f_max)}", "Hz"),
            _line(f"duration = {_format(design.duration)}", "s"),
            f'sweep = "{design.sweep}"',
        ]
    header = [
        f"# Generated by ipgen excite from {source}: an identification experiment about hanging.",
        f"# Predicted (linear model): base within ±{design.base:.3g} {base_unit} of its start, links within "
        f"±{design.swing:.3g} rad of hanging;",
        f"# limits: |u| <= {design.u_max:g} {unit}, travel {design.travel:g} {base_unit}, "
        f"margin {design.margin:g}, swing {design.swing_limit:g} rad.",
        "",
    ]
    tail = [
        "",
        _line("[initial]", "hanging at rest"),
        f"theta = [{theta}]",
        f"dtheta = [{zeros}]",
        "",
        *table,
        "",
        _line("[limits]", "the simulator stops a run beyond it (exit status 4)"),
        _line(f"travel = {_format(design.travel)}", f"{base_unit}: the limit on |θ0|"),
        "",
        "[simulation]",
        f"t_end = {_format(design.duration)}",
        f"sample = {_format(design.sample)}",
    ]
    return "\n".join(header) + _kept_text(rig) + "\n".join(tail) + "\n"


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
    from ipgen.scene.reader import load_scene

    _check_output(rig, output, force)
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
  ipgen excite scenes/rigs/qube_servo2.toml --u-max 10 --travel 1 -o qube_identify.toml
  ipgen excite rig.toml --u-max 5 --travel 0.4 --signal chirp --f-min 0.2 --f-max 5 --duration 60
"""


@click.command(
    "excite",
    help=EXCITE_HELP,
    context_settings={"help_option_names": ["-h", "--help"], "max_content_width": 100},
)
@click.argument("scene", type=click.Path(path_type=Path), metavar="SCENE.toml")
@click.option(
    "-o", "--output", type=click.Path(path_type=Path), default=None, metavar="EXPERIMENT.toml",
    help="The experiment scene to write (a new file; an existing one only with --force).",
)  # fmt: skip
@click.option(
    "--u-max", type=float, required=True, help="Largest |u| allowed [N, N m, or V with a dc_motor]."
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
    help=f"Chirp length [s] [default: {DEFAULT_CHIRP_DURATION:g}].",
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
def command(scene: Path, output: Path | None, **options: object) -> None:
    design = excitation(scene, output, **options)  # type: ignore[arg-type]
    if design.written is not None:
        click.echo(f"wrote {design.written}")
    else:
        click.echo("(no -o: nothing written)")
    click.echo(design.report())
