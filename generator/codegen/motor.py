"""The headers' DC motor, printed from the motor's one formula (`actuator.motor_terms`, `fold_base`).

The C header's `ipgen_NAME_motor_gain`, `_motor_damping`, `_motor_inertia` and `_with_motor`, and
the C++ header's `DcMotor::gain()`, `damping()`, `inertia()` and `with_motor`: their bodies, and
the formulas their comments state, come from `motor_terms` and `fold_base` run on
`printer.Formula` leaves (the motor struct's fields) and printed operation for operation
(`printer.print_formula`). So a header computes, from the same doubles, the bits ipgen's
`Actuator.gain()`, `damping()` and `inertia()` compute, and the formulas are written once, in
model/actuator.py. The templates keep the frames: the signatures and the units in the comments.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from fractions import Fraction

from ipgen.codegen.printer import Formula, c_literal, double_literal, literal, print_formula
from ipgen.model.actuator import MOTOR_CONSTANTS, fold_base, motor_terms
from ipgen.model.system import System

LANGUAGES = ("c", "cpp")


@dataclass(frozen=True)
class MotorFunctions:
    """The printed parts of one header's motor functions (for its template).

    Attributes
    ----------
    gain, damping, inertia : str
        The expressions the functions return: b (the force or torque per volt), c (the back-EMF
        damping) and the rotor's reflected inertia, over the motor struct's fields (damping
        calls the gain function).
    gain_formula, damping_formula, inertia_formula : str
        The same formulas in a comment's notation (``eta_g Kg eta_m kt / Rm``, ``b Kg km``).
    fold : tuple of str
        The statements of with_motor: the base's damping and inertia raised (``+=``).
    unused : tuple of str
        with_motor's pointer arguments the fold does not read (C: ``links`` on a cart).
    """

    gain: str
    damping: str
    inertia: str
    gain_formula: str
    damping_formula: str
    inertia_formula: str
    fold: tuple[str, ...]
    unused: tuple[str, ...]


def _leaves(system: System, spell: str) -> dict[str, Formula]:
    """The motor's constants as leaves spelled `spell` ({name} its field), r on a cart only."""
    return {
        name: Formula.leaf(spell.format(name=name))
        for name in MOTOR_CONSTANTS
        if name != "r" or not system.is_rotary
    }


def motor_functions(system: System, language: str, prefix: str = "") -> MotorFunctions:
    """The motor functions of `system`'s header in `language`, printed from `motor_terms`.

    Parameters
    ----------
    system : System
        The pendulum: a cart's motor divides by the pinion radius r and folds its inertia into
        m[0], an arm's into J[0].
    language : {"c", "cpp"}
        "c": the C99 header's functions (``motor->Rm``, ``prefix_motor_gain(motor)``, IPGEN_SCALAR
        constants); "cpp": the C++ header's DcMotor members (``Rm``, ``gain()``, double constants)
        and with_motor (Scalar).
    prefix : str
        The C functions' prefix (``ipgen_NAME``); unused in C++.

    Returns
    -------
    MotorFunctions
        The bodies, the comments' formulas and with_motor's statements.

    Raises
    ------
    ValueError
        An unknown `language`.

    Examples
    --------
    >>> motor_functions(System("rotary", 1), "cpp").damping
    'gain()*Kg*km'
    >>> motor_functions(System("classical", 1), "c", "ipgen_m").inertia
    'motor->eta_g*(motor->Kg*motor->Kg)*motor->Jm/(motor->r*motor->r)'
    """
    if language not in LANGUAGES:
        raise ValueError(f"motor functions are printed in {' or '.join(LANGUAGES)}, not {language!r}")
    c = language == "c"
    leaves = _leaves(system, "motor->{name}" if c else "{name}")
    gain, damping, inertia = motor_terms(leaves)
    number = c_literal if c else double_literal
    call = (lambda what: f"{prefix}_motor_{what}(motor)") if c else (lambda what: f"{what}()")
    readable = motor_terms(_leaves(system, "{name}"))

    def comment(formula: Formula, names: dict[Formula, str]) -> str:
        return print_formula(formula, number, names, readable=True)

    # with_motor: fold_base on the Params (and links) entries, the terms by their functions
    base = {
        "m0": Formula.leaf("p->m[0]" if c else "p.m[0]"),
        "delta0": Formula.leaf("p->delta[0]" if c else "p.delta[0]"),
        "J0": Formula.leaf("links->J[0]" if c else "p.J[0]"),
    }
    m0, delta0, j0, _ = fold_base(leaves, system.is_rotary, base["m0"], base["delta0"], base["J0"])
    by_call = {damping: call("damping"), inertia: call("inertia")}
    if not c:  # DcMotor computes in double; with_motor in the Params' Scalar
        by_call = {term: f"Scalar(motor.{text})" for term, text in by_call.items()}
    fold = []
    for before, after in ((base["delta0"], delta0), (base["m0"], m0), (base["J0"], j0)):
        if after == before:
            continue
        if after.operator == "+" and after.args[0] == before:
            fold.append(f"{before.name} += {print_formula(after.args[1], _scalar(c), by_call)};")
        else:
            fold.append(f"{before.name} = {print_formula(after, _scalar(c), by_call)};")
    unused = ("links",) if c and not any(line.startswith("links->") for line in fold) else ()
    return MotorFunctions(
        gain=print_formula(gain, number),
        damping=print_formula(damping, number, {gain: call("gain")}),
        inertia=print_formula(inertia, number),
        gain_formula=comment(readable[0], {}),
        damping_formula=comment(readable[1], {readable[0]: "b"}),
        inertia_formula=comment(readable[2], {}),
        fold=tuple(fold),
        unused=unused,
    )


def _scalar(c: bool) -> Callable[[Fraction], str]:
    """The constants' printer of the Params' scalar type: IPGEN_SCALAR (C), Scalar (C++)."""
    return c_literal if c else literal
