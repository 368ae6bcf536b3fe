"""ipgen.linearize and ipgen.lqr: against finite differences, an independent Riccati solve, and
the nonlinear closed loop (integrated here with scipy on the lambdified model)."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
from numeric import assert_close
from scipy.integrate import solve_ivp

import ipgen
from ipgen.control import linear as control
from ipgen.control.linear import ControlError, EquilibriumWarning
from ipgen.errors import Error
from ipgen.model.system import System


def paper_like(type_: str, links: int) -> dict:
    """The paper's parameters (CDIP / RSIP) extended to `links` equal links."""
    if type_ == "classical":
        return {"m": [0.3] + [0.275] * links, "l": [0.0] + [0.5] * links, "delta": [0.3] + [0.1] * links}
    return {"m": [0.5] + [0.275] * links, "l": [0.6] + [0.5] * links, "delta": [0.3] + [0.011458] * links}


SYSTEMS = [(t, n) for t in ("classical", "rotary") for n in (1, 2, 3)]


def flat(p: dict, g: float = 9.81) -> list[float]:
    return [*p["m"], *p["l"], *p["delta"], g]


def central_differences(
    type_: str, links: int, p: dict, x: np.ndarray, u: float
) -> tuple[np.ndarray, np.ndarray]:
    """A and B of ẋ = f(x, u) by central differences of the (lambdified) forward dynamics."""
    dyn = control.dynamics(System(type_, links))
    dof = links + 1

    def f(state: np.ndarray, force: float) -> np.ndarray:
        return np.concatenate([state[dof:], dyn.forward_dynamics(state[:dof], state[dof:], force, flat(p))])

    a = np.zeros((2 * dof, 2 * dof))
    for j in range(2 * dof):
        h = 1e-6 * max(1.0, abs(x[j]))
        step = np.zeros(2 * dof)
        step[j] = h
        a[:, j] = (f(x + step, u) - f(x - step, u)) / (2 * h)
    b = ((f(x, u + 1e-6) - f(x, u - 1e-6)) / 2e-6).reshape(-1, 1)
    return a, b


@pytest.mark.parametrize(("type_", "links"), SYSTEMS)
def test_linearize_matches_central_differences(type_: str, links: int) -> None:
    p = paper_like(type_, links)
    rng = np.random.default_rng(links)
    dof = links + 1
    for _ in range(2):
        x = rng.uniform(-1.5, 1.5, 2 * dof)
        u = float(rng.uniform(-2, 2))
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", EquilibriumWarning)
            a, b = ipgen.linearize(type_, links, **p, q=x[:dof], qd=x[dof:], u=u)
        a_fd, b_fd = central_differences(type_, links, p, x, u)
        assert_close(a, a_fd, 1e-6, f"{type_}{links} A", ("exact", "central differences"))
        assert_close(b, b_fd, 1e-6, f"{type_}{links} B", ("exact", "central differences"))
        assert np.array_equal(a[:dof, :dof], np.zeros((dof, dof))) and np.array_equal(
            a[:dof, dof:], np.eye(dof)
        )


def test_linearize_warns_off_equilibrium_only() -> None:
    p = paper_like("rotary", 2)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        ipgen.linearize("rotary", 2, **p)  # upright at rest: an equilibrium, no warning
        ipgen.linearize("rotary", 2, **p, q=[0.3, math.pi, 0.0])  # mixed equilibrium
    with pytest.warns(EquilibriumWarning, match="not an equilibrium"):
        ipgen.linearize("rotary", 2, **p, q=[0, 0.1, 0])
    with pytest.warns(EquilibriumWarning):
        ipgen.linearize("rotary", 2, **p, qd=[0, 0, 1.0])
    with pytest.warns(EquilibriumWarning):
        ipgen.linearize("classical", 1, **paper_like("classical", 1), u=1.0)  # the cart accelerates


def hamiltonian_riccati(a: np.ndarray, b: np.ndarray, q: np.ndarray, r: np.ndarray) -> np.ndarray:
    """The stabilising solution of the CARE from the stable invariant subspace of the Hamiltonian
    matrix (eigenvectors; a different algorithm from scipy's Schur-based solver)."""
    n = a.shape[0]
    h = np.block([[a, -b @ np.linalg.solve(r, b.T)], [-q, -a.T]])
    values, vectors = np.linalg.eig(h)
    stable = vectors[:, values.real < 0]
    assert stable.shape[1] == n
    return np.real(stable[n:] @ np.linalg.inv(stable[:n]))


@pytest.mark.parametrize(("type_", "links"), SYSTEMS)
@pytest.mark.parametrize("equilibrium", ["upright", "hanging", "mixed"])
def test_lqr_gain_against_an_independent_riccati_solve(type_: str, links: int, equilibrium: str) -> None:
    p = paper_like(type_, links)
    dof = links + 1
    where: str | list[float] = equilibrium
    if equilibrium == "mixed":
        where = [0.0, math.pi] + [0.0] * (links - 1)  # link 1 hanging, the others upright
    rng = np.random.default_rng(7 * links)
    weights = rng.uniform(0.5, 2.0, 2 * dof)
    r = 0.7
    k = ipgen.lqr(type_, links, **p, Q=weights, R=r, equilibrium=where)
    assert k.shape == (1, 2 * dof)  # python-control's convention: A - B @ K is the closed loop
    x_eq = control.equilibrium_state(links, where)
    a, b = ipgen.linearize(type_, links, **p, q=x_eq[:dof], qd=x_eq[dof:])
    q, rr = np.diag(weights), np.array([[r]])
    p_ref = hamiltonian_riccati(a, b, q, rr)
    k_ref = np.linalg.solve(rr, b.T @ p_ref)
    assert_close(k, k_ref, 1e-6, f"{type_}{links} {equilibrium} K", ("scipy", "Hamiltonian"))
    # K = R⁻¹ Bᵀ P with P solving Aᵀ P + P A − P B R⁻¹ Bᵀ P + Q = 0: check that residual for K's P.
    residual = a.T @ p_ref + p_ref @ a - p_ref @ b @ np.linalg.solve(rr, b.T) @ p_ref + q
    assert np.max(np.abs(residual)) <= 1e-7 * np.max(np.abs(p_ref))
    poles = control.closed_loop_poles(a, b, k)
    assert np.max(poles.real) < 0, poles


def test_full_q_matrix_equals_its_diagonal() -> None:
    p = paper_like("rotary", 1)
    diagonal = [1.0, 2.0, 3.0, 4.0]
    k1 = ipgen.lqr("rotary", 1, **p, Q=diagonal, R=1.0)
    k2 = ipgen.lqr("rotary", 1, **p, Q=np.diag(diagonal), R=[1.0])
    assert np.allclose(k1, k2, rtol=1e-12, atol=0)


def test_lqr_refuses_an_undetectable_pair() -> None:
    p = paper_like("rotary", 2)
    with pytest.raises(ControlError, match="not detectable"):
        ipgen.lqr("rotary", 2, **p, Q=np.zeros(6), R=1.0)  # no weight on the unstable upright modes
    assert issubclass(ControlError, Error)


def test_unstabilisable_pair_is_an_error() -> None:
    # Two copies of an unstable mode driven by the same input column cannot be moved apart.
    a = np.diag([1.0, 1.0])
    b = np.array([[1.0], [1.0]])
    with pytest.raises(ControlError, match="not stabilisable"):
        control.check_stabilisable(a, b, np.eye(2))
    control.check_stabilisable(np.diag([1.0, 2.0]), b, np.eye(2))  # distinct modes: controllable


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"Q": [1, 1, 1], "R": 1}, "Q has 3 diagonal entries, expected 4"),
        ({"Q": [1, -1, 1, 1], "R": 1}, ">= 0"),
        ({"Q": [[1, 2, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]], "R": 1}, "symmetric"),
        ({"Q": np.diag([1.0, -1.0, 1.0, 1.0]), "R": 1}, "positive semidefinite"),
        ({"Q": [1, 1, 1, 1], "R": 0}, "R = 0"),
        ({"Q": [1, 1, 1, 1], "R": 1, "equilibrium": [0, 1.0]}, "not an equilibrium angle"),
        ({"Q": [1, 1, 1, 1], "R": 1, "equilibrium": "sideways"}, "expected 'upright', 'hanging'"),
    ],
)
def test_bad_lqr_arguments(kwargs: dict, message: str) -> None:
    with pytest.raises(ControlError, match=message):
        ipgen.lqr("rotary", 1, **paper_like("rotary", 1), **kwargs)


def closed_loop(
    type_: str, links: int, k: np.ndarray, x0: np.ndarray, t_end: float, saturation: float | None = None
) -> np.ndarray:
    """The nonlinear model under u = −K x (upright), integrated with scipy's DOP853; final state."""
    p = paper_like(type_, links)
    dyn = control.dynamics(System(type_, links))
    dof = links + 1

    def f(_t: float, x: np.ndarray) -> np.ndarray:
        u = -float(np.ravel(k) @ x)
        if saturation is not None:
            u = min(max(u, -saturation), saturation)
        return np.concatenate([x[dof:], dyn.forward_dynamics(x[:dof], x[dof:], u, flat(p))])

    solution = solve_ivp(f, (0.0, t_end), x0, method="DOP853", rtol=1e-9, atol=1e-11)
    assert solution.success, solution.message
    return solution.y[:, -1]


@pytest.mark.parametrize(("type_", "links"), SYSTEMS)
def test_nonlinear_closed_loop_returns_upright_from_a_tilt(type_: str, links: int) -> None:
    p = paper_like(type_, links)
    dof = links + 1
    k = ipgen.lqr(type_, links, **p, Q=np.ones(2 * dof), R=1.0)
    x0 = np.zeros(2 * dof)
    x0[1:dof] = 0.05  # the whole pendulum tilted, straight (link 1 alone at 0.05 rad is outside the
    # basin of classical n = 2 with these weights: see docs/bench/control.md)
    final = closed_loop(type_, links, k, x0, t_end=15.0)
    assert np.max(np.abs(final)) < 1e-3, final
    # and the open loop falls: the test can fail
    zero = closed_loop(type_, links, np.zeros(2 * dof), x0, t_end=3.0)
    assert np.max(np.abs(zero[1:dof])) > 0.5


ODD_WEIGHTS = [
    "abc", b"1", None, {"a": 1}, [[1, 0], [0]], [1, "x", 1, 1], [math.nan] * 4, [1, 1], object(), 1j,
]


@pytest.mark.parametrize("which", ["Q", "R"])
@pytest.mark.parametrize("value", ODD_WEIGHTS, ids=[f"odd{i}" for i in range(len(ODD_WEIGHTS))])
def test_weights_of_any_type_are_a_control_error(which: str, value: object) -> None:
    """ipgen.lqr's Q and R of any type: a ControlError (an ipgen.Error) naming the weight in one
    line, as docs/control.md says (text or a ragged list raised numpy's ValueError)."""
    qube = ipgen.Pendulum.preset("qube_servo2")
    weights = {"Q": [1, 1, 1, 1], "R": 1.0} | {which: value}
    with pytest.raises(ControlError) as error:
        ipgen.lqr(qube, weights["Q"], weights["R"])
    assert str(error.value).startswith(which) and "\n" not in str(error.value)


@pytest.mark.parametrize("law", ["energy", "trajectory"])
def test_the_swing_up_laws_refuse_a_rigs_coordinates(law: str) -> None:
    """The swing-up laws and plans take ipgen's coordinates; a Pendulum in a rig's (QUBE's
    counterclockwise) is refused in one line naming p.canonical() (it was taken as ipgen's: the
    hold pushed the wrong way)."""
    from ipgen.control.energy import energy_swingup
    from ipgen.control.swingup import trajectory_swingup

    direct = ipgen.Pendulum("rotary", 1, [0.095, 0.024], [0.085, 0.129], [5e-6, 1e-6])
    rig = direct.replace(positive="counterclockwise")
    with pytest.raises(ControlError, match=r"p\.canonical\(\)"):
        if law == "energy":
            energy_swingup(rig, u_max=0.05)
        else:
            trajectory_swingup(rig, duration=1.0, u_max=0.05)
    assert energy_swingup(direct, u_max=0.05) is not None


@pytest.mark.parametrize("u", ["1", b"1", "nan", None, [1.0]])
def test_linearize_takes_a_number_for_u(u: object) -> None:
    """u about which to linearise: a number; text is refused as the Pendulum refuses it ("1" was
    read as 1)."""
    with pytest.raises(ControlError, match="u must be a finite number"):
        ipgen.linearize(ipgen.Pendulum.preset("qube_servo2"), u=u)


@pytest.mark.parametrize(
    ("key", "value"),
    [("accel_max", -1.0), ("accel_max", "5"), ("gain_energy", "x"), ("gain_position", math.nan),
     ("gain_velocity", [1.0])],
)  # fmt: skip
def test_the_energy_laws_bad_numbers_name_their_key(key: str, value: object) -> None:
    """A bad accel_max is named as such (its derived gain_energy was named), and text is no
    number (gain_energy = "x" raised Python's ValueError)."""
    from ipgen.control.energy import energy_swingup

    rod = ipgen.Pendulum("rotary", 1, [0.095, 0.024], [0.085, 0.129], [5e-6, 1e-6])
    with pytest.raises(Error, match=f"^{key} = "):
        energy_swingup(rod, u_max=0.05, **{key: value})


def test_an_equilibrium_in_a_rigs_coordinates_is_named_as_given() -> None:
    """The QUBE counts counterclockwise: an equilibrium that is no rest is named as the user wrote
    it (0.5; it was named as ipgen's -0.5), with the coordinates it was read in."""
    with pytest.raises(ControlError) as error:
        ipgen.lqr(ipgen.Pendulum.preset("qube_servo2"), [1, 1, 1, 1], 1, equilibrium=[0, 0.5])
    assert "[0.0, 0.5]" in str(error.value) and "counterclockwise" in str(error.value)
