"""A scene's rods (no com, J or tip given) are checked as a double holds them, as `Pendulum`
checks them: an audit found l = 1e200 m (J = m l²/12 overflows) or m = 5e-324 kg (no inertia
about the pivot) accepted by the scene and refused only by the simulator, after its build, in
several lines. Whatever the magnitudes, the scene and `Pendulum.from_scene` agree, and a refusal is
one line."""

from __future__ import annotations

from pathlib import Path

import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

import ipgen
from ipgen.errors import Error
from ipgen.experiment.scene import load_scene

SCENE = """\
[system]
type = "{kind}"
links = {links}
[parameters]
m = {m}
l = {l}
delta = {delta}
[simulation]
t_end = 1
"""

MAGNITUDES = st.sampled_from(
    ["5e-324", "1e-320", "1e-300", "1e-150", "1e-9", "0.5", "3", "1e9", "1e150", "1e200", "1e300"]
)


@settings(max_examples=80, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(
    kind=st.sampled_from(["classical", "rotary"]), links=st.integers(1, 2), m=MAGNITUDES, length=MAGNITUDES
)
def test_the_scene_and_the_pendulum_agree_on_any_rods(
    tmp_path_factory: pytest.TempPathFactory, kind: str, links: int, m: str, length: str
) -> None:
    folder = tmp_path_factory.mktemp("rods")
    masses = f"[{', '.join([m] * (links + 1))}]"
    lengths = f"[{length if kind == 'rotary' else 0}, {', '.join([length] * links)}]"
    scene = folder / "rods.toml"
    scene.write_text(
        SCENE.format(kind=kind, links=links, m=masses, l=lengths, delta=f"[{', '.join(['0'] * (links + 1))}]")
    )
    try:
        load_scene(scene)
        loaded = True
    except Error as error:
        assert "\n" not in str(error)
        loaded = False
    try:
        ipgen.Pendulum.from_scene(Path(scene)) if loaded else None
        built = loaded
    except Error as error:
        assert "\n" not in str(error)
        built = False
    assert loaded == built, (m, length)
    event("loaded" if loaded else "refused")
    if not loaded:  # the same values given as a Pendulum are refused too
        with pytest.raises(Error):
            ipgen.Pendulum(kind, links, m=[float(m)] * (links + 1),
                           l=[float(length) if kind == "rotary" else 0.0] + [float(length)] * links,
                           delta=[0.0] * (links + 1))  # fmt: skip
