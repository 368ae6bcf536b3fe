"""`ipgen.Pendulum`: every preset round-trips, the motor fold is exact in floats, Fractions and
sympy alike, the keyword API and the Pendulum API give the same numbers, and bad constructor
arguments are one-line `PendulumError`s (never another exception)."""

from __future__ import annotations

import doctest
import math
from decimal import Decimal
from fractions import Fraction
from pathlib import Path

import numpy as np
import pytest
import sympy as sp
from hypothesis import given, settings
from hypothesis import strategies as st

import ipgen
from ipgen.control.casadi_model import plant
from ipgen.control.linear import ControlError, EquilibriumWarning
from ipgen.experiment.scene import load_scene
from ipgen.model.actuator import Actuator, motor_terms
from ipgen.model.links import rod_value
from ipgen.model.pendulum import Pendulum, PendulumError, presets
from ipgen.model.system import SystemChoiceError, check_system

ROOT = Path(__file__).resolve().parents[1]
RIGS = sorted(
    path  # the fixed-pivot presets are FixedPendulums (tests/test_fixed_scene.py)
    for path in (ROOT / "scenes" / "rigs").glob("*.toml")
    if 'type = "fixed"' not in path.read_text(encoding="utf-8")
)
MOTOR = {"kind": "dc_motor", "Rm": 2.6, "kt": 0.00767, "km": 0.00767, "Kg": 70.0, "eta_g": 0.9, "eta_m": 0.69}
CART_MOTOR = {**MOTOR, "Kg": 3.71, "Jm": 3.9e-7, "r": 6.35e-3}


def one_line(error: BaseException) -> str:
    text = str(error)
    assert text and "\n" not in text, repr(text)
    return text


# --------------------------------------------------------------------------- presets


def test_presets_are_the_shipped_scenes() -> None:
    """The rigs and the paper's scenes (`ipgen presets` lists the same)."""
    scenes = sorted((ROOT / "scenes").rglob("*.toml"), key=lambda path: path.stem)
    assert presets() == tuple(path.stem for path in scenes)
    assert set(presets()) >= {path.stem for path in RIGS}
    assert "qube_servo2" in presets()
    with pytest.raises(PendulumError) as refused:
        Pendulum.preset("qube_servo3")
    assert "qube_servo2" in one_line(refused.value)


@pytest.mark.parametrize("path", RIGS, ids=lambda path: path.stem)
def test_every_preset_round_trips_to_the_scene_values(path: Path) -> None:
    """from_scene → the Params arrays → the scene's own values, entry by entry; the rods where
    the scene gives no link array; the drive, friction and coordinates as the scene has them."""
    scene = load_scene(path)
    p = Pendulum.preset(path.stem)
    assert p == Pendulum.from_scene(path) == scene.pendulum
    assert (p.type, p.links, p.inertia) == (scene.type, scene.links, scene.inertia)
    arrays = p.params()
    assert arrays["m"] == scene.m and arrays["l"] == scene.l and arrays["delta"] == scene.delta
    assert arrays["g"] == scene.g
    given_groups = dict(scene.links_as_built)
    assert p.links_given() == given_groups
    for group in ("com", "J", "J_axial", "tip"):
        expected = given_groups.get(group) or tuple(
            rod_value(scene.system, group, i, scene.m, scene.l) for i in range(scene.links + 1)
        )
        assert arrays[group] == expected, group
    assert p.coulomb == scene.coulomb and p.coulomb_speed == scene.coulomb_speed
    assert p.actuator == scene.actuator and p.coordinates == scene.coordinates
    for name in scene.parameter_names():
        assert p.value(name) == scene.value(name)
    # exact: the decimals written in the file, as Fractions
    exact = Pendulum.from_scene(path, exact=True)
    for name, text in scene.decimals:
        assert exact.value(name) == Fraction(text), name
    assert [float(v) for v in exact.m] == list(scene.m)
    # the flat order of Dynamics: m, l, delta, g, com, J, J_axial, tip
    dof = p.dof
    flat = p.flat()
    assert flat[: 3 * dof + 1] == [*scene.m, *scene.l, *scene.delta, scene.g]
    assert flat[3 * dof + 1 :] == [*arrays["com"], *arrays["J"], *arrays["J_axial"], *arrays["tip"]]


def test_a_scene_controller_gain_is_the_pendulum_lqr() -> None:
    """The QUBE-Servo 2 scene's LQR gain (computed while reading it, in Quanser's coordinates,
    in volts) is `ipgen.lqr` of its Pendulum with the scene's weights."""
    scene = load_scene(ROOT / "scenes" / "rigs" / "qube_servo2.toml")
    k = ipgen.lqr(Pendulum.preset("qube_servo2"), Q=[5, 1, 1, 1], R=1)
    assert scene.controller is not None
    assert np.array_equal(k.ravel(), np.asarray(scene.controller.gain))


# --------------------------------------------------------------------------- the fold


def test_motor_terms_floats_are_the_actuator_values_bit_for_bit() -> None:
    for constants in (MOTOR, CART_MOTOR):
        actuator = Actuator(**constants)
        b, c, inertia = motor_terms(actuator.constants())
        assert (b, c, inertia) == (actuator.gain(), actuator.damping(), actuator.inertia())
        by_hand = 0.9 * constants["Kg"] * 0.69 * 0.00767 / 2.6
        radius = constants.get("r", 1.0)
        assert b == pytest.approx(by_hand / radius, rel=1e-15)
        assert c == pytest.approx(by_hand * constants["Kg"] * 0.00767 / radius**2, rel=1e-15)


def test_motor_terms_fractions_are_exact() -> None:
    exact = {name: Fraction(repr(value)) for name, value in CART_MOTOR.items() if name != "kind"}
    b, c, inertia = motor_terms(exact)
    rm, kt, km, kg = exact["Rm"], exact["kt"], exact["km"], exact["Kg"]
    eta_g, eta_m, jm, r = exact["eta_g"], exact["eta_m"], exact["Jm"], exact["r"]
    assert all(isinstance(value, Fraction) for value in (b, c, inertia))
    assert b == eta_g * kg * eta_m * kt / (rm * r)
    assert c == eta_g * kg**2 * eta_m * kt * km / (rm * r**2)
    assert inertia == eta_g * kg**2 * jm / r**2


def test_motor_terms_sympy_symbols_are_the_formula() -> None:
    names = ("Rm", "kt", "km", "Kg", "eta_g", "eta_m", "Jm", "r")
    rm, kt, km, kg, eta_g, eta_m, jm, r = symbols = sp.symbols(names, positive=True)
    for cart in (False, True):
        constants = dict(zip(names, symbols, strict=True))
        if not cart:
            del constants["r"]
        radius = r if cart else sp.Integer(1)
        b, c, inertia = motor_terms(constants)
        assert sp.simplify(b - eta_g * kg * eta_m * kt / (rm * radius)) == 0
        assert sp.simplify(c - eta_g * kg**2 * eta_m * kt * km / (rm * radius**2)) == 0
        assert sp.simplify(inertia - eta_g * kg**2 * jm / radius**2) == 0


@pytest.mark.parametrize("cart", [False, True], ids=["arm", "cart"])
def test_folded_is_exact_in_fractions_and_matches_floats(cart: bool) -> None:
    kind = "classical" if cart else "rotary"
    m, lengths, delta = ["0.3", "0.1"], ["0" if cart else "0.2", "0.5"], ["0.05", "0.001"]
    exact = Pendulum(kind, 1, [Decimal(x) for x in m], [Decimal(x) for x in lengths],
                     [Fraction(x) for x in delta], actuator=CART_MOTOR if cart else MOTOR)  # fmt: skip
    floats = Pendulum(kind, 1, [float(x) for x in m], [float(x) for x in lengths],
                      [float(x) for x in delta], actuator=CART_MOTOR if cart else MOTOR)  # fmt: skip
    folded, rounded = exact.folded(), floats.folded()
    motor = {k: Fraction(repr(v)) for k, v in (CART_MOTOR if cart else MOTOR).items() if k != "kind"}
    b, c, inertia = motor_terms(motor)
    assert folded.delta[0] == Fraction("0.05") + c and isinstance(folded.delta[0], Fraction)
    if cart:
        assert folded.m[0] == Fraction("0.3") + inertia and folded.J is None
    else:
        assert folded.J is not None and folded.J[0] == Fraction("0.3") * Fraction("0.2") ** 2 / 3 + inertia
        assert folded.J[1] == Fraction("0.1") * Fraction("0.5") ** 2 / 12  # the rod filled in, exact
    assert folded.actuator.kind == "direct" and exact.gain == pytest.approx(float(b), rel=1e-15)
    assert [float(v) for v in folded.flat()] == pytest.approx(rounded.flat(), rel=1e-15)


def test_the_derivation_folds_the_same_motor() -> None:
    """derive(p)'s sympy views carry the fold of `motor_terms` in exact rationals."""
    p = Pendulum("rotary", 1, [0.2, 0.1], [0.3, 0.4], [0.01, 0.001], actuator={**MOTOR, "Jm": 4e-6})
    equations = ipgen.derive(p)
    exact = {k: sp.Rational(repr(v)) for k, v in p.actuator.constants().items()}
    b, c, inertia = motor_terms(exact)
    plain = ipgen.derive("rotary", 1)
    assert equations.input_matrix[0, 0] == b
    assert sp.expand(equations.mass_matrix[0, 0] - plain.mass_matrix[0, 0]) == inertia
    assert sp.expand(equations.damping[0, 0] - plain.damping[0, 0]) == c


def test_a_folded_pendulum_is_the_direct_model_by_hand() -> None:
    """linearize of a motor pendulum = b × B and A of the direct model with δ0 + c, J0 + I_r
    written out by hand (not through `folded`)."""
    p = Pendulum("rotary", 2, [0.25, 0.13, 0.1], [0.22, 0.34, 0.2], [0.015, 0.0024, 0.0024],
                 actuator={**MOTOR, "Jm": 3.9e-7})  # fmt: skip
    gain = 0.9 * 70.0 * 0.69 * 0.00767 / 2.6
    damping, reflected = gain * 70.0 * 0.00767, 0.9 * 70.0**2 * 3.9e-7
    j = [0.25 * 0.22**2 / 3 + reflected, 0.13 * 0.34**2 / 12, 0.1 * 0.2**2 / 12]
    direct = Pendulum("rotary", 2, p.m, p.l, [0.015 + damping, 0.0024, 0.0024], J=j)
    a, b = ipgen.linearize(p)
    a_direct, b_direct = ipgen.linearize(direct)
    assert np.allclose(a, a_direct, rtol=1e-12, atol=1e-12)
    assert np.allclose(b, gain * b_direct, rtol=1e-12, atol=1e-12)
    with pytest.raises(PendulumError):
        p.replace(actuator={"kind": "acceleration"}).folded()


# --------------------------------------------------------------------------- old API = new API

CASES = [
    ("classical", 1, [1.0, 0.1], [0.0, 0.5], [0.1, 0.001], {}),
    ("rotary", 2, [0.5, 0.275, 0.275], [0.6, 0.5, 0.5], [0.3, 0.011458, 0.011458], {"inertia": "full"}),
    ("rotary", 2, [0.2, 0.1, 0.15], [0.3, 0.5, 0.4], [0.01, 0.001, 0.002],
     {"inertia": "full", "J": [0.004, 0.002, 0.001], "tip": [0, 0.05, 0], "J_axial": [0, 0.001, 0]}),
    ("rotary", 1, [0.095, 0.024], [0.085, 0.129], [0.0015, 0.0005],
     {"actuator": {"kind": "dc_motor", "Rm": 8.4, "kt": 0.042, "km": 0.042}, "positive": "counterclockwise"}),
    ("classical", 2, [0.5, 0.2, 0.15], [0, 0.4, 0.3], [0.3, 0.01, 0.02],
     {"actuator": {"kind": "acceleration"}, "angles": "relative", "zero": "hanging"}),
    ("classical", 1, [0.57, 0.23], [0.0, 0.6413], [5.0, 0.0024],
     {"actuator": CART_MOTOR, "com": [0, 0.3302]}),
]  # fmt: skip


@pytest.mark.parametrize("case", CASES, ids=lambda case: f"{case[0]}{case[1]}-{'-'.join(case[5])}")
def test_keyword_api_equals_the_pendulum_api(case: tuple) -> None:
    kind, links, m, lengths, delta, extra = case
    options = {k: v for k, v in extra.items() if k != "inertia"}
    inertia = extra.get("inertia", "pivot")
    p = Pendulum(kind, links, m, lengths, delta, 9.81, inertia, **options)
    dof = links + 1
    q = [0.01 * (i + 1) for i in range(dof)]
    with pytest.warns(EquilibriumWarning):  # not an equilibrium: warned by both
        old = ipgen.linearize(kind, links, m, lengths, delta, 9.81, inertia, q=q, u=0.2, **options)
    with pytest.warns(EquilibriumWarning):
        new = ipgen.linearize(p, q, None, 0.2)
    assert np.array_equal(old[0], new[0]) and np.array_equal(old[1], new[1])
    weights = np.linspace(1.0, 2.0, 2 * dof)
    equilibrium = "hanging" if extra.get("zero") == "hanging" else None
    old_k = ipgen.lqr(kind, links, m, lengths, delta, weights, 0.5, 9.81, inertia, equilibrium, **options)
    new_k = ipgen.lqr(p, weights, 0.5, equilibrium=equilibrium)
    assert np.array_equal(old_k, new_k)
    assert np.array_equal(ipgen.lqr(p=p, Q=weights, R=0.5, equilibrium=equilibrium), new_k)
    if "actuator" not in extra:
        links_given = {k: v for k, v in options.items() if k in ("com", "J", "J_axial", "tip")}
        assert plant(kind, links, m, lengths, delta, 9.81, inertia, **links_given).params == plant(p).params
    drive = extra.get("actuator")
    built = any(options.get(k) is not None for k in ("com", "J", "J_axial", "tip"))  # derive(p): general
    by_keywords = ipgen.derive(kind, links, inertia, actuator=drive, general=built)
    by_pendulum = ipgen.derive(p)
    assert by_keywords.input_matrix == by_pendulum.input_matrix
    assert sp.expand(by_keywords.mass_matrix[0, 0] - by_pendulum.mass_matrix[0, 0]) == 0


def test_keyword_api_keeps_its_errors_as_control_errors() -> None:
    with pytest.raises(ControlError, match="tip has 2 entries, expected 3"):
        ipgen.linearize("rotary", 2, [0.5, 0.3, 0.2], [0.6, 0.5, 0.4], [0.3, 0.01, 0.02], tip=[0.0, 0.1])
    with pytest.raises(ControlError) as refused:
        ipgen.lqr("rotary", 0, [0.5], [0.6], [0.3], Q=[1, 1], R=1)
    assert one_line(refused.value).startswith("links must be an integer >= 1")
    # a cart ignores inertia in the keyword API, as it always has
    a, _ = ipgen.linearize("classical", 1, [1.0, 0.1], [0.0, 0.5], [0.0, 0.0], inertia="full")
    assert np.array_equal(a, ipgen.linearize(Pendulum("classical", 1, [1.0, 0.1], [0.0, 0.5], [0.0, 0.0]))[0])


# --------------------------------------------------------------------------- validation


def test_the_system_check_speaks_the_library_words() -> None:
    for arguments, start in (
        (("rotary", 0), "links must be an integer >= 1 (got 0)"),
        (("pendulum", 2), "type must be one of classical, rotary"),
        (("rotary", 2, "heavy"), "inertia must be one of pivot, full"),
        (("classical", 2, "full"), "inertia 'full' applies to rotary systems only"),
    ):
        with pytest.raises(SystemChoiceError) as refused:
            check_system(*arguments)
        assert one_line(refused.value).startswith(start) and "--" not in str(refused.value)
    with pytest.raises(ipgen.Error) as refused:
        ipgen.derive("rotary", 0)
    assert one_line(refused.value) == "links must be an integer >= 1 (got 0): it counts the rods in the chain"


VALID = {
    "type": "rotary",
    "links": 2,
    "m": [0.5, 0.3, 0.2],
    "l": [0.6, 0.5, 0.4],
    "delta": [0.3, 0.01, 0.02],
    "g": 9.81,
    "inertia": "full",
    "com": [0.0, 0.25, 0.2],
    "J": [0.06, 0.006, 0.003],
    "J_axial": [0.0, 0.001, 0.0],
    "tip": [0.0, 0.05, 0.0],
    "coulomb": [0.01, 0.0, 0.0],
    "coulomb_speed": 0.01,
    "actuator": {"kind": "dc_motor", "Rm": 2.6, "kt": 0.0077, "km": 0.0077},
    "angles": "relative",
    "zero": "hanging",
    "positive": "counterclockwise",
}
BAD_NUMBERS = st.one_of(
    st.just(math.nan),
    st.just(math.inf),
    st.just(-math.inf),
    st.floats(max_value=-1e-9),
    st.just(0.0),
    st.integers(min_value=10**400, max_value=10**401),
    st.just(Decimal("NaN")),
    st.just(Fraction(-1, 3)),
    st.booleans(),
    st.none(),
    st.text(max_size=4),
    st.complex_numbers(allow_nan=False, max_magnitude=10),
)
BAD_VALUES = st.one_of(
    BAD_NUMBERS,
    st.lists(BAD_NUMBERS, min_size=3, max_size=3),
    st.lists(st.floats(min_value=0.01, max_value=1.0), min_size=0, max_size=6),
    st.dictionaries(st.text(max_size=3), st.floats(), max_size=2),
    st.integers(min_value=-3, max_value=40),
    st.sampled_from(["classical", "pivot", "absolute", "upright", "clockwise", "", "dc_motor"]),
    st.builds(lambda: np.ones((3, 2))),
)


@settings(max_examples=300, deadline=None)
@given(field=st.sampled_from(sorted(VALID)), value=BAD_VALUES, index=st.integers(0, 2))
def test_bad_constructor_arguments_are_one_line_pendulum_errors(
    field: str, value: object, index: int
) -> None:
    """One argument replaced (whole, or one entry of an array) by something odd: the Pendulum is
    built (the value happened to be fine) or a one-line PendulumError is raised; nothing else."""
    arguments = {k: (list(v) if isinstance(v, list) else v) for k, v in VALID.items()}
    if isinstance(arguments[field], list) and not isinstance(value, list | dict | np.ndarray):
        arguments[field][index] = value
    else:
        arguments[field] = value
    try:
        p = Pendulum(**arguments)
    except PendulumError as error:
        one_line(error)
        return
    assert p.dof == len(p.m) == len(p.l) == len(p.delta)
    assert all(math.isfinite(float(v)) for v in p.flat())
    try:
        p.replace(**{field: VALID[field]})
    except PendulumError as error:  # e.g. the links changed, the arrays did not
        one_line(error)


def test_replace_validates_again_and_refuses_unknown_fields() -> None:
    p = Pendulum("classical", 1, [1.0, 0.1], [0.0, 0.5], [0.0, 0.0])
    assert p.replace(g=0.0).g == 0.0 and p.g == 9.81  # immutable: a new one
    for changes, words in (
        ({"m": [1.0, -0.1]}, "m[1] = -0.1: masses must be > 0 kg"),
        ({"links": 2}, "m has 2 entries, expected 3"),
        ({"mass": [1.0]}, "Pendulum has no field 'mass'"),
        ({"inertia": "full"}, "inertia 'full' applies to rotary systems only"),
        ({"J_axial": [0, 0.1]}, "J_axial counts only for a rotary system with inertia 'full'"),
        ({"actuator": {"kind": "dc_motor", "Rm": 1.0, "kt": 1.0, "km": 1.0}}, "needs r"),
        ({"zero": "down"}, "zero = 'down'"),
    ):
        with pytest.raises(PendulumError) as refused:
            p.replace(**changes)
        assert words in one_line(refused.value)
    with pytest.raises(AttributeError):
        p.g = 1.0  # type: ignore[misc]


@pytest.mark.parametrize(
    "module",
    [
        "ipgen.model.pendulum",
        "ipgen.model.actuator",
        "ipgen.model.system",
        "ipgen.control.linear",
        "ipgen.control.casadi_model",
        "ipgen.identification.model",
        "ipgen.identification.synthetic",
        "ipgen.identification.data",
        "ipgen.model.fixed_numeric",  # its example compared a float exactly, an ulp apart
    ],
)
def test_the_examples_in_the_docstrings_hold(module: str) -> None:
    import importlib

    failures, tried = doctest.testmod(importlib.import_module(module), optionflags=doctest.ELLIPSIS)
    assert tried >= 1 and failures == 0


ODD = st.one_of(
    st.none(),
    st.text(max_size=3),
    st.just(math.nan),
    st.just(math.inf),
    st.lists(st.floats(allow_nan=True, allow_infinity=True), max_size=4),
    st.lists(st.text(max_size=2), min_size=2, max_size=2),
)


@settings(max_examples=60, deadline=None)
@given(q=ODD, qd=ODD, u=st.one_of(st.floats(allow_nan=True), st.text(max_size=3), st.none()))
def test_linearize_refuses_a_bad_state_with_one_line(q: object, qd: object, u: object) -> None:
    """Any q, qd, u: (A, B) of the right shape, finite, or a one-line ControlError; nothing else."""
    import warnings

    p = Pendulum("classical", 1, [1.0, 0.1], [0.0, 0.5], [0.1, 0.001])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", EquilibriumWarning)
        try:
            a, b = ipgen.linearize(p, q, qd, u)
        except ControlError as error:
            one_line(error)
            return
    assert a.shape == (4, 4) and b.shape == (4, 1) and np.all(np.isfinite(a))


# --------------------------------------------------------------------------- identify, swing-up


def test_identify_a_pendulum_equals_identify_its_scene(tmp_path: Path) -> None:
    """ipgen.identify(p, csv, free) gives the scene file's estimates, on data simulated from a
    known truth in the rig's coordinates (Quanser's: the pendulum counter-clockwise)."""
    from ipgen.identification.model import Setup
    from ipgen.identification.synthetic import measure, multisine, write_csv

    scene_path = ROOT / "scenes" / "rigs" / "qube_servo2.toml"
    p = Pendulum.preset("qube_servo2")
    truth = Setup.from_pendulum(p.replace(delta=[0.0015, 0.0008]))
    t = np.arange(0.0, 6.0, 0.005)
    data = measure(truth, t, multisine, np.array([0.0, math.pi, 0.0, 0.0]), 1e-4, np.random.default_rng(5))
    user = np.array([p.coordinates.to_user(np.r_[th, 0.0, 0.0], 1)[:2] for th in data.theta])
    csv = tmp_path / "qube.csv"
    write_csv(csv, t, user, np.array([multisine(x) for x in t]))
    fit = ipgen.identify(p, csv, "delta1", output_error=False)
    assert fit.estimate["delta1"] == pytest.approx(0.0008, rel=0.05)
    by_scene = ipgen.identify(scene_path, csv, ["delta1"], output_error=False)
    assert by_scene.fit.estimate == fit.estimate
    with pytest.raises(ipgen.Error) as refused:
        ipgen.identify(p, csv, "delta1", tmp_path / "out")
    one_line(refused.value)


def test_the_energy_swing_up_of_a_pendulum_is_that_of_its_plant() -> None:
    from ipgen.control.energy import energy_swingup
    from ipgen.control.trajectory import PlanError

    values = ([0.5, 0.275], [0.6, 0.5], [0.3, 0.011458])
    by_pendulum = energy_swingup(Pendulum("rotary", 1, *values), u_max=2.0)
    by_plant = energy_swingup(plant("rotary", 1, *values), u_max=2.0)
    assert np.array_equal(by_pendulum.hold_gain, by_plant.hold_gain)
    assert by_pendulum.gain_energy == by_plant.gain_energy
    with pytest.raises(PlanError) as refused:
        energy_swingup(Pendulum.preset("qube_servo2"), u_max=2.0)
    assert "p.folded()" in one_line(refused.value)


def test_a_trajectory_plan_of_a_pendulum_is_that_of_its_plant() -> None:
    """plan_swingup(p) plans the same swing-up as plan_swingup(plant(...)) of the same values."""
    from ipgen.control.trajectory import plan_swingup

    values = ([0.5, 0.275], [0.6, 0.5], [0.3, 0.011458])
    options = {"duration": 2.0, "u_max": 5.0, "intervals": 30}
    by_pendulum = plan_swingup(Pendulum("rotary", 1, *values), **options)
    by_plant = plan_swingup(plant("rotary", 1, *values), **options)
    assert by_pendulum.plant == by_plant.plant
    assert np.array_equal(by_pendulum.inputs, by_plant.inputs)
    assert np.array_equal(by_pendulum.states, by_plant.states)
    assert abs(by_pendulum.states[-1][1]) < 1e-6  # it reaches upright (the test can fail)


def test_canonical_is_the_same_physics_in_ipgens_coordinates() -> None:
    """A − B K of the QUBE in Quanser's coordinates and in ipgen's have the same poles, and the
    state map between them is the one `Coordinates.matrices` gives."""
    qube = Pendulum.preset("qube_servo2")
    a_rig, b_rig = ipgen.linearize(qube)
    a, b = ipgen.linearize(qube.canonical())
    matrix, _ = qube.coordinates.matrices(1)
    assert not np.array_equal(a_rig, a)  # the pendulum's sign differs: the test can fail
    assert np.allclose(a_rig, matrix @ a @ np.linalg.inv(matrix)) and np.allclose(b_rig, matrix @ b)
    k_rig = ipgen.lqr(qube, [5, 1, 1, 1], 1.0)
    k = ipgen.lqr(qube.canonical(), [5, 1, 1, 1], 1.0)
    assert np.allclose(k_rig @ matrix, k, rtol=1e-9)
