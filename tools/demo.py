"""`make demo`: run the paper's two open-loop experiments and plot them (Figs. 4 and 6),
stabilise the rotary double pendulum with LQR (scenes/rdip_lqr.toml), balance a real rig, the
Quanser QUBE-Servo 2, by LQR in motor volts (scenes/rigs/qube_servo2.toml, through `ipgen run`,
its simulator cached in <build>/ipgen-cache), and again as it measures itself, on its
2048-count encoders with a Kalman filter (scenes/rigs/qube_servo2_sensors.toml: it must end
upright within MEASURED_ANGLE and at rest within MEASURED_RATE, or the demo fails), and show a
closed loop that leaves its controller's region being stopped (scenes/cdip_lqr_tilt.toml).

Run after the CMake build (the Makefile does both):
    .venv/bin/python tools/demo.py --build build --out out/demo [--docs docs]

For each scene it runs build/bin/simulate_<model> on build/scenes/<stem>.cfg, writes
<out>/<short>.csv and <out>/<short>.png, and prints the simulator's summary. For the paper's two
systems it also writes the equations for people (ipgen --emit equations): <out>/<short>.md and
.tex, and the .pdf pdflatex makes of it. The LQR run must end upright and at rest: every angle
and rate within 1e-3 of zero in the CSV's last row, or the demo fails. The diverging run must end
with the simulator's exit status 3 and its message, its CSV cut where the loop diverged. With
--docs the plots are also copied there (docs/simulator.md and docs/control.md show docs/cdip.png,
docs/rsip.png and docs/rdip_lqr.png), and the PDFs and PNGs of the equations' pages go to docs/equations/.

Then the swing-ups (scenes/rsip_swingup.toml: energy control of the rotary single pendulum;
scenes/cdip_swingup.toml: a planned trajectory of the cart double pendulum;
scenes/rigs/qube_servo2_swingup.toml: the QUBE-Servo 2 in volts, every |u| within 10 V), each through
`ipgen run` (its cached simulator) into <out>/<stem>.csv, .png, .txt, and `ipgen animate` into
<out>/<stem>.gif. Each must end upright and at rest: in the CSV's last row every link within
SWING_ANGLE rad of upright (a whole turn counts as upright), every rate within SWING_RATE, and
the run in the hold phase; or the demo fails.
"""

from __future__ import annotations

import argparse
import csv
import math
import os
import shutil
import subprocess
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
from ipgen.experiment.scene import Scene, load_scene  # noqa: E402
from ipgen.model.system import System  # noqa: E402
from ipgen.pipeline.generate import generate  # noqa: E402

# (scene stem, short name of the outputs, what the paper calls it)
EXPERIMENTS = [
    ("cdip_pulse", "cdip", "Classical double inverted pendulum (paper Fig. 4)"),
    ("rsip_pulse", "rsip", "Rotary single inverted pendulum (paper Fig. 6)"),
]
# Closed-loop experiments: (scene stem, short name, title); the CSV has a column u.
CONTROL = [("rdip_lqr", "rdip_lqr", "Rotary double inverted pendulum stabilised by LQR")]
# Rig presets run through `ipgen run` (scenes/rigs/<stem>.toml): (stem, title); u in volts.
RIGS = [("qube_servo2", "Quanser QUBE-Servo 2 balanced by LQR in motor volts")]
# Rigs as they measure (encoders, an estimator): (stem, title); the last row within MEASURED_ANGLE
# [rad] of upright for every angle and MEASURED_RATE [rad/s] of rest for every rate (the
# quantised loop settles into a cycle of a few encoder counts, not to rest).
MEASURED_RIGS = [
    ("qube_servo2_sensors", "Quanser QUBE-Servo 2 on its 2048-count encoders, Kalman filter, LQR in volts")
]
MEASURED_ANGLE = 0.01
MEASURED_RATE = 0.5
SETTLED = 1e-3  # the last row of a closed-loop run: |angle|, |rate| <= SETTLED
# A closed loop outside its basin: (scene stem, short name, title); the simulator must stop it.
DIVERGING = [("cdip_lqr_tilt", "cdip_lqr_tilt", "Cart double pendulum under LQR from 0.1 rad: diverges")]
DIVERGED = 3  # the simulator's exit status for a diverged closed loop (cpp/README.md)
# Swing-ups: (scene stem, title); the last row: |θi − 2πk| <= SWING_ANGLE [rad] for the links,
# |θ̇| <= SWING_RATE [m/s or rad/s] for every rate, and phase "hold".
# scenes/<path>.toml; u_limit: every |u| in the CSV must be within it (None: the scene's own clip);
# rate: the last row's rate tolerance (on encoders a held pendulum cycles by a few counts).
SWINGUP = [
    ("rsip_swingup", "Rotary single pendulum swung up by energy control", None, None),
    ("cdip_swingup", "Cart double pendulum swung up along a planned trajectory", None, None),
    ("rigs/qube_servo2_swingup", "Quanser QUBE-Servo 2 swung up on its encoders within ±10 V", 10.0, 0.5),
    ("rigs/ip02_sip_swingup", "Quanser IP02 cart pendulum swung up within ±10 V and its rail", 10.0, None),
]
SWING_ANGLE = 1e-2
SWING_RATE = 1e-2


def read_csv(path: Path) -> dict[str, list[float]]:
    with path.open() as f:
        rows = list(csv.reader(f))
    header, data = rows[0], rows[1:]
    return {name: [float(row[i]) for row in data] for i, name in enumerate(header)}


def plot(columns: dict[str, list[float]], scene: Scene, title: str, path: Path) -> None:
    t = columns["t"]
    fig, (base, links) = plt.subplots(2, 1, figsize=(8, 6.5), sharex=True, constrained_layout=True)
    if scene.type == "classical":
        base.plot(t, columns["theta0"], color="black", label="cart position θ0")
        base.set_ylabel("cart position θ0 [m]")
    else:
        base.plot(t, columns["theta0"], color="black", label="arm angle θ0")
        base.set_ylabel("arm angle θ0 [rad]")
    for i in range(1, scene.links + 1):
        links.plot(t, columns[f"theta{i}"], label=f"link {i} angle θ{i}")
    for level in (-3.141592653589793, 3.141592653589793):
        links.axhline(level, color="grey", linestyle=":", linewidth=0.8)
    links.set_ylabel("link angle from upright [rad]")
    links.set_xlabel("time t [s]")
    pulse = scene.input
    base.set_title(
        f"{title}\n{pulse.kind} input {pulse.amplitude:g} {'N' if scene.type == 'classical' else 'N m'}"
        f" for {pulse.duration:g} s; dotted lines: hanging down (±π)"
    )
    for ax in (base, links):
        ax.grid(True, alpha=0.3)
        ax.axvspan(pulse.start, pulse.start + pulse.duration, color="tab:orange", alpha=0.12)
        ax.legend(loc="best", fontsize="small")
    fig.savefig(path, dpi=110)
    plt.close(fig)


def write_equations(scene: Scene, out: Path, docs: Path | None) -> str:
    """<out>/<name>.md, .tex (ipgen --emit equations) and .pdf (pdflatex); with `docs`, the PDF
    and a PNG per page (pdftoppm) in <docs>/equations/. Returns what was written, for the log."""
    system = System(scene.type, scene.links, scene.inertia)  # type: ignore[arg-type]
    generate(system, scene.name, out, emit=("equations",))
    tex = out / f"{scene.name}.tex"
    result = subprocess.run(
        ["pdflatex", "-interaction=nonstopmode", "-halt-on-error", "-no-shell-escape", tex.name],
        cwd=out,
        capture_output=True,
        text=True,
        env={**os.environ, "SOURCE_DATE_EPOCH": "0", "FORCE_SOURCE_DATE": "1"},  # the same PDF every time
    )
    if result.returncode != 0:
        raise RuntimeError(f"pdflatex {tex} failed:\n{result.stdout[-2000:]}")
    for suffix in (".aux", ".log"):
        (out / f"{scene.name}{suffix}").unlink(missing_ok=True)
    pdf = out / f"{scene.name}.pdf"
    if docs:
        target = docs / "equations"
        target.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(pdf, target / pdf.name)
        for old in target.glob(f"{scene.name}-*.png"):
            old.unlink()
        subprocess.run(["pdftoppm", "-r", "110", "-png", str(pdf), str(target / scene.name)], check=True)
    return f"{out / scene.name}.md, .tex and .pdf"


def plot_control(columns: dict[str, list[float]], scene: Scene, title: str, path: Path) -> None:
    """Angles (base and links) and the input u against time."""
    t = columns["t"]
    fig, (angles, force) = plt.subplots(2, 1, figsize=(8, 6.5), sharex=True, constrained_layout=True)
    base = "cart position θ0 [m]" if scene.type == "classical" else "arm angle θ0 [rad]"
    angles.plot(t, columns["theta0"], color="black", label=base)
    for i in range(1, scene.links + 1):
        angles.plot(t, columns[f"theta{i}"], label=f"link {i} angle θ{i} [rad]")
    classical = scene.type == "classical"
    angles.set_ylabel("θ0 [m], link angles from upright [rad]" if classical else "angles [rad]")
    unit = scene.actuator.unit(scene.type)
    what = "motor voltage" if scene.actuator.is_motor else "force" if classical else "torque"
    force.plot(t, columns["u"], color="tab:red", label=f"u = −K (x − x_eq) [{unit}]")
    if scene.controller is not None and scene.controller.saturation is not None:
        for level in (-scene.controller.saturation, scene.controller.saturation):
            force.axhline(level, color="grey", linestyle=":", linewidth=0.8)
    force.set_ylabel(f"{what} u [{unit}]")
    force.set_xlabel("time t [s]")
    controller = scene.controller
    assert controller is not None
    timing = "continuous" if controller.period is None else f"sampled every {controller.period:g} s"
    gain = ", ".join(f"{k:.3g}" for k in controller.gain)
    angles.set_title(
        f"{title}\nlink 1 tilted by {scene.theta[1]:g} rad at t = 0; LQR ({timing})\nK = [{gain}]"
    )
    for ax in (angles, force):
        ax.grid(True, alpha=0.3)
        ax.legend(loc="best", fontsize="small")
    fig.savefig(path, dpi=110)
    plt.close(fig)


def upright_problems(columns: dict[str, list[float]]) -> list[str]:
    """Columns of the last row that are not within SETTLED of the upright rest state."""
    return [
        f"{name} = {values[-1]:.3g}"
        for name, values in columns.items()
        if name.startswith(("theta", "dtheta")) and not abs(values[-1]) <= SETTLED
    ]


class DemoError(Exception):
    """A run that failed or did not end as the demo requires; the message says which."""


def simulate(
    args: argparse.Namespace, stem: str, short: str, expected_status: int = 0
) -> tuple[Scene, Path, Path, str]:
    """Run build/bin/simulate_<model> on the scene's resolved config, writing <out>/<short>.csv.
    Returns the scene, the CSV and PNG paths and the simulator's summary (and, for a run that
    must fail with `expected_status`, its error line)."""
    scene = load_scene(ROOT / "scenes" / f"{stem}.toml")
    csv_path, png_path = args.out / f"{short}.csv", args.out / f"{short}.png"
    simulator = args.build / "bin" / f"simulate_{scene.name}"
    config = args.build / "scenes" / f"{stem}.cfg"
    result = subprocess.run(
        [str(simulator), str(config), "--csv", str(csv_path)], capture_output=True, text=True
    )
    if result.returncode != expected_status:
        raise DemoError(
            f"{stem} ended with exit status {result.returncode}, expected {expected_status}: "
            f"{result.stderr.strip()}"
        )
    return scene, csv_path, png_path, "\n".join(filter(None, (result.stdout.strip(), result.stderr.strip())))


def publish(png_path: Path, docs: Path | None) -> None:
    """With --docs, a copy of the plot there (docs/simulator.md and docs/control.md show it)."""
    if docs:
        docs.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(png_path, docs / png_path.name)


def run_rig(args: argparse.Namespace, stem: str) -> tuple[Scene, Path, Path, str]:
    """`ipgen run scenes/rigs/<stem>.toml -o <out>/rigs` (simulator cached in <build>/ipgen-cache);
    returns the scene, the CSV and PNG paths and the simulator's summary."""
    toml = ROOT / "scenes" / "rigs" / f"{stem}.toml"
    out = args.out / "rigs"
    command = [sys.executable, "-m", "ipgen", "run", str(toml), "-o", str(out), "--force"]
    result = subprocess.run(
        [*command, "--cache-dir", str(args.build / "ipgen-cache")], capture_output=True, text=True
    )
    if result.returncode != 0:
        raise DemoError(f"rigs/{stem} failed: {result.stderr.strip()}")
    summary = (out / f"{stem}.txt").read_text().strip()
    return load_scene(toml), out / f"{stem}.csv", out / f"{stem}.png", summary


def run_demo(args: argparse.Namespace) -> None:
    for stem, short, title in EXPERIMENTS:
        scene, csv_path, png_path, summary = simulate(args, stem, short)
        plot(read_csv(csv_path), scene, title, png_path)
        equations = write_equations(scene, args.out, args.docs)
        print(f"== {title}\n{summary}\n   wrote {csv_path}, {png_path} and {equations}\n")
        publish(png_path, args.docs)
    for stem, short, title in CONTROL:
        scene, csv_path, png_path, summary = simulate(args, stem, short)
        columns = read_csv(csv_path)
        plot_control(columns, scene, title, png_path)
        print(f"== {title}\n{summary}\n   wrote {csv_path} and {png_path}")
        problems = upright_problems(columns)
        if problems or not math.isclose(columns["t"][-1], scene.t_end):
            raise DemoError(f"{stem} did not end upright and at rest: {', '.join(problems)}")
        print(f"   last row (t = {columns['t'][-1]:g} s) upright and at rest to {SETTLED:g}\n")
        publish(png_path, args.docs)
    for stem, title in RIGS:
        scene, csv_path, png_path, summary = run_rig(args, stem)
        columns = read_csv(csv_path)
        plot_control(columns, scene, title, png_path)  # replaces ipgen run's plot with the demo's
        print(f"== {title}\n{summary}\n   wrote {csv_path} and {png_path}")
        problems = upright_problems(columns)
        if problems or not math.isclose(columns["t"][-1], scene.t_end):
            raise DemoError(f"rigs/{stem} did not end upright and at rest: {', '.join(problems)}")
        print(f"   last row (t = {columns['t'][-1]:g} s) upright and at rest to {SETTLED:g}\n")
    for stem, title in MEASURED_RIGS:
        scene, csv_path, png_path, summary = run_rig(args, stem)
        columns = read_csv(csv_path)
        plot_control(columns, scene, title, png_path)
        print(f"== {title}\n{summary}\n   wrote {csv_path} and {png_path}")
        problems = [
            f"{name} = {values[-1]:.3g}"
            for name, values in columns.items()
            if name.startswith(("theta", "dtheta"))
            and not abs(values[-1]) <= (MEASURED_ANGLE if name.startswith("theta") else MEASURED_RATE)
        ]
        if (
            problems
            or not math.isclose(columns["t"][-1], scene.t_end)
            or "RMS estimation error" not in summary
        ):
            raise DemoError(f"rigs/{stem} did not balance on its measurements: {', '.join(problems)}")
        print(f"   last row upright within {MEASURED_ANGLE:g} rad, at rest within {MEASURED_RATE:g} rad/s\n")
    for stem, short, title in DIVERGING:
        scene, csv_path, png_path, summary = simulate(args, stem, short, expected_status=DIVERGED)
        columns = read_csv(csv_path)
        if "diverged" not in summary or not columns["t"][-1] < scene.t_end:
            raise DemoError(f"{stem}: the simulator did not report the divergence it must stop")
        plot_control(columns, scene, title, png_path)
        print(f"== {title}\n{summary}")
        print(f"   exit status {DIVERGED} as expected; wrote {csv_path} and {png_path}\n")


def swingup_problems(path: Path, u_limit: float | None = None, rate: float | None = None) -> list[str]:
    """What keeps the last row of a swing-up's CSV from upright and at rest (see SWING_*; `rate`
    replaces SWING_RATE), and any |u| beyond `u_limit` in any row."""
    rate_limit = SWING_RATE if rate is None else rate
    with path.open() as f:
        rows = list(csv.reader(f))
    header, last = rows[0], rows[-1]
    problems = [] if last[-1] == "hold" else [f"phase {last[-1]}"]
    if u_limit is not None:
        peak = max(abs(float(row[header.index("u")])) for row in rows[1:])
        if not peak <= u_limit * (1 + 1e-12):
            problems.append(f"|u| reached {peak:.4g} > {u_limit:g}")
    for name, text in zip(header[:-1], last[:-1], strict=True):
        value = float(text)
        if name.startswith("theta") and name != "theta0":
            if not abs(math.remainder(value, 2 * math.pi)) <= SWING_ANGLE:
                problems.append(f"{name} = {value:.3g}")
        elif name.startswith("dtheta") and not abs(value) <= rate_limit:
            problems.append(f"{name} = {value:.3g}")
    return problems


def run_swingups(args: argparse.Namespace) -> None:
    """`ipgen run` and `ipgen animate` for each swing-up scene, and the upright check."""
    from ipgen.command.cli import run

    for path, title, u_limit, rate in SWINGUP:
        print(f"== {title}", flush=True)
        stem = Path(path).name
        if run(["run", str(ROOT / "scenes" / f"{path}.toml"), "-o", str(args.out), "--force"]) != 0:
            raise DemoError(f"{stem}: ipgen run failed")
        csv_path = args.out / f"{stem}.csv"
        gif = args.out / f"{stem}.gif"
        if run(["animate", str(csv_path), "-o", str(gif), "--force"]) != 0:
            raise DemoError(f"{stem}: ipgen animate failed")
        problems = swingup_problems(csv_path, u_limit, rate)
        if problems:
            raise DemoError(f"{stem} did not end upright and at rest: {', '.join(problems)}")
        print(
            f"   wrote {gif}; last row upright (links within {SWING_ANGLE:g} rad) and at rest "
            f"(rates within {SWING_RATE if rate is None else rate:g})\n"
        )


def main() -> int:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--build", type=Path, default=ROOT / "build", help="CMake build folder")
    parser.add_argument("--out", type=Path, default=ROOT / "out" / "demo", help="where CSVs and plots go")
    parser.add_argument("--docs", type=Path, default=None, help="also copy the plots here")
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    try:
        run_demo(args)
        run_swingups(args)
    except DemoError as e:
        print(f"demo: {e}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
