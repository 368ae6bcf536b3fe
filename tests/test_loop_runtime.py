"""ipgen_loop.h through ctypes (ipgen.common.loop_runtime) against the independent numpy
references of tests/loop_reference.py (the package's numpy code before it ran the C header):
the quantiser (half steps, zero step), the delay (0 and 3 periods), the saturation, the
estimators' steps (difference, derivative filter, steady-state Kalman, EKF and its failure
codes), ipgen.gym's measured loop (bitwise) and the energy swing-up; and the library itself: built
only when first used, its structs' layout checked, a missing C compiler one clear line."""

from __future__ import annotations

import ctypes
import math
import os
import subprocess
import sys
from pathlib import Path

import loop_reference as reference
import numpy as np
import pytest
from estimation_cases import EKF_SAMPLES, QUBE, QUBE_LQR, RDIP, RSIP
from hypothesis import HealthCheck, assume, example, given, settings
from hypothesis import strategies as st

import ipgen
from ipgen.common import loop_runtime
from ipgen.common.loop_runtime import LoopRuntimeError, address, library
from ipgen.estimation import EstimationError, Sensors
from ipgen.estimation.estimators import DerivativeFilter, Difference, ExtendedKalman, SteadyStateKalman

SETTINGS = settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
FINITE = st.floats(-1e6, 1e6, allow_nan=False, allow_infinity=False)
CLOSE = 1e-12  # relative (to max(1, |value|)): the C and numpy sums in other orders


def close(got: np.ndarray, want: np.ndarray, tolerance: float = CLOSE) -> bool:
    got, want = np.asarray(got, dtype=float), np.asarray(want, dtype=float)
    return bool(np.all(np.abs(got - want) <= tolerance * np.maximum(1.0, np.abs(want))))


# ---- the library ---------------------------------------------------------------------------------


def test_importing_the_runtime_paths_compiles_nothing(tmp_path: Path) -> None:
    """`import ipgen` and the modules that run the header build no library until one is used."""
    code = (
        "import ipgen, ipgen.estimation.estimators, ipgen.gym.sensing, ipgen.control.energy\n"
        "from ipgen.common import loop_runtime\n"
        "assert loop_runtime._loaded is None\n"
    )
    env = {**os.environ, "IPGEN_CACHE_DIR": str(tmp_path)}
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env)
    assert done.returncode == 0, done.stderr[-2000:]
    assert not (tmp_path / "loop").exists()


def test_the_library_is_cached_and_its_layout_checked() -> None:
    loaded = library()
    assert library() is loaded  # once per process
    assert loaded.ipgen_loop_batch_layout.restype is ctypes.c_long
    with pytest.raises(ctypes.ArgumentError):  # argtypes declared: a string is no double
        loaded.ipgen_loop_saturate("1", 2.0)


def test_the_runtime_sources_compile_without_warnings(tmp_path: Path) -> None:
    """The library's own build has no -Werror (a user's compiler may warn more); here it has."""
    cpp = Path(loop_runtime.__file__).resolve().parents[2] / "cpp"
    command = [
        os.environ.get("CC", "cc"), *loop_runtime.FLAGS, "-Werror", f"-I{cpp / 'include'}",
        str(cpp / "src" / "ipgen_loop_batch.c"), "-o", str(tmp_path / "libloop.so"), "-lm",
    ]  # fmt: skip
    done = subprocess.run(command, capture_output=True, text=True)
    assert done.returncode == 0, done.stderr


def test_a_struct_mirror_out_of_step_is_reported(monkeypatch: pytest.MonkeyPatch) -> None:
    """The layout check is not vacuous: a mirror whose offsets differ from C's is refused."""
    real = loop_runtime._layout()
    monkeypatch.setattr(loop_runtime, "_layout", lambda: [*real[:-1], real[-1] + 8])
    with pytest.raises(LoopRuntimeError, match="structs do not match"):
        loop_runtime.declare(ctypes.CDLL(str(loop_runtime.build())))


def test_an_ekf_scratch_size_out_of_step_is_reported(monkeypatch: pytest.MonkeyPatch) -> None:
    """ekf_work (the scratch Python allocates for C's EKF) equals IPGEN_LOOP_EKF_WORK; one entry
    short is refused when the library loads."""
    loaded = library()
    for n in range(1, 10):
        for c in range(1, 5):
            assert loaded.ipgen_loop_batch_ekf_work(n, c) == loop_runtime.ekf_work(n, c)
    real = loop_runtime.ekf_work
    monkeypatch.setattr(loop_runtime, "ekf_work", lambda n, c: real(n, c) - 1)
    with pytest.raises(LoopRuntimeError, match="IPGEN_LOOP_EKF_WORK"):
        loop_runtime.declare(ctypes.CDLL(str(loop_runtime.build())))


def test_no_c_compiler_is_one_line_naming_the_fix(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("CC", "/nonexistent/ipgen-test-cc")
    with pytest.raises(LoopRuntimeError) as info:
        loop_runtime.build()
    message = str(info.value)
    assert isinstance(info.value, ipgen.Error) and "\n" not in message
    assert "no C compiler found" in message and "apt-get install gcc" in message


# ---- quantiser, delay, saturation ----------------------------------------------------------------


def python_quantise(value: float, zero: float, step: float) -> float:
    return value if not step > 0 else zero + step * math.floor((value - zero) / step + 0.5)


@SETTINGS
@given(value=FINITE, zero=st.floats(-10, 10), step=st.one_of(st.just(0.0), st.floats(1e-6, 10.0)))
@example(value=0.25, zero=0.0, step=0.5)  # half a step above 0: up, to 0.5
@example(value=-0.25, zero=0.0, step=0.5)  # half a step below 0: up, to 0
@example(value=1.75, zero=0.5, step=0.5)  # half a step from a zero that is not 0
@example(value=0.3, zero=0.1, step=0.0)  # no quantisation: the value itself
@example(value=0.3, zero=0.1, step=-1.0)  # step <= 0: the value itself
def test_quantiser_is_the_formula(value: float, zero: float, step: float) -> None:
    """Bitwise the Python formula (no fused multiply-adds: -std=c99)."""
    assert library().ipgen_loop_quantise(value, zero, step) == python_quantise(value, zero, step)


def test_quantiser_at_half_steps_and_without_steps() -> None:
    q = library().ipgen_loop_quantise
    assert [q(v, 0.0, 0.5) for v in (0.25, -0.25, 0.75, -0.75)] == [0.5, 0.0, 1.0, -0.5]
    assert q(0.123456789, 0.0, 0.0) == 0.123456789 and q(-7.5, 3.0, -0.1) == -7.5
    assert math.isnan(q(math.nan, 0.0, 0.0))


@SETTINGS
@given(
    resolution=st.lists(st.sampled_from([0.0, 1.0, 3.0, 512.0, 2048.0, 4096.0]), min_size=2, max_size=2),
    zero=st.lists(st.floats(-4, 4), min_size=2, max_size=2),
    theta=st.lists(st.floats(-50, 50), min_size=2, max_size=2),
    cart=st.booleans(),
)
def test_sensors_quantise_equals_the_reference(resolution, zero, theta, cart) -> None:
    sensors = Sensors.of(2, None, resolution, cart=cart, zero=zero)
    assert np.array_equal(sensors.quantise(np.array(theta)), reference.quantise(sensors, np.array(theta)))


@pytest.mark.parametrize("delay", [0, 1, 3])
def test_delay_is_a_queue_of_whole_periods(delay: int) -> None:
    rng = np.random.default_rng(delay)
    pending = np.zeros(delay + 1)
    queue = [0.0] * delay  # the numpy loop's: pending[0] is applied next
    last = 0.0
    for _ in range(20):
        command = float(rng.normal())
        assert pending[0] == last  # what acted over the period that just ended
        applied = library().ipgen_loop_delay(address(pending), delay, command)
        queue.append(command)
        assert applied == queue.pop(0)
        last = applied
    if delay == 0:
        assert applied == command


def test_saturation() -> None:
    s = library().ipgen_loop_saturate
    assert (s(3.0, 2.0), s(-3.0, 2.0), s(1.5, 2.0), s(-0.0, 0.0)) == (2.0, -2.0, 1.5, -0.0)
    assert math.isnan(s(math.nan, 1.0))  # passes through, for the caller to see


# ---- estimators ----------------------------------------------------------------------------------

SAMPLES = st.lists(
    st.tuples(st.lists(st.floats(-3, 3), min_size=2, max_size=2), st.floats(-5, 5)), min_size=1, max_size=25
)


@SETTINGS
@given(samples=SAMPLES, period=st.floats(1e-4, 0.05), cutoff=st.floats(1.0, 60.0))
def test_difference_and_filter_equal_the_reference(samples, period: float, cutoff: float) -> None:
    pairs = [(Difference(period, 2), reference.Difference(period, 2))]
    pairs.append((DerivativeFilter(period, 2, cutoff), reference.DerivativeFilter(period, 2, cutoff)))
    for estimator, ref in pairs:
        for y, u in samples:
            assert close(estimator.step(y, u), ref.step(y, u))
        estimator.reset()
        ref = type(ref)(period, 2) if isinstance(ref, reference.Difference) else type(ref)(period, 2, cutoff)
        assert close(estimator.step(samples[0][0]), ref.step(samples[0][0]))  # reset: sample 0 again


@pytest.fixture(scope="module")
def rdip_kalman() -> ipgen.estimation.kalman.Kalman:
    return ipgen.kalman(RDIP, 0.002, np.eye(6) * 1e-3, np.eye(2) * 1e-6, measured=[0, 1])


@SETTINGS
@given(samples=SAMPLES)
def test_steady_state_kalman_equals_the_reference(rdip_kalman, samples) -> None:
    estimator, ref = SteadyStateKalman(rdip_kalman), reference.SteadyStateKalman(rdip_kalman)
    for y, u in samples:
        assert close(estimator.step(y, u), ref.step(y, u))


@settings(max_examples=15, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    samples=EKF_SAMPLES,
    case=st.sampled_from(["rsip", "qube", "rdip"]),
)
def test_extended_kalman_equals_the_reference(samples, case: str) -> None:
    """x̂ and P of the C EKF (Cholesky, P⁻ not symmetrised) and the numpy one (LU) agree."""
    pendulum, dof = {"rsip": (RSIP, 2), "qube": (QUBE, 2), "rdip": (RDIP, 3)}[case]
    ekf = ExtendedKalman(pendulum, 0.002, np.eye(2 * dof) * 1e-3, np.eye(2) * 1e-6, measured=[0, 1])
    ref = reference.ExtendedKalman(ekf)
    assert ekf.covariance is None
    for y, u in samples:
        assert close(ekf.step(y, u), ref.step(y, u), 1e-10)
        assert close(ekf.covariance, ref.covariance, 1e-10)


def test_extended_kalman_not_positive_definite_is_an_error() -> None:
    """C P⁻ Cᵀ + Rn not positive definite (ipgen_loop_ekf_update's code 2): EstimationError, the
    estimate left at the sample before; a NaN measurement is refused before the filter sees it."""
    ekf = ExtendedKalman(RSIP, 0.002, np.eye(4) * 1e-3, np.eye(2) * 1e-6)
    before = ekf.step([0.01, 0.02])
    ekf._p[:] = -1e3 * np.eye(4)  # an indefinite covariance, as a diverged filter might hold
    p = ekf._p.copy()
    with pytest.raises(EstimationError, match="not positive definite") as info:
        ekf.step([0.01, 0.02])
    assert "\n" not in str(info.value)
    assert np.array_equal(ekf._x, before) and np.array_equal(ekf._p, p)
    fresh = ExtendedKalman(RSIP, 0.002, np.eye(4) * 1e-3, np.eye(2) * 1e-6)
    fresh.step([0.0, 0.0])
    with pytest.raises(EstimationError, match="not finite"):  # refused before the filter sees it
        fresh.step([math.nan, 0.0])
    assert np.isfinite(fresh.step([0.0, 0.0])).all()  # and the filter goes on


def test_extended_kalman_model_failure_is_an_error() -> None:
    """The model raising inside the C callback (code 1): EstimationError naming the cause."""

    class Failing:
        def __init__(self, model: object) -> None:
            self.model = model

        def __getattr__(self, name: str) -> object:
            return getattr(self.model, name)

        def f(self, x: np.ndarray, u: float) -> np.ndarray:
            raise np.linalg.LinAlgError("M(q) is singular")

        def jacobians(self, x: np.ndarray, u: float) -> tuple:
            raise np.linalg.LinAlgError("M(q) is singular")

    ekf = ExtendedKalman(RSIP, 0.002, np.eye(4) * 1e-3, np.eye(2) * 1e-6)
    first = ekf.step([0.0, 0.0])
    ekf.model = Failing(ekf.model)  # type: ignore[assignment]
    with pytest.raises(EstimationError, match=r"model fails.*singular"):
        ekf.step([0.0, 0.0], 1.0)
    assert np.array_equal(ekf._x, first)


# ---- ipgen.gym's measured loop -------------------------------------------------------------------


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    resolution=st.sampled_from([0, 100, 2048, [0, 512]]),
    noise=st.sampled_from([0.0, 0.003]),
    delay=st.sampled_from([0, 1, 3]),
    rates=st.sampled_from(["filter", "difference"]),
    drive_noise=st.sampled_from([0.0, 0.05]),
    seed=st.integers(0, 2**16),
)
def test_gym_measured_loop_equals_the_reference_bitwise(
    resolution, noise, delay, rates, drive_noise, seed
) -> None:
    from ipgen.gym.sensing import MeasuredLoop, Sensing

    dt, n, dof = 0.01, 6, 2
    options = {
        "resolution": resolution, "noise": noise, "delay": delay * dt, "rates": rates,
        "drive_noise": drive_noise,
    }  # fmt: skip
    sensing = Sensing.from_options(options, "classical", dof, dt)
    loop, ref = MeasuredLoop(sensing, dof, n, dt), reference.MeasuredLoop(sensing, dof, n, dt)
    gens, ref_gens = ([np.random.default_rng(seed + i) for i in range(n)] for _ in range(2))
    rng = np.random.default_rng(seed)
    state = rng.normal(size=(n, 2 * dof))
    obs, ref_obs = np.zeros((n, 3 * dof - 1), np.float32), np.zeros((n, 3 * dof - 1), np.float32)
    everyone = np.arange(n)
    loop.reset(everyone, state, gens, obs)
    ref.reset(everyone, state, ref_gens, ref_obs)
    assert np.array_equal(obs, ref_obs)
    for k in range(25):
        rows = np.flatnonzero(rng.random(n) < 0.7)
        rows = rows if len(rows) else everyone[:1]  # the reference draws no noise for none
        actions = rng.uniform(-1, 1, size=len(rows))
        assert np.array_equal(loop.apply(rows, actions, gens), ref.apply(rows, actions, ref_gens))
        state += 0.05 * rng.normal(size=state.shape)
        if k == 12:
            state[1, 1] = math.inf  # a non-finite observation: reported as failed, as before
        failed = loop.observe(rows, state, gens, obs)
        assert np.array_equal(failed, ref.observe(rows, state, ref_gens, ref_obs))
        finite = np.isfinite(ref_obs).all(axis=1)
        assert np.array_equal(obs[finite], ref_obs[finite])
        if k % 7 == 6:
            again = rows[: max(1, len(rows) // 2)]
            state[again] = rng.normal(size=(len(again), 2 * dof))
            loop.reset(again, state, gens, obs)
            ref.reset(again, state, ref_gens, ref_obs)


def test_a_vector_env_whose_every_env_resets_measures_nothing() -> None:
    """Every env of a noisy vector env being reset at once: no measurement this step (the
    numpy loop stacked no draws and raised)."""
    import gymnasium

    import ipgen.gym  # noqa: F401  registers the ipgen/ environments (not only when another test did)

    env = gymnasium.make_vec(
        "ipgen/CartSingle-Balance-v0", num_envs=1, vectorization_mode="vector_entry_point",
        sensors={"noise": 0.01}, max_episode_steps=2,
    )  # fmt: skip
    env.reset(seed=0)
    for _ in range(5):
        obs, *_ = env.step(np.array([[0.5]], np.float32))
    assert np.isfinite(obs).all()


# ---- energy swing-up -----------------------------------------------------------------------------


@pytest.mark.parametrize("acceleration", [False, True])
def test_energy_swingup_equals_the_reference(acceleration: bool) -> None:
    from ipgen.control.casadi_model import plant
    from ipgen.control.energy import energy_swingup

    qube = plant("rotary", 1, [0.095, 0.024], [0.085, 0.129], [0.0005, 0.0])
    law = energy_swingup(qube, u_max=0.5, acceleration=acceleration)
    ref = reference.EnergyControl(law)
    rng = np.random.default_rng(7)
    phases = set()
    for k in range(300):
        if k % 40 == 0:
            law.reset()
            ref = reference.EnergyControl(law)
        x = np.array([rng.normal(), rng.uniform(-7, 7), rng.normal(), 5 * rng.normal()])
        if k % 40 == 39:  # near an upright 2πk, slow: caught
            x[1], x[3] = 2 * math.pi * round(x[1] / (2 * math.pi)) + 0.05, 0.1
        (u, phase), (u_ref, phase_ref) = law.control(k, x), ref.control(k, x)
        assert phase == phase_ref, (k, x)
        assert abs(u - u_ref) <= 1e-12 * max(1.0, abs(u_ref)), (k, u, u_ref)
        phases.add(phase)
    assert phases == {"swing", "hold"}


def test_energy_swingup_release_equals_the_reference() -> None:
    """release_angle: a hold whose link falls more than it from the caught upright swings again,
    and is caught again, as the reference says; without it the same states stay in the hold."""
    from ipgen.control.casadi_model import plant
    from ipgen.control.energy import energy_swingup

    qube = plant("rotary", 1, [0.095, 0.024], [0.085, 0.129], [0.0005, 0.0])
    caught = np.array([0.1, 2 * math.pi + 0.05, 0.0, 0.1])  # near the upright 2π, slow
    fallen = np.array([0.1, 2 * math.pi + 0.9, 0.0, 2.0])  # 0.9 rad from it
    for release, expected in ((0.8, ["hold", "swing", "hold"]), (None, ["hold", "hold", "hold"])):
        law = energy_swingup(qube, u_max=0.5, release_angle=release)
        ref = reference.EnergyControl(law)
        phases = []
        for k, x in enumerate((caught, fallen, caught)):
            (u, phase), (u_ref, phase_ref) = law.control(k, x), ref.control(k, x)
            assert phase == phase_ref and abs(u - u_ref) <= 1e-12 * max(1.0, abs(u_ref)), (release, k)
            phases.append(phase)
        assert phases == expected, release


@given(angle=st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.floats(-10, 10)))
def test_energy_swingup_bad_release_angle_is_one_line(angle: float) -> None:
    """A release angle not in (catch_angle, π/2) is refused in one line naming it."""
    from ipgen.control.casadi_model import plant
    from ipgen.control.energy import energy_swingup
    from ipgen.control.trajectory import PlanError

    assume(not (0.3 < angle < math.pi / 2))
    qube = plant("rotary", 1, [0.095, 0.024], [0.085, 0.129], [0.0005, 0.0])
    with pytest.raises(PlanError, match="release_angle") as error:
        energy_swingup(qube, u_max=0.5, catch_angle=0.3, release_angle=angle)
    assert "\n" not in str(error.value)


def test_energy_swingup_model_failure_propagates(monkeypatch: pytest.MonkeyPatch) -> None:
    """mass_and_bias raising inside the C callback: control raises that exception."""
    from ipgen.control import energy
    from ipgen.control.casadi_model import plant

    law = energy.energy_swingup(plant("rotary", 1, [0.095, 0.024], [0.085, 0.129], [0.0, 0.0]), u_max=0.5)

    def failing(*_: object) -> None:
        raise ZeroDivisionError("no mass")

    monkeypatch.setattr(energy, "mass_and_bias", failing)
    with pytest.raises(ZeroDivisionError, match="no mass"):
        law.control(0, np.array([0.0, math.pi, 0.0, 1.0]))


# ---- a plan's reference for a tracking controller --------------------------------------------------


def plan_reference(states: np.ndarray, inputs: np.ndarray, k: int, every: int, horizon: int):
    """The reference of ipgen_loop_plan_reference written independently: row j the plan's state at
    sample k + j every (its last row past the end), input j the mean of the plan's inputs over
    samples k + j every .. k + (j + 1) every - 1 (0 past the end)."""
    steps = len(inputs)
    rows = np.array([states[min(k + j * every, steps)] for j in range(horizon + 1)])
    windows = [range(k + j * every, k + (j + 1) * every) for j in range(horizon)]
    means = np.array([sum(inputs[m] for m in window if m < steps) / every for window in windows])
    return rows, means


@SETTINGS
@given(st.integers(1, 40), st.integers(1, 5), st.integers(1, 12), st.integers(0, 60), st.integers(1, 3))
def test_the_plan_reference_equals_the_formula(
    steps: int, every: int, horizon: int, k: int, dof: int
) -> None:
    """Every plan length, sampling ratio, horizon and start, past the plan's end included."""
    rng = np.random.default_rng(steps * 1000 + every * 100 + horizon * 10 + k)
    states = rng.normal(size=(steps + 1, 2 * dof))
    inputs = rng.normal(size=steps)
    law = loop_runtime.SwingUp()
    law.dof, law.steps = dof, steps
    law.states, law.inputs = address(states), address(inputs)
    rows = np.zeros((horizon + 1, 2 * dof))
    means = np.zeros(horizon)
    library().ipgen_loop_plan_reference(ctypes.byref(law), k, every, horizon, address(rows), address(means))
    want_rows, want_means = plan_reference(states, inputs, k, every, horizon)
    assert np.array_equal(rows, want_rows)
    assert close(means, want_means)


# ---- the delay compensated: ipgen_loop_rk4, ipgen_loop_predict ----------------------------------


def _field(rates):
    """An ipgen_loop_field of x' = rates(x, u) for ctypes (2 states, no Jacobian); kept by the caller."""

    def field(context, x, u, f, a) -> int:
        got = rates(np.array([x[0], x[1]]), u)
        if got is None:
            return 1
        f[0], f[1] = got
        return 0

    return loop_runtime.FIELD(field)


def _predict(
    field, period: float, gain: float, pending: list[float], x0: list[float]
) -> tuple[int, np.ndarray]:
    """ipgen_loop_predict over a delay of len(pending) − 1 periods: (its code, x_ahead)."""
    arrays = [np.array(pending, dtype=float), np.array(x0, dtype=float), np.zeros(2), np.zeros(12)]
    code = library().ipgen_loop_predict(field, None, 2, period, gain, len(pending) - 1, *map(address, arrays))
    return code, arrays[2]


@settings(max_examples=15, deadline=None)
@given(delay=st.integers(0, 30), seed=st.integers(0, 2**32 - 1))
def test_the_prediction_is_the_pendulum_over_the_commands_in_flight(delay: int, seed: int) -> None:
    """A damped pendulum θ'' = −(g/l) sin θ − c θ' + b u carried over the pending commands (each
    held one period): as scipy's solve_ivp (DOP853, rtol 1e-12) integrates it, to RK4's error."""
    from scipy.integrate import solve_ivp

    rng = np.random.default_rng(seed)
    period, gain = 0.001, 2.5
    pending = [float(v) for v in rng.uniform(-3, 3, delay + 1)]  # pending[0] acted already
    x0 = [float(rng.uniform(-3, 3)), float(rng.uniform(-5, 5))]

    def rates(x: np.ndarray, u: float) -> tuple[float, float]:
        return x[1], -(9.81 / 0.3) * math.sin(x[0]) - 0.2 * x[1] + u

    field = _field(rates)
    code, ahead = _predict(field, period, gain, pending, x0)
    assert code == 0
    x = np.array(x0)
    for u in pending[1:]:
        x = solve_ivp(lambda t, s, u=u: rates(s, gain * u), (0, period), x, method="DOP853",
                      rtol=1e-12, atol=1e-14).y[:, -1]  # fmt: skip
    np.testing.assert_allclose(ahead, x, rtol=0, atol=1e-9 * (1 + delay))
    if delay == 0:
        assert np.array_equal(ahead, x0)


def test_a_prediction_through_a_failing_model_returns_the_estimate() -> None:
    calls = []

    def rates(x: np.ndarray, u: float) -> tuple[float, float] | None:
        calls.append(u)
        return None if len(calls) > 6 else (x[1], u)  # fails in the second step

    code, ahead = _predict(_field(rates), 0.01, 1.0, [0.0, 1.0, 1.0, 1.0], [0.5, -0.5])
    assert code == 1 and np.array_equal(ahead, [0.5, -0.5])


def test_python_closed_loop_with_a_predicted_delay_runs_as_the_loop_without_it() -> None:
    """ipgen.estimation.loop.closed_loop(predict=True), the QUBE (motor, Quanser's coordinates) on
    its LQR with 20 periods of delay: from t = d on the undelayed loop started at x(d), to the
    prediction's RK4 error; without predict it is not (as the simulator, test_sensors_sim.py)."""
    pytest.importorskip("casadi")
    from ipgen.estimation.loop import closed_loop
    from ipgen.estimation.pendulum import as_model

    pendulum = ipgen.Pendulum(**QUBE)
    model, gain = as_model(pendulum), ipgen.lqr(pendulum, QUBE_LQR["Q"], QUBE_LQR["R"])
    sensors, x_eq = Sensors.of(2, None, 0), np.zeros(4)
    initial = np.array([0.0, 0.1, 0.0, 0.0])
    def states(predict: bool) -> np.ndarray:
        run = closed_loop(model, gain, x_eq, None, sensors, 0.001, 0.3, initial, saturation=10.0,
                          delay=20, predict=predict)  # fmt: skip
        return run.x

    runs = {predict: states(predict) for predict in (True, False)}
    free = closed_loop(model, gain, x_eq, None, sensors, 0.001, 0.28, runs[True][20], saturation=10.0).x
    gap = {predict: np.max(np.abs(x[20 : 20 + len(free)] - free)) for predict, x in runs.items()}
    assert gap[True] < 1e-7 < 1e-3 < gap[False], gap
