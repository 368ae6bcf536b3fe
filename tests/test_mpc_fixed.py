"""The MPC on a chain on a fixed pivot, one driven joint (the acrobot, the pendubot; docs/mpc.md).

- `ipgen.mpc` on a `FixedPendulum` in the converged mode against CasADi + IPOPT on the same problem
  whose model is a second derivation (model/fixed_equations' Lagrange equations through
  control/fixed_swingup's CasADi dynamics, where the MPC's model library is codegen/fixed_poly's):
  first input within 1e-6 at seeded states near upright, the acrobot and the pendubot, the torque
  bound active in some.
- A fixed scene's `[controller] kind = "mpc"` in the simulator, in DFKI's coordinates (relative
  angles, zero hanging, counterclockwise torques): its u at every sample is `ipgen.mpc`'s step fed
  the simulator's state mapped to ipgen's coordinates, with the torque's sign flipped back (the
  coordinates and the sign at the boundary), to 1e-9.
- The presets `acrobot_mpc` and `pendubot_mpc` (the plan tracked by the MPC, `swingup.tracking =
  "mpc"`): swung up and held, |u| <= 6 N m at every sample, every step's status ok.
- Bad `[controller] kind = "mpc"` and `swingup.tracking` values in a fixed scene: one line each
  (hypothesis over the keys and kinds of bad value).
- `controller.model.*` (a sweep's run keeps the MPC's nominal model): the simulator predicts with
  them; `sweeps.design_model` states the nominal config's parameters, for a loop that runs a model.
"""

from __future__ import annotations

import io
import re
import subprocess
from contextlib import redirect_stdout
from functools import cache
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from mpc_reference import IpoptReference
from test_fixed_lqr import CHAIN

import ipgen
from ipgen.command.cli import run
from ipgen.common.presets import preset_path
from ipgen.control.mpc import Mpc, MpcError
from ipgen.model.fixed import FixedPendulum
from ipgen.model.fixed_equations import angle_map
from ipgen.sweeps.design_model import model_lines

pytest.importorskip("casadi")

U_MAX = 6.0
AGREEMENT = 1e-6  # the first input, converged mode against IPOPT [N m]


@cache
def chain(name: str) -> FixedPendulum:
    """The chain of a preset (acrobot_swingup: elbow driven; pendubot_swingup: shoulder)."""
    return FixedPendulum.from_scene(preset_path(name))


def converged(name: str) -> Mpc:
    return ipgen.mpc(
        chain(name), horizon=20, period=0.02, Q=[10, 10, 0.1, 0.1], R=0.1, u_max=U_MAX, mode="converged"
    )


def canonical(c: FixedPendulum, rows: np.ndarray) -> np.ndarray:
    """States [q; q̇] in the chain's coordinates (rows) -> ipgen's [θ; θ̇] (θ = R q + z)."""
    rotation, zero = angle_map(c.coordinates, c.links)
    n = c.links
    return np.hstack([rows[:, :n] @ rotation.T + zero, rows[:, n:] @ rotation.T])


@pytest.mark.parametrize("name", ["acrobot_swingup", "pendubot_swingup"])
def test_converged_mode_equals_ipopt_on_a_second_derivation(name: str) -> None:
    controller = converged(name)
    reference = IpoptReference(controller)
    rng = np.random.default_rng(47)
    active = 0
    for _ in range(6):
        x = np.concatenate([rng.uniform(-0.25, 0.25, 2), rng.uniform(-1.0, 1.0, 2)])
        expected, inputs = reference.solve(x)
        got = controller.solve(x)
        assert controller.info is not None and controller.info.status == "ok"
        assert abs(got - expected) <= AGREEMENT, (x, got, expected)
        active += int(np.max(np.abs(inputs)) > U_MAX - 1e-6)
    assert active >= 1  # the torque bound shaped some of the solutions


def test_a_fixed_chain_is_refused_what_it_cannot_take() -> None:
    both = chain("acrobot_swingup").replace(joints=[1, 2])
    with pytest.raises(MpcError, match="drives 2 joints"):
        ipgen.mpc(both, u_max=U_MAX)
    with pytest.raises(MpcError, match="no base"):
        ipgen.mpc(chain("acrobot_swingup"), u_max=U_MAX, travel=1.0)


# The acrobot in DFKI's coordinates (test_fixed_lqr's chain) balanced from a tilt by the MPC alone.
BALANCE = (
    CHAIN.split("[actuator]")[0].lstrip()
    + """[actuator]
joints = [2]

[initial]
theta = [3.06, 0.12]
dtheta = [0.3, -0.2]

[controller]
kind = "mpc"
period = 0.01
horizon = 30
u_max = 6.0
q = [10.0, 10.0, 0.1, 0.1]
r = 0.1
{extra}
[simulation]
t_end = 3.0
sample = 0.01
"""
)


def simulate(
    tmp_path: Path, text: str, stem: str = "balance", options: tuple[str, ...] = ()
) -> tuple[dict[str, np.ndarray], str]:
    """Runs a fixed scene (`options`: more of ipgen run's); (the CSV's columns by name, the
    resolved config's text)."""
    path = tmp_path / f"{stem}.toml"
    path.write_text(text)
    out = tmp_path / "out"
    assert run(["run", str(path), "-o", str(out), "--no-plot", "--force", *options]) == 0
    header, *rows = (out / f"{stem}.csv").read_text().splitlines()
    numeric = [name for name in header.split(",") if name != "phase"]
    keep = [i for i, name in enumerate(header.split(",")) if name != "phase"]
    data = np.array([[float(row.split(",")[i]) for i in keep] for row in rows])
    return {name: data[:, i] for i, name in enumerate(numeric)}, (out / f"{stem}.cfg").read_text()


def cfg_numbers(cfg: str, key: str) -> np.ndarray:
    found = re.search(rf"^{re.escape(key)} = (.*)$", cfg, re.MULTILINE)
    assert found is not None, key
    return np.array([float(v) for v in found.group(1).split()])


@pytest.mark.parametrize("rotor", ["", "Ir = [0.001]\ngr = [-6.0]\n"], ids=["no rotor", "geared rotor"])
def test_the_simulators_mpc_is_ipgen_mpc_in_dfki_coordinates(tmp_path: Path, rotor: str) -> None:
    text = BALANCE.format(extra="").replace("joints = [2]\n", f"joints = [2]\n{rotor}")
    columns, cfg = simulate(tmp_path, text)
    # Q = diag(10, 10, 0.1, 0.1) on DFKI's q1 = π − θ1, q2 = θ1 − θ2 (and their rates) is, on ipgen's
    # θ1, θ2: 10 (θ1 − π)² + 10 (θ1 − θ2)², i.e. [[20, −10], [−10, 10]] (and 0.1 × that on the rates)
    expected_q = np.kron(np.diag([1.0, 0.01]), np.array([[20.0, -10.0], [-10.0, 10.0]]))
    assert np.allclose(cfg_numbers(cfg, "controller.q").reshape(4, 4), expected_q, rtol=0, atol=1e-12)
    c = FixedPendulum.from_scene(tmp_path / "balance.toml")
    rows = np.column_stack([columns[k] for k in ("theta0", "theta1", "dtheta0", "dtheta1")])
    states = canonical(c, rows)
    controller = ipgen.mpc(
        c.canonical(), horizon=30, period=0.01, Q=cfg_numbers(cfg, "controller.q").reshape(4, 4), R=0.1,
        P=cfg_numbers(cfg, "controller.p").reshape(4, 4), u_max=U_MAX,
    )  # fmt: skip
    expected = -np.array([controller.step(x) for x in states[:-1]])  # clockwise -> DFKI's counterclockwise
    u = columns["u"][:-1]
    assert np.max(np.abs(u - expected)) <= 1e-9
    assert np.max(np.abs(u)) > 1.0  # a real push, not a hold at rest
    assert abs(rows[-1, 0] - np.pi) < 1e-3 and abs(rows[-1, 1]) < 1e-3  # upright (DFKI: q1 = π, q2 = 0)


@pytest.mark.parametrize("name", ["acrobot_mpc", "pendubot_mpc"])
def test_the_presets_swing_up_by_mpc_within_the_torque_bound(tmp_path: Path, name: str) -> None:
    out = tmp_path / "out"
    assert run(["run", "--preset", name, "-o", str(out), "--no-plot"]) == 0
    summary = (out / f"{name}.txt").read_text()
    assert "planned trajectory tracked by the MPC" in summary and "every status ok" in summary
    header, *rows = (out / f"{name}.csv").read_text().splitlines()
    col = {k: i for i, k in enumerate(header.split(","))}
    data = np.array([[float(row.split(",")[col[k]]) for k in ("t", "theta0", "theta1", "u")] for row in rows])
    assert np.max(np.abs(data[:, 3])) <= U_MAX
    assert np.max(np.abs(data[:10, 1])) < 0.1  # it starts hanging (DFKI: q1 = 0)
    end = data[data[:, 0] >= 6.0]
    assert np.max(np.abs(end[:, 1] - np.pi)) < 1e-3 and np.max(np.abs(end[:, 2])) < 1e-3  # held upright


BAD_VALUES = {
    "period": ["0", "-0.01", '"fast"', "20.0", "0.0033"],
    "u_max": ["0", "-6", '"six"', "[6, 6]"],
    "horizon": ["0", "2.5", "1001", '"long"', "true"],
    "substeps": ["0", "101"],
    "iterations": ["0", "1001"],
    "qp_iterations": ["0", "-3"],
    "barrier": ["-1", '"x"', "nan", "[0.1]", "2e6"],
    "sensitivities": ['"exakt"', "1"],
    "q": ["[1, 2, 3]", '["a", 1, 1, 1]', "[1, 1, 1, inf]"],
    "p": ["[1, 2]", "[[1, 0], [0, 1]]"],
    "r": ["0", "-1", "[1, 2]"],
    "mode": ['"fast"', "1"],
    "soft_bounds": ["[[4, -1, 1]]", "[[0, 1, -1]]", "[[0, 1]]", "[]", "[[0, -1, 1], [0, -0.1, 0.1]]"],
    "soft_penalty": ["[-1, 1]", "[1, 0]", "[1]", "[1e7, 2]", "[10, 1000]"],
    "saturation": ["6.0"],
    "gain": ["[1, 2, 3, 4]"],
    "travel": ["1.0"],
    "equilibrium": ['"sideways"', "[0.5, 0]"],
    "kind": ['"pid"'],
}
CASES = [(key, value) for key, values in sorted(BAD_VALUES.items()) for value in values]


def write_scene(tmp_path: Path, key: str, value: str | None) -> Path:
    """BALANCE with `key = value` in its [controller] (None: the key removed)."""
    lines = [line for line in BALANCE.format(extra="").splitlines() if not line.startswith(f"{key} =")]
    if value is not None:
        lines.insert(lines.index("[controller]") + 1, f"{key} = {value}")
    path = tmp_path / "bad.toml"
    path.write_text("\n".join(lines) + "\n")
    return path


def refusal(tmp_path: Path, capsys: pytest.CaptureFixture[str], path: Path) -> str:
    """The one line `ipgen run` prints refusing `path` (it exits non-zero and writes nothing)."""
    capsys.readouterr()
    assert run(["run", str(path), "-o", str(tmp_path / "never"), "--no-plot", "--force"]) != 0
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "Traceback" not in err[0], err
    assert not (tmp_path / "never").exists()  # nothing half-written
    return err[0]


@pytest.mark.parametrize(("key", "value"), CASES, ids=[f"{k}={v}" for k, v in CASES])
def test_every_bad_mpc_key_of_a_fixed_scene_is_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], key: str, value: str
) -> None:
    assert key in refusal(tmp_path, capsys, write_scene(tmp_path, key, value))


@pytest.mark.parametrize("key", ["period", "u_max"])
def test_a_missing_period_or_bound_is_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], key: str
) -> None:
    assert f"controller.{key}" in refusal(tmp_path, capsys, write_scene(tmp_path, key, None))


def test_the_microcontrollers_method_reaches_the_simulator(tmp_path: Path) -> None:
    """barrier, qp_iterations = 1 and frozen sensitivities in a fixed scene's [controller]: in its
    resolved config (absent by default) and run by the simulator, every MPC status ok."""
    lines = BALANCE.format(extra="").splitlines()
    method = ["barrier = 0.001", "qp_iterations = 1", 'sensitivities = "frozen"']
    lines[lines.index("[controller]") + 1 : lines.index("[controller]") + 1] = method
    path = tmp_path / "fast.toml"
    path.write_text("\n".join(lines) + "\n")
    plain = tmp_path / "plain.toml"
    plain.write_text(BALANCE.format(extra=""))
    configs, summaries = [], []
    for scene in (path, plain):
        out = io.StringIO()
        with redirect_stdout(out):
            assert run(["run", str(scene), "-o", str(tmp_path / scene.stem), "--no-plot"]) == 0
        configs.append(next((tmp_path / scene.stem).glob("*.cfg")).read_text())
        summaries.append(out.getvalue())
    assert "controller.barrier = 0.001" in configs[0] and "controller.sensitivities = frozen" in configs[0]
    assert "controller.barrier" not in configs[1] and "controller.sensitivities" not in configs[1]
    assert "every status ok" in summaries[0], summaries[0]


def test_an_unknown_mpc_key_is_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert "controller.horizn" in refusal(tmp_path, capsys, write_scene(tmp_path, "horizn", "30"))


VALUES = st.one_of(
    st.integers(-3, 2000).map(str),
    st.floats(allow_nan=True, allow_infinity=True).map(
        lambda v: repr(v).replace("nan", "nan").replace("inf", "inf")
    ),
    st.sampled_from(['"rti"', '"x"', "true", "[]", "[1, 2]", "[[0, -1, 1]]", "[[9, 0, 1]]", "1e400"]),
)


@settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(key=st.sampled_from(sorted(BAD_VALUES)), value=VALUES)
def test_any_value_of_any_mpc_key_runs_or_is_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], key: str, value: str
) -> None:
    path = write_scene(tmp_path, key, value)
    # 0.2 s of the run: every key is read, checked and used by the simulator's MPC, in a tenth of
    # the time (a long horizon makes every sample costly)
    path.write_text(path.read_text().replace("t_end = 3.0", "t_end = 0.2"))
    capsys.readouterr()
    status = run(["run", str(path), "-o", str(tmp_path / "out"), "--no-plot", "--force"])
    err = capsys.readouterr().err.strip().splitlines()
    if status == 3:  # a value the scene takes whose MPC does not hold the links (a long horizon's RTI)
        assert err[0].startswith("simulate: error: the closed loop diverged at t = "), err
        assert err[1:] == ["ipgen: the simulation ended with exit status 3"], err
        return
    assert status == 0 or (len(err) == 1 and "Traceback" not in err[0]), err


def test_tracking_needs_an_mpc_and_a_known_word(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    source = preset_path("acrobot_swingup")
    (tmp_path / "acrobot_swingup.plan.csv").write_text(
        source.with_name("acrobot_swingup.plan.csv").read_text()
    )
    plan = 'plan = "acrobot_swingup.plan.csv"'
    for extra, says in (('tracking = "mpc"', 'needs a [controller] of kind = "mpc"'),
                        ('tracking = "pid"', "swingup.tracking")):  # fmt: skip
        path = tmp_path / "acrobot_swingup.toml"
        path.write_text(source.read_text().replace(plan, f"{plan}\n{extra}"))
        assert run(["run", str(path), "-o", str(tmp_path / "never"), "--no-plot"]) != 0
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and says in err[0], err


def test_a_plan_with_a_value_that_is_not_finite_is_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A NaN or inf in a plan CSV: one line naming the plan file and its row, nothing written
    (before, the scene's checks took it and the simulator refused its own .cfg in three lines,
    leaving the .cfg and .txt behind)."""
    source = preset_path("acrobot_swingup")
    rows = source.with_name("acrobot_swingup.plan.csv").read_text().splitlines()
    first = next(i for i, row in enumerate(rows) if row and not row.startswith("#")) + 1  # the header's
    for value in ("nan", "inf", "-inf"):
        broken = list(rows)
        cells = broken[first + 4].split(",")
        cells[1] = value
        broken[first + 4] = ",".join(cells)
        (tmp_path / "acrobot_swingup.plan.csv").write_text("\n".join(broken) + "\n")
        path = tmp_path / "acrobot_swingup.toml"
        path.write_text(source.read_text())
        assert run(["run", str(path), "-o", str(tmp_path / "never"), "--no-plot"]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert (
            len(err) == 1
            and "acrobot_swingup.plan.csv: data row 5 holds a value that is not finite" in err[0]
        )
        assert not (tmp_path / "never").exists()


def test_a_presets_scene_copied_without_its_plan_names_where_the_plan_is(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """`ipgen presets acrobot_swingup > acro.toml` copies the scene, not its plan CSV beside it:
    the one-line refusal names the shipped plan to copy (before, only "No such file")."""
    (tmp_path / "acro.toml").write_text(preset_path("acrobot_swingup").read_text())
    assert run(["run", str(tmp_path / "acro.toml"), "-o", str(tmp_path / "never"), "--no-plot"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    shipped = preset_path("acrobot_swingup").with_name("acrobot_swingup.plan.csv")
    assert len(err) == 1 and f"copy it from {shipped}" in err[0], err


def test_the_mpc_predicts_with_controller_model_where_given(tmp_path: Path) -> None:
    """The resolved config with the model stated as the plant's own (the same CSV, bit for bit)
    and as a heavier one (other torques): the simulator reads controller.model.*; `model_lines`
    states a config's plant parameters, for a loop that runs a model only."""
    simulate(tmp_path, BALANCE.format(extra=""))
    out = tmp_path / "out"
    cfg = (out / "balance.cfg").read_text()
    found = re.search(r"Simulator (\S+)", (out / "balance.txt").read_text())
    assert found is not None
    simulator = found.group(1)
    lines = model_lines(cfg)
    assert {line.split(" = ")[0] for line in lines} >= {
        "controller.model.m",
        "controller.model.J",
        "controller.model.Ir",
    }
    assert model_lines(cfg.replace("controller = mpc", "controller = lqr")) == []
    heavier = [re.sub(r"^controller.model.m = .*$", "controller.model.m = 0.6 0.75", line) for line in lines]
    csvs = {}
    for label, extra in (("same", lines), ("heavier", heavier)):
        path = tmp_path / f"{label}.cfg"
        path.write_text(cfg + "\n".join(extra) + "\n")
        done = subprocess.run([simulator, str(path), "--csv", str(tmp_path / f"{label}.csv"), "--force"],
                              capture_output=True, text=True)  # fmt: skip
        assert done.returncode == 0, done.stderr
        csvs[label] = (tmp_path / f"{label}.csv").read_text()
    assert csvs["same"] == (out / "balance.csv").read_text()
    assert csvs["heavier"] != csvs["same"]


def nominal_and_run(cfg: str, key: str) -> tuple[list[float], list[float]]:
    """(the run's plant value of `key`, the MPC's model value) in a resolved config's text."""
    return list(cfg_numbers(cfg, key)), list(cfg_numbers(cfg, f"controller.model.{key}"))


def test_a_sweeps_run_keeps_the_mpcs_nominal_model(tmp_path: Path) -> None:
    """Heavier links in a run of a sweep: the plant's masses change, the MPC's model stays the
    nominal scene's (a fixed chain's run and a cart's); designing anew (a [controller] key)
    gives the MPC the run's own parameters (no model lines); a non-MPC scene gets none."""
    from ipgen.experiment.scene import load_scene, read_document, scene_from_document
    from ipgen.sweeps import execute, fixed, overrides

    scene = fixed.prepare(fixed.load_fixed(preset_path("acrobot_mpc")))
    nominal = list(chain("acrobot_swingup").m)
    run_cfg = fixed.run_config(scene, preset_path("acrobot_mpc"), (("parameters.m[0]", 0.7),))
    plant, model = nominal_and_run(run_cfg, "m")
    assert plant == [0.7, nominal[1]] and model == nominal
    redesigned = fixed.run_config(
        scene, preset_path("acrobot_mpc"), (("parameters.m[0]", 0.7), ("controller.r", 0.2))
    )
    assert "controller.model." not in redesigned
    tvlqr = fixed.prepare(fixed.load_fixed(preset_path("acrobot_swingup")))
    assert not any("controller.model." in line for line in tvlqr.design)

    path = preset_path("cdip_mpc")
    cart = load_scene(path)
    from ipgen.experiment.config import resolved_config

    lines = tuple(model_lines(resolved_config(cart, model="mpc_cdip")))
    prepared = execute.Prepared(path, cart, {}, Path("unused"), tmp_path, "mpc_cdip", (), None, lines)
    changes = (("parameters.m[1]", 2 * cart.m[1]),)
    document = overrides.apply(read_document(path), cart, changes)
    heavier = scene_from_document(path, document, designed=cart)
    text = execute.run_config(prepared, heavier, nominal_design=True)
    plant, model = nominal_and_run(text, "m")
    assert plant[1] == 2 * cart.m[1] and model[1] == cart.m[1] and plant[0] == model[0]
    assert "controller.model." not in execute.run_config(prepared, heavier, nominal_design=False)


def test_a_sweep_judges_a_fixed_mpc_by_its_reference_and_bound(tmp_path: Path) -> None:
    """A fixed scene balanced by the MPC alone: its goal is the MPC's reference in the scene's
    coordinates (DFKI's upright: q1 = π), its bound u_max; the nominal chain passes."""
    path = tmp_path / "balance.toml"
    path.write_text(BALANCE.format(extra=""))
    nominal = chain("acrobot_swingup").m[1]
    outcome = ipgen.sweep(path, tmp_path / "out", vary=[f"parameters.m[1]={nominal}"], jobs=1)
    rows = (tmp_path / "out" / "runs.csv").read_text().splitlines()
    assert outcome.score == 1.0, rows


def test_a_sweeps_mpc_predicts_with_the_nominal_links_the_cfg_leaves_out(tmp_path: Path) -> None:
    """cdip_mpc's config writes no J (the rods): a run whose plant states other inertias still
    has the MPC predict with the nominal rods. The first step (t = 0, the same state) is the
    nominal run's to the bit with the model stated, and differs without it (the old behaviour)."""
    from ipgen.experiment.config import resolved_config
    from ipgen.experiment.scene import load_scene, read_document, scene_from_document
    from ipgen.sweeps import execute, overrides

    out = tmp_path / "nominal"
    assert run(["run", "--preset", "cdip_mpc", "-o", str(out), "--no-plot"]) == 0
    found = re.search(r"Simulator (\S+)", (out / "cdip_mpc.txt").read_text())
    assert found is not None
    path = preset_path("cdip_mpc")
    cart = load_scene(path)
    model = re.search(r"^model = (\S+)$", (out / "cdip_mpc.cfg").read_text(), re.MULTILINE)
    assert model is not None
    lines = tuple(model_lines(resolved_config(cart, model=model.group(1))))
    assert not any(line.startswith("controller.model.J") for line in lines)  # the rods: not written
    prepared = execute.Prepared(
        path, cart, {}, Path(found.group(1)), tmp_path, model.group(1), (), None, lines
    )
    changes = (("parameters.J", [0.0, 0.02, 0.02]),)
    document = overrides.apply(read_document(path), cart, changes)
    stiffer = scene_from_document(path, document, designed=cart)
    first = {}
    for label, nominal_design in (("kept", True), ("own", False)):
        cfg = tmp_path / f"{label}.cfg"
        cfg.write_text(execute.run_config(prepared, stiffer, nominal_design=nominal_design))
        assert "J = 0 0.02 0.02" in cfg.read_text()
        done = subprocess.run([found.group(1), str(cfg), "--csv", str(tmp_path / f"{label}.csv"), "--force"],
                              capture_output=True, text=True)  # fmt: skip
        assert done.returncode in (0, 3, 4), done.stderr  # the plant is another: the loop may lose it
        header, row = (tmp_path / f"{label}.csv").read_text().splitlines()[:2]
        first[label] = float(row.split(",")[header.split(",").index("u")])
    header, row = (out / "cdip_mpc.csv").read_text().splitlines()[:2]
    nominal_u = float(row.split(",")[header.split(",").index("u")])
    assert first["kept"] == nominal_u and first["own"] != nominal_u


@pytest.mark.parametrize("name", ["acrobot_mpc", "pendubot_mpc"])
def test_the_tracked_plan_is_ipgen_mpc_about_the_plan_in_ipgen_coordinates(tmp_path: Path, name: str) -> None:
    """Along the plan (t < its duration) the simulator's u every 10 ms is `ipgen.mpc`'s step with
    the plan as its reference per stage (ipgen_loop_plan_reference's formula: the plan's state
    every 5 of its 2-ms samples, the last from its end on; its mean torque over the sample),
    everything mapped to ipgen's coordinates and the torques' sign flipped (DFKI's
    counterclockwise): the map and the sign of the plan's inputs at the boundary, to 1e-9."""
    out = tmp_path / "out"
    assert run(["run", "--preset", name, "-o", str(out), "--no-plot"]) == 0
    cfg = (out / f"{name}.cfg").read_text()
    c = FixedPendulum.from_scene(preset_path(name))
    steps, every, horizon = int(cfg_numbers(cfg, "swingup.steps")[0]), 5, 40
    plan = canonical(c, cfg_numbers(cfg, "swingup.states").reshape(steps + 1, 4))
    torques = -cfg_numbers(cfg, "swingup.inputs")  # DFKI's counterclockwise -> ipgen's clockwise
    header, *rows = (out / f"{name}.csv").read_text().splitlines()
    col = {k: i for i, k in enumerate(header.split(","))}
    data = np.array(
        [[float(r.split(",")[col[k]]) for k in ("theta0", "theta1", "dtheta0", "dtheta1", "u")] for r in rows]
    )
    controller = ipgen.mpc(
        c.canonical(), horizon=horizon, period=0.01, Q=cfg_numbers(cfg, "controller.q").reshape(4, 4), R=0.1,
        P=cfg_numbers(cfg, "controller.p").reshape(4, 4), u_max=U_MAX,
    )  # fmt: skip
    worst = 0.0
    for j in range(steps // every):
        k = j * every
        states = plan[[min(k + i * every, steps) for i in range(horizon + 1)]]
        inputs = [sum(torques[m] for m in range(k + i * every, k + (i + 1) * every) if m < steps) / every
                  for i in range(horizon)]  # fmt: skip
        u = controller.step(canonical(c, data[k : k + 1, :4])[0], reference=(states, inputs))
        worst = max(worst, abs(-u - data[k, 4]))
    assert worst <= 1e-9
    assert np.max(np.abs(data[:, 4])) > 1.0  # the plan's swing, not a hold at rest
