"""What the scene format's schema library costs, and the candidates it was chosen from.

    .venv/bin/python -m bench.scene_schema            # Markdown tables on stdout
    .venv/bin/python -m bench.scene_schema --no-venvs # ipgen's own numbers only

For each candidate (pydantic, msgspec, attrs + cattrs) a fresh virtualenv in a temporary
folder gets the library from pip; the table gives the installed size of the library and its
dependencies, the median time of a new Python process that imports it, declares a two-table
scene model and validates one document (so lazy imports are paid), and whether the library
writes a JSON Schema. Then ipgen's own: loading each shipped scene in-process (median), and the
whole `ipgen --scene ... --describe` command as a new process (median), for docs/scenes.md.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

# A two-table scene declared with each library, then one document validated and (where the
# library can) its JSON Schema written.
PROGRAMS = {
    "pydantic": (
        ["pydantic"],
        """
from typing import Literal
from pydantic import BaseModel, ConfigDict, Field
class System(BaseModel):
    model_config = ConfigDict(extra="forbid")
    type: Literal["classical", "rotary"]
    links: int = Field(ge=1)
class Parameters(BaseModel):
    model_config = ConfigDict(extra="forbid")
    m: list[float]
    g: float = 9.81
class Scene(BaseModel):
    system: System
    parameters: Parameters
Scene.model_validate({"system": {"type": "rotary", "links": 1}, "parameters": {"m": [1, 2]}})
Scene.model_json_schema()
""",
    ),
    "msgspec": (
        ["msgspec"],
        """
from typing import Annotated, Literal
import msgspec
class System(msgspec.Struct, forbid_unknown_fields=True):
    type: Literal["classical", "rotary"]
    links: Annotated[int, msgspec.Meta(ge=1)]
class Parameters(msgspec.Struct, forbid_unknown_fields=True):
    m: list[float]
    g: float = 9.81
class Scene(msgspec.Struct):
    system: System
    parameters: Parameters
msgspec.convert({"system": {"type": "rotary", "links": 1}, "parameters": {"m": [1, 2]}}, Scene)
msgspec.json.schema(Scene)
""",
    ),
    "attrs + cattrs": (
        ["attrs", "cattrs"],
        """
from typing import Literal
import attrs, cattrs
@attrs.frozen
class System:
    type: Literal["classical", "rotary"]
    links: int = attrs.field(validator=attrs.validators.ge(1))
@attrs.frozen
class Parameters:
    m: list[float]
    g: float = 9.81
@attrs.frozen
class Scene:
    system: System
    parameters: Parameters
converter = cattrs.Converter(forbid_extra_keys=True)
converter.structure({"system": {"type": "rotary", "links": 1}, "parameters": {"m": [1, 2]}}, Scene)
""",
    ),
}
SCHEMA = {
    "pydantic": "yes (model_json_schema)",
    "msgspec": "yes (msgspec.json.schema)",
    "attrs + cattrs": "no",
}
LICENCE = {"pydantic": "MIT", "msgspec": "BSD-3-Clause", "attrs + cattrs": "MIT"}


def _median_seconds(command: list[str], runs: int, **kwargs: object) -> float:
    times = []
    for _ in range(runs):
        started = time.perf_counter()
        subprocess.run(command, check=True, capture_output=True, **kwargs)  # type: ignore[call-overload]
        times.append(time.perf_counter() - started)
    return statistics.median(times)


def _installed_kib(python: Path, packages: list[str]) -> tuple[int, list[str]]:
    """Size of the files of `packages` and their dependencies in the venv, and their names."""
    code = """
import importlib.metadata as md, json, os, re, sys
todo, seen, size = list(sys.argv[1:]), {}, 0
while todo:
    name = re.split(r"[ ;<>=!\\[~]", todo.pop())[0].lower().replace("_", "-")
    if name in seen:
        continue
    try:
        dist = md.distribution(name)
    except md.PackageNotFoundError:
        continue
    seen[name] = dist.version
    paths = [dist.locate_file(f) for f in dist.files or ()]
    size += sum(os.path.getsize(p) for p in paths if p.is_file())
    todo += [r for r in dist.requires or () if "extra ==" not in r]
print(json.dumps([size, [f"{n} {v}" for n, v in sorted(seen.items())]]))
"""
    import json

    out = subprocess.run([python, "-c", code, *packages], check=True, capture_output=True, text=True).stdout
    size, names = json.loads(out)
    return size // 1024, names


def candidates(runs: int) -> list[str]:
    rows = [
        "| library | installed (with dependencies) | import + declare + validate, new process (median) "
        "| base Python process | JSON Schema | licence |",
        "| --- | --- | --- | --- | --- | --- |",
    ]
    with tempfile.TemporaryDirectory() as tmp:
        for name, (packages, program) in PROGRAMS.items():
            venv = Path(tmp) / name.replace(" ", "").replace("+", "_")
            subprocess.run([sys.executable, "-m", "venv", venv], check=True)
            python = venv / "bin" / "python"
            subprocess.run([python, "-m", "pip", "install", "-q", *packages], check=True)
            size, names = _installed_kib(python, packages)
            seconds = _median_seconds([python, "-c", program], runs)
            bare = _median_seconds([python, "-c", "pass"], runs)
            rows.append(
                f"| {name} ({', '.join(names)}) | {size / 1024:.1f} MiB | {seconds * 1e3:.0f} ms "
                f"| {bare * 1e3:.0f} ms | {SCHEMA[name]} | {LICENCE[name]} |"
            )
    return rows


def ipgen_numbers(runs: int) -> list[str]:
    from ipgen.experiment.scene import load_scene

    scenes = sorted((ROOT / "scenes").glob("*.toml"))
    load_scene(scenes[0])  # pydantic imported and the validators built once per process
    per_scene = []
    for scene in scenes:
        times = []
        for _ in range(max(runs, 20)):
            started = time.perf_counter()
            load_scene(scene)
            times.append(time.perf_counter() - started)
        per_scene.append(statistics.median(times))
    ipgen = Path(sys.executable).parent / "ipgen"
    describe = _median_seconds(
        [ipgen, "--scene", scenes[0], "--describe"], runs, env={**os.environ, "PYTHONDONTWRITEBYTECODE": "1"}
    )
    import_cost = _median_seconds([sys.executable, "-c", "import ipgen.experiment.scene"], runs)
    bare = _median_seconds([sys.executable, "-c", "import ipgen"], runs)
    rows = ["| ipgen | median |", "| --- | --- |"]
    rows += [
        f"| load_scene(`{scene.relative_to(ROOT)}`), in-process, after a first load | {t * 1e3:.2f} ms |"
        for scene, t in zip(scenes, per_scene, strict=True)
    ]
    return [
        *rows,
        f"| `import ipgen.experiment.scene` (pydantic, the declaration), new process "
        f"| {import_cost * 1e3:.0f} ms |",
        f"| `import ipgen`, new process | {bare * 1e3:.0f} ms |",
        f"| `ipgen --scene {scenes[0].relative_to(ROOT)} --describe`, new process "
        f"| {describe * 1e3:.0f} ms |",
    ]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--runs", type=int, default=7, help="processes per median (default 7)")
    parser.add_argument("--no-venvs", action="store_true", help="skip the candidates (no pip installs)")
    args = parser.parse_args()
    load = os.getloadavg()
    print(f"Machine: {os.cpu_count()} cores, load average {load[0]:.2f} {load[1]:.2f} {load[2]:.2f}\n")
    if not args.no_venvs:
        print("\n".join(candidates(args.runs)) + "\n")
    print("\n".join(ipgen_numbers(args.runs)))


if __name__ == "__main__":
    main()
