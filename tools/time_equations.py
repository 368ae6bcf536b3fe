"""What `ipgen --emit equations` costs as n grows: wall time, memory, document size, pdflatex.

Each point runs `python -m ipgen --type T --links N --emit equations -o <temporary folder>` in a
fresh process (start-up, derivation, the sympy views, printing, writing) and then, unless
--no-pdf, pdflatex on the .tex. Prints one Markdown table row per point as it finishes, with
the number of entries left unexpanded (above the printer's per-entry cap) and the load average.

    tools/time_equations.py                          # n = 1, 2, 4, 8, 12, 20, both types
    tools/time_equations.py --links 4,30 --types rotary --no-pdf
"""

from __future__ import annotations

import argparse
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DEFAULT_PYTHON = ROOT / ".venv" / "bin" / "python"


def peak_rss_mib() -> float:
    """The largest resident set of any child process so far, in MiB (Linux reports KiB)."""
    return resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024


def main() -> int:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--links", default="1,2,4,8,12,20", help="comma-separated n")
    parser.add_argument("--types", default="classical,rotary")
    parser.add_argument("--python", type=Path, default=DEFAULT_PYTHON)
    parser.add_argument("--no-pdf", action="store_true", help="do not run pdflatex")
    args = parser.parse_args()
    pdflatex = None if args.no_pdf else shutil.which("pdflatex")
    print(f"load average before: {os.getloadavg()[0]:.2f} (cores: {os.cpu_count()})")
    print("| system | n | ipgen [s] | .md | .tex | capped entries | pdflatex [s] | pages |")
    print("| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |")
    for kind in args.types.split(","):
        for links in map(int, args.links.split(",")):
            with tempfile.TemporaryDirectory() as tmp:
                command = [str(args.python), "-m", "ipgen", "--type", kind, "--links", str(links)]
                command += ["--emit", "equations", "--force", "-o", tmp]
                start = time.perf_counter()
                subprocess.run(command, check=True, capture_output=True)
                seconds = time.perf_counter() - start
                stem = Path(tmp) / f"{kind}{links}"
                md, tex = stem.with_suffix(".md").read_text(), stem.with_suffix(".tex").read_text()
                capped = md.count("not expanded here")
                pdf_time, pages = "–", "–"
                if pdflatex:
                    start = time.perf_counter()
                    result = subprocess.run(
                        [
                            pdflatex,
                            "-interaction=nonstopmode",
                            "-halt-on-error",
                            stem.with_suffix(".tex").name,
                        ],
                        cwd=tmp,
                        capture_output=True,
                        text=True,
                    )
                    pdf_time = f"{time.perf_counter() - start:.1f}" if result.returncode == 0 else "failed"
                    pages = next(
                        (
                            line.split("(")[1].split()[0]
                            for line in result.stdout.splitlines()
                            if "Output written" in line
                        ),
                        "?",
                    )
            print(
                f"| {kind} | {links} | {seconds:.2f} | {len(md.encode()) // 1024} KiB | "
                f"{len(tex.encode()) // 1024} KiB | {capped} | {pdf_time} | {pages} |",
                flush=True,
            )
    print(f"load average after: {os.getloadavg()[0]:.2f}; peak memory of a child: {peak_rss_mib():.0f} MiB")
    return 0


if __name__ == "__main__":
    sys.exit(main())
