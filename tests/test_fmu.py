"""`--emit fmu` (FMI 2.0) and `--emit fmu3` (FMI 3.0): the FMUs, checked with FMPy.

Every model (classical and rotary, n = 1, 2, 3) is written once per FMI version (module-scoped
fixtures) and checked against things computed without the FMU: FMPy's validation; the C
header's forward_dynamics and forward_dynamics_derivatives (`--emit c`, compiled into
tests/c/eval_model.c); the energies' gradients differentiated by sympy; central differences;
the simulator's golden runs of the paper's scenes (tests/data/*.golden.csv).
"""

from __future__ import annotations

import shutil
import subprocess
import zipfile
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from c_models import c_command, compile_c, require_cc, run_c
from fmu_models import Loaded

from ipgen.codegen.fmu import FmuError, build_command
from ipgen.model.derivation import derive
from ipgen.model.system import System
from ipgen.pipeline.generate import generate
from ipgen.pipeline.job import plan, run

fmpy = pytest.importorskip("fmpy")

ROOT = Path(__file__).resolve().parents[1]
DRIVER = ROOT / "tests" / "c" / "eval_model.c"
# classical and rotary n = 1, 2, 3, and the rotary "full" link inertia once
SYSTEMS = [
    *(System(kind, n) for kind in ("classical", "rotary") for n in (1, 2, 3)),  # type: ignore[arg-type]
    System("rotary", 2, "full"),
]
VERSIONS = {"fmu": 2, "fmu3": 3}
RNG_SEED = 20260124


def _id(system: System) -> str:
    full = "_full" if system.inertia == "full" else ""
    return f"{system.type}{system.links}{full}"


class Built:
    """One model: its FMU per FMI version, its unzipped folders and the C header's driver."""

    def __init__(self, system: System, folder: Path) -> None:
        self.system = system
        self.name = _id(system)
        self.folder = folder
        self.fmus: dict[int, Path] = {}
        self.unzipped: dict[int, str] = {}
        for target, version in VERSIONS.items():
            out = folder / target
            generate(system, self.name, out, emit=(target,))
            self.fmus[version] = out / f"{self.name}.fmu"
            self.unzipped[version] = fmpy.extract(str(self.fmus[version]), str(folder / f"unzipped{version}"))
        generate(system, self.name, folder / "c", emit=("c",))
        self.driver = folder / f"{self.name}_eval"
        error = compile_c(
            c_command(
                f"-I{folder / 'c'}",
                f'-DIPGEN_C_HEADER="{self.name}.h"',
                f"-DIPGEN_C_NAME={self.name}",
                f"-DIPGEN_C_NAMEU={self.name.upper()}",
                str(DRIVER),
                "-o",
                str(self.driver),
            )
        )
        assert error is None, error

    def load(self, version: int, instance: str = "test") -> Loaded:
        return Loaded(self.fmus[version], self.unzipped[version], instance)


class Models(dict[str, Built]):
    """The models built so far, each built on first use (a pytest-xdist worker builds only the
    models its tests use)."""

    def __init__(self, root: Path) -> None:
        super().__init__()
        self.root = root

    def __missing__(self, key: str) -> Built:
        system = next(s for s in SYSTEMS if _id(s) == key)
        self[key] = Built(system, self.root / key)
        return self[key]


@pytest.fixture(scope="module")
def built(tmp_path_factory: pytest.TempPathFactory) -> Models:
    require_cc()
    return Models(tmp_path_factory.mktemp("fmu"))


def _random_case(
    system: System, rng: np.random.Generator
) -> tuple[dict[str, float], np.ndarray, np.ndarray, float]:
    dof = system.dof
    params: dict[str, float] = {}
    for i in range(dof):
        params[f"m{i}"] = float(rng.uniform(0.1, 1.0))
        if not (i == 0 and system.type == "classical"):
            params[f"l{i}"] = float(rng.uniform(0.2, 1.0))
        params[f"delta{i}"] = float(rng.uniform(0.0, 0.5))
    params["g"] = float(rng.uniform(9.0, 10.0))
    q = rng.uniform(-np.pi, np.pi, dof)
    qd = rng.uniform(-2.0, 2.0, dof)
    return params, q, qd, float(rng.uniform(-1.0, 1.0))


def _with_rod_links(system: System, params: dict[str, float], names: dict[str, int]) -> dict[str, float]:
    """`params` plus the links-as-built parameters (com, J, J_axial, tip) at the homogeneous
    rods of `params` (the model the C header's plain functions compute), those the FMU has:
    a rotary arm given by its inertia J0 has no mass m0."""
    full = dict(params)
    for i in range(system.dof):
        m, length = params[f"m{i}"], params.get(f"l{i}", 0.0)
        rods = {
            f"com{i}": length / 2,
            f"J{i}": m * length**2 / (3 if i == 0 else 12),
            f"J_axial{i}": 0.0,
            f"tip{i}": 0.0,
        }
        full.update(rods)
    return {name: value for name, value in full.items() if name in names}


def _c_reference(model: Built, params: dict[str, float], q: np.ndarray, qd: np.ndarray, u: float) -> dict:
    dof = model.system.dof
    m = np.array([params[f"m{i}"] for i in range(dof)])
    lengths = np.array([params.get(f"l{i}", 0.0) for i in range(dof)])
    delta = np.array([params[f"delta{i}"] for i in range(dof)])
    return run_c(model.driver, (m, lengths, delta, params["g"]), [(q, qd, u)])[0]


STATES = ("theta", "dtheta")


def _names(dof: int) -> tuple[list[str], list[str], list[str]]:
    states = [f"{s}{i}" for s in STATES for i in range(dof)]
    unknowns = [f"ddtheta{i}" for i in range(dof)] + [f"theta{i}" for i in range(dof)]
    unknowns += ["kinetic_energy", "potential_energy", "energy", "damping_power"]
    return states, [*states, "u"], unknowns


@pytest.mark.parametrize("version", [2, 3])
@pytest.mark.parametrize("system", SYSTEMS, ids=_id)
def test_fmpy_validation_finds_no_problem(built: Models, system: System, version: int) -> None:
    from fmpy.validation import validate_fmu

    assert validate_fmu(str(built[_id(system)].fmus[version])) == []


@pytest.mark.parametrize("version", [2, 3])
@pytest.mark.parametrize("system", SYSTEMS, ids=_id)
def test_derivatives_equal_the_c_header(built: Models, system: System, version: int) -> None:
    """GetDerivatives = [θ̇; forward_dynamics] of the C header to 1e-13 (relative), and the
    energy outputs its T, V, D."""
    model = built[_id(system)]
    fmu = model.load(version)
    rng = np.random.default_rng(RNG_SEED + system.links)
    try:
        for _ in range(5):
            params, q, qd, u = _random_case(system, rng)
            fmu.set(_with_rod_links(system, params, fmu.vr))
            fmu.set_state(q, qd, u)
            ref = _c_reference(model, params, q, qd, u)
            got = fmu.derivatives()
            np.testing.assert_allclose(got[: system.dof], qd, rtol=0, atol=0)
            np.testing.assert_allclose(
                got[system.dof :], ref["qdd"], rtol=1e-13, atol=1e-13 * np.abs(ref["qdd"]).max()
            )
            energies = fmu.get(["kinetic_energy", "potential_energy", "energy", "damping_power"])
            expected = [ref["T"][0], ref["V"][0], ref["T"][0] + ref["V"][0], 2 * ref["D"][0]]
            np.testing.assert_allclose(energies, expected, rtol=1e-13, atol=1e-13)
    finally:
        fmu.close()


def _energy_gradients(system: System) -> tuple[Callable[..., object], list[str]]:
    """d(T, V, E, 2D)/d(q, qd) by sympy from the equations' expressions (not the FMU's path),
    as a function of q, qd and the parameters they contain (named like the FMU's)."""
    import sympy as sp

    eqs = derive(system)
    s = eqs.symbols
    x = [*s.q, *s.qd]
    T, V, D = eqs.kinetic_energy, eqs.potential_energy, eqs.dissipation
    rows = [[sp.diff(f, v) for v in x] for f in (T, V, T + V, 2 * D)]
    parameters = sorted((T + V + D).free_symbols - set(x), key=str)
    return sp.lambdify((s.q, s.qd, parameters), rows, "numpy"), [str(p) for p in parameters]


@pytest.mark.parametrize("version", [2, 3])
@pytest.mark.parametrize("system", SYSTEMS, ids=_id)
def test_directional_derivatives_are_exact(built: Models, system: System, version: int) -> None:
    """Every directional (and in FMI 3.0 adjoint) derivative equals the exact Jacobian to 1e-12
    and central differences of the FMU's own outputs to 1e-6; undeclared dependencies are 0."""
    model = built[_id(system)]
    dof = system.dof
    fmu = model.load(version)
    gradients, parameter_names = _energy_gradients(system)
    _, knowns, unknowns = _names(dof)
    rng = np.random.default_rng(RNG_SEED + 10 * system.links)
    try:
        params, q, qd, u = _random_case(system, rng)
        fmu.set(_with_rod_links(system, params, fmu.vr))
        fmu.set_state(q, qd, u)
        ref = _c_reference(model, params, q, qd, u)
        values = [fmu.get([n])[0] for n in parameter_names]  # every parameter as the FMU has it
        energy = np.array(gradients(q, qd, values), dtype=float)
        exact = np.zeros((len(unknowns), len(knowns)))
        exact[:dof, :dof] = ref["dqdd_dq"].reshape(dof, dof)
        exact[:dof, dof : 2 * dof] = ref["dqdd_dqd"].reshape(dof, dof)
        exact[:dof, 2 * dof] = ref["dqdd_du"]
        exact[dof : 2 * dof, :dof] = np.eye(dof)
        exact[2 * dof :, : 2 * dof] = energy
        jacobian = np.column_stack(
            [fmu.directional(unknowns, knowns, np.eye(len(knowns))[j]) for j in range(len(knowns))]
        )
        scale = np.abs(exact).max()
        np.testing.assert_allclose(jacobian, exact, rtol=1e-12, atol=1e-12 * scale)
        # a whole seed at once, and the adjoint (FMI 3.0)
        seed = rng.normal(size=len(knowns))
        np.testing.assert_allclose(
            fmu.directional(unknowns, knowns, seed), exact @ seed, rtol=1e-12, atol=1e-12 * scale
        )
        if version == 3:
            back = rng.normal(size=len(unknowns))
            np.testing.assert_allclose(
                fmu.adjoint(unknowns, knowns, back), exact.T @ back, rtol=1e-12, atol=1e-12 * scale
            )
        # central differences of the FMU's values
        base = {
            **{f"theta{i}": q[i] for i in range(dof)},
            **{f"dtheta{i}": qd[i] for i in range(dof)},
            "u": u,
        }
        differences = np.zeros_like(exact)
        h = 1e-5
        for j, name in enumerate(knowns):
            values = []
            for sign in (1, -1):
                fmu.set({**base, name: base[name] + sign * h})
                values.append(fmu.get(unknowns))
            differences[:, j] = (values[0] - values[1]) / (2 * h)
        fmu.set(base)
        np.testing.assert_allclose(jacobian, differences, rtol=1e-6, atol=1e-6 * scale)
        # the model structure's dependencies: every undeclared one is exactly zero, every
        # declared one non-zero at this generic point
        _check_dependencies(fmu, jacobian, unknowns, knowns)
    finally:
        fmu.close()


def _check_dependencies(fmu: Loaded, jacobian: np.ndarray, unknowns: list[str], knowns: list[str]) -> None:
    description = fmu.description
    by_vr = {v.valueReference: v.name for v in description.modelVariables}
    declared: dict[str, set[str]] = {}
    for unknown in [*description.outputs, *description.derivatives]:
        name = unknown.variable.name
        deps = (
            {d.name for d in unknown.dependencies}
            if unknown.dependencies is not None
            else set(by_vr.values())
        )
        declared.setdefault(name, set()).update(deps)
    checked = 0
    for i, name in enumerate(unknowns):
        if name not in declared:
            continue
        for j, known in enumerate(knowns):
            if known in declared[name]:
                assert jacobian[i, j] != 0, f"{name} is declared to depend on {known} but does not here"
            else:
                assert jacobian[i, j] == 0, f"{name} depends on {known}, which is not declared"
            checked += 1
    assert checked >= len(knowns) * (len(unknowns) - fmu.dof)


def _scene_fmu(scene: str, target: str, folder: Path) -> Path:
    written = run(plan(folder, scene=ROOT / "scenes" / scene, emit=target))
    return written[0].path


# Tolerances of the FMU simulated by FMPy (CVODE, rtol 1e-10) against the simulator's golden
# runs; measured (docs/fmu.md): below 2e-8 for both scenes.
AGREEMENT = 1e-6


@pytest.mark.parametrize("target", list(VERSIONS))
@pytest.mark.parametrize("scene", ["cdip_pulse", "rsip_pulse"])
def test_fmu_agrees_with_the_simulator(tmp_path: Path, scene: str, target: str) -> None:
    require_cc()
    path = _scene_fmu(f"{scene}.toml", target, tmp_path)
    golden = np.genfromtxt(ROOT / "tests" / "data" / f"{scene}.golden.csv", delimiter=",", names=True)
    pulse = np.array([(0.0, 0.4), (1.0, 0.4), (1.0, 0.0), (10.0, 0.0)], dtype=[("time", float), ("u", float)])
    result = fmpy.simulate_fmu(
        str(path), solver="CVode", relative_tolerance=1e-10, stop_time=10.0, output_interval=0.01, input=pulse
    )
    for name in golden.dtype.names[1:]:
        if not name.startswith("theta"):
            continue
        expected = np.interp(result["time"], golden["t"], golden[name])
        assert np.max(np.abs(result[name] - expected)) < AGREEMENT, name


def test_two_instances_are_independent_and_reset_restores_the_start(built: Models) -> None:
    model = built["classical2"]
    for version in (2, 3):
        a, b = model.load(version, "a"), model.load(version, "b")
        try:
            start = a.get(["m1"])[0]
            q, qd = np.array([0.1, 0.2, -0.3]), np.array([0.0, 0.5, -0.5])
            for fmu in (a, b):
                fmu.set_state(q, qd, 0.2)
            before = a.derivatives()
            b.set({"m1": 2 * start, "g": 3.0})
            assert np.array_equal(a.derivatives(), before)
            assert not np.allclose(b.derivatives(), before)
            assert a.get(["m1"])[0] == start
            b.reset()
            assert b.get(["m1", "g", "theta1"]).tolist() == [start, 9.81, 0.0]
            b.set_state(q, qd, 0.2)
            assert np.array_equal(b.derivatives(), before)
        finally:
            a.close()
            b.close()


@pytest.mark.parametrize("version", [2, 3])
def test_bad_calls_return_an_error_and_log_why(built: Models, version: int) -> None:
    from fmpy.fmi1 import FMICallException

    model = built["rotary1"]
    fmu = model.load(version)
    try:
        for name, value, expected in (
            ("m1", -1.0, "m1 = -1 is invalid: it must be > 0"),
            ("l0", 0.0, "l0 = 0 is invalid: it must be > 0"),
            ("delta1", float("nan"), "delta1 = nan is invalid"),
            ("kinetic_energy", 1.0, "cannot be set"),
        ):
            with pytest.raises(FMICallException):
                fmu.set({name: value})
            assert expected in fmu.messages[-1], fmu.messages
        with pytest.raises(FMICallException):
            fmu.directional(["ddtheta0"], ["m1"], [1.0])
        assert "a known must be a state" in fmu.messages[-1]
        assert fmu.get(["m1"])[0] == 0.275  # unchanged by the refused calls
    finally:
        fmu.close()
    with pytest.raises(Exception, match="nstantiate"):
        Loaded(model.fmus[version], model.unzipped[version], guid="{00000000-0000-0000-0000-000000000000}")


@pytest.mark.parametrize("version", [2, 3])
def test_rebuilding_from_the_shipped_sources_gives_identical_results(
    built: Models, tmp_path: Path, version: int
) -> None:
    model = built["rotary2"]
    with zipfile.ZipFile(model.fmus[version]) as archive:
        archive.extractall(tmp_path / "fmu")
    sources = tmp_path / "fmu" / "sources"
    binary = next((tmp_path / "fmu" / "binaries").glob("*/rotary2.so"))
    binary.unlink()
    cc = shutil.which("cc") or shutil.which("gcc")
    assert cc is not None
    # with -Werror, which the user's build leaves out: the shipped sources compile without a warning
    subprocess.run([*build_command(cc, "rotary2_fmu.c", str(binary)), "-Werror"], cwd=sources, check=True)
    if version == 3:  # the build description, valid by FMPy's copy of the FMI 3.0 schema
        from fmpy.model_description import read_build_description

        (configuration,) = read_build_description(str(model.fmus[version]), validate=True)
        assert [f for s in configuration.sourceFileSets for f in s.sourceFiles] == ["rotary2_fmu.c"]
    rebuilt = Loaded(model.fmus[version], str(tmp_path / "fmu"))
    original = model.load(version)
    try:
        rng = np.random.default_rng(RNG_SEED)
        for _ in range(3):
            params, q, qd, u = _random_case(model.system, rng)
            for fmu in (rebuilt, original):
                fmu.set(_with_rod_links(model.system, params, fmu.vr))
                fmu.set_state(q, qd, u)
            assert np.array_equal(rebuilt.derivatives(), original.derivatives())
            names = ["ddtheta1", "energy"]
            assert np.array_equal(
                rebuilt.directional(names, ["theta1", "u"], [1.0, 0.5]),
                original.directional(names, ["theta1", "u"], [1.0, 0.5]),
            )
    finally:
        rebuilt.close()
        original.close()


def test_the_fmu_carries_the_c_header_and_the_licence(built: Models) -> None:
    model = built["classical1"]
    c_header = (model.folder / "c" / "classical1.h").read_text()
    for version, platform in ((2, "linux64"), (3, "x86_64-linux")):
        with zipfile.ZipFile(model.fmus[version]) as archive:
            names = set(archive.namelist())
            shipped = archive.read("sources/classical1.h").decode()
            licence = archive.read("documentation/licenses/fmi-standard-LICENSE.txt").decode()
        assert f"binaries/{platform}/classical1.so" in names
        assert f"sources/fmi{version}Functions.h" in names
        assert "BSD 2-Clause" in licence
        # the same header as --emit c, but for the command line in its comment
        differing = [a for a, b in zip(shipped.splitlines(), c_header.splitlines(), strict=True) if a != b]
        assert len(differing) == 1 and "ipgen --type classical" in differing[0]


def test_writing_is_all_or_nothing_without_a_compiler(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("CC", "no-such-compiler-ipgen")
    with pytest.raises(FmuError, match="no C compiler"):
        run(plan(tmp_path / "out", system_type="classical", links=1, emit="cpp,fmu"))
    assert not (tmp_path / "out").exists()


def test_an_fmu_ipgen_did_not_write_is_kept_without_force(tmp_path: Path) -> None:
    from ipgen.common.files import OutputError

    require_cc()
    foreign = tmp_path / "rotary1.fmu"
    with zipfile.ZipFile(foreign, "w") as archive:
        archive.writestr("modelDescription.xml", "<fmiModelDescription/>")
    before = foreign.read_bytes()
    with pytest.raises(OutputError, match="not written by ipgen"):
        run(plan(tmp_path, system_type="rotary", links=1, emit="fmu"))
    assert foreign.read_bytes() == before
    assert [w.status for w in run(plan(tmp_path, system_type="rotary", links=1, emit="fmu", force=True))] == [
        "replaced"
    ]
    assert [w.status for w in run(plan(tmp_path, system_type="rotary", links=1, emit="fmu3"))] == ["replaced"]


def test_rewriting_the_same_fmu_leaves_it_unchanged(tmp_path: Path) -> None:
    require_cc()
    first = run(plan(tmp_path, system_type="rotary", links=1, emit="fmu"))
    second = run(plan(tmp_path, system_type="rotary", links=1, emit="fmu"))
    assert [w.status for w in first] == ["created"] and [w.status for w in second] == ["unchanged"]


def test_a_scene_emits_its_fmu_with_its_values_as_start_values(tmp_path: Path) -> None:
    """`emit = ["fmu3"]` in a scene; its parameters, links as built and initial state are the start
    values (the links as built were the rods' before: another pendulum than the scene's)."""
    from fmpy import read_model_description

    require_cc()
    text = (ROOT / "scenes" / "rsip_pulse.toml").read_text()
    text = text.replace('inertia = "pivot"', 'inertia = "pivot"\nemit = ["fmu3"]')
    text = text.replace("m = [0.5, 0.275]", "m = [0.45, 0.3]\ncom = [0, 0.13]\ntip = [0, 0.01]").replace(
        "[input]", "[initial]\ntheta = [0, 0.1]\n\n[input]"
    )
    scene = tmp_path / "mine.toml"
    scene.write_text(text)
    (written, _) = run(plan(tmp_path / "out", scene=scene))
    description = read_model_description(str(written.path))
    assert description.fmiVersion == "3.0"
    start = {v.name: float(v.start) for v in description.modelVariables if v.start is not None}
    assert (start["m1"], start["theta1"], start["l0"], start["delta1"]) == (0.3, 0.1, 0.6, 0.011458)
    assert (start["com1"], start["tip1"]) == (0.13, 0.01)
    # the arm: its mass, or (links as built) its inertia, the rod's of the scene's m0 and l0
    assert start.get("m0", 0.45) == 0.45 and start.get("J0", 0.45 * 0.36 / 3) == pytest.approx(
        0.45 * 0.36 / 3
    )
    fmu = Loaded(written.path, fmpy.extract(str(written.path), str(tmp_path / "unzipped")))
    try:
        assert fmu.get(["m1", "theta1", "dtheta1"]).tolist() == [0.3, 0.1, 0.0]
    finally:
        fmu.close()


@pytest.mark.parametrize("kind", ["classical", "rotary"])
def test_a_parameters_declared_min_is_its_rule(kind: str) -> None:
    """An FMU declares min = 0 for the parameters that must be >= 0 or > 0 (m, l, J, delta, tip)
    and none for a com, which may be negative (a counterweight: CoG beyond the pivot); a negative
    com's start value sat below its declared min 0."""
    from ipgen.codegen.fmu_variables import layout

    table = layout(derive(System(kind, 2)), {"com1": -0.1})
    parameters = {v.name: v for v in table.variables if v.kind == "parameter"}
    assert parameters["com1"].start == -0.1 and parameters["com1"].minimum is None
    for name, variable in parameters.items():
        bounded = variable.rule in ("positive", "nonnegative")
        assert (variable.minimum == "0") == bounded, name
        assert not name.startswith("com") or not bounded, name
