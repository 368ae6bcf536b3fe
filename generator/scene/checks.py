"""ipgen's own rules for scene values that a type and a bound cannot say: names of parameters,
lengths by system type, foldable values, the output interval.

Each function raises the one-line refusals of `values` (`refuse`, `refuse_line`); `schema.py`
attaches them to the keys and tables they check.
"""

from __future__ import annotations

import difflib
from decimal import Decimal
from typing import Any

from pydantic import ValidationInfo

from ipgen.codegen.emit import EmitError, parse_emit
from ipgen.common import limits
from ipgen.common.naming import name_problem
from ipgen.model.system import parameter_names, parameter_range, split_parameter, unused_parameter
from ipgen.scene.fields import format_number, type_name
from ipgen.scene.values import at, context_of, refuse, refuse_line

# A CSV row: t, the angles and rates, u, the energies and the loop's columns, about 20 characters
# each; above this many bytes a run says how much it is about to write.
LARGE_CSV_BYTES = 2**30


def csv_size(t_end: float, sample: float, dof: int) -> tuple[str, ...]:
    """The warning of a run whose CSV comes to more than a GiB (MAX_SAMPLES bounds the rows, not
    the bytes: 1e7 rows of 41 links are 18 GB), or none; `dof` the model's coordinates."""
    rows = t_end / sample + 1
    columns = 2 + 2 * dof
    size = rows * columns * 20
    if size <= LARGE_CSV_BYTES:
        return ()
    return (
        f"the run writes about {size / 1e9:.1f} GB of CSV ({rows:,.0f} rows of {columns} or more "
        "columns): a larger simulation.sample writes less",
    )


def model_name(name: str | None) -> str | None:
    """[system] name: a model name (see `common.naming`)."""
    problem = None if name is None else name_problem(name)
    if problem:
        refuse(f"{problem}; choose another model name")
    return name


def inertia(value: Any, info: ValidationInfo) -> Any:
    """[system] inertia: for rotary systems only (whatever its value)."""
    if info.data.get("type") == "classical":
        refuse("applies to rotary systems only; remove it")
    return value


def emit_targets(value: Any) -> tuple[str, ...]:
    """[system] emit: an array of target names (`codegen.emit.TARGETS`)."""
    if not isinstance(value, list):
        refuse(f'expected an array of target names, e.g. ["cpp"], got {type_name(value)}')
    try:
        names = [_Shown(name) if isinstance(name, (list, dict)) else name for name in value]
        return parse_emit(names, where="system.emit")
    except EmitError as error:
        refuse_line(str(error))


class _Shown:
    """An array or table where a name should be: hashable, shown as itself (`parse_emit`)."""

    def __init__(self, value: Any) -> None:
        self.value = value

    def __repr__(self) -> str:
        return repr(self.value)


def free_names(value: Any, info: ValidationInfo) -> tuple[str, ...]:
    """[parameters] free: distinct names of the system's parameters (m0, delta1, g, ...)."""
    if not isinstance(value, list):
        refuse(f"expected an array of names, got {type_name(value)}")
    context = context_of(info, "links", "type")
    if context is None:
        return ()
    names = parameter_names(context["links"])
    seen: list[str] = []

    def check(name: Any, _: dict[str, Any]) -> str:
        if not isinstance(name, str) or name not in names:
            close = difflib.get_close_matches(name, names, n=1) if isinstance(name, str) else []
            hint = f" (did you mean '{close[0]}'?)" if close else ""
            refuse(f"expected a parameter name {parameter_range(context['links'])}{hint}")
        unused = unused_parameter(context["type"], name)
        if unused:
            refuse(f"{unused}: it cannot be free")
        if name in seen:
            refuse("is listed twice")
        return name

    for i, name in enumerate(value):
        seen.append(at(i, check, name, context))
    return tuple(seen)


def lengths(values: tuple[Decimal, ...], system_type: str) -> None:
    """l[0] is the arm (rotary, > 0) or nothing (a cart: 0, ignored); l[1..n] > 0."""
    base = values[0]
    if system_type == "rotary" and float(base) <= 0:
        refuse("the arm length must be > 0 m", key="l", index=(0,), value=base)
    if system_type == "classical" and float(base) < 0:
        refuse("a cart has no length: write 0 (it is ignored)", key="l", index=(0,), value=base)
    for i, length in enumerate(values[1:], start=1):
        if float(length) <= 0:
            refuse("link lengths must be > 0 m", key="l", index=(i,), value=length)


def links_as_built(table: Any, context: dict[str, Any]) -> None:
    """The link arrays a [parameters] table gives (com, J, J_axial, tip), or the rods m and l
    describe without them, are real bodies (`model.links`): J_axial only for a rotary system with
    inertia full, J_axial <= 2 J, some inertia about every pivot, every value finite in double.
    Each array's entries are checked by its declaration."""
    given = table.links_as_built()
    axial = getattr(table, "J_axial", None)
    if axial is not None and not (context["type"] == "rotary" and context.get("inertia") == "full"):
        refuse('counts only for a rotary system with inertia = "full"', key="J_axial", value=list(axial))
    from ipgen.model.links import LinkError, resolve_links
    from ipgen.model.system import System

    system = System(context["type"], context["links"], context.get("inertia", "pivot"))  # type: ignore[arg-type]
    try:
        resolve_links(
            system,
            [float(number) for number in table.m],
            [float(number) for number in table.lengths(context["type"])],
            {group: [float(number) for number in values] for group, values in given},
        )
    except LinkError as problem:  # the rods too: a double must hold m l²/12 (l = 1e200 m does not)
        rods = "" if given else "the rods these m and l describe: "
        refuse_line(f"parameters: {rods}{problem}")


def foldable(decimals: tuple[tuple[str, str], ...], free: tuple[str, ...], system_type: str) -> None:
    """Every parameter a specialised header folds lies in the range folding accepts."""
    for name, text in decimals:
        if name in free or unused_parameter(system_type, name):
            continue
        problem = limits.fold_problem(text)
        if problem:
            group, index = split_parameter(name)
            refuse(
                f"{problem} (specialise = true folds it; or list it in free)",
                key=group,
                index=() if index is None else (index,),
                value=Decimal(text),
            )


def sample(interval: Decimal, info: ValidationInfo) -> Decimal:
    """[simulation] sample: 0 < sample <= t_end, at most `limits.MAX_SAMPLES` output samples."""
    t_end = info.data.get("t_end")
    if t_end is None:  # t_end is refused already
        return interval
    if not 0 < float(interval) <= float(t_end):
        refuse(f"must be > 0 s and <= t_end ({format_number(float(t_end))} s)")
    if float(t_end) / float(interval) > limits.MAX_SAMPLES:
        refuse(
            f"t_end / sample = {float(t_end) / float(interval):.3g} output samples, more than the "
            f"{limits.MAX_SAMPLES:.0e} the simulator accepts: sample less often or shorten t_end"
        )
    return interval


def rtol(value: Decimal) -> Decimal:
    """[simulation] rtol: not below what double precision can meet."""
    if float(value) < limits.RTOL_MIN:
        refuse("cannot be met in double precision; use >= 1e-14")
    return value
