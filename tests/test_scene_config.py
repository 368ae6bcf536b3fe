"""The resolved config's keys are written once (generator/experiment/config.py, `CFG_KEYS`): the C++
parser (cpp/include/ipsim/scene.hpp) knows exactly these, the simulator's help
(cpp/src/simulate.cpp) names no other, and the writer writes no other."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from shipped_scenes import shipped_scene

from ipgen.experiment.config import CFG_KEYS, resolved_config

ROOT = Path(__file__).resolve().parent.parent
SCENES = sorted(
    path  # not the fixed-pivot presets: no simulator config for them yet (tests/test_fixed_scene.py)
    for path in [*ROOT.glob("scenes/*.toml"), *ROOT.glob("scenes/rigs/*.toml")]
    if 'type = "fixed"' not in path.read_text(encoding="utf-8")
)
# Keys the simulator's help does not name one by one (it says "swingup.* (written by ipgen)"):
# adding a key to CFG_KEYS means naming it in the help or here. ("zero" is in the help as an
# input kind, so it counts as named.)
HELP_OMITS = {
    "angles", "positive", "com", "J", "J_axial", "tip", "input.f_min", "input.f_max", "input.period",
    "swingup.u_max", "swingup.period", "swingup.hold_gain", "swingup.target", "swingup.gain_energy",
    "swingup.gain_position", "swingup.gain_velocity", "swingup.accel_max", "swingup.catch_angle",
    "swingup.catch_rate", "swingup.energy_target", "swingup.energy_inertia", "swingup.energy_weight",
    "swingup.steps", "swingup.inputs", "swingup.states", "swingup.gains",
    # the help says "estimator.*" for the estimator's numbers
    "estimator.cutoff", "estimator.equilibrium", "estimator.A", "estimator.B", "estimator.gain",
    "estimator.input", "estimator.process_noise", "estimator.measurement_noise",
}  # fmt: skip


def test_the_cpp_parser_knows_exactly_the_written_keys() -> None:
    """scene.hpp takes its key table from cfg_rules.hpp, generated from CFG_KEYS."""
    parser = (ROOT / "cpp" / "include" / "ipsim" / "scene.hpp").read_text(encoding="utf-8")
    assert "known(std::begin(cfg::kKeys), std::end(cfg::kKeys))" in parser
    table = (ROOT / "cpp" / "include" / "ipsim" / "cfg_rules.hpp").read_text(encoding="utf-8")
    keys = re.search(r"kKeys\[\] = \{(.*?)\};", table, re.DOTALL)
    assert keys is not None
    assert re.findall(r'"([^"]+)"', keys.group(1)) == list(CFG_KEYS)


def test_the_simulators_help_names_the_written_keys() -> None:
    text = (ROOT / "cpp" / "src" / "simulate.cpp").read_text(encoding="utf-8")
    help_ = text[text.index("SCENE.cfg:") : text.index("exit status:")]
    words = set(re.findall(r"[A-Za-z_][A-Za-z_0-9]*(?:\.[A-Za-z_][A-Za-z_0-9]*)*", help_))
    named = {key for key in CFG_KEYS if key in words}
    assert named == set(CFG_KEYS) - HELP_OMITS, (set(CFG_KEYS) - HELP_OMITS - named, named & HELP_OMITS)
    dotted_key = r"\b(?:input|controller|swingup|limits|actuator)\.[a-z_0-9]+(?:\.[A-Za-z_0-9]+)*"
    dotted = set(re.findall(dotted_key, help_))
    assert dotted <= set(CFG_KEYS), dotted - set(CFG_KEYS)


@pytest.mark.parametrize("path", SCENES, ids=[p.stem for p in SCENES])
def test_every_written_key_is_in_the_table(path: Path) -> None:
    lines = resolved_config(shipped_scene(path)).splitlines()
    written = [line.split(" = ", 1)[0] for line in lines if not line.startswith("#")]
    assert written and set(written) <= set(CFG_KEYS)
    assert len(written) == len(set(written))  # one line per key
