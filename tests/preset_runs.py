"""One sweep run of qube_servo2_mpc_swingup_m4f as shipped and without one of its keys: how the
tests show what a key buys on a rig unlike the loop's model (the loop kept nominal, as a sweep
keeps it)."""

from __future__ import annotations

from pathlib import Path

PRESET = Path(__file__).resolve().parents[1] / "scenes" / "rigs" / "qube_servo2_mpc_swingup_m4f.toml"
# The sweep draws these tests replay were found on the preset with the EKF's Rn at 1e-4 (3e-4
# since 2026-11-30, fourth session: other draws sit at the edge there) and Rn fixed (learnt,
# [estimator] noise_memory, since the fifth): they keep that design.
RN = ("measurement_noise = 3e-4 ", "measurement_noise = 1e-4 ")
LEARNT_NOISE = "noise_memory = "


def preset_text(rn: str = "draws") -> str:
    """The preset's text; with rn = "draws" its EKF as the draws were found on (RN, and
    without its LEARNT_NOISE line)."""
    text = PRESET.read_text()
    if rn == "draws":
        assert RN[0] in text, "the preset's Rn changed: find the draws again"
        text = text.replace(*RN, 1)
        assert f"\n{LEARNT_NOISE}" in text, "the preset no longer learns its noise: drop LEARNT_NOISE"
        text = "\n".join(line for line in text.splitlines() if not line.startswith(LEARNT_NOISE)) + "\n"
    return text


def with_and_without(
    key: str, criterion: str, overrides: tuple[tuple[str, object], ...], rn: str = "draws"
) -> dict:
    """{"with": Result, "without": Result}: the preset (`preset_text(rn)`), and it without its line
    `key = ...`, each run once with `overrides` (ipgen.sweeps.execute.run_one, the default success
    test)."""
    from ipgen.sweeps import execute
    from ipgen.sweeps.success import Success

    text = preset_text(rn)
    assert f"\n{key} = " in text, f"the preset has no {key}"
    without = "\n".join(line for line in text.splitlines() if not line.startswith(f"{key} = "))
    task = execute.Task(0, criterion, 0, 0, 0, overrides)
    return {
        name: execute.run_one(execute.SceneSource(f"qube_{name}", body), task, Success())
        for name, body in (("with", text), ("without", without))
    }
