"""ipgen's own rules for scene values that a type and a bound cannot say: names of parameters,
lengths by system type, foldable values, and the relations between simulation settings.

Each function raises the one-line refusals of `fieldtypes` (`refuse`, `refuse_key`,
`refuse_line`); `schema.py` attaches them to the keys and tables they check.
"""

from __future__ import annotations

import difflib
from dataclasses import dataclass
from decimal import Decimal
from typing import Any

from pydantic_core import PydanticCustomError

from ipgen.codegen.emit import EmitError, parse_emit
from ipgen.common import limits
from ipgen.common.naming import name_problem
from ipgen.model.system import (
    INERTIA_VARIANTS,
    parameter_names,
    parameter_range,
    split_parameter,
    unused_parameter,
)
from ipgen.scene.fields import _one_of, _type_name, format_number
from ipgen.scene.fieldtypes import Choice, Exact, Number, at, refuse, refuse_line


def model_name_problem(name: str) -> str | None:
    """Why `name` cannot be a model name (see `common.naming`), or None."""
    return name_problem(name)


def emit_targets(value: Any, context: dict[str, Any]) -> tuple[str, ...]:
    """[system] emit: an array of target names (`codegen.emit.TARGETS`)."""
    if not isinstance(value, list):
        refuse(f'expected an array of target names, e.g. ["cpp"], got {_type_name(value)}')
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


def free_names(value: Any, context: dict[str, Any]) -> tuple[str, ...]:
    """[parameters] free: distinct names of the system's parameters (m0, delta1, g, ...)."""
    if not isinstance(value, list):
        refuse(f"expected an array of names, got {_type_name(value)}")
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


def lengths(values: tuple[Exact, ...], system_type: str) -> None:
    """l[0] is the arm (rotary, > 0) or nothing (a cart: 0, ignored); l[1..n] > 0."""
    base = values[0]
    if system_type == "rotary" and base.value <= 0:
        refuse("the arm length must be > 0 m", key="l", index=(0,), value=base)
    if system_type == "classical" and base.value < 0:
        refuse("a cart has no length: write 0 (it is ignored)", key="l", index=(0,), value=base)
    for i, length in enumerate(values[1:], start=1):
        if length.value <= 0:
            refuse("link lengths must be > 0 m", key="l", index=(i,), value=length)


def links_as_built(table: Any, context: dict[str, Any]) -> None:
    """The link arrays a [parameters] table gives (com, J, J_axial, tip) describe real bodies
    (`model.links`): J_axial only for a rotary system with inertia full, J_axial <= 2 J, some
    inertia about every pivot. Each array's entries are checked by its declaration."""
    given = table.links_as_built()
    if not given:
        return  # the rods: nothing to check
    axial = getattr(table, "J_axial", None)
    if axial is not None and not (context["type"] == "rotary" and context.get("inertia") == "full"):
        refuse('counts only for a rotary system with inertia = "full"', key="J_axial", value=list(axial))
    from ipgen.model.links import LinkError, resolve_links
    from ipgen.model.system import System

    system = System(context["type"], context["links"], context.get("inertia", "pivot"))  # type: ignore[arg-type]
    lengths = [number.value for number in table.lengths(context["type"])]
    try:
        resolve_links(
            system,
            [number.value for number in table.m],
            lengths,
            {group: [number.value for number in values] for group, values in given},
        )
    except LinkError as problem:
        refuse_line(f"parameters: {problem}")


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


def sample(value: Any, context: dict[str, Any]) -> Exact:
    """[simulation] sample: 0 < sample <= t_end, at most `limits.MAX_SAMPLES` output samples."""
    interval = Number().check(value, context)
    t_end = context["fields"].get("t_end")
    if t_end is None:  # t_end is refused already
        return interval
    if not 0 < interval.value <= t_end.value:
        refuse(f"must be > 0 s and <= t_end ({format_number(t_end.value)} s)")
    if t_end.value / interval.value > limits.MAX_SAMPLES:
        refuse(
            f"t_end / sample = {t_end.value / interval.value:.3g} output samples, more than the "
            f"{limits.MAX_SAMPLES:.0e} the simulator accepts: sample less often or shorten t_end"
        )
    return interval


def inertia(value: Any, context: dict[str, Any]) -> str:
    """[system] inertia: for rotary systems only (whatever its value), one of INERTIAS."""
    if context["fields"].get("type") == "classical":
        refuse("applies to rotary systems only; remove it")
    return Choice(options=INERTIA_VARIANTS).check(value, context)


def raw(value: Any, context: dict[str, Any]) -> Any:
    """A value kept as written, checked later by its table's rules (`method_settings`)."""
    return value


@dataclass(frozen=True)
class MethodKeys:
    """Which integration methods take a Jacobian choice (and the choices), which a fixed step."""

    JACOBIAN_METHODS: tuple[str, ...]
    JACOBIANS: tuple[str, ...]
    DEFAULT_JACOBIAN: str
    FIXED_STEP_METHODS: tuple[str, ...]


def method_settings(table: Any, given: set[str], methods: MethodKeys) -> tuple[str | None, Exact | None]:
    """(jacobian, step) of `table.method`, whose keys are checked only when the method uses
    them: a Jacobian choice for bdf and adams (default "exact"); a fixed step for rk4
    (required, in (0, sample]), which takes no rtol and atol."""
    method = table.method
    jacobian = None
    if method in methods.JACOBIAN_METHODS:
        if table.jacobian is not None:
            jacobian = keyed("jacobian", Choice(options=methods.JACOBIANS).check, table.jacobian)
        else:
            jacobian = methods.DEFAULT_JACOBIAN
    elif "jacobian" in given:
        refuse(
            f'applies to methods {_one_of(methods.JACOBIAN_METHODS)} only (method is "{method}"); remove it',
            key="jacobian",
            value=table.jacobian,
        )
    if method not in methods.FIXED_STEP_METHODS:
        if "step" in given:
            refuse(
                f'applies to method "rk4" only (method "{method}" chooses its own steps); remove it',
                key="step",
                value=table.step,
            )
        return jacobian, None
    for key in ("rtol", "atol"):
        if key in given:
            fixed = 'does not apply to method "rk4" (it has a fixed step); remove it'
            refuse(fixed, key=key, value=getattr(table, key))
    if table.step is None:
        refuse_line(
            "missing required key 'simulation.step' "
            '(the fixed step of method "rk4" in s, > 0 and <= sample)'
        )
    step = keyed("step", Number().check, table.step)
    if not 0 < step.value <= table.sample.value:
        refuse(
            f"must be > 0 s and <= sample ({format_number(table.sample.value)} s)",
            key="step",
            value=step,
        )
    return jacobian, step


def keyed(key: str, check: Any, value: Any) -> Any:
    """`check(value)` for `key` of the table (from a table's rule): its errors name `key`."""
    try:
        return check(value, {})
    except PydanticCustomError as error:
        where = {"key": key, "value": value, **(error.context or {})}
        raise PydanticCustomError(error.type, error.message_template, where) from None
