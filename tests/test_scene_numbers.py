"""Numbers of any size and any TOML form in every numeric key of a scene (issue #31, "scenes"):
the scene loads and its resolved config holds only finite numbers, or loading fails with one
`SceneError` line that shows the value as written, never a traceback, never an internal repr.

The reported cases are regressions here: a 4,301-digit t_end, long hex integers,
`1e9999999999999999999` (decimal.InvalidOperation), `[actuator] Kg = 1e200` (OverflowError),
`[swingup] period = 1e-300` and `5e-324`, an energy swing-up with `g = 0` or `-0.0`
(ZeroDivisionError), and `parameters.J_axial = [Exact(value=0.0, text='0'), ...]` in a message.
"""

from __future__ import annotations

import functools
import re
import tempfile
import time
from pathlib import Path

import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from ipgen.errors import SceneError

# Scenes that together use every table; each numeric key is replaced in the scenes that have it.
from ipgen.experiment.config import resolved_config
from ipgen.experiment.scene import load_scene
from ipgen.scene import schema

PULSE_LQR = """\
[system]
type = "classical"
links = 2
[parameters]
m = [0.3, 0.275, 0.275]
l = [0, 0.5, 0.5]
delta = [0.3, 0.1, 0.1]
J = [0, 0.006, 0.006]
tip = [0, 0, 0]
com = [0, 0.25, 0.25]
coulomb = [0.1, 0, 0]
[controller]
kind = "lqr"
r = 1
saturation = 20
period = 0.01
equilibrium = [0, 0, 0]
q = [1, 1, 1, 1, 1, 1]
[initial]
theta = [0, 0.01, 0]
dtheta = [0, 0, 0]
[limits]
travel = 2
[simulation]
t_end = 2
sample = 0.01
rtol = 1e-8
atol = 1e-10
max_steps = 1000
"""
MOTOR_SWINGUP = """\
[system]
type = "rotary"
links = 1
inertia = "full"
[parameters]
m = [0.095, 0.024]
l = [0.085, 0.129]
delta = [0.0005, 0.00003]
g = 9.81
J_axial = [0, 0]
coulomb_speed = 0.01
[actuator]
kind = "dc_motor"
Rm = 8.4
kt = 0.042
km = 0.042
Kg = 1
eta_g = 1
eta_m = 1
Jm = 4e-6
[swingup]
method = "energy"
u_max = 10
period = 0.01
hold = 1
[simulation]
t_end = 5
sample = 0.01
"""
# The measured loop ([sensors], [estimator], the drive's keys) on the sampled LQR above.
LOOP = """\
[actuator]
noise = 0.1
lag = 0.01
pulses = [[0.5, 0.1, 1.0]]
[sensors]
measured = [0, 1, 2]
resolution = [1000, 2048, 2048]
noise = 0.001
delay = 0.01
seed = 3
[estimator]
kind = "kalman"
process_noise = 0.01
measurement_noise = 1e-6
"""
FILTER = "[sensors]\nresolution = 2048\n[estimator]\nkind = 'filter'\ncutoff = 50\n"
# The sampled loop above with a gain given instead of designed ([controller] kind = "gain").
GIVEN = PULSE_LQR.replace('kind = "lqr"\nr = 1\n', 'kind = "gain"\ngain = [1, -40, 60, 2, 1, 8]\n').replace(
    "q = [1, 1, 1, 1, 1, 1]\n", ""
)
INPUTS = {
    "pulse": "kind = 'pulse'\namplitude = 0.4\nstart = 0.5\nduration = 1",
    "step": "kind = 'step'\namplitude = 0.4\ntime = 1",
    "sine": "kind = 'sine'\namplitude = 0.4\nfrequency = 2\nphase = 0.1",
    "chirp": "kind = 'chirp'\namplitude = 0.4\nf0 = 0.1\nf1 = 5\nduration = 10\nstart = 0",
    "multisine": "kind = 'multisine'\namplitude = 0.4\nf_min = 0.1\nf_max = 5\nperiod = 10",
}
# The cart double pendulum under constrained MPC ([controller] kind = "mpc", docs/mpc.md): a short
# horizon keeps each design (the terminal Riccati matrix) cheap.
MPC_KEYS = "period = 0.01\nhorizon = 5\nsubsteps = 1\niterations = 1\nqp_iterations = 20\n"
MPC_KEYS += "soft_penalty = [1000, 1000]\nbarrier = 0.001\n"
MPC = PULSE_LQR.replace(
    'kind = "lqr"\nr = 1\nsaturation = 20\n', 'kind = "mpc"\nr = 1\nu_max = 20\ntravel = 1.5\n'
).replace("period = 0.01\n", MPC_KEYS)
RK4 = "[system]\ntype = 'rotary'\nlinks = 1\n[parameters]\nm = [0.2, 0.1]\nl = [0.3, 0.5]\n"
RK4 += "delta = [0.01, 0.001]\n[simulation]\nt_end = 1\nsample = 0.01\nmethod = 'rk4'\nstep = 0.001\n"


def _scenes() -> list[str]:
    open_loop = PULSE_LQR.split("[controller]")[0] + "[initial]" + PULSE_LQR.split("[initial]")[1]
    return [
        PULSE_LQR, MOTOR_SWINGUP, PULSE_LQR + LOOP, PULSE_LQR + FILTER, RK4, GIVEN, MPC,
        *(f"{open_loop}[input]\n{body}\n" for body in INPUTS.values()),
    ]  # fmt: skip


def _numeric_keys(text: str) -> list[tuple[int, str, str]]:
    """(line index, key, 'scalar' or 'array') of every number-valued key in `text`."""
    found = []
    for i, line in enumerate(text.splitlines()):
        match = re.match(r"(\w+) = (\[?)[-0-9]", line)
        if match and match.group(1) not in ("links", "max_steps"):
            found.append((i, match.group(1), "array" if match.group(2) else "scalar"))
        elif match:
            found.append((i, match.group(1), "integer"))
    return found


SCENES = _scenes()
KEYS = [(s, i, key, kind) for s, text in enumerate(SCENES) for i, key, kind in _numeric_keys(text)]

digits = st.text("0123456789", min_size=1, max_size=40)
NUMBERS = st.one_of(
    st.integers(-(10**30), 10**30).map(str),
    st.integers(1, 5000).map(lambda n: "9" * n),  # up to and past Python's 4300-digit limit
    st.integers(1, 2000).map(lambda n: "0x" + "f" * n),  # hex, octal and binary of any length
    st.integers(1, 400).map(lambda n: "0o" + "7" * n),
    st.integers(1, 4000).map(lambda n: "0b" + "1" * n),
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.builds(
        lambda sign, mantissa, exponent: f"{sign}{mantissa}e{exponent}",
        st.sampled_from(["", "-", "+"]),
        st.one_of(digits, st.builds(lambda a, b: f"{a}.{b}", digits, digits)),
        st.one_of(st.integers(-400, 400), st.integers(-(10**25), 10**25)),
    ),
    st.sampled_from(["nan", "+inf", "-inf", "-0.0", "0.0", "5e-324", "1e-300", "1e200", "1e308", "2e308"]),
)
_CHECKS = [HealthCheck.too_slow, HealthCheck.data_too_large]


def _outcome(text: str) -> str:
    """load_scene + resolved_config on `text`: the config, or the one-line message."""
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "s.toml"
        path.write_text(text, encoding="utf-8")
        try:
            scene = load_scene(path)
        except SceneError as error:
            message = str(error)
            assert "\n" not in message and len(message) < 400, message
            assert not re.search(r"Exact\(|Decimal\(|<[a-z_.]+ object|Traceback", message), message
            return message
        config = resolved_config(scene)
    for line in config.splitlines():
        if not line.startswith("#"):
            for word in line.split(" = ", 1)[1].split():
                assert word not in ("inf", "-inf", "nan"), line
    return config


def _replaced(scene: int, line: int, kind: str, number: str, position: int) -> str:
    lines = SCENES[scene].splitlines()
    key, value = lines[line].split(" = ", 1)
    if kind == "array":
        items = [item.strip() for item in value.strip("[]").split(",")]
        items[position % len(items)] = number
        lines[line] = f"{key} = [{', '.join(items)}]"
    else:
        lines[line] = f"{key} = {number}"
    return "\n".join(lines) + "\n"


# Not yet in the property: the energy law's constants (tests/test_swingup_tuning.py checks them;
# release_angle, energy_step, catch_deficit and catch_base: tests/test_scene_swingup.py);
# `pulses` (arrays of arrays) is covered by tests/test_sensors.py's hypothesis tests.
SWINGUP_TUNING = ("gain_energy", "accel_max", "design_speed", "energy_target", "catch_angle", "catch_rate",
                  "gain_position", "gain_velocity", "release_angle", "energy_step",
                  "catch_deficit", "catch_base")  # fmt: skip


def test_every_numeric_key_is_covered() -> None:
    """The scenes above give every numeric key of the format a number to replace (but [swingup]
    x_max and margin: a trajectory plan per example would take minutes; they are `Real`s like the
    others; and the MPC's matrices p and soft_bounds, whose entries tests/test_mpc_scene.py's
    property test replaces)."""
    covered = {key for _, _, key, _ in KEYS}
    numeric = {
        key
        for name, keys in schema.TABLES.items()
        for key in keys
        if key not in ("kind", "method", "type", "inertia", "name", "specialise", "emit", "free", "jacobian")
        and key not in ("angles", "zero", "positive", "sweep", "energy", "predict", "x_max", "margin", "law")
        and key != "compensate_lag"  # a bool: tests/test_lag_compensation.py
        and key != "pulses"
        and key not in ("mode", "p", "soft_bounds", "tracking", "sensitivities")  # words; two matrices
        and key not in SWINGUP_TUNING
        and key not in ("gain_spread", "gain_drift")  # an EKF with a swing-up: tests/test_sensors.py
        and key != "noise_memory"  # an EKF's: tests/test_sensors.py
    }
    assert numeric <= covered, numeric - covered


@functools.cache
def _warm_up() -> None:
    for text in SCENES:
        _outcome(text)


@settings(max_examples=300, deadline=None, suppress_health_check=_CHECKS)
@given(key=st.sampled_from(KEYS), number=NUMBERS, position=st.integers(0, 6))
def test_any_number_in_any_numeric_key_loads_or_is_one_line(
    key: tuple[int, int, str, str], number: str, position: int
) -> None:
    scene, line, _, kind = key
    _warm_up()  # the first load imports CasADi, scipy, ...: not what the time bound is about
    started = time.process_time()
    _outcome(_replaced(scene, line, kind, number, position))
    assert time.process_time() - started < 10


REGRESSIONS = [
    (0, "t_end", "9" * 4301, "an integer of more than 4300 digits"),
    (0, "t_end", "0x" + "f" * 1200, "...8566515865407717375: is too large for a double"),
    (0, "t_end", "0x" + "f" * 4000, "simulation.t_end = 0xffff"),
    (0, "t_end", "1e9999999999999999999", "t_end = 1e9999999999999999999: is too large for a double"),
    (1, "Kg", "1e200", "the motor's gain is 5e+197, outside [1e-100, 1e+100]"),  # Kg² is inf
    (1, "period", "1e-300", "swingup.period = 1e-300: t_end / period"),
    (1, "period", "5e-324", "swingup.period = 5e-324: t_end / period"),
    (1, "g", "0", "energy swing-up needs gravity"),
    (1, "g", "-0.0", "energy swing-up needs gravity"),
    # Found by CI's property runs: over- and underflow in the measured loop and the motor's fold.
    (1, "g", "5e-324", "m1 g l1 underflows to 0"),
    (1, "Rm", "1e308", "the motor's gain is 4.2e-310, outside [1e-100, 1e+100]"),
    (1, "Jm", "1e308", "the motor's rotor inertia is 1e+308"),
    (2, "resolution", "1e-300", "must be 0 (exact) or >= 1 count per revolution or metre"),
    (2, "delay", "1e308", "is more than 1,000,000 periods of 0.01 s"),
    (2, "process_noise", "1e308", "must be <= 1e+100"),
    # (the DARE fails, and the rank test, now on the model as built, doubts the input's reach)
    (1, "Jm", "9" * 25, "swingup: (A, B) is not stabilisable"),
    (2, "measured", "9" * 310, "measured[0] = 99999999999999999999999999999999999999...9999999999999999999:"),
    # A decimal no exact rational is made of, refused on loading (before, by the motor's exact fold
    # in resolved_config, after the scene had loaded)
    (1, "delta", "1e-401", "parameter delta0 = 1E-401: outside 1e-400 .. 1e400"),
    (0, "delta", "1e-401", "parameter delta0 = 1E-401: outside 1e-400 .. 1e400"),
]


# The numbers each regression above was an example of: the extremes of a double, and an integer
# longer than any message should echo.
EXTREMES = ("1e308", "-1e308", "1e200", "1e25", "1e-300", "5e-324", "-0.0", "9" * 310)


def test_every_numeric_key_takes_every_extreme() -> None:
    """Each numeric key of every scene above with each extreme (first array entry): loads, or one
    line. Exhaustive where the property above samples, so no key waits for a lucky draw."""
    _warm_up()
    failures = []
    for scene, line, key, kind in KEYS:
        for number in EXTREMES:
            try:
                _outcome(_replaced(scene, line, kind, number, 0))
            except Exception as error:  # collect them all: one run names every broken key
                failure = f"{key} = {number[:12]} in scene {scene}: {type(error).__name__}: {error}"
                failures.append(failure[:300])
    assert not failures, "\n".join(failures)


@pytest.mark.parametrize(("scene", "key", "number", "expected"), REGRESSIONS)
def test_reported_numbers(scene: int, key: str, number: str, expected: str) -> None:
    (line, kind) = next((i, k) for s, i, name, k in KEYS if s == scene and name == key)
    outcome = _outcome(_replaced(scene, line, kind, number, 0))
    assert expected in outcome, outcome


def test_messages_show_values_as_written() -> None:
    text = SCENES[0].replace("[parameters]\n", "[parameters]\nJ_axial = [0, 0.5, 0]\n")
    outcome = _outcome(text)
    assert "parameters.J_axial = [0, 0.5, 0]: counts only for a rotary system" in outcome, outcome



def _through_the_command(key: tuple[int, int, str, str], number: str) -> None:
    """`ipgen --scene S -o DIR` (the scene resolved, gains and plans designed) on the scene with
    `number` at `key`: exit 0, or one line on stderr and status 2, and no numpy RuntimeWarning
    (an overflow inside the design) shown to the user before it."""
    import contextlib
    import io
    import warnings

    from ipgen.command.cli import run as cli

    scene, line, _, kind = key
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "s.toml"
        path.write_text(_replaced(scene, line, kind, number, 0), encoding="utf-8")
        stderr = io.StringIO()
        with warnings.catch_warnings(record=True) as shown, contextlib.redirect_stderr(stderr):
            warnings.simplefilter("always")
            status = cli(["--scene", str(path), "-o", str(Path(tmp) / "out")])
    printed = stderr.getvalue()
    assert not [w for w in shown if issubclass(w.category, RuntimeWarning)], [str(w.message) for w in shown]
    assert status == 0 or (status == 2 and printed.count("\n") == 1 and "error:" in printed), printed


@settings(max_examples=40, deadline=None, suppress_health_check=_CHECKS)
@given(key=st.sampled_from(KEYS), number=st.sampled_from(EXTREMES))
# Found in a make test run (2026-11-29): the MPC's terminal Riccati design at m = 1e308 let scipy's
# "QZ iteration failed" LinAlgWarning through before the one-line error.
@example(key=next(k for k in KEYS if k[0] == SCENES.index(MPC) and k[2] == "m"), number="1e308")
def test_the_command_prints_one_line_and_no_numpy_warning(
    key: tuple[int, int, str, str], number: str
) -> None:
    _through_the_command(key, number)


def test_the_reported_overflow_warnings_stay_inside() -> None:
    """The two reports: g = 1e200 under the motor's swing-up (tvlqr's matmul overflowed) and a
    saturation of 1e308 under the measured loop (the covariance's)."""
    for scene, name, number in ((1, "g", "1e200"), (2, "saturation", "1e308")):
        matches = [k for k in KEYS if k[0] == scene and k[2] == name]
        assert matches, (scene, name)
        _through_the_command(matches[0], number)


def test_a_too_long_integer_is_named_by_its_line_in_linear_time() -> None:
    """The 4300-digit refusal names the line; finding it stays linear on many long digit runs
    (a search that restarts inside a run is quadratic: seconds on this 250 KiB scene)."""
    lines = SCENES[0].splitlines()
    at = next(i for i, line in enumerate(lines) if line.startswith("t_end = "))
    filler = [f"# {'7' * 4300}" for _ in range(58)]
    text = "\n".join([*filler, *lines[:at], "t_end = " + "9" * 4301, *lines[at + 1 :]]) + "\n"
    clock = time.perf_counter()
    outcome = _outcome(text)
    assert time.perf_counter() - clock < 1.0
    assert f"line {len(filler) + at + 1}: an integer of more than 4300 digits" in outcome, outcome[:200]
