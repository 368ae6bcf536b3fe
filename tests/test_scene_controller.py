"""The [controller] table of scenes: the gain in the resolved config, and every bad key as one line."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from test_scene import ROTARY, config_dict, expect_error, make

import ipgen
from ipgen.command.cli import run
from ipgen.errors import SceneError
from ipgen.experiment.config import resolved_config
from ipgen.experiment.scene import load_scene

REPO = Path(__file__).resolve().parent.parent

# A rotary single pendulum under LQR: no [input], link 1 tilted.
CONTROLLED = {
    **ROTARY,
    "input.kind": None,
    "input.amplitude": None,
    "input.duration": None,
    "initial.theta": "[0, 0.05]",
    "controller.kind": '"lqr"',
}


def controlled(tmp_path: Path, changes: dict[str, str | None] | None = None) -> Path:
    return make(tmp_path, {**CONTROLLED, **(changes or {})})


def test_gain_and_equilibrium_in_the_resolved_config(tmp_path: Path) -> None:
    path = controlled(
        tmp_path,
        {"controller.q": "[1, 2, 3, 4]", "controller.r": "0.5", "controller.saturation": "2.5"},
    )
    scene = load_scene(path)
    gain = ipgen.lqr("rotary", 1, scene.m, scene.l, scene.delta, Q=[1, 2, 3, 4], R=0.5)[0]
    assert scene.controller is not None
    assert scene.controller.gain == tuple(gain.tolist())
    config = config_dict(resolved_config(scene))
    assert config["controller"] == "lqr"
    assert [float(v) for v in config["controller.gain"].split()] == gain.tolist()  # exact round trip
    assert config["controller.equilibrium"] == "0 0 0 0"
    assert config["controller.saturation"] == "2.5"
    assert "controller.period" not in config


def test_hanging_and_mixed_equilibria(tmp_path: Path) -> None:
    hanging = load_scene(controlled(tmp_path, {"controller.equilibrium": '"hanging"'})).controller
    assert hanging is not None and hanging.equilibrium == (0.0, math.pi, 0.0, 0.0)
    mixed = load_scene(
        make(
            tmp_path,
            {
                **CONTROLLED,
                "system.links": "2",
                "parameters.m": "[0.5, 0.275, 0.275]",
                "parameters.l": "[0.6, 0.5, 0.5]",
                "parameters.delta": "[0.3, 0.011458, 0.011458]",
                "initial.theta": "[0, 3.1, 0]",
                "controller.equilibrium": "[0.5, 3.141592653589793, 0]",
                "controller.period": "0.02",
            },
        )
    ).controller
    assert mixed is not None and mixed.equilibrium == (0.5, math.pi, 0.0, 0.0, 0.0, 0.0)
    assert mixed.period == 0.02 and len(mixed.gain) == 6


def test_full_q_matrix(tmp_path: Path) -> None:
    matrix = "[[2, 1, 0, 0], [1, 2, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]"
    scene = load_scene(controlled(tmp_path, {"controller.q": matrix}))
    q = np.array([[2, 1, 0, 0], [1, 2, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]], float)
    assert scene.controller is not None
    assert np.allclose(
        scene.controller.gain, ipgen.lqr("rotary", 1, scene.m, scene.l, scene.delta, q, 1.0)[0]
    )


ASYMMETRIC = "[[1, 2, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]"
INDEFINITE = "[[1, 2, 0, 0], [2, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]"
RAGGED = "[[1, 0, 0], [0, 1, 0], [0, 0, 1], [0, 0, 1]]"
NO_INPUT = 'remove [input] (or set kind = "zero")'

BAD = [
    ({"controller.kind": '"pid"'}, "controller.kind", 'expected "lqr"'),
    ({"controller.kind": None, "controller.r": "1"}, "controller.kind", "missing required key"),
    ({"controller.qq": "1"}, "controller.qq", "did you mean 'q'"),
    ({"controller.q": "[1, 1, 1]"}, "controller.q has 3 entries, expected 4", "θ0"),
    ({"controller.q": "[1, -1, 1, 1]"}, "controller.q[1] = -1", ">= 0"),
    ({"controller.q": '[1, "a", 1, 1]'}, "controller.q[1]", "expected a number"),
    ({"controller.q": "[1, nan, 1, 1]"}, "controller.q[1]", "finite"),
    ({"controller.q": "1"}, "controller.q = 1", "expected an array of 4 weights"),
    (
        {"controller.q": "[[1, 2, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]"},
        "controller.q[1][0]",
        "symmetric",
    ),
    (
        {"controller.q": "[[1, 2, 0, 0], [2, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]"},
        "controller.q",
        "semidefinite",
    ),
    (
        {"controller.q": "[[1, 0, 0], [0, 1, 0], [0, 0, 1], [0, 0, 1]]"},
        "controller.q[0] has 3 entries",
        "4 × 4",
    ),
    ({"controller.q": "[0, 0, 0, 0]"}, "controller: no LQR gain", "not detectable"),
    ({"controller.r": "0"}, "controller.r = 0", "> 0"),
    ({"controller.r": "-1"}, "controller.r = -1", "> 0"),
    ({"controller.r": '"1"'}, "controller.r", "expected a number"),
    ({"controller.equilibrium": '"sideways"'}, "controller.equilibrium", '"upright" or "hanging"'),
    ({"controller.equilibrium": "[0, 1.0]"}, "controller.equilibrium[1] = 1.0", "at a multiple of π"),
    ({"controller.equilibrium": "[0, 0, 0]"}, "controller.equilibrium has 3 entries, expected 2", "θ0"),
    ({"controller.equilibrium": "true"}, "controller.equilibrium", "got a boolean"),
    ({"controller.saturation": "0"}, "controller.saturation = 0", "must be > 0 N m"),
    ({"controller.saturation": "-2"}, "controller.saturation = -2", "must be > 0"),
    ({"controller.period": "0"}, "controller.period = 0", "must be > 0 s"),
    ({"controller.period": "-0.01"}, "controller.period = -0.01", "must be > 0 s"),
    ({"controller.period": "20"}, "controller.period = 20", "<= t_end"),
    ({"controller.period": "0.015"}, "controller.period = 0.015", "whole multiple or a whole fraction"),
    (
        {"input.kind": '"constant"', "input.amplitude": "1"},
        "controller.kind",
        'remove [input] (or set kind = "zero")',
    ),
    ({"controller.kind": '"gain"'}, 'controller.kind = "gain"', "add gain = [...]"),
    (
        {"controller.kind": '"gain"', "controller.gain": "[1, 2, 3, 4]", "controller.r": "2"},
        "controller.r = 2",
        'kind = "gain" takes K as given',
    ),
    ({"controller.kind": '"gain"', "controller.gain": "[1, 2, 3]"}, "controller.gain has 3 entries", "4"),
    ({"controller.kind": '"gain"', "controller.gain": "[1, 2, nan, 4]"}, "controller.gain[2]", "finite"),
    (
        {"controller.kind": '"gain"', "controller.gain": "2"},
        "controller.gain = 2",
        "an array of the 4 entries",
    ),
    ({"controller.gain": "[1, 2, 3, 4]"}, "controller.gain", 'is for kind = "gain"'),
]


@pytest.mark.parametrize(("changes", "key", "expected"), BAD, ids=[f"{c}" for c, _, _ in BAD])
def test_bad_controller_key_is_one_line(tmp_path: Path, changes: dict, key: str, expected: str) -> None:
    expect_error(controlled(tmp_path, changes), key, expected)


def test_command_exits_2_and_writes_nothing(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = controlled(tmp_path, {"controller.r": "0"})
    out = tmp_path / "out"
    assert run(["--scene", str(path), "-o", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("ipgen: error: ") and "controller.r = 0" in err[0]
    assert not out.exists()


def test_a_given_gain_runs_as_the_same_lqr_gain_does(tmp_path: Path) -> None:
    """kind = "gain" with the gain kind = "lqr" computes: the same resolved feedback, and the
    simulator's trajectory is the same, bit for bit (a policy trained elsewhere runs this way)."""
    sampled = {"controller.period": "0.01", "controller.saturation": "3"}
    lqr = load_scene(controlled(tmp_path, sampled))
    assert lqr.controller is not None
    gain = "[" + ", ".join(repr(k) for k in lqr.controller.gain) + "]"
    (tmp_path / "lqr").mkdir()
    given_path = make(
        tmp_path / "lqr", {**CONTROLLED, **sampled, "controller.kind": '"gain"', "controller.gain": gain}
    )
    given = load_scene(given_path)
    assert given.controller is not None and given.controller.kind == "gain"
    assert given.controller.gain == lqr.controller.gain
    assert given.controller.equilibrium == lqr.controller.equilibrium
    csvs = []
    for name, path in (("a", controlled(tmp_path, sampled)), ("b", given_path)):
        assert run(["run", str(path), "-o", str(tmp_path / name), "--no-plot"]) == 0
        csvs.append(next((tmp_path / name).glob("*.csv")).read_text().splitlines())
    assert len(csvs[0]) > 10 and csvs[0][1:] == csvs[1][1:]


def test_specialised_scene_keeps_the_input_path(tmp_path: Path) -> None:
    from ipgen.experiment.specialisation import from_scene

    scene = load_scene(controlled(tmp_path, {"system.specialise": "true"}))
    assert not from_scene(scene).zero_input


def test_demo_scene() -> None:
    scene = load_scene(REPO / "scenes" / "rdip_lqr.toml")
    assert scene.controller is not None and scene.controller.period is None
    assert scene.theta == (0.0, 0.1, 0.0) and scene.t_end == 10.0


# Any controller table: a scene with a controller or one clean SceneError line naming [controller].
VALUES = st.one_of(
    st.integers(-3, 3).map(str),
    st.sampled_from(
        ["0.5", "1e-3", "-0.0", "nan", "inf", "1e400", '"lqr"', '"gain"', '"upright"', '"hanging"', "true"]
    ),
    st.lists(st.sampled_from(["0", "1", "-1", "2.5", "3.141592653589793", '"x"']), max_size=5).map(
        lambda items: "[" + ", ".join(items) + "]"
    ),
    st.just("[[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]"),
)
KEYS = st.sampled_from(["kind", "q", "r", "equilibrium", "saturation", "period", "gain"])


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.dictionaries(KEYS, VALUES, max_size=4))
def test_any_controller_table_loads_or_fails_in_one_line(tmp_path: Path, table: dict[str, str]) -> None:
    changes: dict[str, str | None] = {f"controller.{key}": value for key, value in table.items()}
    path = controlled(tmp_path, changes)
    try:
        scene = load_scene(path)
    except SceneError as exc:
        message = str(exc)
        assert "\n" not in message and message.startswith(f"{path.as_posix()}: "), message
        assert "controller" in message, message  # names the table or one of its keys
        return
    assert scene.controller is not None
    assert all(math.isfinite(k) for k in scene.controller.gain)
    assert scene.controller.saturation is None or scene.controller.saturation > 0
    assert scene.controller.period is None or scene.controller.period > 0
