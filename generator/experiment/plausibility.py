"""Unit slips: values far outside what any pendulum rig has, warned about (not refused).

A scene in SI units with millimetres for metres (l = [600, 500, 500]), grams for kilograms, or
degrees for radians is still a valid model, so it runs; these bounds, far above any laboratory
or industrial pendulum, catch the slip and say which unit was probably meant."""

from __future__ import annotations

import math
from collections.abc import Sequence

from ipgen.scene.fields import format_number

__all__ = ["HEAVIEST", "LONGEST", "unit_slips"]

LONGEST = 10.0  # m: no arm, link or cart rod of a pendulum rig is longer
HEAVIEST = 1000.0  # kg: no cart, arm or link of a pendulum rig is heavier
WIDEST_ANGLE = 2 * math.pi  # rad: an initial angle beyond one full turn


def unit_slips(
    system_type: str, m: Sequence[float], l: Sequence[float], theta: Sequence[float]  # noqa: E741
) -> list[str]:
    """One line per value far outside any pendulum rig: lengths l > 10 m, masses m > 1000 kg,
    initial angles |θ| > 2π (the link angles; on a rotary pendulum the arm's too)."""
    found = []
    for i, value in enumerate(l):
        if value > LONGEST:
            found.append(
                f"parameters.l[{i}] = {format_number(value)} m is longer than any pendulum rig "
                f"(> {LONGEST:g} m): lengths are in metres (millimetres? {format_number(value / 1000)} m)"
            )
    for i, value in enumerate(m):
        if value > HEAVIEST:
            found.append(
                f"parameters.m[{i}] = {format_number(value)} kg is heavier than any pendulum rig "
                f"(> {HEAVIEST:g} kg): masses are in kilograms (grams? {format_number(value / 1000)} kg)"
            )
    first_angle = 0 if system_type == "rotary" else 1
    for i, value in enumerate(theta):
        if i >= first_angle and abs(value) > WIDEST_ANGLE:
            found.append(
                f"initial.theta[{i}] = {format_number(value)} rad is more than a full turn (2π): "
                f"angles are in radians (degrees? {math.radians(value):.4g} rad)"
            )
    return found
