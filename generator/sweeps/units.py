"""The units of the scene keys a `--vary` grid sweeps, for its plots' axes.

A key's unit depends on the system: index 0 of a cart's arrays is the cart (m, N), of an arm's the
arm (rad, N m); a fixed chain's arrays are all links. u's unit is the scene's (V for a dc_motor,
m/s² or rad/s² for an acceleration input, else N or N m). Keys whose unit is not a plain SI unit
(weights, counts, switches) have none.
"""

from __future__ import annotations

from ipgen.sweeps.spec import Key

# (table, name): (the unit on a cart's coordinate, on an angle: a link's or an arm's); entry
# index 0 is the base, the others links (a fixed chain's are all links)
_PER_COORDINATE = {
    ("initial", "theta"): ("m", "rad"),
    ("initial", "dtheta"): ("m/s", "rad/s"),
    ("parameters", "delta"): ("N s/m", "N m s/rad"),
    ("parameters", "coulomb"): ("N", "N m"),
    ("parameters", "coulomb_speed"): ("m/s", "rad/s"),  # one number for every coordinate
}
# the base's bound: one number, in the base's unit
_BASE = {("limits", "travel"), ("controller", "travel")}
# keys of one unit whatever the system
_FIXED = {
    ("parameters", "m"): "kg",
    ("parameters", "l"): "m",
    ("parameters", "com"): "m",
    ("parameters", "J"): "kg m²",
    ("parameters", "J_axial"): "kg m²",
    ("parameters", "tip"): "kg",
    ("parameters", "g"): "m/s²",
    ("actuator", "Rm"): "Ω",
    ("actuator", "kt"): "N m/A",
    ("actuator", "km"): "V s/rad",
    ("actuator", "lag"): "s",
    ("controller", "period"): "s",
    ("swingup", "period"): "s",
    ("swingup", "duration"): "s",
    ("swingup", "hold"): "s",
    ("swingup", "catch_angle"): "rad",
    ("swingup", "release_angle"): "rad",
    ("swingup", "catch_base"): "rad",
    ("swingup", "catch_rate"): "rad/s",
    ("swingup", "energy_target"): "J",
    ("swingup", "energy_step"): "J",
    ("swingup", "catch_deficit"): "J",
    ("sensors", "delay"): "s",
    ("simulation", "t_end"): "s",
    ("simulation", "sample"): "s",
}
# keys in u's unit
_INPUT = {
    ("actuator", "noise"),
    ("controller", "saturation"),
    ("controller", "u_max"),
    ("swingup", "u_max"),
}


def key_unit(key: Key, system: str, input_unit: str | None) -> str:
    """The unit of `key`'s values in a scene of `system` ("classical", "rotary" or "fixed"), whose
    u is in `input_unit` (None: a force or torque); "" where the key has no plain unit."""
    where = (key.table, key.name)
    if where in _FIXED:
        return _FIXED[where]
    if where in _BASE:
        return "m" if system == "classical" else "rad"
    if where in _PER_COORDINATE:
        linear, angular = _PER_COORDINATE[where]
        if system != "classical" or (key.index is not None and key.index > 0):
            return angular
        return linear if key.index == 0 else ""  # the whole array of a cart's: metres and radians
    if where in _INPUT:
        return input_unit or ("N" if system == "classical" else "N m")
    return ""


def axis_label(key: Key, system: str, input_unit: str | None) -> str:
    """`key` as an axis label: its text with its unit in brackets, where it has one."""
    unit = key_unit(key, system, input_unit)
    return f"{key.text} [{unit}]" if unit else key.text
