"""Scene-specialised generation: fold fixed parameters into the equations, emit only what is used.

A general header takes every parameter at run time and defines every function. A
specialised one folds the parameters a scene (or `--fix`) fixes into the expressions as exact
rationals — so 0.275 is 11/40, not the nearest double —, which removes the terms a zero
damping coefficient multiplies, and emits only the functions its consumers call.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from fractions import Fraction

from ipgen.common.limits import fold_problem
from ipgen.common.safetext import abbreviate
from ipgen.errors import Error
from ipgen.model.derivation import Equations
from ipgen.model.polynomial import PARAMETER, Algebra
from ipgen.model.system import (
    System,
    all_parameter_names,
    all_parameter_range,
    split_parameter,
    unused_parameter,
)

# Every function a header can define, in header order.
FUNCTIONS: tuple[str, ...] = (
    "mass_matrix",
    "bias",
    "gravity",
    "n_matrix",
    "forward_dynamics",
    "forward_dynamics_derivatives",
    "kinetic_energy",
    "potential_energy",
    "dissipation",
)
# What the simulator calls: the dynamics and its Jacobian; the energies for an energy ledger.
SIMULATOR_FUNCTIONS: tuple[str, ...] = ("forward_dynamics", "forward_dynamics_derivatives")
ENERGY_FUNCTIONS: tuple[str, ...] = ("kinetic_energy", "potential_energy", "dissipation")


class SpecialisationError(Error, ValueError):
    """An invalid --fix or --outputs value; the message names it and what is expected."""


@dataclass(frozen=True)
class Specialisation:
    """What a header is specialised to; the default is the general header."""

    fixed: tuple[tuple[str, Fraction], ...] = ()  # parameter name (m0, l1, delta2, g) -> value
    outputs: tuple[str, ...] = FUNCTIONS  # functions to emit, in header order
    zero_input: bool = False  # the input is identically zero: drop its path
    scene: str = ""  # the scene file it is made for (posix path, `quote_path`d), or "" for --fix/--outputs
    motor: bool = False  # a dc_motor scene: delta0 and J0 (m0 on a cart) are folded with the motor

    @property
    def origin(self) -> str:
        """Where the specialisation comes from, for the header comment: "scene <path>" or ""."""
        return f"scene {self.scene}" if self.scene else ""

    def notes(self) -> list[str]:
        """One line per specialisation, for the header: "m1 = 0.275 (11/40) folded"."""
        lines = []
        for name, value in self.fixed:
            shown = format_exact(value)
            exact = "" if value.denominator == 1 or shown == f"{value}" else f" ({value})"
            effect = "pruned (its terms vanish)" if value == 0 else "folded"
            lines.append(f"{name} = {shown}{exact} {effect}")
        if self.motor:
            lines.append(
                "dc_motor folded into delta0 and J0 (m0 on a cart): pass the .cfg's params, not "
                "_with_motor's (its sum may differ in the last bit; check_folded reports it)"
            )
        if self.zero_input:
            lines.append("input u = 0: its path is pruned (u is accepted and ignored)")
        missing = [f for f in FUNCTIONS if f not in self.outputs]
        if missing:
            lines.append("not emitted: " + ", ".join(missing))
        return lines


def format_exact(value: Fraction) -> str:
    """A fixed value as the user would write it: 0.275, 3, or 1/3 when no decimal is exact."""
    if value.denominator == 1:
        return str(value.numerator)
    decimal = repr(float(value))
    return decimal if Fraction(decimal) == value else str(value)


def check_parameter(system: System, name: str, value: Fraction) -> str | None:
    """Why `name = value` cannot be fixed for `system`, or None (links as built: `model.links`;
    com may be any number)."""
    if name not in all_parameter_names(system.links):
        return f"unknown parameter {abbreviate(name)!r}: expected one of {all_parameter_range(system.links)}"
    unused = unused_parameter(system.type, name, system.inertia)
    if unused:
        return f"{unused}: it cannot be fixed"
    group, _ = split_parameter(name)
    if group in ("m", "l") and value <= 0:
        return f"{name} = {format_exact(value)}: masses and lengths must be > 0"
    if group in ("J", "J_axial", "tip") and value < 0:
        what = "a mass" if group == "tip" else "an inertia"
        return f"{name} = {format_exact(value)}: {what} cannot be negative (use 0 for none)"
    if group in ("delta", "g") and value < 0:
        return f"{name} = {format_exact(value)}: damping and g must be >= 0"
    return None


def check_combination(fixed: dict[str, Fraction]) -> str | None:
    """Why fixed values that are each allowed cannot go together, or None: J_axial_i <= 2 J_i
    (an axisymmetric body) when both are fixed."""
    for name, axial in fixed.items():
        if name.startswith("J_axial"):
            across = fixed.get("J" + name[len("J_axial") :])
            if across is not None and axial > 2 * across:
                index = name[len("J_axial") :]
                return (
                    f"{name} = {format_exact(axial)} > 2 J{index} = {format_exact(2 * across)}: "
                    "no axisymmetric body has that (J is across the link, J_axial about it)"
                )
    return None


def parse_fix(system: System, text: str) -> tuple[tuple[str, Fraction], ...]:
    """`m0=0.3,l1=0.5` -> ((m0, 3/10), (l1, 1/2)); exact decimals, validated."""
    fixed: dict[str, Fraction] = {}
    for item in filter(None, (part.strip() for part in text.split(","))):
        name, sep, number = item.partition("=")
        name = name.strip()
        if not sep:
            raise SpecialisationError(
                f"--fix {abbreviate(item)!r}: expected NAME=VALUE, e.g. --fix m0=0.3,delta1=0"
            )
        shown = f"--fix {abbreviate(name)}={abbreviate(number.strip())!r}"
        problem = fold_problem(number)
        if problem:  # before Fraction(): 1e-99999999 would build a 1e8-digit denominator
            raise SpecialisationError(f"{shown}: {problem}")
        try:
            value = Fraction(number.strip())
        except (ValueError, ZeroDivisionError):
            raise SpecialisationError(f"{shown}: not a number") from None
        problem = check_parameter(system, name, value)
        if problem:
            raise SpecialisationError(f"--fix {problem}")
        if name in fixed:
            raise SpecialisationError(f"--fix names {name} twice: give each parameter once")
        fixed[name] = value
    if not fixed:
        raise SpecialisationError("--fix is empty: name parameters and values, e.g. --fix m0=0.3,delta1=0")
    problem = check_combination(fixed)
    if problem:
        raise SpecialisationError(f"--fix {problem}")
    order = all_parameter_names(system.links)
    return tuple(sorted(fixed.items(), key=lambda item: order.index(item[0])))


def parse_outputs(text: str) -> tuple[str, ...]:
    """`mass_matrix,bias` -> those functions in header order; unknown names are errors."""
    wanted = [part.strip() for part in text.split(",") if part.strip()]
    if not wanted:
        raise SpecialisationError("--outputs is empty: name functions, e.g. --outputs mass_matrix,bias")
    for name in wanted:
        if name not in FUNCTIONS:
            raise SpecialisationError(
                f"--outputs: unknown function {abbreviate(name)!r}: choose from {', '.join(FUNCTIONS)}"
            )
    return tuple(f for f in FUNCTIONS if f in wanted)


def specialise(eqs: Equations, spec: Specialisation, keys: tuple[str, ...]) -> Equations:
    """The equations with `spec.fixed` folded (exactly) into the polynomials `keys`, those the
    wanted functions read (`codegen.header.poly_keys`); the others are left out."""
    if not spec.fixed:
        return eqs
    values = {_generator_index(eqs.algebra, name): value for name, value in spec.fixed}
    algebra = eqs.algebra.folded(values)
    # Named quantities that became constants (the per-link combinations of fixed parameters)
    # are folded too: a header with every link parameter fixed computes none of them.
    values |= algebra.constant_named()
    algebra = eqs.algebra.folded(values)
    poly = {key: [[algebra.substitute(p, values) for p in row] for row in eqs.poly[key]] for key in keys}
    return replace(eqs, algebra=algebra, poly=poly)


def _generator_index(algebra: Algebra, name: str) -> int:
    index = algebra.index(name)
    if algebra.generators[index].kind != PARAMETER:
        raise KeyError(name)
    return index
