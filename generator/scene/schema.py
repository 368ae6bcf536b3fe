"""What a scene file may contain: tables, keys, choices, defaults and C++ naming rules.

Pure data, no logic: `ipgen.scene` reads and checks scene files against it.
"""

from __future__ import annotations

import re

from ipgen.common import limits
from ipgen.model import system as model

# Every table a scene may have and the keys each may contain, in the order they are documented.
TABLES: dict[str, tuple[str, ...]] = {
    "system": ("type", "links", "inertia", "name", "specialise", "emit"),
    "parameters": ("m", "l", "delta", "g", "com", "J", "J_axial", "tip", "free"),
    "initial": ("theta", "dtheta"),
    "input": ("kind", "amplitude", "start", "duration", "time", "frequency", "phase"),
    "simulation": ("t_end", "sample", "method", "jacobian", "rtol", "atol", "step", "max_steps"),
    "outputs": ("energy",),
    "controller": ("kind", "q", "r", "equilibrium", "saturation", "period"),
}

SYSTEM_TYPES = model.SYSTEM_TYPES
INERTIAS = model.INERTIA_VARIANTS
# Integration methods (the C++ simulator's names): CVODE's, ARKODE's explicit Runge-Kutta and a
# fixed-step RK4. Which settings each one uses:
METHODS: tuple[str, ...] = (
    "bdf",
    "adams",
    "adams-fixed-point",
    "erk-dp5",
    "erk-fehlberg8",
    "rk4",
)
JACOBIAN_METHODS: tuple[str, ...] = ("bdf", "adams")  # Newton iteration: jacobian = exact | dq
FIXED_STEP_METHODS: tuple[str, ...] = ("rk4",)  # step required; rtol and atol do not apply
JACOBIANS: tuple[str, ...] = ("exact", "dq")

# Input kinds: the keys each one uses (in resolved-config order) and which of them are required.
INPUT_KEYS: dict[str, tuple[str, ...]] = {
    "zero": (),
    "constant": ("amplitude",),
    "pulse": ("amplitude", "start", "duration"),
    "step": ("amplitude", "time"),
    "sine": ("amplitude", "frequency", "phase"),
}
INPUT_REQUIRED: dict[str, tuple[str, ...]] = {
    "zero": (),
    "constant": ("amplitude",),
    "pulse": ("amplitude", "duration"),
    "step": ("amplitude", "time"),
    "sine": ("amplitude", "frequency"),
}
INPUT_DEFAULTS: dict[str, float] = {"start": 0.0, "phase": 0.0}

# Feedback controllers ([controller] kind) and the named equilibria they stabilise.
CONTROLLER_KINDS: tuple[str, ...] = ("lqr",)
EQUILIBRIA: tuple[str, ...] = ("upright", "hanging")
DEFAULT_EQUILIBRIUM = "upright"
DEFAULT_R = 1.0  # LQR weight of u²; the default Q is the identity
# A sampling period and the output interval must be whole multiples of one another, to this
# relative tolerance, so that every sampling instant or every sample is a stop of the other.
COMMENSURATE_TOLERANCE = 1e-9

# Defaults of optional scalar keys.
DEFAULT_INERTIA = "pivot"
DEFAULT_G = "9.81"  # as text: the exact decimal is kept next to the float
DEFAULT_SAMPLE = 0.01
DEFAULT_METHOD = "bdf"
DEFAULT_JACOBIAN = "exact"
DEFAULT_RTOL = 1e-10
DEFAULT_ATOL = 1e-12
DEFAULT_MAX_STEPS = 100_000

# rtol below RTOL_MIN cannot be met in double precision; below RTOL_ADVISED it is unlikely to be.
RTOL_MIN = limits.RTOL_MIN  # shared with the simulator (limits.py)
RTOL_ADVISED = 1e-14

# Scene file stems end up in output file names and in the resolved config.
STEM = re.compile(r"[A-Za-z0-9_][A-Za-z0-9_.+-]*\Z")
