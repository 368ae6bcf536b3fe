"""The rig's own coordinates, re-exported where the control code has always found them.

The convention is a fact of the system, so `Coordinates` lives with the model
(`model.coordinates`, which `model.pendulum.Pendulum` uses); this module keeps every import of
`ipgen.control.coordinates` working.
"""

from __future__ import annotations

from ipgen.model.coordinates import ANGLES, POSITIVE, ZEROS, CoordinateError, Coordinates

__all__ = ["ANGLES", "POSITIVE", "ZEROS", "CoordinateError", "Coordinates"]
