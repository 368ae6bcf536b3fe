"""ipgen's own rules for scene values that a type and a bound cannot say: names of parameters,
lengths by system type, foldable values, and the relations between simulation settings.

Each function raises the one-line refusals of `fieldtypes` (`refuse`, `refuse_key`,
`refuse_line`); `schema.py` attaches them to the keys and tables they check.
"""

from __future__ import annotations

import difflib
from decimal import Decimal
from typing import Any

from ipgen.codegen.emit import EmitError, parse_emit
from ipgen.common import limits
from ipgen.common.naming import name_problem
from ipgen.model.system import parameter_names, parameter_range, split_parameter, unused_parameter
from ipgen.scene.fields import _one_of, _type_name, format_number
from ipgen.scene.fieldtypes import Exact, at, refuse, refuse_line


def model_name_problem(name: str) -> str | None:
    """Why `name` cannot be a model name (see `common.naming`), or None."""
    return name_problem(name)


def emit_targets(value: Any, context: dict[str, Any]) -> tuple[str, ...]:
    """[system] emit: an array of target names (`codegen.emit.TARGETS`)."""
    if not isinstance(value, list):
        refuse(f'expected an array of target names, e.g. ["cpp"], got {_type_name(value)}')
    try:
        return parse_emit(value, where="system.emit")
    except EmitError as error:
        refuse_line(str(error))


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


def sample_interval(t_end: float, sample: Exact) -> None:
    """0 < sample <= t_end, and at most `limits.MAX_SAMPLES` output samples."""
    if not 0 < sample.value <= t_end:
        refuse(f"must be > 0 s and <= t_end ({format_number(t_end)} s)", key="sample", value=sample)
    if t_end / sample.value > limits.MAX_SAMPLES:
        refuse(
            f"t_end / sample = {t_end / sample.value:.3g} output samples, more than the "
            f"{limits.MAX_SAMPLES:.0e} the simulator accepts: sample less often or shorten t_end",
            key="sample",
            value=sample,
        )


def method_settings(table: Any, given: set[str], jacobian_methods: tuple[str, ...]) -> tuple[str | None, Any]:
    """(jacobian, step) of `table.method`: a Jacobian choice for bdf and adams only (default
    "exact"); a fixed step for rk4 only (required, in (0, sample]), which takes no rtol, atol."""
    method = table.method
    jacobian = None
    if method in jacobian_methods:
        jacobian = table.jacobian or "exact"
    elif "jacobian" in given:
        refuse(
            f'applies to methods {_one_of(jacobian_methods)} only (method is "{method}"); remove it',
            key="jacobian",
            value=table.jacobian,
        )
    if method != "rk4":
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
    if not 0 < table.step.value <= table.sample.value:
        refuse(
            f"must be > 0 s and <= sample ({format_number(table.sample.value)} s)",
            key="step",
            value=table.step,
        )
    return jacobian, table.step
