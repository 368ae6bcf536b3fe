"""Property: for any dc_motor scene with `specialise = true`, every parameter the specialised
header folds (`experiment.specialisation.from_scene`, printed there as the double nearest the exact
value) is written to the resolved config as that same double, so the simulator's check_folded
passes whatever the masses, lengths and links as built (issue 31: J1 was computed in floats)."""

from __future__ import annotations

from pathlib import Path

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from ipgen.experiment.config import resolved_config
from ipgen.experiment.scene import load_scene
from ipgen.experiment.specialisation import from_scene
from ipgen.model.system import split_parameter

DECIMALS = st.decimals(min_value="0.001", max_value="50", places=6, allow_nan=False, allow_infinity=False)


def _scene(kind: str, links: int, m: list, l: list, given_j: list | None, jm: object) -> str:  # noqa: E741
    built = f"J = [{', '.join(str(v) for v in given_j)}]\n" if given_j is not None else ""
    return f"""
[system]
type = "{kind}"
links = {links}
specialise = true

[parameters]
m = [{", ".join(str(v) for v in m)}]
l = [{", ".join(str(v) for v in l)}]
delta = [{", ".join("0.01" for _ in m)}]
{built}
[actuator]
kind = "dc_motor"
Rm = 8.4
kt = 0.042
km = 0.042
Jm = {jm}
{"r = 0.01" if kind == "classical" else ""}

[input]
kind = "pulse"
amplitude = 1.0
duration = 0.5

[simulation]
t_end = 1.0
"""


@st.composite
def scenes(draw: st.DrawFn) -> str:
    kind = draw(st.sampled_from(["rotary", "classical"]))
    links = draw(st.integers(1, 3))
    m = draw(st.lists(DECIMALS, min_size=links + 1, max_size=links + 1))
    l = draw(st.lists(DECIMALS, min_size=links + 1, max_size=links + 1))  # noqa: E741
    given_j = draw(st.none() | st.lists(DECIMALS, min_size=links + 1, max_size=links + 1))
    if given_j is not None and kind == "classical":
        given_j[0] = 0
    jm = draw(st.sampled_from(["0.0", "4.0e-6", "1.3e-5"]))
    return _scene(kind, links, m, l, given_j, jm)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(text=scenes())
def test_config_carries_every_folded_value_to_the_last_bit(tmp_path: Path, text: str) -> None:
    path = tmp_path / "motor_special.toml"
    path.write_text(text)
    scene = load_scene(path)
    config = {
        key.strip(): value.split()
        for key, _, value in (line.partition("=") for line in resolved_config(scene).splitlines())
        if value and not key.startswith("#") and "." not in key
    }
    checked = 0
    for name, value in from_scene(scene).fixed:
        group, index = split_parameter(name)
        if group not in config:
            continue  # not in the config: the simulator's default (the rod), compared to a few ulp
        written = float(config[group][index or 0])
        assert written == float(value), f"{name}: config {written!r}, header {float(value)!r}"
        checked += 1
    assert checked >= 3 * (scene.links + 1)  # m, l, delta at least
