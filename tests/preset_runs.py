"""One sweep run of qube_servo2_mpc_swingup_m4f as shipped and without one of its keys: how the
tests show what a key buys on a rig unlike the loop's model (the loop kept nominal, as a sweep
keeps it)."""

from __future__ import annotations

from pathlib import Path

PRESET = Path(__file__).resolve().parents[1] / "scenes" / "rigs" / "qube_servo2_mpc_swingup_m4f.toml"


def with_and_without(key: str, criterion: str, overrides: tuple[tuple[str, object], ...]) -> dict:
    """{"with": Result, "without": Result}: the preset, and the preset without its line `key = ...`,
    each run once with `overrides` (ipgen.sweeps.execute.run_one, the default success test)."""
    from ipgen.sweeps import execute
    from ipgen.sweeps.success import Success

    text = PRESET.read_text()
    assert f"\n{key} = " in text, f"the preset has no {key}"
    without = "\n".join(line for line in text.splitlines() if not line.startswith(f"{key} = "))
    task = execute.Task(0, criterion, 0, 0, 0, overrides)
    return {
        name: execute.run_one(execute.SceneSource(f"qube_{name}", body), task, Success())
        for name, body in (("with", text), ("without", without))
    }
