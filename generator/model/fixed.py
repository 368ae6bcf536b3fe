"""`FixedPendulum`: a chain of n links on a fixed pivot, driven by torques at chosen joints.

The pendubot (a motor at the shoulder), the acrobot (at the elbow), the fully actuated double
pendulum and the DFKI double pendulum (docs/model.md, "A fixed pivot"). There is no base
coordinate: the state is x = [θ1..θn, θ̇1..θ̇n], every array has one entry per link (no base
entry), and link 1 hangs from a pivot fixed in space.

Inputs: u_k (k = 1..m) is the torque of the motor at joint `joints[k-1]` (1 = shoulder, between
the ground and link 1; j between links j−1 and j), acting on link j and, reacting, on link j−1,
positive in the rig's positive sense. Each motor may have a rotor inertia `Ir` turning at `gr`
times the joint's rate relative to its housing, which sits on the body before the joint
(ground or link j−1).
"""

from __future__ import annotations

import dataclasses
import math
import numbers
from collections.abc import Mapping, Sequence, Set
from dataclasses import KW_ONLY, dataclass
from decimal import Decimal
from pathlib import Path
from typing import Any

from ipgen.common.limits import MAX_FIXED_LINKS
from ipgen.common.safetext import abbreviate
from ipgen.errors import Error
from ipgen.model.coordinates import Coordinates
from ipgen.model.system import UnknownParameter

__all__ = ["COULOMB_LAWS", "FixedPendulum", "FixedPendulumError"]

COULOMB_LAWS: tuple[str, ...] = ("tanh", "atan")
DEFAULT_COULOMB_SPEED = 0.01  # tanh law: f = c tanh(w / v_s), v_s [rad/s]
DEFAULT_COULOMB_GAIN = 100.0  # atan law (DFKI's): f = c atan(k w), k [s/rad]


class FixedPendulumError(Error, ValueError):
    """A fixed-pivot chain that cannot be built; one line naming the value and the fix."""


def _fail(message: str) -> Any:
    raise FixedPendulumError(message)


def _number(name: str, value: object) -> float:
    """`value` as a finite float (a real number: numpy's and Decimal included), else one line."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real | Decimal):
        return _fail(f"{name} = {abbreviate(repr(value))}: expected a number")
    try:
        number = float(value)
    except (OverflowError, ValueError):
        number = math.inf
    if not math.isfinite(number):
        return _fail(f"{name} = {abbreviate(str(value))}: must be a finite number")
    return number


def _array(name: str, value: object, size: int, what: str) -> tuple[float, ...]:
    if isinstance(value, str | bytes | Mapping | Set) or not hasattr(value, "__len__"):
        return _fail(f"{name} must be a list of {size} numbers ({what}), got {abbreviate(str(value))}")
    items = list(value)  # type: ignore[call-overload]
    if len(items) != size:
        if what == "one per link" and len(items) == size + 1:
            return _fail(
                f"{name} has {len(items)} entries, expected {size}: a fixed pivot has no base entry "
                "(one per link, link 1 first)"
            )
        return _fail(f"{name} has {len(items)} entries, expected {size} ({what})")
    return tuple(_number(f"{name}[{i}]", item) for i, item in enumerate(items))


def joints_problem(joints: object, links: int) -> str | None:
    """Why `joints` cannot be the actuated joints of an n-link chain, or None."""
    if isinstance(joints, str | bytes | Mapping | Set) or not hasattr(joints, "__len__"):
        return (
            f"joints must be a list of joint numbers 1..{links} (1 = shoulder), got {abbreviate(str(joints))}"
        )
    items = list(joints)  # type: ignore[call-overload]
    if not items:
        return f"joints is empty: give at least one actuated joint, 1..{links} (1 = shoulder)"
    for joint in items:
        if isinstance(joint, bool) or not isinstance(joint, numbers.Integral):
            return f"joints: {abbreviate(repr(joint))} is not a joint number: expected integers 1..{links}"
        if not 1 <= joint <= links:
            return f"joints: joint {joint} is out of range: this chain has joints 1..{links} (1 = shoulder)"
    if len(set(items)) != len(items):
        return f"joints {items}: a joint is listed twice: each actuated joint once"
    return None


@dataclass(frozen=True)
class FixedPendulum:
    """An n-link pendulum on a fixed pivot, with torques at chosen joints.

    Parameters
    ----------
    links : int
        Number of links n >= 1.
    m, l, delta : sequence of float
        n entries each (link 1 first; no base): masses [kg] (> 0), lengths [m] (> 0), viscous
        damping of each joint [N m s/rad] (>= 0; joint 1 against the ground, joint i against
        link i − 1).
    g : float, default 9.81
        Gravitational acceleration [m/s²], >= 0.
    com, J : sequence of float or None, keyword-only
        Pivot-to-CoG distances [m] (default l/2) and inertias about the CoGs [kg m²] (default
        m l²/12). J may be negative where identified parameters have it (DFKI's model_3.0), as
        long as each link's inertia about its pivot, J + m com², is > 0.
    coulomb : sequence of float or None, keyword-only
        Coulomb friction of each joint [N m] (>= 0), on the joint's relative rate; not
        linearised. None: none.
    coulomb_law : str, keyword-only, default "tanh"
        "tanh": f = c tanh(w / coulomb_speed) (ipgen's smooth sign); "atan": f = c atan(k w)
        with k = coulomb_gain (DFKI's form, k = 100).
    coulomb_speed, coulomb_gain : float, keyword-only
        v_s > 0 [rad/s] of the tanh law (0.01), k > 0 [s/rad] of the atan law (100).
    joints : sequence of int, keyword-only, default (1,)
        The actuated joints, one input each in this order (1 = shoulder, 2 = elbow, ...).
    Ir, gr : sequence of float or None, keyword-only
        Per actuated joint: rotor inertia [kg m²] (>= 0) and gear ratio (rotor turns per joint
        turn relative to the motor's housing, != 0; negative: the rotor turns against the
        joint). Ir needs gr.
    angles, zero, positive : str, keyword-only
        The rig's coordinates (docs/model.md, "The rig's coordinates"); DFKI's are "relative",
        "hanging", "counterclockwise".

    Raises
    ------
    FixedPendulumError
        One line naming the value and what is expected.

    Examples
    --------
    >>> p = FixedPendulum(2, m=[1.0, 1.0], l=[1.0, 2.0], delta=[0.1, 0.1], joints=[2])
    >>> p.inputs, p.value("J2") == 1.0 * 2.0 * 2.0 / 12
    (1, True)
    """

    links: int
    m: Sequence[float]
    l: Sequence[float]  # noqa: E741 (the paper's name for the lengths)
    delta: Sequence[float]
    g: float = 9.81
    _: KW_ONLY
    com: Sequence[float] | None = None
    J: Sequence[float] | None = None
    coulomb: Sequence[float] | None = None
    coulomb_law: str = "tanh"
    coulomb_speed: float = DEFAULT_COULOMB_SPEED
    coulomb_gain: float = DEFAULT_COULOMB_GAIN
    joints: Sequence[int] = (1,)
    Ir: Sequence[float] | None = None
    gr: Sequence[float] | None = None
    angles: str = "absolute"
    zero: str = "upright"
    positive: str = "clockwise"

    def __post_init__(self) -> None:
        if isinstance(self.links, numbers.Integral) and not isinstance(self.links, bool):
            object.__setattr__(self, "links", int(self.links))  # numpy's integers too
        n = self.links
        if isinstance(n, bool) or not isinstance(n, int) or n < 1:
            _fail(
                f"links must be an integer >= 1 (got {abbreviate(repr(n))}): it counts the links on the pivot"
            )
        if n > MAX_FIXED_LINKS:  # each numeric tool derives the model: minutes, gigabytes
            _fail(
                f"links = {n}: a FixedPendulum has at most {MAX_FIXED_LINKS} links (what linearize, lqr, "
                "mpc, the gym and the simulator take); the equations of more: ipgen --type fixed --links N "
                "--force"
            )
        problem = joints_problem(self.joints, n)
        if problem:
            _fail(problem)
        fixed: dict[str, Any] = {"joints": tuple(int(joint) for joint in self.joints)}
        for name in ("m", "l", "delta"):
            fixed[name] = _array(name, getattr(self, name), n, "one per link")
        for name in ("com", "J", "coulomb"):
            value = getattr(self, name)
            fixed[name] = None if value is None else _array(name, value, n, "one per link")
        for name in ("Ir", "gr"):
            value = getattr(self, name)
            fixed[name] = (
                None if value is None else _array(name, value, len(self.joints), "one per actuated joint")
            )
        for name in ("g", "coulomb_speed", "coulomb_gain"):
            fixed[name] = _number(name, getattr(self, name))
        for name, value in fixed.items():
            object.__setattr__(self, name, value)
        self._check_values()
        try:
            Coordinates(self.angles, self.zero, self.positive)
        except Error as exc:
            raise FixedPendulumError(str(exc)) from None

    def _check_values(self) -> None:
        for i, mass in enumerate(self.m, start=1):
            if mass <= 0:
                _fail(f"m[{i - 1}] = {mass:g}: masses must be > 0 kg")
        for i, length in enumerate(self.l, start=1):
            if length <= 0:
                _fail(f"l[{i - 1}] = {length:g}: link lengths must be > 0 m")
        for i, damping in enumerate(self.delta):
            if damping < 0:
                _fail(f"delta[{i}] = {damping:g}: damping must be >= 0")
        for i, friction in enumerate(self.coulomb or ()):
            if friction < 0:
                _fail(f"coulomb[{i}] = {friction:g}: friction must be >= 0")
        if self.g < 0:
            _fail(f"g = {self.g:g}: gravity must be >= 0 m/s² (0 switches it off)")
        if self.coulomb_law not in COULOMB_LAWS:
            _fail(f"coulomb_law = {abbreviate(repr(self.coulomb_law))}: expected 'tanh' or 'atan'")
        for name in ("coulomb_speed", "coulomb_gain"):
            if getattr(self, name) <= 0:
                _fail(f"{name} = {getattr(self, name):g}: must be > 0")
        if self.Ir is not None and self.gr is None:
            _fail("Ir without gr: a rotor's inertia needs its gear ratio (gr, one per actuated joint)")
        for k, rotor in enumerate(self.Ir or ()):
            if rotor < 0:
                _fail(f"Ir[{k}] = {rotor:g}: an inertia cannot be negative (use 0 for none)")
        for k, ratio in enumerate(self.gr or ()):
            if ratio == 0:
                _fail(
                    f"gr[{k}] = 0: a gear ratio is not 0 (rotor turns per joint turn; 1 for a direct drive)"
                )
        com, inertia = self.resolved("com"), self.resolved("J")
        for i in range(self.links):
            about_pivot = inertia[i] + self.m[i] * com[i] * com[i]
            if not math.isfinite(about_pivot):  # a rod's m l²/12 past a double's range
                _fail(
                    f"link {i + 1}'s inertia about its pivot overflows (m[{i}] = {self.m[i]:g}, "
                    f"l[{i}] = {self.l[i]:g}): check the units"
                )
            if not about_pivot > 0:
                _fail(
                    f"link {i + 1} has no inertia about its pivot (J[{i}] + m[{i}] com[{i}]² = "
                    f"{inertia[i] + self.m[i] * com[i] * com[i]:g} <= 0): check J and com"
                )

    # ------------------------------------------------------------------ views

    @property
    def type(self) -> str:
        """ "fixed": the system type, as scenes write it."""
        return "fixed"

    @property
    def dof(self) -> int:
        """Degrees of freedom: the number of links."""
        return self.links

    @property
    def inputs(self) -> int:
        """m: the number of inputs (actuated joints)."""
        return len(self.joints)

    @property
    def coordinates(self) -> Coordinates:
        """The rig's coordinates (`angles`, `zero`, `positive`)."""
        return Coordinates(self.angles, self.zero, self.positive)

    def resolved(self, group: str) -> tuple[float, ...]:
        """com or J with every entry filled in (the rods' l/2 and m l²/12 where not given).

        Parameters
        ----------
        group : {"com", "J"}
            The group of link values.

        Returns
        -------
        tuple of float
            One per link [m or kg m²].
        """
        given = getattr(self, group)
        if given is not None:
            return tuple(given)
        if group == "com":
            return tuple(length / 2 for length in self.l)
        return tuple(mass * length * length / 12 for mass, length in zip(self.m, self.l, strict=True))

    def motor(self, group: str) -> tuple[float, ...]:
        """Ir (0 where not given) or gr (1 where not given), one per actuated joint.

        Parameters
        ----------
        group : {"Ir", "gr"}
            The rotor inertia [kg m²] or the gear ratio of the joints' motors.

        Returns
        -------
        tuple of float
            One per actuated joint.
        """
        given = getattr(self, group)
        return tuple(given) if given is not None else (0.0 if group == "Ir" else 1.0,) * self.inputs

    def value(self, name: str) -> float:
        """A parameter by name: m1, l2, com1, J2, delta1, coulomb2 (link numbers from 1), g.

        Parameters
        ----------
        name : str
            The group and the link's number from 1, or "g".

        Returns
        -------
        float
            Its value in SI units (com and J filled in as `resolved` does, delta and coulomb 0
            where not given).

        Raises
        ------
        UnknownParameter
            A name that is no parameter of this chain.

        Examples
        --------
        >>> FixedPendulum(1, m=[2.0], l=[0.5], delta=[0.0]).value("com1")
        0.25
        """
        if not isinstance(name, str):
            raise UnknownParameter(f"parameter name {name!r}: expected text such as 'm1' or 'g'")
        if name == "g":
            return self.g
        group = name.rstrip("0123456789")
        if group not in ("m", "l", "delta", "com", "J", "coulomb") or group == name:
            raise UnknownParameter(
                f"unknown parameter {name!r}: a fixed chain has m, l, delta, com, J, coulomb and g"
            )
        index = int(name[len(group) :])
        if not 1 <= index <= self.links:
            raise UnknownParameter(f"unknown parameter {name!r}: links are numbered 1..{self.links}")
        if group in ("com", "J"):
            return self.resolved(group)[index - 1]
        values = getattr(self, group)
        return 0.0 if values is None else values[index - 1]

    def replace(self, **changes: Any) -> FixedPendulum:
        """A new FixedPendulum with `changes`, validated again.

        Parameters
        ----------
        **changes
            Fields and their new values, e.g. ``m=[0.6, 0.5]``.

        Returns
        -------
        FixedPendulum
            The changed chain (this one is unchanged).

        Raises
        ------
        FixedPendulumError
            An unknown field, or a value the chain does not take.
        """
        known = {f.name for f in dataclasses.fields(self) if f.name != "_"}
        unknown = sorted(set(changes) - known)
        if unknown:
            _fail(f"FixedPendulum has no field {unknown[0]!r}: expected one of {', '.join(sorted(known))}")
        return dataclasses.replace(self, **changes)

    def canonical(self) -> FixedPendulum:
        """This chain in ipgen's coordinates (absolute angles from upright, clockwise)."""
        return dataclasses.replace(self, angles="absolute", zero="upright", positive="clockwise")

    @classmethod
    def from_scene(cls, path: str | Path) -> FixedPendulum:
        """The chain a fixed scene file describes (`[system] type = "fixed"`; docs/scenes.md).

        Parameters
        ----------
        path : str or Path
            The scene file.

        Returns
        -------
        FixedPendulum
            Its chain, in the scene's coordinates.

        Raises
        ------
        SceneError
            One line naming the file and the problem.
        """
        from ipgen.scene.fixed import load_fixed_scene

        return load_fixed_scene(path)

    @classmethod
    def preset(cls, name: str) -> FixedPendulum:
        """A fixed-pivot preset shipped with ipgen by name ("dfki_c0", "dfki_c1"; `ipgen presets`).

        Parameters
        ----------
        name : str
            The preset's name.

        Returns
        -------
        FixedPendulum
            Its chain.

        Examples
        --------
        >>> FixedPendulum.preset("dfki_c0").coulomb_law
        'atan'
        """
        from ipgen.common.presets import preset_path

        return cls.from_scene(preset_path(name))

    def numbers(self) -> dict[str, float]:
        """{symbol name: value} for the symbolic model (`fixed_equations.FixedEquations`)."""
        values: dict[str, float] = {"g": self.g}
        com, inertia = self.resolved("com"), self.resolved("J")
        friction = self.coulomb or (0.0,) * self.links
        for i in range(self.links):
            k = i + 1
            values |= {f"m{k}": self.m[i], f"l{k}": self.l[i], f"delta{k}": self.delta[i]}
            values |= {f"com{k}": com[i], f"J{k}": inertia[i], f"cf{k}": friction[i]}
        for k, (rotor, ratio) in enumerate(zip(self.motor("Ir"), self.motor("gr"), strict=True), start=1):
            values |= {f"Ir{k}": rotor, f"gr{k}": ratio}
        values["coulomb_rate"] = 1 / self.coulomb_speed if self.coulomb_law == "tanh" else self.coulomb_gain
        return values
