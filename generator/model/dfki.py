"""The DFKI double pendulum's parameter files (model_parameters.yml) as a `FixedPendulum`.

github.com/dfki-ric-underactuated-lab/double_pendulum (BSD-3-Clause), its closed form in
src/python/double_pendulum/model/symbolic_plant.py ("UnderactuatedLecture"):

    M11 = I1 + I2 + m2 l1² + 2 m2 l1 r2 cos q2 + gr² Ir + Ir,  M12 = I2 + m2 l1 r2 cos q2 − gr Ir,
    M22 = I2 + gr² Ir;  F_j = b_j q̇_j + cf_j atan(100 q̇_j);  M q̈ + C q̇ − G + F = B τ,

in relative angles from hanging, counterclockwise. Their I1, I2 are about the joint axes, so
ipgen's J (about the CoG) is I − m r². The −gr Ir of M12 is a rotor that turns against its joint
relative to its housing: ipgen's gear ratio −gr (docs/model.md, "Geared motors at joints").
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from ipgen.model.fixed import FixedPendulum, FixedPendulumError

DFKI_KEYS: tuple[str, ...] = (
    "m1",
    "m2",
    "l1",
    "l2",
    "r1",
    "r2",
    "I1",
    "I2",
    "b1",
    "b2",
    "cf1",
    "cf2",
    "Ir",
    "gr",
    "g",
)
DFKI_COULOMB_GAIN = 100.0  # symbolic_plant.py: cf·atan(100 q̇)


def read_model_parameters(path: str | Path) -> dict[str, float]:
    """A DFKI model_parameters.yml as {name: float} (needs PyYAML: pip install pyyaml)."""
    try:
        import yaml
    except ImportError:  # pragma: no cover - the identify and test extras have it
        raise FixedPendulumError("reading DFKI's .yml files needs PyYAML: pip install pyyaml") from None
    document = yaml.safe_load(Path(path).read_text(encoding="utf-8"))
    if not isinstance(document, Mapping):
        raise FixedPendulumError(
            f"{path}: expected DFKI's model_parameters.yml (a mapping of names to numbers)"
        )
    return {str(key): float(value) for key, value in document.items()}


def dfki_pendulum(
    values: Mapping[str, float], joints: Sequence[int] = (1, 2), **changes: Any
) -> FixedPendulum:
    """The `FixedPendulum` of DFKI's parameters `values` (m1, m2, l1, l2, r1, r2, I1, I2, b1, b2,
    cf1, cf2, Ir, gr, g), in DFKI's coordinates, driven at `joints`; `changes` overrides fields.
    A rotor is modelled at a driven joint only: with one joint driven (an acrobot, a pendubot) a
    rotor inertia Ir > 0 is refused (DFKI's closed form keeps the passive motor's rotor, which
    `FixedPendulum` cannot hold); their leaderboard's parameters have Ir = 0.

    Examples
    --------
    >>> p = dfki_pendulum({"m1": 0.6, "m2": 0.5, "l1": 0.2, "l2": 0.3, "r1": 0.2, "r2": 0.3,
    ...                    "I1": 0.03, "I2": 0.05, "b1": 0, "b2": 0, "cf1": 0, "cf2": 0,
    ...                    "Ir": 0, "gr": 6, "g": 9.81})
    >>> round(p.value("J1"), 6), p.gr
    (0.006, (-6.0, -6.0))
    """
    missing = [key for key in DFKI_KEYS if key not in values]
    if missing:
        raise FixedPendulumError(
            f"DFKI parameters lack {', '.join(missing)}: expected {', '.join(DFKI_KEYS)}"
        )
    v = {key: float(values[key]) for key in DFKI_KEYS}
    if v["Ir"] != 0 and len(set(joints)) < 2 and "Ir" not in changes:
        raise FixedPendulumError(
            f"Ir = {v['Ir']:g} with joints = {tuple(joints)}: the passive joint's motor rotor is not "
            "modelled (a rotor sits at a driven joint only); set Ir to 0, as DFKI's leaderboard does, "
            "or drive both joints"
        )
    fields: dict[str, Any] = {
        "m": [v["m1"], v["m2"]],
        "l": [v["l1"], v["l2"]],
        "delta": [v["b1"], v["b2"]],
        "g": v["g"],
        "com": [v["r1"], v["r2"]],
        "J": [v["I1"] - v["m1"] * v["r1"] ** 2, v["I2"] - v["m2"] * v["r2"] ** 2],
        "coulomb": [v["cf1"], v["cf2"]],
        "coulomb_law": "atan",
        "coulomb_gain": DFKI_COULOMB_GAIN,
        "joints": tuple(joints),
        "Ir": [v["Ir"]] * len(joints),
        "gr": [-v["gr"]] * len(joints),
        "angles": "relative",
        "zero": "hanging",
        "positive": "counterclockwise",
    }
    return FixedPendulum(2, **(fields | changes))
