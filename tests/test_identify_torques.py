"""Identification of a fixed-pivot chain from joint torques (ipgen identify of a fixed scene):
the reader of DFKI's CSV as it is, the regression's exactness on torques computed from known
parameters, the base parameters' algebra, and the command end to end on excerpts of DFKI's
design C.0 recordings (tests/data/dfki, BSD-3-Clause)."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

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


def test_dfkis_torques_are_read_by_joint_number(tmp_path: Path) -> None:
    """DFKI's header has a torque per joint, `tau_measJ` joint J's (0 where passive): an acrobot
    (joints = [2]) reads tau_meas2, a pendubot (joints = [1]) tau_meas1, joints = [2, 1] both in
    that order (before, tau_meas1..m were taken in the order of joints: the acrobot read its
    passive shoulder's zeros and identified nothing); a header without the joint's column is one
    line naming it."""
    t = np.arange(100) * 0.002
    table = np.column_stack([t, np.sin(t), np.cos(t), np.zeros_like(t), 1 + t])
    path = tmp_path / "acrobot.csv"
    np.savetxt(path, table, delimiter=",", header="time,pos_meas1,pos_meas2,tau_meas1,tau_meas2", comments="")
    np.testing.assert_array_equal(read_recording(path, 2, 1, (2,)).tau[:, 0], 1 + t)
    np.testing.assert_array_equal(read_recording(path, 2, 1, (1,)).tau[:, 0], 0 * t)
    both = read_recording(path, 2, 2, (2, 1)).tau
    np.testing.assert_array_equal(both, np.column_stack([1 + t, 0 * t]))
    short = tmp_path / "short.csv"
    np.savetxt(short, table[:, :4], delimiter=",", header="time,pos_meas1,pos_meas2,tau_meas1", comments="")
    with pytest.raises(RecordingError) as refused:
        read_recording(short, 2, 1, (2,))
    assert "\n" not in str(refused.value) and "tau_meas2" in str(refused.value)


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


@pytest.mark.parametrize("method", ["sequential", "joint"])
def test_fit_recovers_parameters_from_exact_torques(method: str) -> None:
    """Torques computed from known parameters at the excerpt's (filtered) motion, each read with
    a constant offset: the fit returns those parameters' base combinations and the offsets."""
    truth = DFKI.replace(delta=(0.02, 0.005), coulomb=(0.05, 0.11), Ir=(8e-5, 1.2e-4))
    offsets = np.array([0.04, -0.03])
    reg = regressor(DFKI)
    recordings = []
    for path in (FIT, VALIDATE):
        data = filtered(read_recording(path, 2, 2))
        torque = reference_torques(reg, truth, data) + offsets
        recordings.append(dataclasses.replace(data, tau=torque, tau_raw=torque))
    fit = fit_torques(reg, recordings, method=method)
    expected = fit.reference(truth)
    expected[-2:] = offsets
    assert fit.labels()[-2:] == ["offset tau1", "offset tau2"]
    np.testing.assert_allclose(fit.estimate, expected, rtol=1e-6, atol=1e-9)
    assert np.all(fit.interval[:, 0] <= expected + 1e-9) and np.all(expected - 1e-9 <= fit.interval[:, 1])
    without = fit_torques(reg, recordings, method=method, offset=False)  # the offsets then bias the fit
    assert len(without.estimate) == 9
    assert np.max(np.abs(without.estimate - expected[:9]) / np.abs(expected[:9])) > 0.05


def _simulated(pendulum: ipgen.FixedPendulum, seconds: float, seed: int) -> tuple[np.ndarray, ...]:
    """t, q, τ of ipgen's own simulator (FixedModel.forward_dynamics, scipy DOP853) driven by a
    random multisine in both joints' torques, sampled at 500 Hz."""
    from scipy.integrate import solve_ivp

    model = FixedModel(pendulum)
    rng = np.random.default_rng(seed)
    frequencies = rng.uniform(0.3, 2.5, (2, 4))
    phases = rng.uniform(0, 2 * np.pi, (2, 4))

    def torque(t: float) -> np.ndarray:
        return 0.3 * np.sin(2 * np.pi * frequencies * t + phases).sum(axis=1)

    def rhs(t: float, x: np.ndarray) -> np.ndarray:
        return np.concatenate([x[2:], model.forward_dynamics(x[:2], x[2:], torque(t))])

    t = np.arange(0, seconds, 0.002)
    run = solve_ivp(rhs, (0, t[-1]), np.zeros(4), t_eval=t, method="DOP853", rtol=1e-9, atol=1e-11)
    return t, run.y[:2].T, np.array([torque(s) for s in t])


def test_noisy_simulation_recovers_parameters_and_offsets() -> None:
    """An independent check of the whole chain (reader's filtering, regressor, sequential fit with
    offsets): ipgen's simulator, the measured angles quantised like the drives' encoders and the
    torques read with offsets and noise; the fit finds the inertial parameters within 3 %, the
    offsets within 0.01 N m. (Cutoff 20 Hz: the simulated elbow moves faster than DFKI's.)"""
    from ipgen.identification.recording import Recording

    truth = DFKI.replace(delta=(0.02, 0.01), coulomb=(0.06, 0.05))
    reg = regressor(DFKI)
    offsets = np.array([0.05, -0.02])
    rng = np.random.default_rng(11)
    recordings = []
    for seed in (1, 2):
        t, q, tau = _simulated(truth, 6.0, seed)
        q = np.round(q / 4e-4) * 4e-4
        measured = tau + offsets + rng.normal(0, 0.05, tau.shape)
        recordings.append(filtered(Recording(f"sim{seed}", t, q, measured), cutoff=20.0))
    fit = fit_torques(reg, recordings, stride=12)
    expected = fit.reference(truth)
    inertial = [0, 1, 2, 3, 8]  # I1 + ..., I2, h1 + ..., h2, Ir2
    np.testing.assert_allclose(fit.estimate[inertial], expected[inertial], rtol=0.03)
    np.testing.assert_allclose(fit.estimate[-2:], offsets, atol=0.01)


def test_a_passive_tip_is_fitted_jointly() -> None:
    """A pendubot (DFKI's C.0 driven at the shoulder only, no rotor or friction) simulated by scipy
    on ipgen's model under a multisine at the shoulder: its elbow's equation has no torque, so the
    default fit (tip first) is done jointly, says so, and finds the base parameters within 1 %
    (tip first gave the elbow's I2, h2 as 0 and the shoulder's from them)."""
    from scipy.integrate import solve_ivp

    from ipgen.identification.recording import Recording

    truth = DFKI.replace(joints=(1,), Ir=None, gr=None, coulomb=None)
    model = FixedModel(truth)
    recordings = []
    for seed in (1, 2):
        rng = np.random.default_rng(seed)
        frequencies, phases = rng.uniform(0.3, 2.5, 4), rng.uniform(0, 2 * np.pi, 4)

        def torque(t: float, f: np.ndarray = frequencies, p: np.ndarray = phases) -> np.ndarray:
            return np.array([0.4 * np.sin(2 * np.pi * f * t + p).sum()])

        def rhs(t: float, x: np.ndarray, u=torque) -> np.ndarray:
            return np.concatenate([x[2:], model.forward_dynamics(x[:2], x[2:], u(t))])

        t = np.arange(0, 6.0, 0.002)
        run = solve_ivp(rhs, (0, t[-1]), np.zeros(4), t_eval=t, method="DOP853", rtol=1e-9, atol=1e-11)
        tau = np.array([torque(s) for s in t])
        recordings.append(filtered(Recording(f"sim{seed}", t, run.y[:2].T, tau), cutoff=20.0))
    fit = fit_torques(regressor(truth), recordings, stride=12)
    assert fit.method == "joint"
    expected = fit.reference(truth)
    np.testing.assert_allclose(fit.estimate[:4], expected[:4], rtol=0.01)  # I1 + …, I2, h1 + …, h2


def test_sequential_fit_keeps_the_outer_link_from_the_inner_joints_error() -> None:
    """A torque the model does not contain, in the shoulder's reading only: the tip-first fit's
    outer-link estimates (those of the elbow's equation) do not move; the joint fit's do."""
    reg = regressor(DFKI)
    recordings, disturbed = [], []
    rng = np.random.default_rng(4)
    for path in (FIT, VALIDATE):
        data = filtered(read_recording(path, 2, 2))
        torque = reference_torques(reg, DFKI, data) + rng.normal(0, 0.02, data.tau.shape)
        recordings.append(dataclasses.replace(data, tau=torque, tau_raw=torque))
        bent = torque + np.column_stack([0.2 * np.sin(3 * data.q[:, 0]) * np.abs(data.qd[:, 0]), 0 * data.t])
        disturbed.append(dataclasses.replace(data, tau=bent, tau_raw=bent))
    outer = [1, 3, 5, 7, 8, 10]  # I2, h2, delta2, cf2, Ir2, offset tau2
    clean = fit_torques(reg, recordings).estimate[outer]
    np.testing.assert_allclose(fit_torques(reg, disturbed).estimate[outer], clean, rtol=1e-9, atol=1e-12)
    moved = fit_torques(reg, disturbed, method="joint").estimate[outer]
    assert np.max(np.abs(moved - clean)) > 1e-4


def test_identify_command_on_dfki_excerpts(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "out"
    code = cli(
        ["identify", "--preset", "dfki_c0", "--data", str(FIT), "--validate", str(VALIDATE), "-o", str(out)]
    )
    report = capsys.readouterr().out
    assert code == 0, report
    assert "Not identifiable alone (absorbed in the combinations): Ir1, m1, m2" in report
    assert "warning:" not in report  # every sum of inertias and friction comes out positive
    rows = [line.split(",") for line in (out / "dfki_c0_identify.csv").read_text().splitlines()[2:]]
    assert [(r[1], r[2]) for r in rows] == [
        ("fit", "identified"),
        ("fit", "scene"),
        ("validate", "identified"),
        ("validate", "scene"),
    ]
    assert (out / "dfki_c0_identify.png").read_bytes().startswith(b"\x89PNG")
    # Least squares on the elbow's equation first (the default fit): on the fit recording the
    # identified values' elbow error is not above the scene's (which the regression could have
    # chosen); with --fit joint, the weighted error of both joints is not.
    ours, scene = (np.array([float(x) for x in r[3:5]]) for r in rows[:2])
    assert ours[1] <= scene[1] * (1 + 1e-6)
    from ipgen.pipeline.identify_torques import identify_torques

    result = identify_torques(DFKI, "dfki_c0", [FIT], method="joint", offset=False)
    ours, scene = (result.pooled("fit", model) for model in ("identified", "scene"))
    weights = result.fit.weights
    assert np.sum((weights * ours) ** 2) <= np.sum((weights * scene) ** 2) * (1 + 1e-6)
    assert "Fit: weighted least squares on all joints' equations together" in result.report


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
    assert result.files == () and len(result.fit.estimate) == 11  # 9 base parameters, 2 offsets
    assert result.pooled("validate", "identified") is not None
    with pytest.raises(ipgen.Error):
        ipgen.identify(DFKI, [FIT], "m1")


def test_public_identify_takes_the_fit_choices_of_the_command() -> None:
    """ipgen.identify's fit and offset are `ipgen identify --fit` and `--no-offset`; they are
    refused for anything but a fixed-pivot chain, and a fit that is not one is a one-line Error."""
    joint = ipgen.identify(DFKI, [FIT], fit="joint", offset=False)
    assert joint.fit.method == "joint" and not joint.fit.offset and len(joint.fit.estimate) == 9
    default = ipgen.identify(DFKI, [FIT])
    assert default.fit.method == "sequential" and default.fit.offset
    assert not np.allclose(joint.fit.estimate, default.fit.estimate[:9])
    with pytest.raises(ipgen.Error, match="fit method 'newton'"):
        ipgen.identify(DFKI, [FIT], fit="newton")
    with pytest.raises(ipgen.Error, match="for fixed-pivot chains"):
        ipgen.identify(ipgen.Pendulum.preset("qube_servo2"), FIT, "J1", offset=False)


def test_a_recording_larger_than_the_limit_is_refused_reading_no_more(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A recording (a .gz too, whose few kB can hold gigabytes) is read up to the data limit and
    refused past it in one line (it was read whole: 11.8 GB for a 4 MB .gz of spaces)."""
    import gzip

    from ipgen.identification import recording

    monkeypatch.setattr(recording, "MAX_DATA_BYTES", 1000)
    rows = "t,q1,q2,tau1,tau2\n" + "".join(f"{k * 0.002},0,0,0,0\n" for k in range(200))
    plain, packed = tmp_path / "big.csv", tmp_path / "big.csv.gz"
    plain.write_text(rows)
    packed.write_bytes(gzip.compress(rows.encode()))
    for path in (plain, packed):
        with pytest.raises(RecordingError, match=r"more than 0 MB \(decompressed\): cut it into parts"):
            read_recording(path, 2, 2)


@pytest.mark.parametrize("validate", [False, True])
def test_the_pictures_title_names_the_recordings_drawn(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, validate: bool
) -> None:
    """Without --validate the picture draws the fit recordings and says so (its title said "the
    validation recordings" there)."""
    from ipgen.pipeline import identify_torques as module

    titles: list[str] = []
    monkeypatch.setattr(module, "_png", lambda fit, scene, recordings, title: titles.append(title) or b"png")
    module.identify_torques(DFKI, "dfki_c0", [FIT], [VALIDATE] if validate else [], tmp_path / "out")
    assert titles and titles[0].endswith("validation recordings" if validate else "on the fit recordings")


def _excerpt(
    tmp_path: Path, name: str, change: Callable[[np.ndarray], np.ndarray], bom: bool = False
) -> Path:
    """The fit excerpt as t, q1, q2, tau1, tau2 with `change` applied to its table."""
    recording = read_recording(FIT, 2, 2)
    table = change(np.column_stack([recording.t, recording.q, recording.tau]))
    path = tmp_path / name
    text = "t,q1,q2,tau1,tau2\n" + "\n".join(",".join(repr(float(v)) for v in row) for row in table) + "\n"
    path.write_text(("\ufeff" if bom else "") + text, encoding="utf-8")
    return path


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(
    kind=st.sampled_from(["tiny_steps", "gap", "huge_value", "huge_time", "milliseconds"]),
    factor=st.floats(1e1, 1e300),
    where=st.integers(1, 1400),
)
def test_a_recording_no_fit_can_use_is_one_line(tmp_path: Path, kind: str, factor: float, where: int) -> None:
    """Unevenly spaced samples (steps of 1 ns, a pause), an angle or torque or time far beyond any
    rig's, and a time in milliseconds: a RecordingError of one line naming the file, before the
    grid is made (before, uneven samples allocated gigabytes and huge values gave a report of
    1e297 N m)."""

    def change(table: np.ndarray) -> np.ndarray:
        t = table[:, 0]
        if kind == "tiny_steps":  # most steps 1 ns: the median step is tiny, the span is not
            most = 760 + where % 640
            t[:] = np.concatenate([np.arange(most) * 1e-9, t[most:]])
        elif kind == "gap":
            t[where:] += min(factor, 1e8)
        elif kind == "huge_value":
            table[where, 1 + where % 4] = 1e6 * (1 + factor)
        elif kind == "huge_time":
            t[:] += 1e9 * (1 + min(factor, 1e8))
        else:
            t *= 1000.0
        return table

    path = _excerpt(tmp_path, "bad.csv", change)
    with pytest.raises(RecordingError) as refused:
        filtered(read_recording(path, 2, 2))
    message = str(refused.value)
    assert "\n" not in message and "bad" in message
    if kind == "milliseconds":
        assert "in ms?" in message


def test_a_byte_order_mark_is_not_part_of_the_first_name(tmp_path: Path) -> None:
    """A CSV saved as spreadsheets' "CSV UTF-8" starts with a byte-order mark: read as without
    (before, "no time column")."""
    plain = read_recording(_excerpt(tmp_path, "plain.csv", lambda table: table), 2, 2)
    marked = read_recording(_excerpt(tmp_path, "marked.csv", lambda table: table, bom=True), 2, 2)
    np.testing.assert_array_equal(plain.tau, marked.tau)


def _dfki_identify(*options: str) -> list[str]:
    """`ipgen identify --preset dfki_c0 --data FIT` with `options`."""
    return ["identify", "--preset", "dfki_c0", "--data", str(FIT), *options]


def test_a_recording_is_fitted_or_validated_once(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """The same file twice in --data (its samples counted twice: narrower intervals for nothing),
    or in --data and --validate (not held out): one line naming it, nothing written."""
    from ipgen.pipeline.identify_torques import identify_torques

    copy = tmp_path / "same.csv.gz"
    copy.write_bytes(FIT.read_bytes())
    for data, validate in (
        ([FIT, FIT], []),
        ([FIT], [FIT]),
        ([FIT], [VALIDATE, tmp_path / ".." / tmp_path.name / "same.csv.gz", copy]),
    ):
        with pytest.raises(ipgen.Error) as refused:
            identify_torques(DFKI, "dfki_c0", data, validate, tmp_path / "out")
        assert "give each file once" in str(refused.value) and "\n" not in str(refused.value)
    assert not (tmp_path / "out").exists()
    assert cli(_dfki_identify("--validate", str(FIT), "-o", str(tmp_path / "o"))) == 2
    assert capsys.readouterr().err.count("\n") == 1


def test_equation_error_only_is_refused_for_a_fixed_scene(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert cli(_dfki_identify("--equation-error-only", "-o", str(tmp_path))) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--equation-error-only" in err
    assert not list(tmp_path.iterdir())


def test_negative_sums_of_inertias_are_warned_of(tmp_path: Path) -> None:
    """DFKI's excerpt with its torques' sign flipped (a motor's sign convention the scene does not
    share): the sums of inertias come out negative with their whole 95 % interval, which the report
    now warns of (before, it printed them as any estimate); physics keeps every I, Ir, m, delta and
    cf sum >= 0, while h (a first moment) may be < 0. The excerpt as recorded: no warning."""
    from ipgen.pipeline.identify_torques import identify_torques

    def flipped(table: np.ndarray) -> np.ndarray:
        table[:, 3:] *= -1.0
        return table

    report = identify_torques(DFKI, "dfki_c0", [_excerpt(tmp_path, "flipped.csv", flipped)]).report
    warnings = [line for line in report.splitlines() if line.startswith("warning:")]
    assert len(warnings) >= 2 and all("is negative" in line and "tau_measJ" in line for line in warnings)
    assert any(line.startswith("warning: I1 ") for line in warnings)
    plain = identify_torques(DFKI, "dfki_c0", [_excerpt(tmp_path, "plain.csv", lambda table: table)]).report
    assert "warning:" not in plain
    base = base_parameters(regressor(DFKI))
    for label, sure in zip(base.labels(), base.sign_definite(), strict=True):
        kind = label.split()[0].rstrip("0123456789")
        terms_signed = "−" not in label and " h" not in label
        assert sure == (kind in ("I", "Ir", "m", "delta", "cf") and terms_signed), label


def test_the_recording_is_never_written_over_not_even_with_force(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """--data named as the command's own output CSV, with --force: refused in one line naming it an
    input, the recording unchanged (it was replaced by the fit's score table)."""
    import gzip

    data = tmp_path / "dfki_c0_identify.csv"
    data.write_bytes(gzip.decompress(FIT.read_bytes()))
    before = data.read_bytes()
    code = cli(["identify", "--preset", "dfki_c0", "--data", str(data), "-o", str(tmp_path), "--force"])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and "is one of the command's inputs" in err, err
    assert data.read_bytes() == before


@pytest.mark.parametrize("rows", ["", "\n\n", "# a comment\n", "# 1,2,3,4,5\n\n# another\n"])
def test_a_recording_without_rows_is_one_line_and_no_warning(tmp_path: Path, rows: str) -> None:
    """A header and no data (blank or comment lines only): numpy's loadtxt warned 'input contained
    no data' before the refusal; the check before it is one line, without the warning."""
    import warnings

    path = tmp_path / "empty.csv"
    path.write_text("t,q1,q2,tau1,tau2\n" + rows)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # any warning fails the test
        with pytest.raises(RecordingError, match="needs at least") as refused:
            read_recording(path, 2, 2)
    assert "\n" not in str(refused.value)
