"""The variables of an ipgen FMU (`--emit fmu`, `--emit fmu3`) and their true dependencies.

One table serves the model description (XML) and the C glue (templates/fmu_model.c.jinja):
value references, names, causality, start values, how the C code reads and writes each
variable, and which states and inputs each output and derivative depends on, read from the
derived polynomials (an acceleration depends on the angles that occur in M or the bias).

Layout (D = links + 1 coordinates; a fixed-pivot chain's, `fixed_layout`, has D = links and m
inputs u1..um): time (0); theta0..thetaD-1 (states, outputs);
dtheta0..dtheta (states, the derivatives of theta); ddtheta0.. (the derivatives of dtheta);
the input u; the energy outputs; then every parameter the model's equations read (the
generators the C header's functions take from their params struct, and from the links
struct where the header has one), in the algebra's order, as tunable parameters.
"""

from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction

from ipgen.codegen.functions import C_SYNTAX, params_field
from ipgen.model.derivation import Equations
from ipgen.model.paper import PAPER_RIGS
from ipgen.model.polynomial import LETTER, PARAMETER, VELOCITY
from ipgen.model.specialise import check_parameter
from ipgen.model.system import System, split_parameter

DEFAULT_G = 9.81


@dataclass(frozen=True)
class Variable:
    """One FMI variable: its value reference, name and role, and its C access."""

    vr: int
    name: str
    causality: str  # independent | output | local | input | parameter
    variability: str  # continuous | tunable
    description: str
    initial: str = ""  # exact | calculated | "" (none allowed)
    start: float | None = None
    derivative_of: int | None = None  # the value reference this variable is the derivative of
    c_value: str = ""  # C expression of the value, in the model struct `m`
    rule: str = ""  # parameters: "positive" (> 0), "nonnegative" (>= 0), "finite", "nonzero"
    kind: str = ""  # time | q | qd | qdd | u | energy | parameter
    minimum: str | None = "0"  # a parameter's declared min (None: none, e.g. a com, which may be negative)


@dataclass(frozen=True)
class Layout:
    """All variables of one model, and the dependencies the model structure declares."""

    variables: tuple[Variable, ...]
    dof: int
    # Value references each output / derivative depends on (states and the input).
    output_dependencies: tuple[tuple[int, tuple[int, ...]], ...]
    derivative_dependencies: tuple[tuple[int, tuple[int, ...]], ...]

    def by_kind(self, kind: str) -> tuple[Variable, ...]:
        return tuple(v for v in self.variables if v.kind == kind)


def default_start(system: System, name: str, given: dict[str, float] | None = None) -> float:
    """The start value of parameter `name` without a scene value: the paper's value; a
    parameter beyond m, l, delta and g gets the homogeneous rod's value of the masses and lengths
    in `given` (else the paper's): centre of gravity `com` at l/2, inertia `J` = m l^2/12 about
    it, a rotary arm's J0 = m0 l0^2/3 about the vertical, no axial inertia or tip mass; 0 if the
    parameter is unknown here."""
    group, index = split_parameter(name)
    if group == "g":
        return DEFAULT_G
    if index is None:
        return 0.0
    paper = PAPER_RIGS[system.type]  # start values without a scene: the paper's systems
    if group in paper:
        return paper[group][0 if index == 0 else 1]
    known = given or {}
    mass = known.get(f"m{index}", paper["m"][0 if index == 0 else 1])
    length = known.get(f"l{index}", paper["l"][0 if index == 0 else 1])
    rod = {"com": length / 2, "J": mass * length**2 / (3 if index == 0 else 12)}
    return rod.get(group, 0.0)


def _rule(system: System, name: str) -> str:
    """The validity rule of a parameter, from the one that checks --fix values: "positive"
    (> 0), "nonnegative" (>= 0) or "finite" (any real)."""
    if check_parameter(system, name, Fraction(0)) is not None:
        return "positive"
    if check_parameter(system, name, Fraction(-1)) is not None:
        return "nonnegative"
    return "finite"


def model_parameters(eqs: Equations) -> list[str]:
    """The parameters the model reads, in the algebra's order: those occurring in M, the bias
    or the energies (a cart's l0, for one, does not)."""
    algebra = eqs.algebra
    used: set[int] = set()
    for key in ("mass_matrix", "bias", "kinetic_energy", "potential_energy", "dissipation"):
        for row in eqs.poly[key]:
            for p in row:
                used |= algebra.used(p)
    for g in sorted(algebra.named, reverse=True):
        if g in used:
            used |= algebra.used(algebra.named[g])
    return [info.name for g, info in enumerate(algebra.generators) if info.kind == PARAMETER and g in used]


def c_field(name: str) -> str:
    """Parameter `name` in the FMU's model struct `m`: the C header's params (m->p.m[1]) or,
    for the links as built where the header has them, links (m->links.com[1])."""
    field = params_field(name, C_SYNTAX)
    for pointer, member in (("p->", "m->p."), ("links->", "m->links.")):
        if field.startswith(pointer):
            return member + field.removeprefix(pointer)
    raise ValueError(f"parameter {name} is read as {field}: not in the params or links struct")


def _angles_and_rates(eqs: Equations, keys: tuple[str, ...]) -> tuple[set[int], set[int]]:
    """The angles (coordinate indices) and velocities the polynomials `keys` depend on."""
    algebra = eqs.algebra
    used: set[int] = set()
    for key in keys:
        for row in eqs.poly[key]:
            for p in row:
                used |= algebra.used(p)
    for g in sorted(algebra.named, reverse=True):
        if g in used:
            used |= algebra.used(algebra.named[g])
    angles: set[int] = set()
    rates: set[int] = set()
    for g in used:  # named quantities are expanded above: their letters are in `used`
        info = algebra.generators[g]
        if info.kind == LETTER:
            angles |= set(info.angles)
        elif info.kind == VELOCITY:
            rates.add(info.index)
    return angles, rates


# The energy outputs every FMU has, in this order: (name, C value); `energy_variables`.
ENERGIES = (("kinetic_energy", "m->T"), ("potential_energy", "m->V"), ("energy", "m->T + m->V"),
            ("damping_power", "2*m->D"))  # fmt: skip


def energy_variables(first: int, kinetic: str, origin: str) -> list[Variable]:
    """The `ENERGIES` outputs from value reference `first` on: T described as `kinetic`, V zero
    with the centres of gravity at `origin`'s height (the base's, the pivot's), E and the damping
    power."""
    descriptions = (
        kinetic,
        f"potential energy V [J], zero with the centres of gravity at {origin}'s height",
        "total mechanical energy E = T + V [J]",
        "power lost to damping, 2 D (D the Rayleigh dissipation) [W]",
    )
    return [
        Variable(first + k, name, "output", "continuous", text, "calculated", c_value=value, kind="energy")
        for k, ((name, value), text) in enumerate(zip(ENERGIES, descriptions, strict=True))
    ]


def energy_dependencies(
    first: int, kinetic: list[int], potential: list[int], damping: list[int]
) -> list[tuple[int, tuple[int, ...]]]:
    """The `ENERGIES` outputs' dependencies (value references) from `first` on: T's, V's, both
    for E, and the damped rates for the damping power."""
    return [
        (first, tuple(kinetic)),
        (first + 1, tuple(potential)),
        (first + 2, tuple(sorted(set(kinetic) | set(potential)))),
        (first + 3, tuple(damping)),
    ]


def layout(eqs: Equations, start: dict[str, float], initial: tuple[float, ...] = ()) -> Layout:
    """The FMU's variables for `eqs`; `start` overrides parameter start values (a scene's),
    `initial` the states' (θ then θ̇)."""
    system = eqs.system
    dof = system.dof
    base_unit = "m" if system.type == "classical" else "rad"
    x0 = list(initial) if len(initial) == 2 * dof else [0.0] * (2 * dof)
    variables: list[Variable] = [
        Variable(
            0, "time", "independent", "continuous", "simulation time [s]", kind="time", c_value="m->time"
        )
    ]
    vr = 1
    for i in range(dof):
        base = "cart position [m]" if system.type == "classical" else "arm angle [rad]"
        what = base if i == 0 else f"absolute angle of link {i} from the upright [rad]"
        variables.append(
            Variable(
                vr, f"theta{i}", "output", "continuous", what, "exact", x0[i], c_value=f"m->q[{i}]", kind="q"
            )
        )
        vr += 1
    for i in range(dof):
        unit = "m/s" if i == 0 and base_unit == "m" else "rad/s"
        variables.append(
            Variable(
                vr,
                f"dtheta{i}",
                "local",
                "continuous",
                f"rate of theta{i} [{unit}]",
                "exact",
                x0[dof + i],
                derivative_of=1 + i,
                c_value=f"m->qd[{i}]",
                kind="qd",
            )
        )
        vr += 1
    for i in range(dof):
        unit = "m/s2" if i == 0 and base_unit == "m" else "rad/s2"
        variables.append(
            Variable(
                vr,
                f"ddtheta{i}",
                "local",
                "continuous",
                f"acceleration of theta{i} [{unit}]",
                "calculated",
                derivative_of=1 + dof + i,
                c_value=f"m->qdd[{i}]",
                kind="qdd",
            )
        )
        vr += 1
    force = "force on the cart [N]" if system.type == "classical" else "torque on the arm [N m]"
    u_vr = vr
    variables.append(Variable(vr, "u", "input", "continuous", force, "", 0.0, c_value="m->u", kind="u"))
    vr += 1
    variables += energy_variables(vr, "kinetic energy T = 1/2 qd^T M qd [J]", "the base")
    vr += len(ENERGIES)
    paper = {f"{group}{i}": default_start(system, f"{group}{i}") for group in ("m", "l") for i in range(dof)}
    given = {**paper, **start}  # the masses and lengths the rod defaults are computed from
    for name in model_parameters(eqs):
        value = start.get(name, default_start(system, name, given))
        rule = _rule(system, name)
        variables.append(
            Variable(
                vr,
                name,
                "parameter",
                "tunable",
                _parameter_description(system, name),
                "exact",
                float(value),
                c_value=c_field(name),
                rule=rule,
                kind="parameter",
                minimum="0" if rule in ("positive", "nonnegative") else None,  # com: any finite number
            )
        )
        vr += 1

    q_vr = {i: 1 + i for i in range(dof)}
    qd_vr = {i: 1 + dof + i for i in range(dof)}
    angles, rates = _angles_and_rates(eqs, ("mass_matrix", "bias"))
    dynamics = tuple(sorted([q_vr[i] for i in angles] + [qd_vr[i] for i in rates] + [u_vr]))
    derivatives = [(qd_vr[i], (qd_vr[i],)) for i in range(dof)]
    derivatives += [(1 + 2 * dof + i, dynamics) for i in range(dof)]
    t_angles, t_rates = _angles_and_rates(eqs, ("kinetic_energy",))
    v_angles, _ = _angles_and_rates(eqs, ("potential_energy",))
    _, d_rates = _angles_and_rates(eqs, ("dissipation",))
    kinetic = sorted([q_vr[i] for i in t_angles] + [qd_vr[i] for i in t_rates])
    potential = sorted(q_vr[i] for i in v_angles)
    outputs = [(q_vr[i], (q_vr[i],)) for i in range(dof)]
    energy_vr = u_vr + 1
    outputs += energy_dependencies(energy_vr, kinetic, potential, sorted(qd_vr[i] for i in d_rates))
    return Layout(tuple(variables), dof, tuple(outputs), tuple(derivatives))


def _parameter_description(system: System, name: str) -> str:
    """What parameter `name` is, with its unit, for the model description."""
    group, index = split_parameter(name)
    if index is None:
        return "gravitational acceleration g [m/s2]" if group == "g" else name
    base = "cart" if system.type == "classical" else "arm"
    part = f"the {base}" if index == 0 else f"link {index}"
    damping_unit = "kg/s" if index == 0 and system.type == "classical" else "N m s"
    described = {
        "m": f"mass of {part} [kg]",
        "l": f"length of {part} [m]",
        "delta": f"viscous damping of {part} [{damping_unit}]",
    }
    return described.get(group, f"{group} of {part}")


# A fixed chain's parameters without a scene: the paper's cart's links (rods), no rotor.
_FIXED_RULES = {
    "m": "positive",
    "l": "positive",
    "com": "finite",
    "J": "finite",
    "delta": "nonnegative",
    "g": "nonnegative",
    "Ir": "nonnegative",
    "gr": "nonzero",
}
_FIXED_DESCRIPTIONS = {
    "m": "mass of link {i} [kg]",
    "l": "length of link {i}, pivot to far end [m]",
    "com": "distance from the pivot of link {i} to its centre of gravity [m]",
    "J": "inertia of link {i} about its centre of gravity [kg m2] (J + m com^2 > 0)",
    "delta": "viscous damping of joint {i} [N m s]",
    "Ir": "rotor inertia of motor {i} [kg m2] (0: none)",
    "gr": "gear ratio of motor {i} (rotor turns per joint turn relative to its housing; != 0)",
}


def fixed_parameters(links: int, inputs: int) -> list[str]:
    """The tunable parameters of a fixed chain's FMU, as its C header's structs hold them:
    m, l, com, J, delta per link, g, then Ir and gr per input."""
    per_link = [f"{group}{i}" for group in ("m", "l", "com", "J", "delta") for i in range(1, links + 1)]
    return [*per_link, "g", *(f"{group}{k}" for group in ("Ir", "gr") for k in range(1, inputs + 1))]


def _split_fixed(name: str) -> tuple[str, int | None]:
    """ "J2" -> ("J", 2), "g" -> ("g", None): a fixed chain's parameter (`fixed_parameters`)."""
    group = name.rstrip("0123456789")
    return group, (int(name[len(group) :]) if group != name else None)


def fixed_default_start(name: str, given: dict[str, float]) -> float:
    """A fixed chain's parameter without a scene value: the paper's classical links (m = 0.275
    kg, l = 0.5 m, delta = 0.1 N m s) as rods (com = l/2, J = m l^2/12), g = 9.81, no rotor
    (Ir = 0, gr = 1); com and J from the masses and lengths in `given`."""
    group, index = _split_fixed(name)
    paper = PAPER_RIGS["classical"]
    if group == "g":
        return DEFAULT_G
    if group in ("m", "l", "delta"):
        return paper[group][1]
    if group in ("Ir", "gr"):
        return 0.0 if group == "Ir" else 1.0
    mass = given.get(f"m{index}", paper["m"][1])
    length = given.get(f"l{index}", paper["l"][1])
    return length / 2 if group == "com" else mass * length**2 / 12


def _fixed_c_field(group: str, index: int | None) -> str:
    if index is None:
        return f"m->p.{group}"
    where = "m->links." if group in ("com", "J") else "m->p."
    return f"{where}{group}[{index - 1}]"


def fixed_layout(
    joints: tuple[int, ...], links: int, start: dict[str, float], initial: tuple[float, ...] = ()
) -> Layout:
    """The FMU variables of a chain on a fixed pivot, as `layout`'s for the cart and the arm.

    The links are numbered from 1 (theta1..thetan, value references 1..n), one input u_k per
    driven joint follows the accelerations, then the four energies and the parameters of the
    chain's C header (`fixed_parameters`).

    Parameters
    ----------
    joints : tuple of int
        The driven joints (1 = the shoulder), one input each in this order.
    links : int
        The number of links n >= 1.
    start : dict of str to float
        Parameter start values that replace `fixed_default_start`'s.
    initial : tuple of float, optional
        The states' start values, θ then θ̇ (2n, ipgen's coordinates); default all 0.

    Returns
    -------
    Layout
        The variables and the dependencies the model structure declares.
    """
    from ipgen.model.fixed_poly import fixed_poly_equations

    n, inputs = links, len(joints)
    x0 = list(initial) if len(initial) == 2 * n else [0.0] * (2 * n)
    variables: list[Variable] = [
        Variable(
            0, "time", "independent", "continuous", "simulation time [s]", kind="time", c_value="m->time"
        )
    ]
    q_vr = {i: i for i in range(1, n + 1)}
    qd_vr = {i: n + i for i in range(1, n + 1)}
    for i in range(1, n + 1):
        variables.append(
            Variable(
                q_vr[i],
                f"theta{i}",
                "output",
                "continuous",
                f"absolute angle of link {i} from the upright, clockwise [rad]",
                "exact",
                x0[i - 1],
                c_value=f"m->q[{i - 1}]",
                kind="q",
            )
        )
    for i in range(1, n + 1):
        variables.append(
            Variable(
                qd_vr[i],
                f"dtheta{i}",
                "local",
                "continuous",
                f"rate of theta{i} [rad/s]",
                "exact",
                x0[n + i - 1],
                derivative_of=q_vr[i],
                c_value=f"m->qd[{i - 1}]",
                kind="qd",
            )
        )
    for i in range(1, n + 1):
        variables.append(
            Variable(
                2 * n + i,
                f"ddtheta{i}",
                "local",
                "continuous",
                f"acceleration of theta{i} [rad/s2]",
                "calculated",
                derivative_of=qd_vr[i],
                c_value=f"m->qdd[{i - 1}]",
                kind="qdd",
            )
        )
    u_vr = 3 * n + 1
    for k, joint in enumerate(joints):
        where = "the shoulder (joint 1)" if joint == 1 else f"joint {joint}"
        variables.append(
            Variable(
                u_vr + k,
                f"u{k + 1}",
                "input",
                "continuous",
                f"torque of the motor at {where}, on link {joint} and, reacting, the body before it, "
                "clockwise [N m]",
                "",
                0.0,
                c_value=f"m->u[{k}]",
                kind="u",
            )
        )
    energy_vr = u_vr + inputs
    variables += energy_variables(
        energy_vr, "kinetic energy T = 1/2 qd^T M qd, the rotors included [J]", "the pivot"
    )
    given = {**{f"{g}{i}": fixed_default_start(f"{g}{i}", {}) for g in ("m", "l") for i in range(1, n + 1)}}
    given |= start
    for vr, name in enumerate(fixed_parameters(n, inputs), start=energy_vr + len(ENERGIES)):
        group, index = _split_fixed(name)
        rule = _FIXED_RULES[group]
        description = (
            _FIXED_DESCRIPTIONS[group].format(i=index)
            if index is not None
            else "gravitational acceleration g [m/s2]"
        )
        variables.append(
            Variable(
                vr,
                name,
                "parameter",
                "tunable",
                description,
                "exact",
                float(start.get(name, fixed_default_start(name, given))),
                c_value=_fixed_c_field(group, index),
                rule=rule,
                kind="parameter",
                minimum="0" if rule in ("positive", "nonnegative") else None,
            )
        )

    eqs = fixed_poly_equations(n)
    angles, rates = _angles_and_rates(eqs, ("mass_matrix", "bias"))
    inputs_vr = [u_vr + k for k in range(inputs)]
    dynamics = tuple(sorted([q_vr[i] for i in angles] + [qd_vr[i] for i in rates] + inputs_vr))
    derivatives = [(qd_vr[i], (qd_vr[i],)) for i in range(1, n + 1)]
    derivatives += [(2 * n + i, dynamics) for i in range(1, n + 1)]
    t_angles, t_rates = _angles_and_rates(eqs, ("kinetic_energy",))
    for joint in joints:  # a rotor's energy: the rates of its joint's two bodies
        t_rates |= {joint} | ({joint - 1} if joint >= 2 else set())
    v_angles, _ = _angles_and_rates(eqs, ("potential_energy",))
    _, d_rates = _angles_and_rates(eqs, ("dissipation",))
    kinetic = sorted([q_vr[i] for i in t_angles] + [qd_vr[i] for i in t_rates])
    potential = sorted(q_vr[i] for i in v_angles)
    outputs = [(q_vr[i], (q_vr[i],)) for i in range(1, n + 1)]
    outputs += energy_dependencies(energy_vr, kinetic, potential, sorted(qd_vr[i] for i in d_rates))
    return Layout(tuple(variables), n, tuple(outputs), tuple(derivatives))
