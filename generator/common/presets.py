"""The preset scenes shipped with ipgen (the checkout's scenes/, installed as `ipgen/presets/`):
found by name (`ipgen run --preset qube_servo2`), listed with the source of their values
(`ipgen presets`)."""

from __future__ import annotations

import re
import tomllib
from dataclasses import dataclass
from pathlib import Path

from ipgen.common.locations import presets_dir
from ipgen.common.safetext import abbreviate
from ipgen.errors import Error

__all__ = ["Preset", "preset_names", "preset_path", "presets"]

SOURCE_PREFIX = "# Values from: "


@dataclass(frozen=True)
class Preset:
    """One preset: its name (the file's stem), file, system, what it shows and where its values
    come from (the scene's `# Values from:` comment)."""

    name: str
    path: Path
    system: str  # e.g. "rotary, 1 link"
    title: str  # the scene's first comment sentence
    source: str


def _describe(path: Path) -> Preset:
    text = path.read_text(encoding="utf-8")
    header: list[str] = []
    for line in text.splitlines():
        if not line.startswith("#") or line.strip() == "#":
            break
        header.append(line[1:].strip())
    marker = SOURCE_PREFIX.removeprefix("# ")
    # The source runs from its marker to the header's end (it may wrap onto more lines).
    start = next((i for i, line in enumerate(header) if line.startswith(marker)), len(header))
    source = " ".join(header[start:]).removeprefix(marker)
    paragraph = " ".join(header[:start])
    title = re.split(r"\.\s+(?=[A-Z`])", paragraph, maxsplit=1)[0].rstrip(".") + "."
    try:
        system = tomllib.loads(text).get("system", {})
        links = int(system.get("links", 0))
        kind = f"{system.get('type', '?')}, {links} link{'s' if links != 1 else ''}"
    except (tomllib.TOMLDecodeError, ValueError, TypeError, AttributeError):
        kind = "?"
    return Preset(path.stem, path, kind, title, source.rstrip("."))


def presets() -> list[Preset]:
    """Every preset, sorted by name (the paper's scenes, then rigs/ merged in one namespace)."""
    folder = presets_dir()
    return sorted((_describe(path) for path in folder.rglob("*.toml")), key=lambda p: p.name)


def preset_names() -> tuple[str, ...]:
    """Every preset's name, sorted: the files' stems only (`presets` also reads each file)."""
    return tuple(sorted(path.stem for path in presets_dir().rglob("*.toml")))


def preset_of(path: Path) -> str | None:
    """The preset's name if `path` is a preset's own file as `--preset NAME` chooses it, else None."""
    path = Path(path)
    if path.is_absolute() and path.suffix == ".toml":
        try:
            shipped = path.resolve().parent.is_relative_to(presets_dir().resolve())
            if shipped and preset_path(path.stem) == path:
                return path.stem
        except (Error, OSError):
            pass
    return None


def scene_source(path: Path) -> str:
    """How a generated file names the scene it comes from: "preset NAME" for a preset's own file
    (`preset_of`: its absolute path in this installation would make the bytes differ from one
    installation to the next), else the path as given, made comment-safe."""
    from ipgen.common.safetext import quote_path

    name = preset_of(path)
    return f"preset {name}" if name else quote_path(Path(path).as_posix())


def preset_path(name: str) -> Path:
    """The scene file of the preset `name`; an `Error` naming the presets there are otherwise."""
    if not isinstance(name, str):
        raise Error(f"preset {abbreviate(repr(name))}: expected a preset's name (ipgen presets lists them)")
    folder = presets_dir()
    found = [path for path in folder.rglob("*.toml") if path.stem == name]
    if len(found) == 1:
        return found[0]
    names = preset_names()
    suggestion = _suggestion(name, names)
    raise Error(f"no preset {abbreviate(name)!r}: {suggestion} (ipgen presets lists all {len(names)})")


def _suggestion(name: str, names: tuple[str, ...], most: int = 5) -> str:
    """The presets `name` may have meant (those containing it, then difflib's close matches), or,
    with none, every name: one line that the CLI's 400 characters do not cut in the middle."""
    import difflib

    containing = [found for found in names if name.lower() in found.lower()]
    close = difflib.get_close_matches(name, names, n=most, cutoff=0.6)
    meant = list(dict.fromkeys(containing + close))
    if meant:
        more = ", …" if len(meant) > most else ""
        return f"did you mean {', '.join(meant[:most])}{more}?"
    listed = ", ".join(names)
    return f"choose one of {listed}" if len(listed) < 250 else f"choose one of {', '.join(names[:8])}, …"
