"""What `ipgen run` makes of a scene before it simulates, kept in the cache for its next run.

A run's plan is the model's name and library sources (`--emit library`), the resolved scene
(`<stem>.cfg`) and the few facts about the scene that the run's other files need: its stem, type,
number of links, coordinates, the unit of u and its warnings. Making it costs the scene's checks
(pydantic), the derivation, a controller's LQR design (sympy, scipy) and an estimator's, with
their imports: most of the CPU time of a run whose simulator is cached (docs/bench/runtime.md).
A plan depends only on the scene file (its text and its path, as given and resolved), the files
it names (a fixed chain's `[swingup] plan` CSV: its contents, or that it is missing), ipgen's own
sources (every Python file and template of the package) and the installed distributions (their
names and versions), so `<cache>/runs/<key>.json` keeps it, the key the SHA-256 of all of them
and of the run's --force. The next run of the same scene reads it instead of making it again.

An entry is written to a temporary name and renamed, with the SHA-256 of its contents inside; one
that cannot be read, does not match its checksum or holds values of the wrong kind is ignored (the
plan is made again and written over it). Only a plan made without an error is kept: a scene that
fails its checks is checked again at every run. At most `MAX_PLANS` are kept: the least recently
used go first (`prune_plans`).
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import sys
import tomllib
from dataclasses import asdict, dataclass, fields
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ipgen.common.build_cache import cache_root
from ipgen.common.limits import MAX_SCENE_BYTES

if TYPE_CHECKING:
    from ipgen.model.coordinates import Coordinates

# Part of every key: a new layout of the entries gets new keys.
FORMAT = "ipgen run plan 1"
FOLDER = "runs"
# The plans kept at most: a study over many distinct scenes (initial conditions, a specialised
# scene's parameters) added one entry of about 40 kB each, forever. Beyond it the least recently
# used go (about 40 MB kept; a plan removed is made again, a second or so).
MAX_PLANS = 1000
# A temporary entry older than this [s] is a crashed writer's, removed when plans are pruned.
STALE_PARTIAL = 3600.0
METADATA = (".dist-info", ".egg-info")  # an installed distribution's metadata folder
PACKAGE = Path(__file__).resolve().parents[1]  # the package's folder: generator/ or site-packages/ipgen


@dataclass(frozen=True)
class RunPlan:
    """Everything `ipgen run` needs of a scene besides the simulator (module docstring)."""

    name: str  # the model's name: its library and simulator (rotary1, cdip, ...)
    stem: str  # the scene file's stem: the output files' names
    type: str  # "classical" or "rotary"
    links: int
    angles: str  # the scene's coordinates (model.coordinates.Coordinates)
    zero: str
    positive: str
    unit: str | None  # u's unit when it is not a force or torque (V, m/s², rad/s²)
    warnings: tuple[str, ...]  # the scene's warnings, announced at every run
    cfg: str  # the resolved scene's text
    sources: dict[str, str]  # the model library's sources: file name -> text

    @property
    def coordinates(self) -> Coordinates:
        """The scene's coordinates (the convention of the CSV's angles)."""
        from ipgen.model.coordinates import Coordinates

        return Coordinates(self.angles, self.zero, self.positive)


def _files_digest(digest: Any, folder: Path, pattern: str) -> None:
    for path in sorted(folder.rglob(pattern)):
        if "__pycache__" in path.parts:
            continue
        with contextlib.suppress(OSError):
            digest.update(path.relative_to(folder).as_posix().encode() + b"\0" + path.read_bytes() + b"\0")


def named_files(scene: Path) -> list[Path]:
    """The files `scene` names as inputs (a fixed chain's `[swingup] plan`): a run reads them and
    never writes over them, not even with --force. Nothing for a scene it cannot read."""
    try:
        if scene.stat().st_size > MAX_SCENE_BYTES:
            return []
        return _named_files(scene, scene.read_bytes())
    except OSError:
        return []


def _named_files(scene: Path, text: bytes) -> list[Path]:
    """The files `scene` names whose contents its plan reads: a fixed chain's `[swingup] plan`
    (relative to the scene, as pipeline/fixed_run.py reads it). Nothing for a scene that is not TOML
    (the run refuses it and keeps no plan)."""
    try:
        table = tomllib.loads(text.decode("utf-8-sig"))
    except (UnicodeDecodeError, tomllib.TOMLDecodeError, RecursionError):
        return []
    swingup = table.get("swingup")
    plan = swingup.get("plan") if isinstance(swingup, dict) else None
    return [scene.parent / plan] if isinstance(plan, str) and "\0" not in plan else []


def _templates() -> Path | None:
    """The templates folder (as codegen.header.templates_dir finds it, without importing jinja2)."""
    for folder in (PACKAGE / "templates", PACKAGE.parent / "templates"):
        if folder.is_dir():
            return folder
    return None


def _distributions() -> list[str]:
    """The names of the installed distributions' metadata folders on sys.path (name-version.dist-info):
    a package installed, removed or upgraded changes them."""
    names: list[str] = []
    for entry in sys.path:
        with contextlib.suppress(OSError), os.scandir(entry or ".") as found:
            names += [f"{entry}/{item.name}" for item in found if item.name.endswith(METADATA)]
    return sorted(names)


def plan_key(scene: Path, force: bool) -> str | None:
    """The cache key of the plan of `scene` (module docstring); None when the scene file cannot
    be read or is larger than a scene may be (the run then reports it as it checks the scene).

    Parameters
    ----------
    scene : Path
        The scene file, as the run was given it.
    force : bool
        The run's --force (a scene of many links needs it).

    Returns
    -------
    str or None
        64 hexadecimal digits, or None.
    """
    try:
        if not scene.is_file() or scene.stat().st_size > MAX_SCENE_BYTES:
            return None
        text = scene.read_bytes()
        resolved = scene.resolve()
    except (OSError, RuntimeError):
        return None
    digest = hashlib.sha256()
    for part in (FORMAT, sys.version, str(scene), str(resolved), str(force)):
        digest.update(part.encode(errors="surrogateescape") + b"\0")
    digest.update(text + b"\0")
    for named in _named_files(scene, text):  # an edited or deleted plan CSV is a new plan
        try:
            contents = b"file\0" + named.read_bytes() if named.is_file() else b"missing\0"
        except OSError:
            contents = b"unreadable\0"
        digest.update(str(named).encode(errors="surrogateescape") + b"\0" + contents + b"\0")
    _files_digest(digest, PACKAGE, "*.py")
    templates = _templates()
    if templates is not None:
        _files_digest(digest, templates, "*.jinja")
    for name in _distributions():
        digest.update(name.encode(errors="surrogateescape") + b"\0")
    return digest.hexdigest()


def _entry(cache: Path | None, key: str) -> Path:
    return cache_root(cache) / FOLDER / f"{key}.json"


def _is_name_text(value: Any) -> bool:
    return isinstance(value, dict) and all(
        isinstance(k, str) and isinstance(v, str) and "/" not in k and k not in ("", ".", "..")
        for k, v in value.items()
    )


# What each of RunPlan's fields may hold in an entry, by its annotation (a new field without a
# rule here is an error at import, not an unchecked value).
_KINDS: dict[str, Any] = {
    "str": lambda v: isinstance(v, str),
    "str | None": lambda v: v is None or isinstance(v, str),
    "int": lambda v: isinstance(v, int) and not isinstance(v, bool) and v >= 1,
    "tuple[str, ...]": lambda v: isinstance(v, list) and all(isinstance(w, str) for w in v),
    "dict[str, str]": _is_name_text,  # file names: no folders
}
_RULES = {f.name: _KINDS[str(f.type)] for f in fields(RunPlan)}


def _checked(data: Any) -> RunPlan | None:
    """The plan an entry's JSON holds, or None when any value is not of its kind."""
    if not isinstance(data, dict) or set(data) != set(_RULES):
        return None
    if not all(rule(data[name]) for name, rule in _RULES.items()):
        return None
    plan = RunPlan(**{**data, "warnings": tuple(data["warnings"])})
    try:
        plan.coordinates  # noqa: B018 -- the convention's own check
    except Exception:  # any refusal: not a usable entry
        return None
    return plan


def load_plan(cache: Path | None, key: str) -> RunPlan | None:
    """The plan kept under `key` in the cache (`cache_root(cache)`), or None: none kept, or an
    entry that is unreadable, altered or malformed (module docstring).

    Parameters
    ----------
    cache : Path or None
        The cache folder (`--cache-dir`), None for the default.
    key : str
        `plan_key`'s key.

    Returns
    -------
    RunPlan or None
    """
    entry = _entry(cache, key)
    try:
        record = json.loads(entry.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, ValueError, RecursionError):
        return None
    with contextlib.suppress(OSError):
        os.utime(entry)  # used now: the last to go when the plans are pruned
    if not isinstance(record, dict) or not isinstance(record.get("plan"), dict):
        return None
    body = json.dumps(record["plan"], sort_keys=True)
    if record.get("sha256") != hashlib.sha256(body.encode()).hexdigest():
        return None
    return _checked(record["plan"])


def store_plan(cache: Path | None, key: str, plan: RunPlan) -> None:
    """Keep `plan` under `key` (a temporary file renamed into place). A cache that cannot be
    written is not an error: the next run makes the plan again.

    Parameters
    ----------
    cache : Path or None
        The cache folder (`--cache-dir`), None for the default.
    key : str
        `plan_key`'s key.
    plan : RunPlan
        The plan the run made.
    """
    body = asdict(plan)
    body["warnings"] = list(plan.warnings)
    text = json.dumps(
        {"sha256": hashlib.sha256(json.dumps(body, sort_keys=True).encode()).hexdigest(),
         "plan": body},
    )  # fmt: skip
    entry = _entry(cache, key)
    partial = entry.with_name(f".{entry.name}.{os.getpid()}")
    try:
        entry.parent.mkdir(parents=True, exist_ok=True)
        partial.write_text(text, encoding="utf-8")
        os.replace(partial, entry)
    except OSError:
        with contextlib.suppress(OSError):
            partial.unlink()
        return
    prune_plans(entry.parent, spare=entry)


def prune_plans(folder: Path, keep: int | None = None, spare: Path | None = None) -> None:
    """Remove the least recently used plans (modification time: written or read) beyond `keep`
    (default `MAX_PLANS`) down to nine tenths of it (at least one), never `spare` (the plan just
    written), and temporary entries older than `STALE_PARTIAL`. Files another run removes
    meanwhile, or that cannot be removed, are skipped: a plan that is gone is made again.

    Parameters
    ----------
    folder : Path
        The cache's `runs/` folder.
    keep : int, optional
        The most plans kept.
    spare : Path, optional
        A plan never removed.
    """
    import time

    keep = MAX_PLANS if keep is None else keep
    plans: list[tuple[float, Path]] = []
    now = time.time()
    try:
        with os.scandir(folder) as entries:
            for item in entries:
                with contextlib.suppress(OSError):
                    modified = item.stat(follow_symlinks=False).st_mtime
                    if item.name.startswith("."):
                        if now - modified > STALE_PARTIAL:
                            os.unlink(item.path)
                    elif item.name.endswith(".json") and Path(item.path) != spare:
                        plans.append((modified, Path(item.path)))
    except OSError:
        return
    kept = len(plans) + (spare is not None)
    if kept <= keep:
        return
    plans.sort()
    for _, path in plans[: kept - max(1, keep * 9 // 10)]:
        with contextlib.suppress(OSError):
            path.unlink()
