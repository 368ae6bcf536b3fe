"""Run every shipped scene with this checkout and with another revision, and compare the CSVs byte
for byte: the check that a change to ipsim or to the scene layer leaves every trajectory as it was.

    .venv/bin/python tools/same_csvs.py [REV] [--keep DIR]

REV (default HEAD) is checked out into a temporary git worktree. Each side runs `ipgen run` with its
own ipgen (its generator/ and cpp/, through PYTHONPATH) and its own simulator cache, on the scenes
of scenes/ and scenes/rigs/ plus three Coulomb-friction variants (the friction paths of the
right-hand side and the exact Jacobian, which no shipped scene takes). Prints one line per scene
and exits 0 when every exit status and every CSV is the same, 1 otherwise. It compiles each model
twice: about 10 minutes on 2 cores.
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

from ipgen.common.presets import presets

ROOT = Path(__file__).resolve().parent.parent
# (scene, Coulomb friction per coordinate): variants of shipped scenes with friction.
FRICTION = (
    ("rsip_pulse", "[0.01, 0.002]"),
    ("cdip_pulse", "[0.5, 0.002, 0.002]"),
    ("rdip_lqr", "[0.01, 0.001, 0.001]"),  # BDF with the exact Jacobian: the friction's slope
)


def scenes(folder: Path) -> list[Path]:
    """The shipped scenes and the friction variants, copied into `folder`."""
    folder.mkdir(parents=True)
    copied = []
    # scenes/ and scenes/rigs/, not the fixed-pivot presets (the simulator does not take them yet)
    for path in (preset.path for preset in presets() if not preset.system.startswith("fixed")):
        target = folder / (("rig_" if path.parent.name == "rigs" else "") + path.name)
        shutil.copy(path, target)
        copied.append(target)
    for stem, coulomb in FRICTION:
        text = (ROOT / "scenes" / f"{stem}.toml").read_text()
        text, found = re.subn(r"(\n\[parameters\][^\n]*\n)", rf"\1coulomb = {coulomb}\n", text, count=1)
        assert found == 1, stem
        target = folder / f"{stem}_coulomb.toml"
        target.write_text(text)
        copied.append(target)
    return copied


def run_all(checkout: Path, scene_paths: list[Path], work: Path, label: str) -> dict[str, int]:
    """`ipgen run` of every scene with the ipgen of `checkout`; the exit status of each."""
    package = work / f"{label}-package"
    package.mkdir()
    (package / "ipgen").symlink_to(checkout / "generator")
    env = {**os.environ, "PYTHONPATH": str(package)}
    statuses = {}
    for scene in scene_paths:
        output = work / label / scene.stem
        command = [sys.executable, "-m", "ipgen", "run", str(scene), "-o", str(output)]
        command += ["--cache-dir", str(work / f"{label}-cache")]
        statuses[scene.stem] = subprocess.run(command, env=env, capture_output=True).returncode
        print(f"{label}: {scene.stem}: exit status {statuses[scene.stem]}", flush=True)
    return statuses


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("rev", nargs="?", default="HEAD", help="the revision to compare with (default HEAD)")
    parser.add_argument("--keep", type=Path, help="work in this new folder and keep it (default: temporary)")
    args = parser.parse_args()
    work = args.keep or Path(tempfile.mkdtemp(prefix="same_csvs-"))
    if args.keep:
        work.mkdir(parents=True)
    other = work / "other"
    worktree = ["git", "-C", str(ROOT), "worktree"]
    subprocess.run([*worktree, "add", "--detach", "-q", str(other), args.rev], check=True)
    try:
        scene_paths = scenes(work / "scenes")
        before = run_all(other, scene_paths, work, "before")
        after = run_all(ROOT, scene_paths, work, "after")
    finally:
        subprocess.run([*worktree, "remove", "--force", str(other)], check=False)
    different = 0
    for scene in scene_paths:
        stem = scene.stem
        csv_before, csv_after = (work / side / stem / f"{stem}.csv" for side in ("before", "after"))
        same_status = before[stem] == after[stem]
        same_csv = csv_before.exists() == csv_after.exists() and (
            not csv_before.exists() or csv_before.read_bytes() == csv_after.read_bytes()
        )
        different += not (same_status and same_csv)
        verdict = "same" if same_status and same_csv else "DIFFERENT"
        print(f"{stem}: {verdict} (exit status {before[stem]} -> {after[stem]})")
    if not args.keep:
        shutil.rmtree(work, ignore_errors=True)
    print(f"{len(scene_paths) - different} of {len(scene_paths)} scenes: the same exit status and CSV")
    return 1 if different else 0


if __name__ == "__main__":
    raise SystemExit(main())
