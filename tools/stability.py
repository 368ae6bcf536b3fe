"""Run the stability scenarios (cpp/stability/) and write docs/stability.md.

    python tools/stability.py --build build [--out docs/stability.md]

Runs every `stability_<model>` driver the build has (`make stability` builds them), then the
long-horizon runs one process each so that their peak RSS can be compared, and writes one table
per scenario with the measured error or drift, the bound it is held to, the integrator's steps,
the wall time and the outcome. Exits 1 if any row failed (the document is written anyway, with
the failures in it).
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import platform
import re
import subprocess
import sys
import time
from pathlib import Path

# Drivers in table order; a missing one is reported and skipped.
DRIVERS = [
    "rsip",
    "cdip",
    "rdip",
    "ctip",
    "classical10",
    "rotary10",
    "classical20",
    "rotary20",
]
# Long-horizon runs: (driver, arguments). Peak RSS is compared between 1e3 s and 1e4 s with
# samples every 0.01 s (memory grows with the samples requested) and with only the final state
# kept (sample = t_end: it must not grow).
LONG_RUNS = [
    ("cdip", ["--long", "1000", "0.01"]),
    ("cdip", ["--long", "10000", "0.01"]),
    ("cdip", ["--long", "1000", "1000"]),
    ("cdip", ["--long", "10000", "10000"]),
    ("rsip", ["--long", "10000", "10000"]),
    ("rsip", ["--long-undamped", "10000"]),
    ("cdip", ["--long-undamped", "10000"]),
]
# Memory that is not samples (allocator noise) allowed between the 1e3 s and 1e4 s runs.
RSS_NOISE_MB = 2.0


def run_driver(binary: Path, args: list[str]) -> tuple[list[dict], float, int]:
    started = time.monotonic()
    done = subprocess.run([str(binary), *args], capture_output=True, text=True, check=False)
    wall = time.monotonic() - started
    rows = [json.loads(line) for line in done.stdout.splitlines() if line.startswith("{")]
    if done.returncode not in (0, 1) or not rows:
        rows.append(
            {
                "scenario": "driver",
                "model": binary.name,
                "what": " ".join(args) or "all scenarios",
                "measure": "",
                "value": None,
                "bound": None,
                "steps": -1,
                "wall": wall,
                "outcome": f"FAILED: exit status {done.returncode}: {done.stderr.strip()[:300]}",
                "passed": False,
                "note": "",
                "rss_mb": None,
            }
        )
    return rows, wall, done.returncode


def memory_row(long_rows: list[dict]) -> list[dict]:
    """Peak RSS of 1e3 s against 1e4 s: flat when only the final state is kept."""

    def rss(t_end: str, sample: str) -> float | None:
        for row in long_rows:
            if (
                row["model"].startswith("cdip")
                and row["what"].startswith("paper pulse")
                and (f", {t_end} s, sample {sample} s" in row["what"])
            ):
                return row.get("rss_mb")
        return None

    out = []
    for label, short, long_, sample_short, sample_long, expect_flat in [
        ("final state only (sample = t_end)", "1e+03", "1e+04", "1e+03", "1e+04", True),
        ("samples every 0.01 s", "1e+03", "1e+04", "0.01", "0.01", False),
    ]:
        a, b = rss(short, sample_short), rss(long_, sample_long)
        row = {
            "scenario": "long horizon",
            "model": "cdip (classical, 2 links)",
            "what": f"peak RSS, 1e3 s vs 1e4 s, {label}",
            "measure": "RSS growth [MB]",
            "value": None if a is None or b is None else b - a,
            "bound": RSS_NOISE_MB if expect_flat else None,
            "steps": -1,
            "wall": None,
            "outcome": "measured",
            "passed": True,
            "note": "" if a is None or b is None else f"{a:.1f} MB -> {b:.1f} MB",
            "rss_mb": None,
        }
        if a is None or b is None:
            row["outcome"], row["passed"] = "FAILED: a long-horizon run is missing", False
        elif expect_flat:
            row["passed"] = row["value"] <= RSS_NOISE_MB
            row["outcome"] = "ok" if row["passed"] else f"FAILED: grew {row['value']:.1f} MB"
        else:
            # 9e5 more samples of 6 doubles and a time: about 50 MB expected.
            row["outcome"] = "grows with the samples, as requested"
        out.append(row)
    return out


def machine() -> str:
    cpu = "unknown CPU"
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    compiler = subprocess.run(["c++", "--version"], capture_output=True, text=True, check=False).stdout
    sundials = "unknown"
    config = Path("/usr/include/sundials/sundials_config.h")
    if config.exists():
        match = re.search(r'SUNDIALS_VERSION "([^"]+)"', config.read_text())
        sundials = match.group(1) if match else sundials
    load = " ".join(f"{x:.2f}" for x in os.getloadavg())
    return (
        f"{cpu}, {os.cpu_count()} cores, {platform.system()} {platform.release()}; "
        f"{compiler.splitlines()[0] if compiler else 'c++'}; SUNDIALS {sundials}; "
        f"load average at start {load}"
    )


def fmt(value, digits: int = 3) -> str:
    if value is None:
        return ""
    if isinstance(value, (int, float)):
        return f"{value:.{digits}g}"
    return str(value)


def cell(text: str) -> str:
    return str(text).replace("|", "\\|").replace("\n", " ")


def table(rows: list[dict]) -> list[str]:
    lines = [
        "| model | case | measured | value | bound | steps | wall [s] | outcome | notes |",
        "| --- | --- | --- | ---: | ---: | ---: | ---: | --- | --- |",
    ]
    for r in rows:
        outcome = r["outcome"] if r["passed"] else f"**{r['outcome']}**"
        note = r["note"]
        if r.get("rss_mb") is not None:
            note = (note + "; " if note else "") + f"peak RSS {r['rss_mb']:.1f} MB"
        lines.append(
            "| "
            + " | ".join(
                cell(x)
                for x in [
                    r["model"],
                    r["what"],
                    r["measure"],
                    fmt(r["value"]),
                    fmt(r["bound"]),
                    "" if r["steps"] is None or r["steps"] < 0 else r["steps"],
                    fmt(r["wall"], 2),
                    outcome[:400],
                    note[:400],
                ]
            )
            + " |"
        )
    return lines


def worst(rows: list[dict], scenario: str, key=lambda r: True) -> float | None:
    values = [r["value"] for r in rows if r["scenario"] == scenario and r["value"] is not None and key(r)]
    return max(values) if values else None


def note_numbers(rows: list[dict], pattern: str, key=lambda r: True) -> list[float]:
    """Numbers captured by `pattern` in the notes of the rows that satisfy `key`."""
    found = []
    for r in rows:
        if key(r):
            found += [float(x) for x in re.findall(pattern, r["note"] or "")]
    return found


def summary(rows: list[dict]) -> list[str]:
    """What holds and where the limits are, with the numbers of this run."""
    many = worst(rows, "undamped 10 s", lambda r: "10 links" in r["model"] or "20 links" in r["model"])
    long_drift = worst(rows, "undamped 1e+03 s")
    longest = worst(rows, "undamped 1e+04 s")

    def in_range(r):
        return r["scenario"] == "mass/length ratios" and not r["what"].startswith("beyond")

    ratio_error = worst(rows, "mass/length ratios", lambda r: not r["what"].startswith("beyond"))
    length_error = worst(rows, "mass/length ratios", lambda r: r["what"].startswith("lengths"))
    raw_cond = max(note_numbers(rows, r"cond\(M\) ([0-9.e+-]+),", in_range), default=None)
    length_cond = max(
        note_numbers(
            rows, r"cond\(M\) ([0-9.e+-]+),", lambda r: in_range(r) and r["what"].startswith("lengths")
        ),
        default=None,
    )
    scaled_cond = max(note_numbers(rows, r"scaled ([0-9.e+-]+);", in_range), default=None)
    beyond = worst(rows, "mass/length ratios", lambda r: r["what"].startswith("beyond"))
    residual = max(
        note_numbers(rows, r"residual ([0-9.e+-]+)", lambda r: r["scenario"] == "mass/length ratios")
    )
    factor = max(note_numbers(rows, r"error/\(scaled cond eps\) ([0-9.e+-]+);", in_range), default=None)
    float_all = worst(rows, "float", lambda r: r["what"].startswith("all"))
    float_mild = worst(rows, "float", lambda r: "< 1e3" in r["what"])
    stiff_stopped = sum(
        1 for r in rows if r["scenario"] == "stiff damping" and "stiff: use BDF" in r["outcome"]
    )
    bdf_steps = [r["steps"] for r in rows if r["scenario"] == "stiff damping" and " bdf " in r["what"] + " "]
    fast_drift = worst(rows, "fast motion", lambda r: "spinning" in r["what"])
    fast_stops = sum(1 for r in rows if r["scenario"] == "fast motion" and r["outcome"].startswith("stopped"))

    def regular(method_pattern):
        return lambda r: (
            r["scenario"] == "fast motion"
            and re.search(f", {method_pattern} rtol", r["what"]) is not None
            and "(bound" in r["note"]
        )

    fast_bdf = max(note_numbers(rows, r"by ([0-9.e+-]+) of max", regular("bdf")), default=None)
    fast_erk = max(note_numbers(rows, r"by ([0-9.e+-]+) of max", regular("erk-[a-z0-9]+")), default=None)
    balance = worst(rows, "fast motion", lambda r: r["what"].startswith("input"))
    horizontal = worst(rows, "links through horizontal")
    turns = worst(rows, "links spinning many turns", lambda r: "1e+06 turns" in r["what"])
    arm = worst(rows, "arm spinning many turns")
    cart = worst(rows, "cart far from origin")
    return [
        "## What holds, where the limits are, and why",
        "",
        f"- **Many links.** n = 10 and n = 20, both types, 10 s without damping from every link tilted "
        f"0.3 rad (a chaotic fall): T + V drifts by at most {fmt(many)} of the energy in play at rtol "
        "1e-10 (bound rtol·(1e4 + 100 t/s) = 1.1e-6). The drift is BDF's global error; it does not grow "
        "with n in any way that matters up to n = 20.",
        f"- **No damping, long horizons.** 1000 s: drift at most {fmt(long_drift)} (bound 1.1e-5); 1e4 s: "
        f"{fmt(longest)} (bound 1e-4), no failure. BDF is not symplectic: the drift grows about linearly "
        "in time (here 20–30·rtol per second on chaotic motions), so the bound is stated per second. "
        "Memory does not grow with the horizon when only the final state is kept (`sample = t_end`: "
        "the same peak RSS at 1e3 s and 1e4 s); it grows by the samples asked for otherwise.",
        f"- **Mass and length ratios.** Within masses 1e-3..1e3 × the base's and lengths 1e-3..100 m, "
        f"θ̈ in double agrees with the long-double evaluation of the same header to {fmt(ratio_error)} "
        f"(relative). Raw cond(M) reaches {fmt(raw_cond)}, but it is the wrong yardstick: lengths only "
        f"scale M's rows and columns (units), which an L D Lᵀ solve does not notice (van der Sluis) — "
        f"with lengths alone cond(M) reaches {fmt(length_cond)} and the error stays at "
        f"{fmt(length_error)}. The error follows ε·cond(S M S), S = diag(M)^-1/2, within a factor of "
        f"{fmt(factor, 2)}, and the backward residual stays at rounding level (≤ {fmt(residual, 2)}) "
        "everywhere. What does "
        "make M ill-conditioned is a heavy link carried by light ones: the scaled condition number grows "
        f"with that mass ratio (up to {fmt(scaled_cond)} within the range, for a 1e6 heavy tip on ten "
        f"links), and beyond the range (1e12, 1e14 with a light base) θ̈ loses up to {fmt(beyond)}. "
        "The simulator warns when the scaled cond(M) exceeds 1e10, naming the mass ratio: for every "
        "such case and for none within the range. A warning on raw cond(M) > 1e10 would fire for 1 mm "
        "links next to 100 m ones with no loss of accuracy.",
        f"- **Float.** The headers compile and run with Scalar = float. θ̈ keeps a relative accuracy of "
        f"{fmt(float_mild)} where the scaled cond(M) is below 1e3 (about 3 digits): float is safe for "
        "evaluating the model in a controller there (nominal parameters: about 1e-6 to 1e-5). It is not "
        f"safe for heavy links on light ones: over the whole range the error reaches {fmt(float_all)} "
        "(scaled cond(M) above 1e7 is beyond float's 1/ε). Integrating in float is not supported "
        "(SUNDIALS is built for double).",
        f"- **Stiff damping.** A 1e-3 kg tip link with δ up to 1e4 (a decaying mode near −1e8 1/s): "
        f"BDF succeeds in {min(bdf_steps) if bdf_steps else '?'}–{max(bdf_steps) if bdf_steps else '?'} "
        "steps; explicit methods either finish (dp5 and the Adams variants at δ = 1e2, taking up to a "
        f'million steps) or stop within seconds with "stiff: use BDF" ({stiff_stopped} rows), never '
        "run on for hours: max_steps bounds the work between two samples, and the message estimates "
        "the stiffness (eigenvalues of ∂f/∂x) to say why.",
        f"- **Fast motion.** Rates of 1e3 rad/s (8 turns in 0.05 s): T + V is conserved to "
        f"{fmt(fast_drift)} by every method that finishes; where the motion is regular (one or two "
        f"links spinning straight) the explicit methods agree with a Fehlberg 8 reference at rtol 1e-12 "
        f"to {fmt(fast_erk)} and BDF, low order, to {fmt(fast_bdf)}: prefer an explicit method for fast, "
        "non-stiff motion. With more links the chain whips (tip rates of 4e4 rad/s) and the motion is "
        f"chaotic within hundredths of a second; erk-fehlberg8 stopped there {fast_stops} times with a "
        "diagnosed ARK_ERR_FAILURE (the error test cannot be met at rtol 1e-10), which is the loud "
        f"failure asked for. A 1e4 N (N m) input keeps the work–energy balance to {fmt(balance)} of the "
        "work.",
        f"- **Rotary geometry.** Links pass through horizontal 34 (one link) to 7900 (20 links) times "
        f"in 10 s with T + V conserved to "
        f"{fmt(horizontal)}. The arm shifted by up to 1e6 turns (θ0 ≈ 6e6 rad) changes the "
        f"trajectory by at most {fmt(arm)}, the cart shifted by up to 1e6 m by {fmt(cart)}, both within "
        "the runs' own global error: θ0 never enters the equations. Links spinning "
        "many turns are different: the integrator's error weight is rtol·|θ| + atol, so a link at 2πk "
        f"rad is integrated to an absolute error of about rtol·2πk (measured {fmt(turns)} at 1e6 turns), "
        "and sin θ carries ε·|θ|. Wrap link angles (θ mod 2π) before a long spinning run if absolute "
        "accuracy matters.",
        "- **Non-finite values.** A NaN or overflow in the right-hand side is a recoverable error for "
        "CVODE; if it persists, the run stops with the time, the state and the likely cause (input "
        "not finite, state grew without bound, M near singular), and `simulate_<model>` writes no "
        "CSV: it refuses a row with NaN or inf (ctest `ipsim.cli.overflow`, `ipsim.unit`).",
        "",
    ]


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--build", type=Path, default=Path("build"))
    parser.add_argument("--out", type=Path, default=Path("docs/stability.md"))
    parser.add_argument(
        "--render-only",
        action="store_true",
        help="rewrite the document from the rows of the last run (BUILD/stability_rows.json)",
    )
    args = parser.parse_args()
    bin_dir = args.build / "bin"
    saved = args.build / "stability_rows.json"
    if args.render_only:
        state = json.loads(saved.read_text())
        return write_document(args.out, state["rows"], state["header"], state["total"], state["walls"])
    header = f"{datetime.datetime.now().strftime('%Y-%m-%d %H:%M')} on {machine()}"
    started = time.monotonic()
    rows: list[dict] = []
    walls: dict[str, float] = {}
    for name in DRIVERS:
        binary = bin_dir / f"stability_{name}"
        if not binary.exists():
            print(f"stability: {binary} not built, skipped", file=sys.stderr)
            continue
        print(f"stability: {binary.name} ...", file=sys.stderr, flush=True)
        got, wall, _ = run_driver(binary, [])
        walls[name] = wall
        rows += got
    long_rows: list[dict] = []
    for name, extra in LONG_RUNS:
        binary = bin_dir / f"stability_{name}"
        if not binary.exists():
            continue
        print(f"stability: {binary.name} {' '.join(extra)} ...", file=sys.stderr, flush=True)
        got, _, _ = run_driver(binary, extra)
        long_rows += got
    rows += long_rows + memory_row(long_rows)
    total = time.monotonic() - started
    saved.write_text(json.dumps({"rows": rows, "header": header, "total": total, "walls": walls}))
    return write_document(args.out, rows, header, total, walls)


def write_document(out: Path, rows: list[dict], header: str, total: float, walls: dict[str, float]) -> int:
    """Writes the tables and the summary; returns the exit status (1 if a row failed)."""

    order: list[str] = []
    for r in rows:
        if r["scenario"] not in order:
            order.append(r["scenario"])
    failed = [r for r in rows if not r["passed"]]
    lines = [
        "# Numerical stability at the extremes",
        "",
        "Regenerated by `make stability` (cpp/stability/ drivers, tools/stability.py); do not edit.",
        f"Run {header}. "
        f"Scenarios took {total:.0f} s of wall time (drivers: "
        + ", ".join(f"{k} {v:.0f} s" for k, v in walls.items())
        + ").",
        "",
        f"**{len(rows) - len(failed)} of {len(rows)} rows passed.**"
        + (
            " Failed: " + "; ".join(f"{r['scenario']} / {r['model']} / {r['what']}" for r in failed)
            if failed
            else ""
        ),
        "",
        "Each row is one run or one measurement with an asserted outcome: *value* must not exceed "
        "*bound* (empty: measured only), and *outcome* says what happened. Relative energy drift is "
        "max |E(t) − E(0)| / max (T + |V|) over the samples. Settings unless stated: BDF with the exact "
        "Jacobian, rtol 1e-10, atol 1e-12; parameters after the paper (base 0.5 kg, arm 0.6 m, links "
        "0.275 kg and 0.5 m, damping 0.3 and 0.1 where damped).",
        "",
        *summary(rows),
    ]
    for scenario in order:
        lines += [f"## {scenario}", "", *table([r for r in rows if r["scenario"] == scenario]), ""]
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text("\n".join(lines))
    print(
        f"stability: wrote {out} ({len(rows)} rows, {len(failed)} failed, {total:.0f} s)",
        file=sys.stderr,
    )
    for r in failed:
        print(
            f"stability: FAILED {r['scenario']} / {r['model']} / {r['what']}: {r['outcome']}", file=sys.stderr
        )
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
