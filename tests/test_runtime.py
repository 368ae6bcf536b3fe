"""The simulator compiled once (issue 45): one compiled program runs every model, each model a
small library behind the C model interface (cpp/include/ipgen_model.h, `--emit library`).

Checked here: the library's functions against Kane's equations built independently
(tests/independent_model.py), through ctypes and the interface's own parameter layout; two models
of different types and sizes run by the same compiled program; bad model libraries refused in
one line before anything runs.
"""

from __future__ import annotations

import ctypes
import io
import math
import re
import shlex
import subprocess
import sys
from contextlib import redirect_stderr, redirect_stdout
from pathlib import Path

import numpy as np
import pytest
from cxx import require_toolchain
from independent_model import reference
from run_summary import simulator_of

from ipgen.command.cli import run
from ipgen.common.build_cache import cache_root
from ipgen.common.limits import MAX_SIMULATED_LINKS
from ipgen.pipeline import simulator
from ipgen.pipeline.simulator import c_compiler, c_optimisation, simulator_sources

MAX_DOF = 41
# A shared object that is not a model library.
LIBM = tuple(Path(p) for p in ("/lib/x86_64-linux-gnu/libm.so.6", "/usr/lib/x86_64-linux-gnu/libm.so.6"))
ARRAY = ctypes.c_double * MAX_DOF


class Parameters(ctypes.Structure):
    """ipgen_parameters."""

    _fields_ = [
        ("m", ARRAY), ("l", ARRAY), ("delta", ARRAY), ("g", ctypes.c_double),
        ("com", ARRAY), ("J", ARRAY), ("J_axial", ARRAY), ("tip", ARRAY), ("Ir", ARRAY), ("gr", ARRAY),
    ]  # fmt: skip


VEC = ctypes.POINTER(ctypes.c_double)
PARAMS = ctypes.POINTER(Parameters)


class Model(ctypes.Structure):
    """ipgen_model (the fields this test calls, in the header's order)."""

    _fields_ = [
        ("abi", ctypes.c_int), ("name", ctypes.c_char_p), ("type", ctypes.c_char_p),
        ("inertia", ctypes.c_char_p), ("links", ctypes.c_int), ("dof", ctypes.c_int),
        ("inputs", ctypes.c_int), ("links_as_built", ctypes.c_int),
        ("forward_dynamics", ctypes.CFUNCTYPE(ctypes.c_int, VEC, VEC, VEC, PARAMS, VEC)),
        ("forward_dynamics_derivatives", ctypes.c_void_p),
        ("linearize", ctypes.CFUNCTYPE(ctypes.c_int, VEC, VEC, VEC, PARAMS, VEC, VEC)),
        ("mass_matrix", ctypes.CFUNCTYPE(None, VEC, PARAMS, VEC)),
        ("bias", ctypes.CFUNCTYPE(None, VEC, VEC, PARAMS, VEC)),
        ("kinetic_energy", ctypes.CFUNCTYPE(ctypes.c_double, VEC, VEC, PARAMS)),
        ("potential_energy", ctypes.CFUNCTYPE(ctypes.c_double, VEC, PARAMS)),
        ("dissipation", ctypes.CFUNCTYPE(ctypes.c_double, VEC, PARAMS)),
        ("rod_links", ctypes.CFUNCTYPE(None, PARAMS)),
        ("check_folded", ctypes.CFUNCTYPE(ctypes.c_char_p, PARAMS)),
        ("gravity", ctypes.CFUNCTYPE(None, VEC, PARAMS, VEC)),
        ("n_matrix", ctypes.CFUNCTYPE(None, VEC, VEC, PARAMS, VEC)),
        ("input_matrix", VEC), ("joints", ctypes.POINTER(ctypes.c_int)),
        ("rk4_step", ctypes.CFUNCTYPE(ctypes.c_int, VEC, VEC, ctypes.c_double, PARAMS)),
    ]  # fmt: skip


def compile_library(folder: Path, name: str) -> Path:
    """NAME.h and NAME_model.c in `folder` compiled into a shared library, as `ipgen run` does
    (and with -Wmissing-prototypes: the exported ipgen_model_get had no declaration, a clang audit)."""
    _, include = simulator_sources()
    library = folder / f"lib{name}.so"
    command = [c_compiler(), *c_optimisation(), "-Wall", "-Wextra", "-Wpedantic", "-Wmissing-prototypes"]
    command += ["-Werror"]
    command += [f"-I{include}", f"-I{folder}", str(folder / f"{name}_model.c"), "-o", str(library), "-lm"]
    subprocess.run(command, check=True, capture_output=True, text=True)
    return library


def generate(folder: Path, *options: str) -> None:
    with redirect_stdout(io.StringIO()), redirect_stderr(io.StringIO()) as err:
        assert run([*options, "--emit", "library", "-o", str(folder)]) == 0, err.getvalue()


def vector(values: np.ndarray) -> ctypes.Array:
    return (ctypes.c_double * len(values))(*values)


@pytest.mark.parametrize(
    ("kind", "links", "inertia"),
    [("classical", 2, "pivot"), ("rotary", 1, "pivot"), ("rotary", 3, "full")],
)
def test_the_model_library_equals_kanes_equations(
    tmp_path: Path, kind: str, links: int, inertia: str
) -> None:
    """forward_dynamics, linearize's B, the mass matrix, gravity, N and the energies, called
    through the interface with its parameter layout, against Kane's equations of the same rig as
    built; and NaN com and J read as the homogeneous rods."""
    require_toolchain()
    options = ["--type", kind, "--links", str(links), "--name", "m"]
    if kind == "rotary":
        options += ["--inertia", inertia]
    generate(tmp_path, *options)
    lib = ctypes.CDLL(str(compile_library(tmp_path, "m")))
    lib.ipgen_model_get.restype = ctypes.POINTER(Model)
    model = lib.ipgen_model_get().contents
    dof = links + 1
    assert (model.abi, model.links, model.dof, model.inputs) == (4, links, dof, 1)
    assert [model.input_matrix[i] for i in range(dof)] == [1.0] + [0.0] * links and not model.joints
    assert model.type.decode() == kind and model.name.decode() == "m"
    ref = reference(kind, links, inertia, True)
    rng = np.random.default_rng(45)
    for _ in range(5):
        m, length = rng.uniform(0.1, 1.0, dof), rng.uniform(0.2, 0.8, dof)
        delta = rng.uniform(0.0, 0.1, dof)
        com, tip = length * rng.uniform(0.2, 0.8, dof), rng.uniform(0.0, 0.1, dof)
        J = m * length**2 * rng.uniform(0.02, 0.1, dof)
        axial = J * rng.uniform(0.0, 1.0, dof) if inertia == "full" else np.zeros(dof)
        if kind == "classical":
            length[0], J[0] = 0.0, 0.0
        p = Parameters()
        for field, values in (("m", m), ("l", length), ("delta", delta), ("com", com), ("J", J),
                              ("J_axial", axial), ("tip", tip)):  # fmt: skip
            getattr(p, field)[:dof] = values
        p.g = 9.81
        q, qd, u = rng.uniform(-math.pi, math.pi, dof), rng.uniform(-2, 2, dof), rng.uniform(-1, 1)
        args = (q, qd, u, (m, length, delta, 9.81, com, J, axial, tip))
        M_ref = np.asarray(ref.mass_matrix(*args), dtype=float)
        qdd_ref = ref.accelerations(*args)
        qdd = vector(np.zeros(dof))
        assert model.forward_dynamics(vector(q), vector(qd), vector([u]), ctypes.byref(p), qdd) == 0
        assert np.allclose(np.asarray(qdd), qdd_ref, rtol=1e-10, atol=1e-10)
        # rk4_step: the classic RK4 step of forward_dynamics, to the bit (IEEE doubles here too).
        x, h = np.concatenate([q, qd]), 0.01
        stepped = vector(x)
        assert model.rk4_step(stepped, vector([u]), h, ctypes.byref(p)) == 0
        assert np.asarray(stepped).tolist() == rk4_of(model, p, x.tolist(), u, h)
        M = vector(np.zeros(dof * dof))
        model.mass_matrix(vector(q), ctypes.byref(p), M)
        assert np.allclose(np.asarray(M).reshape(dof, dof), M_ref, rtol=1e-12, atol=1e-12)
        A, B = vector(np.zeros(4 * dof * dof)), vector(np.zeros(2 * dof))
        assert model.linearize(vector(q), vector(qd), vector([u]), ctypes.byref(p), A, B) == 0
        assert np.allclose(
            np.asarray(B)[dof:], np.linalg.solve(M_ref, np.eye(dof)[:, 0]), rtol=1e-10, atol=1e-12
        )
        # bias = B u - forcing = N qd + P, and P = bias at rest (no Coriolis, no damping).
        params = args[3]
        bias_ref = np.eye(dof)[:, 0] * u - np.asarray(ref.forcing(*args), dtype=float).ravel()
        gravity_ref = -np.asarray(ref.forcing(q, np.zeros(dof), 0.0, params), dtype=float).ravel()
        P, N = vector(np.zeros(dof)), vector(np.zeros(dof * dof))
        model.gravity(vector(q), ctypes.byref(p), P)
        model.n_matrix(vector(q), vector(qd), ctypes.byref(p), N)
        assert np.allclose(np.asarray(P), gravity_ref, rtol=1e-10, atol=1e-10)
        with_n = np.asarray(N).reshape(dof, dof) @ qd + np.asarray(P)
        assert np.allclose(with_n, bias_ref, rtol=1e-10, atol=1e-10)
        kinetic = model.kinetic_energy(vector(q), vector(qd), ctypes.byref(p))
        assert math.isclose(kinetic, float(ref.kinetic(*args)), rel_tol=1e-11, abs_tol=1e-12)
        potential = model.potential_energy(vector(q), ctypes.byref(p))
        assert math.isclose(potential, float(ref.potential(*args)), rel_tol=1e-11, abs_tol=1e-12)
        # Unset (NaN) com and J are the rods' l/2 and m l^2/12 (the arm's m l^2/3).
        p.com[:dof] = [math.nan] * dof
        p.J[:dof] = [math.nan] * dof
        model.rod_links(ctypes.byref(p))
        rods = np.array(p.J[:dof])
        assert np.allclose(np.array(p.com[1:dof]), length[1:] / 2, rtol=1e-15)
        assert np.allclose(rods[1:], m[1:] * length[1:] ** 2 / 12, rtol=1e-15)
        if kind == "rotary":
            assert math.isclose(rods[0], m[0] * length[0] ** 2 / 3, rel_tol=1e-15)
    assert model.check_folded(ctypes.byref(p)) is None  # a general model folds nothing
    # A step that fails leaves the state as it was: M not positive definite (a negative mass),
    # a derivative that is not finite (an infinite rate).
    for field, index, value in (("m", dof - 1, -1e3), ("delta", 0, math.inf)):
        kept = getattr(p, field)[index]
        getattr(p, field)[index] = value
        x = np.concatenate([q, qd])
        stepped = vector(x)
        assert model.rk4_step(stepped, vector([u]), 0.01, ctypes.byref(p)) != 0
        assert np.asarray(stepped).tolist() == x.tolist()
        getattr(p, field)[index] = kept


def rk4_of(model: Model, p: Parameters, x: list[float], u: float, h: float) -> list[float]:
    """One RK4 step of x = [q; qd] from the library's forward_dynamics, in Python floats, in the
    order of operations ipgen_model.h states."""
    dof = len(x) // 2

    def rate(state: list[float]) -> list[float]:
        qdd = vector(np.zeros(dof))
        q, qd = vector(state[:dof]), vector(state[dof:])
        assert model.forward_dynamics(q, qd, vector([u]), ctypes.byref(p), qdd) == 0
        return state[dof:] + list(qdd)

    half, sixth = 0.5 * h, h / 6.0
    k1 = rate(x)
    k2 = rate([a + half * b for a, b in zip(x, k1, strict=True)])
    k3 = rate([a + half * b for a, b in zip(x, k2, strict=True)])
    k4 = rate([a + h * b for a, b in zip(x, k3, strict=True)])
    return [a + sixth * (b + 2.0 * c + 2.0 * d + e) for a, b, c, d, e in zip(x, k1, k2, k3, k4, strict=True)]


SCENE = """\
[system]
type = "{kind}"
links = {links}
[parameters]
m = {m}
l = {l}
delta = {delta}
[initial]
theta = {theta}
[outputs]
energy = true
[simulation]
t_end = 2
"""


def launcher_parts(summary: str) -> tuple[Path, Path]:
    """(the compiled simulator, the model library) the summary's launcher runs."""
    words = shlex.split(simulator_of(summary).read_text().splitlines()[1])
    assert words[0] == "exec" and words[2] == "--model"
    return Path(words[1]), Path(words[3])


def test_two_models_run_on_one_compiled_simulator(tmp_path: Path) -> None:
    """A cart double pendulum and a rotary single pendulum: one compiled program, two model
    libraries; run directly with --model, each conserves energy without damping (the summary's
    work-energy balance) and writes its own number of columns."""
    require_toolchain()
    cart = {"m": [1, 0.3, 0.2], "l": [0, 0.5, 0.4], "delta": [0, 0, 0], "theta": [0, 0.3, -0.2]}
    arm = {"m": [0.5, 0.2], "l": [0.3, 0.4], "delta": [0, 0], "theta": [0, 0.5]}
    scenes = {
        "cart2": SCENE.format(kind="classical", links=2, **cart),
        "arm1": SCENE.format(kind="rotary", links=1, **arm),
    }
    parts = {}
    for stem, text in scenes.items():
        path = tmp_path / f"{stem}.toml"
        path.write_text(text)
        with redirect_stdout(io.StringIO()), redirect_stderr(io.StringIO()) as err:
            assert run(["run", str(path), "-o", str(tmp_path / "out"), "--no-plot"]) == 0, err.getvalue()
        parts[stem] = launcher_parts((tmp_path / "out" / f"{stem}.txt").read_text())
    (program, cart), (same, arm) = parts["cart2"], parts["arm1"]
    external = simulator.external_program()  # make test's CMake-built simulator (Makefile), else the cache's
    assert program == same and cart != arm
    assert program == external.path if external is not None else program.is_relative_to(cache_root())
    for stem, library, columns in (("cart2", cart, 7), ("arm1", arm, 5)):
        csv = tmp_path / f"{stem}_direct.csv"
        cfg = tmp_path / "out" / f"{stem}.cfg"
        done = subprocess.run([str(program), str(cfg), "--model", str(library), "--csv", str(csv)],
                              capture_output=True, text=True)  # fmt: skip
        assert done.returncode == 0, done.stderr
        balance = float(re.search(r"balance error (\S+) J", done.stdout).group(1))
        assert abs(balance) < 1e-6, done.stdout
        header = csv.read_text().splitlines()[0].split(",")
        assert header[:columns] == ["t", *[f"theta{i}" for i in range((columns - 1) // 2)],
                                    *[f"dtheta{i}" for i in range((columns - 1) // 2)]]  # fmt: skip
    # A bare file name is the current folder's, as the docs write it (dlopen alone would search the
    # system's library path for it, and not find it here)
    cfg, csv = tmp_path / "out" / "arm1.cfg", tmp_path / "bare.csv"
    bare = [str(program), str(cfg), "--model", arm.name, "--csv", str(csv)]
    done = subprocess.run(bare, cwd=arm.parent, capture_output=True, text=True)
    assert done.returncode == 0, done.stderr


def library_of_another_abi(folder: Path) -> Path:
    """A model library of ABI 99 (this ipgen reads 4), compiled into `folder`."""
    _, include = simulator_sources()
    source, library = folder / "abi.c", folder / "libabi.so"
    source.write_text(
        '#include "ipgen_model.h"\n'
        'static const ipgen_model model = {99, "x", "rotary", "pivot", 1, 2, 1, 1};\n'
        "const ipgen_model *ipgen_model_get(void) { return &model; }\n"
    )
    subprocess.run([c_compiler(), "-shared", "-fPIC", f"-I{include}", str(source), "-o", str(library)],
                   check=True)  # fmt: skip
    return library


def test_a_bad_model_library_is_refused_in_one_line(tmp_path: Path) -> None:
    """No such file, a shared object that is no model library, a library of another ABI, and
    none at all: exit status 2, one line naming the problem, no CSV."""
    require_toolchain()
    scene = tmp_path / "s.toml"
    arm = {"m": [0.5, 0.2], "l": [0.3, 0.4], "delta": [0, 0], "theta": [0, 0.1]}
    scene.write_text(SCENE.format(kind="rotary", links=1, **arm))
    with redirect_stdout(io.StringIO()), redirect_stderr(io.StringIO()):
        assert run(["run", str(scene), "-o", str(tmp_path / "out"), "--no-plot"]) == 0
    program, _ = launcher_parts((tmp_path / "out" / "s.txt").read_text())
    abi_library = library_of_another_abi(tmp_path)
    not_a_model = next(path for path in LIBM if path.exists())
    cases = {
        str(tmp_path / "missing.so"): "cannot load the model library",
        str(not_a_model): "exports no ipgen_model_get (not an ipgen model library)",
        str(abi_library): "built for model ABI 99, this simulator reads 4",
    }
    cfg = tmp_path / "out" / "s.cfg"
    for library, message in cases.items():
        csv = tmp_path / "no.csv"
        done = subprocess.run([str(program), str(cfg), "--model", library, "--csv", str(csv)],
                              capture_output=True, text=True)  # fmt: skip
        assert done.returncode == 2 and done.stderr.count("\n") == 1, done.stderr
        assert done.stderr.startswith("simulate: error: ") and message in done.stderr
        assert not csv.exists()
    done = subprocess.run([str(program), str(cfg)], capture_output=True, text=True)
    assert done.returncode == 2 and "no model is linked into this simulator: pass --model LIB" in done.stderr


def test_the_capacity_is_stated_once_and_a_longer_chain_is_refused_in_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """limits.MAX_SIMULATED_LINKS is the interface's IPGEN_MAX_DOF - 1, and `ipgen run` refuses a
    longer chain before building anything, naming the way to simulate it."""
    _, include = simulator_sources()
    found = re.search(r"#define IPGEN_MAX_DOF (\d+)", (include / "ipgen_model.h").read_text())
    assert found and int(found.group(1)) - 1 == MAX_SIMULATED_LINKS == MAX_DOF - 1
    links = MAX_SIMULATED_LINKS + 1
    scene = tmp_path / "long.toml"
    scene.write_text(
        f'[system]\ntype = "classical"\nlinks = {links}\n[parameters]\nm = {[1.0] * (links + 1)}\n'
        f"l = {[0.0] + [0.1] * links}\ndelta = {[0.0] * (links + 1)}\n[simulation]\nt_end = 1\n"
    )
    capsys.readouterr()
    cache = tmp_path / "cache"
    assert run(["run", str(scene), "-o", str(tmp_path / "out"), "--cache-dir", str(cache), "--force"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"up to {MAX_SIMULATED_LINKS} links, this scene has {links}" in err
    assert "ipgen_add_simulator" in err and not cache.exists()


def test_the_library_rk4_step_gives_the_simulators_own_steps(tmp_path: Path) -> None:
    """Method rk4 runs on the model library's rk4_step when the right-hand side is the model's
    alone (no energy ledger) and on ipsim's own step otherwise (with the ledger): the angles and
    rates are the same to the bit, through a pulse on the arm."""
    require_toolchain()
    columns = {}
    arm = {"m": [0.5, 0.2, 0.1], "l": [0.3, 0.4, 0.3], "delta": [0.01, 0.001, 0.001], "theta": [0, 0.5, -0.3]}
    for energy in ("true", "false"):
        scene = tmp_path / f"rk4_{energy}.toml"
        text = SCENE.format(kind="rotary", links=2, **arm).replace("energy = true", f"energy = {energy}")
        pulse = '[input]\nkind = "pulse"\namplitude = 0.2\nduration = 0.5\n'
        scene.write_text(text + 'method = "rk4"\nstep = 0.002\n' + pulse)
        with redirect_stdout(io.StringIO()), redirect_stderr(io.StringIO()) as err:
            assert run(["run", str(scene), "-o", str(tmp_path / "out"), "--no-plot"]) == 0, err.getvalue()
        rows = (tmp_path / "out" / f"rk4_{energy}.csv").read_text().splitlines()
        columns[energy] = [",".join(row.split(",")[:7]) for row in rows]
    assert len(columns["true"]) > 100 and columns["true"] == columns["false"]


def test_a_failing_library_step_is_diagnosed_as_ipsims_own(tmp_path: Path) -> None:
    """A stiff cart (a light link, joint damping 1e4 N m s: a decaying mode near -1e8 1/s) with
    method rk4 and no energy ledger: the library's rk4_step runs until a derivative is not
    finite, then ipsim redoes that step itself and stops with RK4_RHSFUNC_FAIL, the likely cause
    and "stiff: use BDF", writing no CSV (as the simulator compiled for the model does: ctest
    ipsim.cli.stiff_rk4)."""
    require_toolchain()
    scene = tmp_path / "stiff.toml"
    scene.write_text(
        '[system]\ntype = "classical"\nlinks = 1\n[parameters]\nm = [0.3, 0.001]\nl = [0, 0.5]\n'
        'delta = [0.3, 10000]\n[initial]\ntheta = [0, 0.2]\n[input]\nkind = "pulse"\namplitude = 0.4\n'
        'duration = 0.5\n[simulation]\nt_end = 1\nmethod = "rk4"\nstep = 0.001\n'
    )
    with redirect_stdout(io.StringIO()), redirect_stderr(io.StringIO()) as err:
        status = run(["run", str(scene), "-o", str(tmp_path / "out"), "--no-plot"])
    message = err.getvalue()
    assert status == 1, message
    assert all(part in message for part in ("RK4_RHSFUNC_FAIL", "likely cause", "stiff: use BDF")), message
    assert not (tmp_path / "out" / "stiff.csv").exists()


def test_the_mpc_refuses_a_model_library_of_another_abi(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """ipgen.mpc reads the model library's description by the layout of its ABI: a library of
    another ABI is refused in one line (it stepped with whatever the fields then held), and the
    ABI it reads is ipgen_model.h's."""
    import ipgen
    from ipgen.control import mpc as mpc_module

    _, include = simulator_sources()
    header = (Path(include) / "ipgen_model.h").read_text()
    assert re.search(r"#define IPGEN_MODEL_ABI (\d+)", header).group(1) == str(mpc_module.MODEL_ABI)
    loaded = ctypes.CDLL(str(library_of_another_abi(tmp_path)))
    loaded.ipgen_model_get.restype = ctypes.c_void_p
    monkeypatch.setattr(mpc_module, "model_library", lambda pendulum: loaded)
    with pytest.raises(mpc_module.MpcError, match=r"built for model ABI 99, this ipgen reads 4"):
        ipgen.mpc(ipgen.Pendulum.preset("qube_servo2"), u_max=10.0)


def test_a_model_library_refuses_to_compile_in_float(tmp_path: Path) -> None:
    """The model interface passes doubles: a model library (a cart's or arm's, a fixed chain's)
    compiled with -DIPGEN_SCALAR=float stops at compile time, naming why (it compiled with
    warnings, passed ipsim's check and failed at run time as a near-singular mass matrix)."""
    from ipgen.codegen.fixed_header import fixed_library_sources

    _, include = simulator_sources()
    with redirect_stdout(io.StringIO()):
        assert run(["--type", "rotary", "--links", "1", "--emit", "library", "-o", str(tmp_path / "a")]) == 0
    name, texts = fixed_library_sources(2, (2,))
    for file_name, text in texts.items():
        (tmp_path / file_name).write_text(text)
    for source in (tmp_path / "a" / "rotary1_model.c", tmp_path / f"{name}_model.c"):
        for scalar, fails in (("double", False), ("float", True)):
            done = subprocess.run(
                [c_compiler(), "-std=c99", "-fsyntax-only", f"-DIPGEN_SCALAR={scalar}", f"-I{include}",
                 f"-I{source.parent}", str(source)], capture_output=True, text=True,
            )  # fmt: skip
            assert (done.returncode != 0) == fails, done.stderr
            assert ("library_needs_a_double_scalar" in done.stderr) == fails


@pytest.mark.parametrize("edit", ["actuator = direct", "actuator = acceleration", None])
def test_a_motor_gain_without_a_motor_is_refused(tmp_path: Path, edit: str | None) -> None:
    """A .cfg with actuator.gain but a direct drive (or no actuator line: direct): one line naming
    the key (the simulator ran, u taken as a torque and the gain ignored)."""
    require_toolchain()
    text = (Path(__file__).resolve().parents[1] / "scenes" / "rigs" / "qube_servo2.toml").read_text()
    scene = tmp_path / "qube.toml"
    scene.write_text(re.sub(r"(?m)^t_end = .*$", "t_end = 0.05", text, count=1))
    with redirect_stdout(io.StringIO()), redirect_stderr(io.StringIO()) as err:
        assert run(["run", str(scene), "-o", str(tmp_path / "out"), "--no-plot"]) == 0, err.getvalue()
    program, library = launcher_parts((tmp_path / "out" / "qube.txt").read_text())
    cfg = (tmp_path / "out" / "qube.cfg").read_text()
    assert "\nactuator = dc_motor\n" in cfg and "\nactuator.gain = " in cfg
    edited = tmp_path / "edited.cfg"
    edited.write_text(cfg.replace("\nactuator = dc_motor\n", f"\n{edit}\n" if edit else "\n"))
    done = subprocess.run(
        [str(program), str(edited), "--model", str(library), "--csv", str(tmp_path / "edited.csv")],
        capture_output=True, text=True,
    )  # fmt: skip
    assert done.returncode == 2, done.stderr
    assert "actuator.gain applies to actuator = dc_motor only" in done.stderr, done.stderr


def _arm_run(tmp_path: Path) -> tuple[Path, Path, Path]:
    """(the compiled simulator, the model library, the .cfg) of a rotary single pendulum's `ipgen
    run` in tmp_path/out, to run the simulator directly."""
    scene = tmp_path / "arm.toml"
    arm = {"m": [0.5, 0.2], "l": [0.3, 0.4], "delta": [0, 0], "theta": [0, 0.5]}
    scene.write_text(SCENE.format(kind="rotary", links=1, **arm))
    with redirect_stdout(io.StringIO()), redirect_stderr(io.StringIO()) as err:
        assert run(["run", str(scene), "-o", str(tmp_path / "out"), "--no-plot"]) == 0, err.getvalue()
    program, library = launcher_parts((tmp_path / "out" / "arm.txt").read_text())
    return program, library, tmp_path / "out" / "arm.cfg"


def test_a_csv_path_that_is_not_a_regular_file_is_refused(tmp_path: Path) -> None:
    """--csv naming a FIFO: one line, exit 2, the FIFO left as it was (without --force the
    simulator blocked reading it; with --force its rename replaced it, as it would /dev/null)."""
    import os
    import stat

    require_toolchain()
    program, library, cfg = _arm_run(tmp_path)
    fifo = tmp_path / "pipe.csv"
    os.mkfifo(fifo)
    command = [str(program), str(cfg), "--model", str(library), "--csv", str(fifo)]
    for force in ([], ["--force"]):
        done = subprocess.run([*command, *force], capture_output=True, text=True, timeout=60)
        assert done.returncode == 2 and "is not a regular file: name a file" in done.stderr, done.stderr
        assert stat.S_ISFIFO(fifo.stat().st_mode)


def test_the_simulator_reports_its_progress_and_ipgen_run_announces_it(tmp_path: Path) -> None:
    """--progress S: lines `progress T T_END` on stderr, T rising to t_end (S tiny: every sample);
    a bad S is one line, exit 2. `ipgen run` hands each to its announcement and keeps the other
    stderr lines as they were (a 48 s run said nothing until it ended)."""
    require_toolchain()
    from ipgen.pipeline.run import _simulate

    program, library, cfg = _arm_run(tmp_path)
    base = [str(program), str(cfg), "--model", str(library), "--csv", str(tmp_path / "p.csv")]
    done = subprocess.run([*base, "--progress", "1e-9"], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    lines = [line for line in done.stderr.splitlines() if line.startswith("progress ")]
    reported = [tuple(map(float, line.split()[1:])) for line in lines]
    assert len(reported) > 10 and all(end == 2.0 for _, end in reported)
    times = [t for t, _ in reported]
    assert times == sorted(times) and times[-1] <= 2.0
    for bad in ("0", "-1", "inf", "x"):
        refused = subprocess.run([*base, "--progress", bad], capture_output=True, text=True)
        assert refused.returncode == 2 and "--progress" in refused.stderr, refused.stderr
    seen: list[tuple[float, float]] = []
    script = "import sys; print('progress 1 4', file=sys.stderr); print('a warning', file=sys.stderr)"
    script += "; print('out')"
    result = _simulate([sys.executable, "-c", script], lambda t, end: seen.append((t, end)))
    assert seen == [(1.0, 4.0)] and result.stderr == "a warning\n" and result.stdout == "out\n"
