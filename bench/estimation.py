"""`make bench-estimation` (part of `make bench`): what a rig's measurements cost the loop
(docs/bench/estimation.md).

For the paper's rotary single and double pendulum (scenes/rsip_pulse.toml, scenes/rdip_lqr.toml
parameters; LQR Q = I, R = 1) and the QUBE-Servo 2 preset (scenes/rigs/qube_servo2.toml: LQR in
volts, 10 V limit), sampled at 1 kHz and 500 Hz with 2048-count encoders on every angle (the arm
included), LQR acts on: the exact state; the backward difference; the 50 rad/s derivative
filter (Quanser's discretisation); the steady-state Kalman filter with the default covariances
(ipgen.estimation.covariance). Measured per case:

- basin: the largest initial tilt (every link tilted by the same absolute angle, at rest)
  from which the loop ends balanced (not past π/2, every link within 0.05 rad of upright over
  the last second of T_END), by bisection on [SMALLEST, LARGEST] (assumes an interval);
- RMS estimation error of every state over a run from TILT_RMS;
- the largest delay (whole periods, the command applied j periods after sampling) that still
  balances from TILT_DELAY, by doubling then bisection on j.

The loop is Python's (ipgen.estimation.loop.closed_loop: CasADi RK4 flow map in 0.1 ms
substeps between samples, the estimators of ipgen.estimation, numpy PCG64 noise from one
seed); the simulator's own loop with sensors (issue 32, C++) is checked against the same
estimators elsewhere. One run is cross-checked against scipy's solve_ivp (DOP853, rtol 1e-11).

    .venv/bin/python -m bench.estimation [--quick] [--out docs/bench] [--jobs 2]
"""

from __future__ import annotations

import argparse
import json
import math
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from tqdm import tqdm

from bench.report import BUILD, ROOT, machine, table

DOCS = ROOT / "docs" / "bench"
T_END = 2.0  # s per run
SMALLEST, LARGEST = 0.01, 1.5  # rad: the basin's bisection bracket
TILT_RMS = 0.1  # rad
TILT_DELAY = 0.05  # rad
RESOLUTION = 2048  # counts per revolution
CUTOFF = 50.0  # rad/s
PERIODS = {"1 kHz": 1e-3, "500 Hz": 2e-3}
MAX_DELAY = 128  # periods: the doubling stops here
ESTIMATORS = ("exact", "difference", "filter", "kalman")
COLORS = {"exact": "black", "difference": "tab:orange", "filter": "tab:green", "kalman": "tab:red"}
SYSTEMS = {
    "rsip": {"type": "rotary", "links": 1, "m": [0.5, 0.275], "l": [0.6, 0.5], "delta": [0.3, 0.011458]},
    "rdip": {
        "type": "rotary",
        "links": 2,
        "m": [0.5, 0.275, 0.275],
        "l": [0.6, 0.5, 0.5],
        "delta": [0.3, 0.011458, 0.011458],
    },
    "qube": "qube_servo2",  # the preset scene
}
TITLES = {
    "rsip": "rotary single (paper)",
    "rdip": "rotary double (paper)",
    "qube": "QUBE-Servo 2 (preset)",
}


def setup(system: str) -> tuple:
    """The pendulum, its LQR gain and input limit."""
    import ipgen

    if system == "qube":
        scene = ROOT / "scenes" / "rigs" / "qube_servo2.toml"
        pendulum = ipgen.Pendulum.from_scene(scene)
        return pendulum, ipgen.lqr(pendulum, [5, 1, 1, 1], 1.0), 10.0
    keywords = SYSTEMS[system]
    pendulum = ipgen.Pendulum(**keywords)
    dof = keywords["links"] + 1
    return pendulum, ipgen.lqr(pendulum, [1.0] * (2 * dof), 1.0), None


def run(system: str, estimator: str, period: float, tilt: float, delay: int, seed: int = 0) -> Any:
    """One closed-loop run (ipgen.estimation.loop.LoopRun)."""
    from ipgen.estimation import Sensors, design
    from ipgen.estimation.loop import closed_loop
    from ipgen.estimation.pendulum import as_model

    pendulum, gain, saturation = setup(system)
    model = as_model(pendulum)
    dof = model.dof
    sensors = Sensors.of(dof, None, RESOLUTION)
    if estimator == "exact":
        est = None
    else:
        d = design(
            pendulum, estimator, period, sensors, cutoff=CUTOFF if estimator == "filter" else None,
            u_scale=saturation,
        )  # fmt: skip
        est = d.build(pendulum)
    initial = np.zeros(2 * dof)
    initial[1:dof] = tilt
    return closed_loop(
        model, gain, np.zeros(2 * dof), est, sensors, period, T_END, initial,
        saturation=saturation, delay=delay, seed=seed,
    )  # fmt: skip


def case(args: tuple[str, str, str, int, int]) -> dict:
    """Basin, RMS error and largest delay of one (system, estimator, rate)."""
    system, estimator, rate, steps, refine = args
    period = PERIODS[rate]
    started = time.perf_counter()
    runs = 0

    def balanced(tilt: float, delay: int = 0) -> bool:
        nonlocal runs
        runs += 1
        return run(system, estimator, period, tilt, delay).balanced

    # basin: geometric bisection on the tilt
    if not balanced(SMALLEST):
        basin = 0.0
    elif balanced(LARGEST):
        basin = LARGEST
    else:
        low, high = SMALLEST, LARGEST
        for _ in range(steps):
            mid = math.sqrt(low * high)
            low, high = (mid, high) if balanced(mid) else (low, mid)
        basin = low
    reference = run(system, estimator, period, TILT_RMS, 0)
    runs += 1
    rms = reference.rms_error().tolist()
    # largest delay in periods: doubling (1, 2, 4, ... periods), then `refine` bisection steps
    if not balanced(TILT_DELAY, 0):
        delay = -1
    else:
        good, bad = 0, 1
        while bad <= MAX_DELAY and balanced(TILT_DELAY, bad):
            good, bad = bad, bad * 2
        for _ in range(refine):
            if bad - good <= 1:
                break
            mid = (good + bad) // 2
            good, bad = (mid, bad) if balanced(TILT_DELAY, mid) else (good, mid)
        delay = good
    return {
        "system": system,
        "estimator": estimator,
        "rate": rate,
        "basin": basin,
        "rms": rms,
        "rms_balanced": reference.balanced,
        "delay_periods": delay,
        "delay_s": delay * period if delay >= 0 else None,
        "runs": runs,
        "seconds": time.perf_counter() - started,
    }


def cross_check() -> dict:
    """The QUBE at 1 kHz on the Kalman filter: the CasADi RK4 loop against solve_ivp (same
    measurements, same commands replayed): max |Δθ| over the run."""
    from scipy.integrate import solve_ivp

    from ipgen.estimation.pendulum import as_model

    pendulum, _, _ = setup("qube")
    model = as_model(pendulum)
    loop = run("qube", "kalman", 1e-3, 0.2, 0)
    x = loop.x[0].copy()
    worst = 0.0
    for k in range(len(loop.t) - 1):
        u = float(loop.applied[k])
        sol = solve_ivp(
            lambda _t, s, u=u: model.f(s, u), (0.0, 1e-3), x, method="DOP853", rtol=1e-11, atol=1e-13
        )
        x = sol.y[:, -1]
        worst = max(worst, float(np.max(np.abs(x - loop.x[k + 1]))))
        x = loop.x[k + 1].copy()  # one-interval error, restarted from the loop's state
    return {"max_interval_error": worst, "samples": len(loop.t) - 1}


def plot_basins(results: list[dict], path: Path) -> None:
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.5), constrained_layout=True)
    for axis, (metric, label) in zip(
        axes,
        (("basin", "largest tilt recovered [rad]"), ("delay_s", "largest delay still balancing [ms]")),
        strict=True,
    ):
        groups = [(s, r) for s in SYSTEMS for r in PERIODS]
        width = 0.8 / len(ESTIMATORS)
        for j, estimator in enumerate(ESTIMATORS):
            values = []
            for system, rate in groups:
                row = next(
                    x
                    for x in results
                    if (x["system"], x["estimator"], x["rate"]) == (system, estimator, rate)
                )
                value = row[metric]
                values.append(0.0 if value is None else (value * 1e3 if metric == "delay_s" else value))
            axis.bar(
                np.arange(len(groups)) + (j - 1.5) * width,
                values,
                width,
                label=estimator,
                color=COLORS[estimator],
            )
        axis.set_xticks(range(len(groups)), [f"{s}\n{r}" for s, r in groups])
        axis.set_ylabel(label)
        axis.grid(True, axis="y", alpha=0.3)
        axis.legend(fontsize="small")
    axes[0].set_title("Basin: every link tilted equally, at rest (no bar: fails)")
    axes[1].set_title(f"Delay from {TILT_DELAY} rad (no bar: fails without delay)")
    fig.suptitle(f"LQR on {RESOLUTION}-count encoders: exact state vs estimators")
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_traces(path: Path) -> None:
    """The QUBE at 1 kHz from 0.2 rad: the pendulum's rate and its estimate, and the voltage."""
    fig, axes = plt.subplots(2, 1, figsize=(10, 6.5), sharex=True, constrained_layout=True)
    for estimator in ESTIMATORS:
        loop = run("qube", estimator, 1e-3, 0.2, 0)
        color = COLORS[estimator]
        if estimator == "exact":
            axes[0].plot(loop.t, loop.x[:, 3], color=color, lw=2, label="true α̇")
        else:
            axes[0].plot(loop.t, loop.estimate[:, 3], color=color, lw=0.8, label=f"{estimator} estimate")
        axes[1].plot(loop.t, loop.u, color=color, lw=0.8, label=estimator)
    axes[0].set_ylabel("pendulum rate α̇ [rad/s]")
    axes[0].set_xlim(0, 1.0)
    axes[0].legend(fontsize="small")
    axes[1].set_ylabel("command [V]")
    axes[1].set_xlabel("t [s]")
    axes[1].legend(fontsize="small")
    axes[0].set_title("QUBE-Servo 2, 1 kHz, 2048 counts, LQR from α = 0.2 rad: rate estimates (first second)")
    fig.savefig(path, dpi=110)
    plt.close(fig)


CDIP_EKF = ROOT / "bench" / "scenes" / "cdip_swingup_ekf.toml"


def cart_double_ekf(out: Path) -> dict:
    """The paper's cart double pendulum swung up (planned trajectory + TVLQR) and held at 1 kHz on
    encoder readings only, the state from the EKF: `ipgen run` on bench/scenes/cdip_swingup_ekf.toml
    (the simulator's loop), its plot copied to `out`; what it reached and what it cost."""
    import csv
    import shutil
    import subprocess
    import sys
    import tempfile

    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        done = subprocess.run([sys.executable, "-m", "ipgen", "run", str(CDIP_EKF), "-o", str(folder)],
                              capture_output=True, text=True)  # fmt: skip
        summary = (folder / f"{CDIP_EKF.stem}.txt").read_text() if done.returncode == 0 else done.stderr
        if done.returncode != 0:
            return {"status": done.returncode, "message": " ".join(summary.split())[:300]}
        with open(folder / f"{CDIP_EKF.stem}.csv", encoding="utf-8") as handle:
            rows = list(csv.DictReader(line for line in handle if not line.startswith("#")))
        shutil.copyfile(folder / f"{CDIP_EKF.stem}.png", out / "estimation_cdip_ekf.png")
    t = np.array([float(r["t"]) for r in rows])
    x = {k: np.array([float(r[k]) for r in rows]) for k in rows[0] if k != "phase"}
    hold = np.array([r["phase"] == "hold" for r in rows])
    last = t >= t[-1] - 1.0
    errors = {k: float(np.sqrt(np.mean((x[f"hat_{k}"] - x[k]) ** 2))) for k in
              ("theta0", "theta1", "theta2", "dtheta0", "dtheta1", "dtheta2")}  # fmt: skip
    u_max = 50.0
    return {
        "status": 0,
        "last_second_max_link": float(
            max(np.max(np.abs(x["theta1"][last])), np.max(np.abs(x["theta2"][last])))
        ),
        "largest_cart": float(np.max(np.abs(x["theta0"]))),
        "rms": errors,
        "hold_saturated": float(np.mean(np.abs(x["u"][hold]) >= u_max - 1e-9)) if hold.any() else 0.0,
        "hold_u_rms": float(np.sqrt(np.mean(x["u"][hold] ** 2))) if hold.any() else 0.0,
    }


def render(results: dict, out: Path) -> None:
    rows = []
    for row in results["cases"]:
        names = ["θ0", "θ1", "θ2"][: len(row["rms"]) // 2]
        rms_angles = ", ".join(f"{v * 1e3:.2f}" for v in row["rms"][: len(names)])
        rms_rates = ", ".join(f"{v:.3f}" for v in row["rms"][len(names) :])
        rows.append(
            [
                TITLES[row["system"]],
                row["rate"],
                row["estimator"],
                f"{row['basin']:.3f}" if row["basin"] > 0 else "**fails**",
                rms_angles,
                rms_rates,
                (
                    "**fails**"
                    if row["delay_periods"] < 0
                    else f"{row['delay_s'] * 1e3:.0f} ({row['delay_periods']})"
                ),
            ]
        )
    failures = [
        f"- {TITLES[r['system']]}, {r['rate']}, {r['estimator']}: "
        + ("does not balance even from 0.01 rad" if r["basin"] == 0 else "")
        + ("; " if r["basin"] == 0 and r["delay_periods"] < 0 else "")
        + ("does not balance from the delay test's tilt without delay" if r["delay_periods"] < 0 else "")
        for r in results["cases"]
        if r["basin"] == 0 or r["delay_periods"] < 0
    ]
    check = results["cross_check"]
    lines = [
        "# What measuring costs the loop: encoders, derivative estimates, Kalman filter",
        "",
        "Generated by `make bench-estimation` (bench/estimation.py); numbers from one run on the",
        "machine below. LQR (rsip, rdip: Q = I, R = 1 in N m; QUBE: the preset's Q = diag(5, 1, 1, 1),",
        "R = 1 in volts, 10 V limit) acts on the exact state or on the estimate from "
        f"{RESOLUTION}-count encoders",
        "on every angle (arm included), sampled at 1 kHz or 500 Hz. Estimators: `difference`",
        f"(backward difference), `filter` ({CUTOFF:g} rad/s, ω_c(z − 1)/(z − e^(−ω_c T)): Quanser's "
        "discretisation, low-frequency",
        "gain ω_c T/(1 − e^(−ω_c T)) = 1.0252 at 1 ms, 1.0508 at 2 ms), `kalman` (steady state, default",
        "covariances: Rn = Δ²/12, Qn = B_d B_dᵀ (0.01 u_scale)² + T diag(0, 1),",
        "u_scale = the input limit or 1).",
        "",
        f"- basin: the largest tilt (every link tilted by it, at rest) still balanced after {T_END:g} s "
        "(no link past π/2,",
        f"  every link within 0.05 rad of upright over the last second), by {results['steps']} steps of "
        f"geometric bisection on [{SMALLEST}, {LARGEST}] rad;",
        f"- RMS estimation error over a {T_END:g} s run from {TILT_RMS} rad: angles in mrad, rates in rad/s "
        "(θ0 the arm; exact = 0);",
        f"- largest delay (ms, in periods) that still balances from {TILT_DELAY} rad: doubling 1, 2, 4, … "
        f"periods (up to {MAX_DELAY}),",
        f"  then {results.get('refine', 0)} bisection steps: a lower bound, the limit is below "
        f"{1 + 2 ** -results.get('refine', 0):g}× it.",
        "",
        *table(
            [
                "system",
                "rate",
                "estimator",
                "basin [rad]",
                "RMS angles [mrad]",
                "RMS rates [rad/s]",
                "largest delay [ms] (periods)",
            ],
            rows,
        ),
        "",
        "![basins and delays](estimation.png)",
        "",
        "![QUBE rate estimates](estimation_qube.png)",
        "",
        "## Failures",
        "",
        *(
            failures
            or ["None: every case balances from 0.01 rad and from the delay test's tilt without delay."]
        ),
        "",
        *cdip_lines(results.get("cdip_ekf")),
        "## How the loop is simulated",
        "",
        "ipgen.estimation.loop.closed_loop: at t_k the encoders quantise the true angles",
        "(y = Δ·floor(θ/Δ + 1/2)), the estimator's `step(y_k, ū_{k−1})` gives x̂_k, u_k = sat(−K x̂_k)",
        "is applied from t_k + j T and held;",
        "between samples CasADi's RK4 flow map of ipgen's exact model in 0.1 ms substeps. Cross-check: the",
        "QUBE Kalman run restarted every interval against scipy's solve_ivp (DOP853, rtol 1e-11):",
        f"max |Δx| = {check['max_interval_error']:.1e} over {check['samples']} intervals.",
        "",
        "## Machine",
        "",
        *results["machine"],
        "",
        f"{results['runs']} closed-loop runs in {results['seconds']:.0f} s ({results['jobs']} processes).",
        "",
    ]
    out.mkdir(parents=True, exist_ok=True)
    (out / "estimation.md").write_text("\n".join(lines))
    plot_basins(results["cases"], out / "estimation.png")


def cdip_lines(found: dict | None) -> list[str]:
    """The section on the cart double pendulum's EKF swing-up (none before it was measured)."""
    if found is None:
        return []
    head = [
        "## The cart double pendulum swung up on encoders, EKF at 1 kHz",
        "",
        f"`ipgen run {CDIP_EKF.relative_to(ROOT)}`: scenes/cdip_swingup.toml (planned trajectory,",
        "TVLQR, then the LQR hold; |u| ≤ 50 N, plan within ±1 m) sampled at 1 kHz, the controller",
        "seeing only the EKF's estimate from the cart's encoder (102,654 counts per metre) and",
        "both links' (4096 counts per revolution); the simulator's own loop (CVODE BDF).",
        "",
    ]
    if found["status"] != 0:
        return [*head, f"**Fails**: exit status {found['status']}: {found['message']}", ""]
    rms = found["rms"]
    return [
        *head,
        f"- over the last second both links stay within {found['last_second_max_link'] * 1e3:.1f} mrad "
        f"of upright; the cart's largest excursion is {found['largest_cart']:.4f} m (the plan's limit: 1 m);",
        "- RMS estimation error over the run: positions "
        + ", ".join(f"{rms[k] * 1e3:.3f}" for k in ("theta0", "theta1", "theta2"))
        + " mm or mrad, rates "
        + ", ".join(f"{rms[k]:.3f}" for k in ("dtheta0", "dtheta1", "dtheta2"))
        + " m/s or rad/s;",
        "- **what it costs**: in the hold the force is at its ±50 N limit "
        f"{100 * found['hold_saturated']:.0f} % of the samples (RMS {found['hold_u_rms']:.1f} N): the hold's",
        "  LQR gain (Q = I, R = 1e-4 by default) turns the estimate's quantisation noise into a",
        "  chattering force (the plot shows it from the tracking's second half on). It holds, but a",
        "  rig's drive would not thank it: weight u more (`[swingup] r`) or filter the estimate.",
        "",
        "![cart double pendulum, EKF at 1 kHz](estimation_cdip_ekf.png)",
        "",
    ]


def main() -> int:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--quick", action="store_true", help="4 bisection steps, into build/bench/quick/")
    parser.add_argument("--out", type=Path, default=None, help="where estimation.md/.json/.png go")
    parser.add_argument("--jobs", type=int, default=2, help="processes (default 2)")
    parser.add_argument("--from-json", type=Path, default=None, help="render a previous run's JSON only")
    parser.add_argument(
        "--traces", action="store_true", help="with --from-json: run and plot the QUBE traces"
    )
    args = parser.parse_args()
    out = args.out or (BUILD / "quick" if args.quick else DOCS)
    if args.from_json:
        results = json.loads(args.from_json.read_text())
        if args.traces:
            plot_traces(out / "estimation_qube.png")
            results["cdip_ekf"] = cart_double_ekf(out)
            (out / "estimation.json").write_text(json.dumps(results, indent=1))
        render(results, out)
        return 0
    steps, refine = (2, 0) if args.quick else (3, 0)
    started = time.perf_counter()
    out.mkdir(parents=True, exist_ok=True)
    partial = out / "estimation.partial.jsonl"  # one line per finished case: a rerun resumes
    done = [json.loads(line) for line in partial.read_text().splitlines()] if partial.exists() else []
    have = {(c["system"], c["estimator"], c["rate"]) for c in done}
    order = ("qube", "rsip", "rdip")
    tasks = [
        (s, e, r, steps, refine) for s in order for r in PERIODS for e in ESTIMATORS if (s, e, r) not in have
    ]
    cases = list(done)
    with ProcessPoolExecutor(args.jobs) as pool, partial.open("a") as log:
        for result in tqdm(pool.map(case, tasks), total=len(tasks), desc="estimation", unit="case"):
            cases.append(result)
            log.write(json.dumps(result) + "\n")
            log.flush()
    cases.sort(key=lambda c: (list(SYSTEMS).index(c["system"]), list(PERIODS).index(c["rate"]),
                              ESTIMATORS.index(c["estimator"])))  # fmt: skip
    results = {
        "cases": cases,
        "steps": steps,
        "refine": refine,
        "cross_check": cross_check(),
        "runs": sum(c["runs"] for c in cases),
        "seconds": time.perf_counter() - started + sum(c["seconds"] for c in done) / args.jobs,
        "jobs": args.jobs,
        "machine": machine(),
    }
    out.mkdir(parents=True, exist_ok=True)
    results["cdip_ekf"] = cart_double_ekf(out)
    (out / "estimation.json").write_text(json.dumps(results, indent=1))
    render(results, out)
    plot_traces(out / "estimation_qube.png")
    partial.unlink()
    print(f"wrote {out / 'estimation.md'}, estimation.png, estimation_qube.png")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
