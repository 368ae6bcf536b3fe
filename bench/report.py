"""What both benchmark parts share: paths, the machine description and Markdown tables."""

from __future__ import annotations

import datetime
import os
import platform
import re
import subprocess
import sys
from importlib import metadata
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent
BUILD = ROOT / "build" / "bench"
PYTHON = sys.executable
# When the run started (report.py is imported first), and how busy the machine was then.
STARTED = datetime.datetime.now().astimezone()
LOAD_AT_START = os.getloadavg()


def cpu_model() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown CPU"


def compiler_version(compiler: str = "g++") -> str:
    try:
        return subprocess.run([compiler, "--version"], capture_output=True, text=True).stdout.splitlines()[0]
    except (OSError, IndexError):
        return f"{compiler} (version unknown)"


def version(package: str) -> str:
    try:
        return metadata.version(package)
    except metadata.PackageNotFoundError:
        return "not installed"


def sundials_version(config: Path = Path("/usr/include/sundials/sundials_config.h")) -> str:
    """The SUNDIALS version the simulator compiles against, from its sundials_config.h."""
    try:
        match = re.search(r'SUNDIALS_VERSION "([^"]+)"', config.read_text())
    except OSError:
        return "unknown"
    return match.group(1) if match else "unknown"


def commit() -> str:
    try:
        done = subprocess.run(
            ["git", "describe", "--always", "--dirty"], cwd=ROOT, capture_output=True, text=True
        )
    except OSError:  # no git
        return "unknown"
    return done.stdout.strip() or "unknown"


def machine(extra: dict[str, str] | None = None) -> list[str]:
    """Markdown bullet lines describing the machine and software versions."""
    facts = {
        "CPU": f"{cpu_model()}, {os.cpu_count()} cores",
        "OS": f"{platform.system()} {platform.release()}",
        "Python": platform.python_version(),
        "sympy": version("sympy"),
        "ipgen": f"{version('ipgen-pendulum')}, commit {commit()}",
        "started": STARTED.strftime("%Y-%m-%d %H:%M %Z"),
        "load average at the start (1, 5, 15 min)": " ".join(f"{x:.2f}" for x in LOAD_AT_START),
        "load average at the end": " ".join(f"{x:.2f}" for x in os.getloadavg()),
    }
    facts |= extra or {}
    return [f"- {key}: {value}" for key, value in facts.items()]


def table(header: list[str], rows: list[list[str]]) -> list[str]:
    """A Markdown table; the first column left-aligned, the others right-aligned."""
    lines = ["| " + " | ".join(header) + " |", "| --- |" + " ---: |" * (len(header) - 1)]
    lines += ["| " + " | ".join(row) + " |" for row in rows]
    return lines


def seconds(value: float | None) -> str:
    if value is None:
        return "–"
    return f"{value:.3f}" if value < 10 else f"{value:.1f}"


def verdict(met: bool) -> str:
    return "met" if met else "MISSED"


def style_axis(axis: Any, links: list[int], ylabel: str, title: str) -> None:
    """Log-log axes with the measured n as the x ticks."""
    from matplotlib.ticker import NullLocator  # here, so that tools without matplotlib can import report

    axis.set(xscale="log", yscale="log", xlabel="links n", ylabel=ylabel, title=title)
    axis.set_xticks(links, [str(n) for n in links])
    axis.xaxis.set_minor_locator(NullLocator())
    axis.grid(True, which="both", alpha=0.3)
    axis.legend(fontsize=7)
