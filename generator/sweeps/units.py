"""The units of the scene keys a `--vary` grid sweeps, for its plots' axes.

A key's unit depends on the system: index 0 of a cart's arrays is the cart (m, N), of an arm's the
arm (rad, N m); a fixed chain's arrays are all links. u's unit is the scene's (`Actuator.unit`).
A key without one plain unit (weights, counts, switches, a cart's whole array of metres and
radians) has none.
"""

from __future__ import annotations

from ipgen.sweeps.spec import Key

# (table, name): (its unit on a cart's coordinate, on an angle: a link's or an arm's). Entry 0
# of an array is the base, the others links; a key of one number is the base's (a bound, a
# law's acceleration) or every coordinate's (coulomb_speed, sensors.noise)
_PER_COORDINATE = {
    ("initial", "theta"): ("m", "rad"),
    ("initial", "dtheta"): ("m/s", "rad/s"),
    ("parameters", "delta"): ("N s/m", "N m s/rad"),
    ("parameters", "coulomb"): ("N", "N m"),
    ("parameters", "coulomb_speed"): ("m/s", "rad/s"),
    ("sensors", "noise"): ("m", "rad"),
}
_BASE = {
    ("limits", "travel"): ("m", "rad"),
    ("controller", "travel"): ("m", "rad"),
    ("swingup", "x_max"): ("m", "rad"),
    ("swingup", "catch_base"): ("m", "rad"),
    ("swingup", "accel_max"): ("m/s²", "rad/s²"),
}
# keys of one unit on every system
_ANY_SYSTEM = {
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
    ("actuator", "Jm"): "kg m²",
    ("actuator", "Ir"): "kg m²",  # a fixed chain's rotor
    ("actuator", "r"): "m",
    ("actuator", "lag"): "s",
    ("controller", "period"): "s",
    ("swingup", "period"): "s",
    ("swingup", "duration"): "s",
    ("swingup", "hold"): "s",
    ("swingup", "catch_angle"): "rad",
    ("swingup", "release_angle"): "rad",
    ("swingup", "catch_rate"): "rad/s",
    ("swingup", "energy_target"): "J",
    ("swingup", "energy_step"): "J",
    ("swingup", "catch_deficit"): "J",
    ("swingup", "gain_position"): "1/s²",
    ("swingup", "gain_velocity"): "1/s",
    ("sensors", "delay"): "s",
    ("estimator", "delay"): "s",
    ("estimator", "lag"): "s",
    ("estimator", "noise_memory"): "s",
    ("estimator", "cutoff"): "rad/s",
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


def key_unit(key: Key, system: str, input_unit: str) -> str:
    """The unit of `key`'s values in a scene of `system` ("classical", "rotary" or "fixed"), whose
    u is in `input_unit`; "" where the key has no one plain unit."""
    where = (key.table, key.name)
    cart = system == "classical"
    if where in _ANY_SYSTEM:
        return _ANY_SYSTEM[where]
    if where in _INPUT:
        return input_unit
    if where in _BASE:
        return "" if system == "fixed" else _BASE[where][0 if cart else 1]
    if where in _PER_COORDINATE:
        linear, angular = _PER_COORDINATE[where]
        if not cart or (key.index is not None and key.index > 0):
            return angular
        return linear if key.index == 0 else ""  # all of a cart's coordinates: metres and radians
    return ""


def axis_label(key: Key, system: str, input_unit: str) -> str:
    """`key` as an axis label: its text with its unit in brackets, where it has one."""
    unit = key_unit(key, system, input_unit)
    return f"{key.text} [{unit}]" if unit else key.text
