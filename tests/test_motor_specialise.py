"""A dc_motor scene with `specialise = true`: the motor-folded parameters (δ0 + back-EMF, J0 or
m0 + the rotor) are folded exactly into the header, the resolved config carries the same values
to the last bit (check_folded passes), and the run is the general header's run."""

from __future__ import annotations

import os
import subprocess
import sys
from fractions import Fraction
from pathlib import Path

import numpy as np
from cxx import require_toolchain
from run_csv import read_run_csv

from ipgen.experiment.config import resolved_config
from ipgen.experiment.scene import load_scene

RIGS = Path(__file__).resolve().parents[1] / "scenes" / "rigs"


def test_motor_folded_exactly() -> None:
    """The QUBE preset with the rotor (Jm) and a gear: the config's δ0 and J0 are the exact fold
    rounded once (by hand: δ0 + kt km Kg² / Rm, J0 + Kg² Jm)."""
    text = (RIGS / "qube_servo2.toml").read_text().replace("# Jm = 4.0e-6", "Jm = 4.0e-6\nKg = 1.5")
    path = Path(os.environ.get("TMPDIR", "/tmp")) / f"qube_fold_{os.getpid()}.toml"
    path.write_text(text)
    try:
        scene = load_scene(path)
    finally:
        path.unlink()
    folded = scene.motor_folded()
    kg, kt, km, rm = Fraction("1.5"), Fraction("0.042"), Fraction("0.042"), Fraction("8.4")
    assert folded["delta0"] == Fraction("0.0015") + kt * km * kg**2 / rm
    assert folded["J0"] == Fraction("5.7197916666666667e-05") + kg**2 * Fraction("4.0e-6")
    config = resolved_config(scene)
    delta = next(line for line in config.splitlines() if line.startswith("delta = "))
    j = next(line for line in config.splitlines() if line.startswith("J = "))
    assert float(delta.split()[2]) == float(folded["delta0"])
    assert float(j.split()[2]) == float(folded["J0"])


def test_specialised_motor_scene_runs_like_the_general_one(tmp_path: Path) -> None:
    require_toolchain()
    env = dict(os.environ)  # the run's shared simulator cache (tests/conftest.py)
    general = (RIGS / "qube_servo2.toml").read_text()
    special = general.replace('name = "qube_servo2"', 'name = "qube_servo2_special"\nspecialise = true')
    runs = {}
    # A specialised header names its scene's path: the scenes live in a fixed folder of the run's
    # cache (tests/conftest.py), so the header, and its cached simulator, are the same every run.
    scenes = Path(os.environ.get("IPGEN_CACHE_DIR") or tmp_path) / "scenes" / "test_motor_specialise"
    scenes.mkdir(parents=True, exist_ok=True)
    for stem, text in (("general", general), ("special", special)):
        scene = scenes / f"{stem}.toml"
        partial = scenes / f".{stem}.{os.getpid()}.toml"
        partial.write_text(text)
        partial.replace(scene)
        done = subprocess.run(
            [sys.executable, "-m", "ipgen", "run", str(scene), "-o", str(tmp_path / stem), "--no-plot"],
            capture_output=True,
            text=True,
            env=env,
        )
        assert done.returncode == 0, done.stderr
        runs[stem] = read_run_csv(tmp_path / stem / f"{stem}.csv", phase=False).data
    import ipgen

    ipgen.write_header(tmp_path / "gen", scene=scenes / "special.toml")
    header = (tmp_path / "gen" / "qube_servo2_special.hpp").read_text()
    folded = load_scene(scenes / "special.toml").motor_folded()
    assert "kSpecialised = true" in header and f"Scalar({float(folded['delta0'])!r})" in header
    # Same model, expressions rounded differently: the runs agree to the integrator's tolerance.
    np.testing.assert_allclose(runs["special"], runs["general"], rtol=1e-7, atol=1e-8)


RSIP_MOTOR = """
[actuator]
kind = "dc_motor"
Rm = 8.4
kt = 0.042
km = 0.042
"""


def test_specialised_rsip_with_a_motor_runs_like_the_general_one(tmp_path: Path) -> None:
    """scenes/rsip_pulse.toml with a dc_motor: the links' rod inertias (J1 = m1 l1²/12, not in the
    scene) are folded into the specialised header; the config must carry them to the last bit,
    else the simulator refuses the run ("J1: differs from the value folded ...", issue 31). Both
    simulators come from the shared cache (the general one is rsip_pulse's own)."""
    require_toolchain()
    general = (Path(__file__).resolve().parents[1] / "scenes" / "rsip_pulse.toml").read_text() + RSIP_MOTOR
    special = general.replace('inertia = "pivot"', 'inertia = "pivot"\nspecialise = true')
    runs = {}
    # In a fixed folder of the run's cache (as above): the specialised header names its scene.
    scenes = Path(os.environ.get("IPGEN_CACHE_DIR") or tmp_path) / "scenes" / "test_motor_specialise_rsip"
    scenes.mkdir(parents=True, exist_ok=True)
    for stem, text in (("general", general), ("special", special)):
        scene = scenes / f"{stem}.toml"
        partial = scenes / f".{stem}.{os.getpid()}.toml"
        partial.write_text(text)
        partial.replace(scene)
        done = subprocess.run(
            [sys.executable, "-m", "ipgen", "run", str(scene), "-o", str(tmp_path / stem), "--no-plot"],
            capture_output=True,
            text=True,
        )
        assert done.returncode == 0, done.stderr
        runs[stem] = read_run_csv(tmp_path / stem / f"{stem}.csv", phase=False).data
    assert np.ptp(runs["general"][:, 1]) > 1e-3  # the arm moved: the comparison means something
    np.testing.assert_allclose(runs["special"], runs["general"], rtol=1e-6, atol=1e-8)


def test_a_specialised_motor_header_says_its_damping_and_inertia_hold_the_motor(tmp_path: Path) -> None:
    """A dc_motor scene with specialise = true: the header says delta0 and J0 are folded with the
    motor and to pass the .cfg's params (a user who followed its _with_motor instructions on the
    datasheet's values got "delta0" from check_folded, a last-bit difference); a scene without a
    motor has no such line."""
    from ipgen.command.cli import run

    notes = {}
    for name, source in (("motor", RIGS / "qube_servo2.toml"), ("direct", RIGS.parent / "rsip_lqr.toml")):
        text = source.read_text()
        text = text.replace("[system]\n", "[system]\nspecialise = true\n", 1)
        scene = tmp_path / f"{name}.toml"
        scene.write_text(text)
        assert run(["--scene", str(scene), "-o", str(tmp_path / name), "--emit", "c"]) == 0
        notes[name] = "\n".join(path.read_text() for path in (tmp_path / name).glob("*.h"))
    assert "dc_motor folded into delta0 and J0" in notes["motor"]
    assert "check_folded reports it" in notes["motor"]
    assert "dc_motor folded" not in notes["direct"]
