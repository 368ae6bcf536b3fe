"""Identification of a fixed-pivot chain from joint torques (ipgen identify of a fixed scene):
the reader of DFKI's CSV as it is, the regression's exactness on torques computed from known
parameters, the base parameters' algebra, and the command end to end on excerpts of DFKI's
design C.0 recordings (tests/data/dfki, BSD-3-Clause)."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

import ipgen
from ipgen.command.cli import run as cli
from ipgen.common.presets import preset_path
from ipgen.identification.recording import RecordingError, filtered, read_recording
from ipgen.identification.torque import base_parameters, fit_torques, reference_torques, regressor
from ipgen.model.fixed_numeric import FixedModel

DATA = Path(__file__).parent / "data" / "dfki"
FIT = DATA / "design_C.0_20220914_sys_id_trajectory_02_excerpt.csv.gz"
VALIDATE = DATA / "design_C.0_20220914_sys_id_trajectory_05_excerpt.csv.gz"
DFKI = ipgen.FixedPendulum.preset("dfki_c0")


def test_dfki_csv_is_read_as_it_is() -> None:
    recording = read_recording(FIT, 2, 2)
    assert recording.q.shape == (1500, 2) and recording.tau.shape == (1500, 2)
    assert recording.name == "design_C.0_20220914_sys_id_trajectory_02_excerpt"


def test_ipgen_columns_and_missing_columns(tmp_path: Path) -> None:
    t = np.arange(100) * 0.002
    table = np.column_stack([t, np.sin(t), np.cos(t), t, -t])
    good = tmp_path / "rig.csv"
    np.savetxt(good, table, delimiter=",", header="t,q1,q2,tau1,tau2", comments="")
    np.testing.assert_array_equal(read_recording(good, 2, 2).tau[:, 1], -t)
    bad = tmp_path / "bad.csv"
    np.savetxt(bad, table, delimiter=",", header="t,q1,q3,tau1,tau2", comments="")
    with pytest.raises(RecordingError) as refused:
        read_recording(bad, 2, 2)
    assert "\n" not in str(refused.value) and "angle columns" in str(refused.value)


def test_base_parameters_reproduce_the_full_model() -> None:
    """Y_b β(φ) = Y φ for random φ: the dropped parameters are exact combinations of the kept."""
    reg = regressor(DFKI)
    base = base_parameters(reg)
    assert base.unidentifiable() == ["Ir1", "m1", "m2"]  # m1 never enters a fixed chain
    rng = np.random.default_rng(3)
    q, qd, qdd = (rng.uniform(-3, 3, (40, 2)) for _ in range(3))
    y = reg.matrix(q, qd, qdd)
    for _ in range(3):
        phi = rng.uniform(0.01, 1, len(reg.names))
        np.testing.assert_allclose(y[:, list(base.kept)] @ base.of(phi), y @ phi, rtol=1e-10, atol=1e-12)


def test_regressor_is_the_model_inverse_dynamics() -> None:
    reg = regressor(DFKI)
    model = FixedModel(DFKI)
    rng = np.random.default_rng(5)
    q, qd, qdd = (rng.uniform(-3, 3, (10, 2)) for _ in range(3))
    forces = (reg.matrix(q, qd, qdd) @ reg.parameters(DFKI)).reshape(-1, 2)
    for k in range(10):
        np.testing.assert_allclose(forces[k], model.generalised_force(q[k], qd[k], qdd[k]), rtol=1e-10)


def test_fit_recovers_parameters_from_exact_torques() -> None:
    """Torques computed from known parameters at the excerpt's (filtered) motion: the fit returns
    those parameters' base combinations."""
    truth = DFKI.replace(delta=(0.02, 0.005), coulomb=(0.05, 0.11), Ir=(8e-5, 1.2e-4))
    reg = regressor(DFKI)
    recordings = []
    for path in (FIT, VALIDATE):
        data = filtered(read_recording(path, 2, 2))
        torque = reference_torques(reg, truth, data)
        recordings.append(dataclasses.replace(data, tau=torque, tau_raw=torque))
    fit = fit_torques(reg, recordings)
    expected = fit.base.of(reg.parameters(truth))
    np.testing.assert_allclose(fit.estimate, expected, rtol=1e-6, atol=1e-9)
    assert np.all(fit.interval[:, 0] <= expected + 1e-9) and np.all(expected - 1e-9 <= fit.interval[:, 1])


def test_identify_command_on_dfki_excerpts(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "out"
    code = cli(
        ["identify", "--preset", "dfki_c0", "--data", str(FIT), "--validate", str(VALIDATE), "-o", str(out)]
    )
    report = capsys.readouterr().out
    assert code == 0, report
    assert "Not identifiable alone (absorbed in the combinations): Ir1, m1, m2" in report
    rows = [line.split(",") for line in (out / "dfki_c0_identify.csv").read_text().splitlines()[2:]]
    assert [(r[1], r[2]) for r in rows] == [
        ("fit", "identified"),
        ("fit", "scene"),
        ("validate", "identified"),
        ("validate", "scene"),
    ]
    assert (out / "dfki_c0_identify.png").read_bytes().startswith(b"\x89PNG")
    # Least squares: on the fit recording the identified values' weighted error is not above
    # the scene's (which the regression could have chosen).
    from ipgen.pipeline.identify_torques import identify_torques

    result = identify_torques(DFKI, "dfki_c0", [FIT])
    ours, scene = (np.array([float(x) for x in r[3:5]]) for r in rows[:2])
    weights = result.fit.weights
    assert np.sum((weights * ours) ** 2) <= np.sum((weights * scene) ** 2) * (1 + 1e-6)


def test_free_is_refused_for_a_fixed_scene(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert (
        cli(
            [
                "identify",
                "--scene",
                str(preset_path("dfki_c0")),
                "--data",
                str(FIT),
                "--free",
                "m1",
                "-o",
                str(tmp_path),
            ]
        )
        == 2
    )
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--free" in err


def test_rigs_table_is_the_bench_output() -> None:
    """docs/rigs.md's DFKI table quotes docs/bench/dfki_identify.md (make bench-dfki) number for
    number, so that no number there is typed by hand."""
    root = Path(__file__).resolve().parent.parent
    rigs = (root / "docs" / "rigs.md").read_text(encoding="utf-8")
    bench = (root / "docs" / "bench" / "dfki_identify.md").read_text(encoding="utf-8")
    section = rigs.split("## The DFKI double pendulum (design C.0)", 1)[1].split("\n## ", 1)[0]
    quoted = [
        line.split("|")[2:-1] for line in section.splitlines() if line.startswith("| ") and "0." in line
    ]
    produced = {tuple(line.split("|")[2:-1]) for line in bench.splitlines() if line.startswith("| ")}
    assert len(quoted) == 5
    for numbers in quoted:
        assert tuple(numbers) in produced, numbers


def test_public_identify_takes_a_fixed_pendulum() -> None:
    result = ipgen.identify(DFKI, [FIT], validate=[VALIDATE])
    assert result.files == () and len(result.fit.estimate) == 9
    assert result.pooled("validate", "identified") is not None
    with pytest.raises(ipgen.Error):
        ipgen.identify(DFKI, [FIT], "m1")
