"""`ipgen --type fixed --links N --joints 1,2 -o DIR`: write a fixed-pivot chain's files.

The targets are the cart's and the arm's (`--emit cpp, c, library, equations, fmu, fmu3`),
rendered by the same printers and templates over the chain's equations (`render_target`). The
options are checked in the order the command reports them, each problem one line
(`job.OptionsError`); the files are written all or none (`files.write_files`), as for the
cart's and the arm's.
"""

from __future__ import annotations

import contextlib
from pathlib import Path

from ipgen.codegen.emit import parse_emit
from ipgen.codegen.fixed_header import FixedHeaderRequest, fixed_command, render_fixed
from ipgen.common.files import prepare_directory, write_files
from ipgen.common.naming import name_problem
from ipgen.common.safetext import abbreviate
from ipgen.model.fixed import joints_problem
from ipgen.pipeline.generate import Written
from ipgen.pipeline.job import LINKS_WITHOUT_FORCE, OptionsError

FIXED_TARGETS: tuple[str, ...] = ("cpp", "c", "library", "equations", "fmu", "fmu3")


def parse_joints(text: str | None, links: int) -> tuple[int, ...]:
    """`"1,2"` -> (1, 2); None -> (1,); checked against the chain (`fixed.joints_problem`)."""
    if text is None:
        return (1,)
    joints: list[object] = []
    for part in text.split(","):
        part = part.strip()
        try:
            joints.append(int(part))
        except ValueError:
            raise OptionsError(
                f"--joints {abbreviate(text)!r}: expected joint numbers 1..{links} separated by commas, "
                "e.g. --joints 1,2"
            ) from None
    problem = joints_problem(joints, links)
    if problem:
        raise OptionsError(f"--{problem}")
    return tuple(joints)  # type: ignore[arg-type]


def plan_fixed(
    links: object,
    joints: str | None,
    directory: str | Path | None,
    name: str | None,
    emit: str | None,
    force: bool,
) -> tuple[FixedHeaderRequest, Path, tuple[str, ...]]:
    """The request, the folder and the targets of one command, or an OptionsError."""
    if links is None:
        raise OptionsError(
            "missing --links: say how many links hang from the pivot, e.g. --type fixed --links 2"
        )
    if isinstance(links, bool) or not isinstance(links, int) or links < 1:
        raise OptionsError(
            f"--links must be an integer >= 1 (got {abbreviate(repr(links))}): it counts the links"
        )
    if links > LINKS_WITHOUT_FORCE and not force:
        raise OptionsError(
            f"--links {links} is large; pass --force to go ahead (up to {LINKS_WITHOUT_FORCE} need none)"
        )
    chosen = parse_joints(joints, links)
    if directory is None:
        raise OptionsError("missing -o DIR: say where to write the header")
    if not str(directory).strip():
        raise OptionsError(f"-o {str(directory)!r} is empty: name the output folder, e.g. -o out/")
    name = name if name is not None else f"fixed{links}"
    problem = name_problem(name)
    if problem:
        raise OptionsError(f"--name {abbreviate(name)!r} {problem}; choose another name")
    targets = parse_emit(emit) if emit is not None else ("cpp",)
    others = [target for target in targets if target not in FIXED_TARGETS]
    if others:
        raise OptionsError(
            f"--emit {others[0]}: not yet supported for fixed-pivot models; "
            f"choose from {', '.join(FIXED_TARGETS)}"
        )
    request = FixedHeaderRequest(name, links, chosen, fixed_command(name, links, chosen, targets))
    return request, Path(directory), targets


def render_target(request: FixedHeaderRequest, target: str) -> dict[str, str | bytes]:
    """{suffix: text or bytes} of one target of the chain (`FIXED_TARGETS`); deterministic.

    Parameters
    ----------
    request : FixedHeaderRequest
        The chain's name, links, driven joints and command.
    target : str
        One of `FIXED_TARGETS`.

    Returns
    -------
    dict of str to str or bytes
        File suffix -> contents (bytes for the .fmu archive).
    """
    if target == "equations":
        from ipgen.codegen.equations import render_fixed_equations

        return dict(render_fixed_equations(request.name, request.command, request.joints, request.links))
    if target in ("fmu", "fmu3"):
        from ipgen.codegen.fmu import render_fixed_fmu

        return {".fmu": render_fixed_fmu(request, 2 if target == "fmu" else 3)}
    return dict(render_fixed(request, target))


def generate_fixed(
    links: object,
    joints: str | None,
    directory: str | Path | None,
    name: str | None = None,
    emit: str | None = None,
    force: bool = False,
) -> list[Written]:
    """Render every target of `emit` for the chain as DIR/<name><suffix> and write them all or none."""
    request, folder, targets = plan_fixed(links, joints, directory, name, emit, force)
    files: list[tuple[Path, str | bytes]] = []
    for target in targets:
        files += [
            (folder / f"{request.name}{suffix}", text)
            for suffix, text in render_target(request, target).items()
        ]
    created = prepare_directory(folder)
    try:
        statuses = write_files(files, force)
    except BaseException:
        if created:
            with contextlib.suppress(OSError):
                folder.rmdir()
        raise
    return [
        Written(path, status, len(text.encode() if isinstance(text, str) else text))
        for (path, text), status in zip(files, statuses, strict=True)
    ]
