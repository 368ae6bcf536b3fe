"""`Pendulum`: one immutable description of a system, its parameters, its drive and its rig's
coordinates: what `ipgen.linearize`, `ipgen.lqr`, `ipgen.derive`, the swing-up planners and the
identification take.

A Pendulum is validated once, on construction (every problem a one-line `PendulumError` in the
library's words), and never changes: `replace` makes a new one, validated again. Its numbers are
floats, or Fractions where they were given as Fractions or Decimals (exact values, e.g. a scene's
decimals with `from_scene(..., exact=True)`); `folded` folds a DC motor into the equivalent
direct model in that arithmetic (`actuator.fold_base`, the motor's one formula).

Arrays are indexed 0 (the base: the cart or the arm) to n (the links), as in docs/model.md:
m [kg], l [m] (l[0] the arm; a cart has none: 0), delta (viscous damping), g [m/s²], and the
links as built: com (pivot-to-CoG distances), J (inertias about the CoGs; J[0] the arm's about
the vertical), J_axial (about the links' own axes; rotary "full" only), tip (point masses at the
far ends); each of these left out (None) is the paper's homogeneous rod. coulomb is the
simulator's Coulomb friction per coordinate (not linearised).
"""

from __future__ import annotations

import dataclasses
import math
import numbers
from collections.abc import Mapping, Sequence, Set
from dataclasses import KW_ONLY, dataclass
from decimal import Decimal
from fractions import Fraction
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ipgen.common.limits import MAX_SIMULATED_LINKS, exact_problem
from ipgen.common.safetext import abbreviate
from ipgen.errors import Error
from ipgen.model.actuator import DIRECT, Actuator, as_actuator, fold_base
from ipgen.model.coordinates import Coordinates
from ipgen.model.links import LinkValues, link_problem, rod_value
from ipgen.model.system import LINK_GROUPS, System, UnknownParameter, split_parameter, system_problem

if TYPE_CHECKING:
    from ipgen.experiment.scene import Scene

__all__ = ["DEFAULT_COULOMB_SPEED", "Number", "Pendulum", "PendulumError"]

Number = float | Fraction
DEFAULT_COULOMB_SPEED = 0.01  # m/s or rad/s: the smooth Coulomb law's rate (docs/rigs.md)


class PendulumError(Error, ValueError):
    """A Pendulum that cannot be built; the message (one line) names the value and the fix."""


def _number(name: str, value: object) -> Number:
    """`value` as a float, or as a Fraction if it is one (or an exact Decimal); finite."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real | Decimal):
        return _fail(f"{name} = {abbreviate(repr(value))}: expected a number")
    too_large = exact_problem(value) if isinstance(value, Decimal) else None
    if too_large:  # 1e-99999999 as a Fraction takes minutes and memory: refused on its exponent first
        return _fail(f"{name} = {abbreviate(str(value))}: {too_large}")
    try:
        if isinstance(value, Decimal):
            number: Number = Fraction(value)
        elif isinstance(value, Fraction):
            number = value
        else:
            number = float(value)
        finite = math.isfinite(float(number))
    except (OverflowError, ValueError):  # a huge int or Fraction, a Decimal NaN or infinity
        finite = False
    if not finite:
        return _fail(f"{name} = {_shown(value)}: must be a finite number")
    return number


def _shown(value: object) -> str:
    """`value` for a message: its text on one line, abbreviated."""
    return abbreviate(str(value))


def _fail(message: str) -> Any:
    raise PendulumError(message)


def _array(name: str, value: object, dof: int) -> tuple[Number, ...]:
    """`value` as a tuple of `dof` numbers (base, link 1, ...)."""
    if isinstance(value, str | bytes | Mapping | Set) or not hasattr(value, "__len__"):
        return _fail(
            f"{name} must be a list of {dof} numbers (the base, then each link), got {_shown(value)}"
        )
    items = list(value)  # type: ignore[call-overload]
    if len(items) != dof:
        return _fail(f"{name} has {len(items)} entries, expected {dof} (links + 1: the base, then each link)")
    return tuple(_number(f"{name}[{i}]", item) for i, item in enumerate(items))


class _ActuatorField:
    """`Pendulum.actuator`: set (by the constructor and `replace`) as an `Actuator`, a mapping of
    its fields or None, read as the `Actuator` that `Pendulum.__post_init__` makes of it.

    A data descriptor is how a dataclass field converts (the "descriptor-typed fields" of the
    dataclasses documentation): type checkers take the constructor's argument type from `__set__`
    and the attribute's from `__get__`. The value lives in the instance's `__dict__` under
    "actuator", as a plain field's would, so pickles, copies, `vars`, equality and hashing see
    what they saw before.
    """

    def __get__(self, pendulum: object, owner: type | None = None) -> Actuator:
        if pendulum is None:  # on the class: the field's default (what dataclass reads)
            return DIRECT
        # unset (an instance made without __init__): the default, as a plain field's class attribute;
        # until __post_init__ has converted it, what the constructor was given (read there only)
        drive: Actuator = vars(pendulum).get("actuator", DIRECT)
        return drive

    def __set__(self, pendulum: object, value: Actuator | Mapping[str, object] | None) -> None:
        vars(pendulum)["actuator"] = value  # converted and checked in Pendulum.__post_init__


@dataclass(frozen=True)
class Pendulum:
    """An n-link inverted pendulum on a cart ("classical") or a Furuta arm ("rotary").

    Parameters
    ----------
    type : str
        "classical" (a cart) or "rotary" (a Furuta arm).
    links : int
        Number of links n >= 1.
    m, l, delta : sequence of float
        n + 1 entries each, index 0 the base: masses [kg] (> 0), lengths [m] (l[0] the arm,
        > 0; a cart's l[0] is ignored, >= 0; links > 0) and viscous damping (>= 0; the base's
        in N s/m or N m s/rad, the joints' in N m s/rad).
    g : float, default 9.81
        Gravitational acceleration [m/s²], >= 0.
    inertia : str, default "pivot"
        Rotary only: "pivot" (the published model) or "full" (the complete thin-rod inertia).
    com, J, J_axial, tip : sequence of float or None, keyword-only
        The links as built (docs/model.md), n + 1 entries each: pivot-to-CoG distances [m], the
        inertias about the CoGs [kg m²] (J[0]: the arm's about the vertical), about the links'
        axes [kg m²] (rotary "full" only, <= 2 J) and tip masses [kg]. None: the paper's rods
        (l/2, m l²/12 and m0 l0²/3, 0, 0).
    coulomb : sequence of float or None, keyword-only
        Coulomb friction per coordinate [N or N m] (>= 0), used by the simulator, not by the
        linear model; None: none.
    coulomb_speed : float, keyword-only, default 0.01
        The smooth Coulomb law's rate v_s [m/s or rad/s], > 0: f = c tanh(w / v_s).
    actuator : Actuator, dict or None, keyword-only
        What drives the base (`ipgen.Actuator`; a dict of its fields; None: "direct", u the
        force or torque). Read back, `actuator` is always the `Actuator`.
    angles, zero, positive : str, keyword-only
        The rig's coordinates: "absolute" | "relative", "upright" | "hanging", "clockwise" |
        "counterclockwise" (default ipgen's own: absolute, upright, clockwise).

    Raises
    ------
    PendulumError
        One line naming the value that no system has and what is expected.

    Examples
    --------
    >>> p = Pendulum("rotary", 1, m=[0.095, 0.024], l=[0.085, 0.129], delta=[0.0015, 0.0005])
    >>> p.dof, p.value("J1") == 0.024 * 0.129 * 0.129 / 12
    (2, True)
    >>> p.replace(g=0.0).g
    0.0
    """

    type: str
    links: int
    m: Sequence[Number]
    l: Sequence[Number]  # noqa: E741 (the paper's name for the lengths)
    delta: Sequence[Number]
    g: Number = 9.81
    inertia: str = "pivot"
    _: KW_ONLY
    com: Sequence[Number] | None = None
    J: Sequence[Number] | None = None
    J_axial: Sequence[Number] | None = None
    tip: Sequence[Number] | None = None
    coulomb: Sequence[Number] | None = None
    coulomb_speed: Number = DEFAULT_COULOMB_SPEED
    actuator: _ActuatorField = _ActuatorField()  # takes an Actuator, a mapping or None; reads an Actuator
    angles: str = "absolute"
    zero: str = "upright"
    positive: str = "clockwise"

    def __post_init__(self) -> None:
        if isinstance(self.links, numbers.Integral) and not isinstance(self.links, bool):
            object.__setattr__(self, "links", int(self.links))  # numpy's integers too
        problem = system_problem(self.type, self.links, self.inertia)
        if problem is not None:
            raise PendulumError(str(problem))
        if self.links > MAX_SIMULATED_LINKS:  # each numeric tool derives the model: minutes, gigabytes
            raise PendulumError(
                f"links = {self.links}: a Pendulum has at most {MAX_SIMULATED_LINKS} links (what linearize, "
                "lqr, mpc, kalman, the gym and the simulator take); the equations of more: "
                "ipgen.derive(type, links, force=True) or ipgen --links N --force"
            )
        dof = self.links + 1
        fixed: dict[str, Any] = {}
        for name in ("m", "l", "delta"):
            fixed[name] = _array(name, getattr(self, name), dof)
        fixed["g"] = _number("g", self.g)
        for name in (*LINK_GROUPS, "coulomb"):
            value = getattr(self, name)
            fixed[name] = None if value is None else _array(name, value, dof)
        fixed["coulomb_speed"] = _number("coulomb_speed", self.coulomb_speed)
        for name, value in fixed.items():
            object.__setattr__(self, name, value)
        self._check_values()
        try:
            Coordinates(self.angles, self.zero, self.positive)
            given = vars(self)["actuator"]  # as passed: an Actuator, a mapping or None
            drive = as_actuator(dict(given) if isinstance(given, Mapping) else given)
            drive.check(self.system)
        except Error as exc:
            raise PendulumError(str(exc)) from None
        object.__setattr__(self, "actuator", drive)

    def _check_values(self) -> None:
        """The rules of the class docstring, first broken one as a PendulumError."""
        m, l, delta = self.m, self.l, self.delta  # noqa: E741
        for i, mass in enumerate(m):
            if mass <= 0:
                _fail(f"m[{i}] = {_shown(mass)}: masses must be > 0 kg")
        if self.type == "rotary" and l[0] <= 0:
            _fail(f"l[0] = {_shown(l[0])}: the arm length must be > 0 m")
        if self.type == "classical" and l[0] < 0:
            _fail(f"l[0] = {_shown(l[0])}: a cart has no length: use 0 (it is ignored)")
        for i, length in enumerate(l[1:], start=1):
            if length <= 0:
                _fail(f"l[{i}] = {_shown(length)}: link lengths must be > 0 m")
        for i, damping in enumerate(delta):
            if damping < 0:
                _fail(f"delta[{i}] = {_shown(damping)}: damping must be >= 0")
        if self.g < 0:
            _fail(f"g = {_shown(self.g)}: gravity must be >= 0 m/s² (0 switches it off)")
        if self.J_axial is not None and any(self.J_axial) and not (self.is_rotary and self.inertia == "full"):
            _fail("J_axial counts only for a rotary system with inertia 'full': leave it out (or zeros)")
        for i, friction in enumerate(self.coulomb or ()):
            if friction < 0:
                _fail(f"coulomb[{i}] = {_shown(friction)}: friction must be >= 0")
        if self.coulomb_speed <= 0:
            _fail(f"coulomb_speed = {_shown(self.coulomb_speed)}: must be > 0 (m/s or rad/s)")
        problem = link_problem(self.system, self._floats(m), self._floats(l), self.resolved_links())
        if problem:
            _fail(problem)

    @staticmethod
    def _floats(values: Sequence[Number]) -> list[float]:
        return [float(v) for v in values]

    # ------------------------------------------------------------------ views

    @property
    def system(self) -> System:
        """The `System` (type, links, inertia) whose equations this pendulum's values enter."""
        return System(self.type, self.links, self.inertia)  # type: ignore[arg-type]

    @property
    def dof(self) -> int:
        """Degrees of freedom: links + 1 (the base, then each link)."""
        return self.links + 1

    @property
    def is_rotary(self) -> bool:
        """Whether the base is a Furuta arm (type "rotary") rather than a cart."""
        return self.type == "rotary"

    @property
    def coordinates(self) -> Coordinates:
        """The rig's coordinates (`angles`, `zero`, `positive`) as a `Coordinates`."""
        return Coordinates(self.angles, self.zero, self.positive)

    @property
    def gain(self) -> float:
        """b: the force or torque on the base per unit of u (a dc_motor's per volt; else 1)."""
        return self.actuator.gain()

    def links_given(self) -> dict[str, tuple[Number, ...]]:
        """{group: values} of the link arrays given (com, J, J_axial, tip), in that order.

        Returns
        -------
        dict
            Only the groups given (not None): the others are the paper's rods.

        Examples
        --------
        >>> Pendulum("classical", 1, [1.0, 0.1], [0, 0.5], [0, 0], tip=[0, 0.02]).links_given()
        {'tip': (0.0, 0.02)}
        """
        return {group: values for group in LINK_GROUPS if (values := getattr(self, group)) is not None}

    def resolved_links(self) -> LinkValues:
        """com, J, J_axial, tip as floats, every entry filled in (the rods' where not given).

        Returns
        -------
        LinkValues
            `.com`, `.J`, `.J_axial`, `.tip`: dof floats each; `.flat()` concatenates them.

        Examples
        --------
        >>> Pendulum("classical", 1, [1.0, 0.1], [0, 0.5], [0, 0]).resolved_links().com
        (0.0, 0.25)
        """
        m, l = self._floats(self.m), self._floats(self.l)  # noqa: E741
        groups = {}
        for group in LINK_GROUPS:
            given = getattr(self, group)
            groups[group] = (
                tuple(float(v) for v in given)
                if given is not None
                else tuple(rod_value(self.system, group, i, m, l) for i in range(self.dof))
            )
        return LinkValues(**groups)

    def params(self) -> dict[str, tuple[float, ...] | float]:
        """The arrays the generated C++ and C `Params` take, as floats: m, l, delta, g, and com,
        J, J_axial, tip with every entry filled in (the rods' where not given; the generated
        code's NaN default computes the same rods).

        Returns
        -------
        dict
            {"m": (...), "l": (...), "delta": (...), "g": float, "com": (...), "J": (...),
            "J_axial": (...), "tip": (...)}, dof floats per array.

        Examples
        --------
        >>> Pendulum("classical", 1, [1.0, 0.1], [0, 0.5], [0, 0]).params()["J"]
        (0.0, 0.0020833333333333333)
        """
        links = self.resolved_links()
        return {
            "m": tuple(self._floats(self.m)),
            "l": tuple(self._floats(self.l)),
            "delta": tuple(self._floats(self.delta)),
            "g": float(self.g),
            "com": links.com,
            "J": links.J,
            "J_axial": links.J_axial,
            "tip": links.tip,
        }

    def flat(self) -> list[float]:
        """m, l, delta, g, com, J, J_axial, tip in one list: the parameters of
        `control.linear.Dynamics` and `Symbols.parameters` + `Symbols.link_parameters`.

        Returns
        -------
        list of float
            3 dof + 1 + 4 dof numbers.

        Examples
        --------
        >>> len(Pendulum("rotary", 2, [1, 1, 1], [1, 1, 1], [0, 0, 0]).flat())
        22
        """
        values = self.params()
        return [*values["m"], *values["l"], *values["delta"], values["g"], *self.resolved_links().flat()]  # type: ignore[misc]

    def value(self, name: str) -> Number:
        """A parameter by its name in scenes and --fix ("m1", "delta0", "g", "J0", "tip2", ...);
        the links' rods where not given.

        Parameters
        ----------
        name : str
            A parameter's name: m<i>, l<i>, delta<i>, g, com<i>, J<i>, J_axial<i>, tip<i>.

        Returns
        -------
        float or Fraction
            In the pendulum's arithmetic (a rod's value computed in it).

        Raises
        ------
        UnknownParameter
            A name this pendulum has not (an ipgen.Error and a KeyError).

        Examples
        --------
        >>> Pendulum("rotary", 1, [0.3, 0.1], [0.2, 0.5], [0, 0]).value("J0") == 0.3 * 0.2 * 0.2 / 3
        True
        """
        group, index = split_parameter(name)
        if index is None:
            return self.g
        if index > self.links:
            raise UnknownParameter(f"unknown parameter {name!r}: this pendulum has indices 0..{self.links}")
        given = getattr(self, group)
        if given is not None:
            return given[index]
        return rod_value(self.system, group, index, self.m, self.l) if group in LINK_GROUPS else 0.0

    # ------------------------------------------------------------------ new pendulums

    def replace(self, **changes: Any) -> Pendulum:
        """A new Pendulum with `changes` (field=value), validated again.

        Parameters
        ----------
        **changes
            Any constructor argument by name, e.g. ``m=[0.1, 0.03]``, ``actuator=None``.

        Returns
        -------
        Pendulum

        Raises
        ------
        PendulumError
            An unknown field, or a value the constructor refuses.

        Examples
        --------
        >>> p = Pendulum("classical", 1, m=[1.0, 0.1], l=[0.0, 0.5], delta=[0.0, 0.0])
        >>> p.replace(links=2, m=[1.0, 0.1, 0.1], l=[0, 0.5, 0.5], delta=[0, 0, 0]).links
        2
        """
        known = {f.name for f in dataclasses.fields(self) if f.name != "_"}
        unknown = sorted(set(changes) - known)
        if unknown:
            raise PendulumError(
                f"Pendulum has no field {unknown[0]!r}: expected one of {', '.join(sorted(known))}"
            )
        return dataclasses.replace(self, **changes)

    def canonical(self) -> Pendulum:
        """This pendulum in ipgen's own coordinates (absolute angles from upright, clockwise):
        the same physics, with `linearize`, `lqr` and the CSVs then in ipgen's state.

        Returns
        -------
        Pendulum

        Examples
        --------
        >>> Pendulum.preset("qube_servo2").canonical().coordinates.is_canonical
        True
        """
        return dataclasses.replace(self, angles="absolute", zero="upright", positive="clockwise")

    def folded(self) -> Pendulum:
        """The direct model equivalent to this pendulum's drive (docs/model.md, "A DC motor on
        the base"): a "dc_motor" raises delta[0] by the back-EMF damping c and J[0] (an arm; J
        then has every entry, the rods' filled in) or m[0] (a cart) by the rotor's reflected
        inertia, and drives the base with u = `gain` · V. The arithmetic is the values': Fractions
        stay exact (the motor constants then enter as the exact decimals of their shortest repr).
        A "direct" pendulum is returned as it is.

        Returns
        -------
        Pendulum
            With `actuator` "direct"; the input gain b is the original's `gain`.

        Raises
        ------
        PendulumError
            For an "acceleration" drive, which no direct model is (the base is kinematic).

        Examples
        --------
        >>> motor = {"kind": "dc_motor", "Rm": 8.4, "kt": 0.042, "km": 0.042}
        >>> p = Pendulum("rotary", 1, m=[0.095, 0.024], l=[0.085, 0.129], delta=[0.0015, 0.0005],
        ...              actuator=motor)
        >>> round(p.folded().delta[0] - 0.0015, 6)  # kt km / Rm
        0.00021
        """
        drive = self.actuator
        if drive.is_acceleration:
            raise PendulumError(
                "an acceleration-driven base has no equivalent direct model: its base coordinate is kinematic"
            )
        if not drive.is_motor:
            return self
        exact = isinstance(self.delta[0], Fraction)
        constants: dict[str, Any] = {
            name: Fraction(repr(float(value))) if exact else value
            for name, value in drive.constants().items()
        }
        inertias = (
            list(self.J)
            if self.J is not None
            else [rod_value(self.system, "J", i, self.m, self.l) for i in range(self.dof)]
        )
        m, delta = list(self.m), list(self.delta)
        m[0], delta[0], inertias[0], _ = fold_base(constants, self.is_rotary, m[0], delta[0], inertias[0])
        J = inertias if (self.J is not None or self.is_rotary) else None
        return dataclasses.replace(self, m=m, delta=delta, J=J, actuator=DIRECT)

    # ------------------------------------------------------------------ from scenes

    @classmethod
    def from_scene(cls, scene: str | Path | Scene, *, exact: bool = False) -> Pendulum:
        """The pendulum a scene file describes (its [system], [parameters] and [actuator]).

        Parameters
        ----------
        scene : str, Path or Scene
            A scene file (read and validated with `load_scene`), or a loaded `Scene`.
        exact : bool, default False
            True: the parameters as Fractions of the decimals the file writes (0.1 -> 1/10),
            so that `folded` is exact.

        Returns
        -------
        Pendulum

        Raises
        ------
        SceneError
            The file cannot be read or used (one line naming the file and the key).

        Examples
        --------
        >>> Pendulum.from_scene(presets_dir() / "rigs" / "qube_servo2.toml").positive  # doctest: +SKIP
        'counterclockwise'
        """
        from ipgen.experiment.scene import Scene, load_scene  # the scene stage: read on request only

        if isinstance(scene, Scene):
            return from_scene_object(scene, exact=exact)
        if not isinstance(scene, str | Path):
            raise PendulumError(
                f"from_scene({abbreviate(repr(scene))}): expected a scene file's path or a Scene"
            )
        return from_scene_object(load_scene(Path(scene)), exact=exact)

    @classmethod
    def preset(cls, name: str, *, exact: bool = False) -> Pendulum:
        """A preset shipped with ipgen, by name: one of `presets()` (the rigs "qube_servo2",
        "ip02_sip", ..., and the paper's systems "cdip_pulse", ...; `ipgen presets` lists them).

        Parameters
        ----------
        name : str
            The preset's name (its file's stem under `common.locations.presets_dir()`).
        exact : bool, default False
            As for `from_scene`.

        Returns
        -------
        Pendulum

        Raises
        ------
        PendulumError
            No preset of that name (the message lists them).

        Examples
        --------
        >>> Pendulum.preset("qube_servo2").actuator.kind
        'dc_motor'
        """
        names = presets()
        if not isinstance(name, str) or name not in names:
            raise PendulumError(f"no preset {_shown(name)!r}: expected one of {', '.join(names)}")
        from ipgen.common.presets import preset_path

        return cls.from_scene(preset_path(name), exact=exact)


# help(Pendulum) and inspect.signature show what the constructor takes (the annotation the
# dataclass gave it names the descriptor; type checkers read the same from its __set__)
Pendulum.__init__.__annotations__["actuator"] = "Actuator | Mapping[str, object] | None"


def presets() -> tuple[str, ...]:
    """The names `Pendulum.preset` knows: the scenes shipped with ipgen (the rigs and the
    paper's systems; `ipgen presets` lists them), sorted.

    Returns
    -------
    tuple of str

    Raises
    ------
    Error
        The presets are not part of this installation.

    Examples
    --------
    >>> "qube_servo2" in presets()
    True
    """
    from ipgen.common.presets import preset_names

    return preset_names()


def from_scene_object(scene: Scene, *, exact: bool = False) -> Pendulum:
    """The Pendulum of a loaded `Scene` (the conversion `Scene.pendulum` and `Pendulum.from_scene`
    use).

    Parameters
    ----------
    scene : Scene
        A scene as `load_scene` returns it.
    exact : bool, default False
        The parameters as Fractions of the decimals the file writes.

    Returns
    -------
    Pendulum

    Raises
    ------
    PendulumError
        Not expected for a loaded scene (the scene's checks are at least as strict).

    Examples
    --------
    >>> from ipgen.experiment.scene import load_scene  # doctest: +SKIP
    >>> from_scene_object(load_scene("scenes/rigs/ip02_sip.toml")).type  # doctest: +SKIP
    'classical'
    """

    def values(group: str, given: Sequence[float]) -> tuple[Number, ...]:
        if not exact:
            return tuple(given)
        return tuple(
            scene.exact(f"{group}{i}") if f"{group}{i}" in dict(scene.decimals) else Fraction(repr(v))
            for i, v in enumerate(given)
        )

    built = dict(scene.links_as_built)
    coordinates = scene.coordinates
    return Pendulum(
        scene.type,
        scene.links,
        m=values("m", scene.m),
        l=values("l", scene.l),
        delta=values("delta", scene.delta),
        g=scene.exact("g") if exact else scene.g,
        inertia=scene.inertia,
        **{group: values(group, entries) for group, entries in built.items()},
        coulomb=scene.coulomb,
        coulomb_speed=scene.coulomb_speed,
        actuator=scene.actuator,
        angles=coordinates.angles,
        zero=coordinates.zero,
        positive=coordinates.positive,
    )
