"""The `[controller]` table's rules that a type cannot say: the weights `q` (a diagonal or a
symmetric PSD matrix), a `gain` given for kind "gain", the `equilibrium` (named, or angles at 0 or
π), and `relations` (no driving [input]; a period in (0, t_end], commensurate with the sample).
Its keys are declared in `schema.ControllerTable`, its gain designed by `experiment.feedback`.
Every problem is one line naming the file and the key.
"""

from __future__ import annotations

from typing import Any

from pydantic import ValidationInfo

from ipgen.common import limits
from ipgen.model.coordinates import rests
from ipgen.scene.fields import format_number, one_of, type_name
from ipgen.scene.values import at, check_count, context_of, number, refuse, refuse_key

# Feedback controllers ([controller] kind) and the named equilibria they stabilise.
CONTROLLER_KINDS: tuple[str, ...] = ("lqr", "gain", "mpc")
# kind = "mpc" (docs/mpc.md): its defaults and bounds, and the keys only it takes.
MPC_MODES: tuple[str, ...] = ("rti", "converged")
MPC_SENSITIVITIES: tuple[str, ...] = ("exact", "frozen", "shifted")
DEFAULT_HORIZON = 30
MAX_HORIZON = limits.MAX_MPC_HORIZON
MAX_ITERATIONS = limits.MAX_MPC_ITERATIONS
MAX_SUBSTEPS = 100
DEFAULT_SOFT_PENALTY = (1000.0, 1000.0)  # ρ1, ρ2: an exact penalty on the QUBE's arm (docs/mpc.md)
# The refusals an MPC's soft bounds share in every scene (cart, arm and fixed chain)
BOUNDED_TWICE = "each state index may be bounded once"
PENALTY_WITHOUT_BOUNDS = (
    "weighs the violation of soft_bounds, which this MPC has none of: add soft_bounds or remove it"
)
MPC_KEYS: tuple[str, ...] = (
    "horizon", "p", "u_max", "travel", "soft_bounds", "soft_penalty", "mode", "iterations", "qp_iterations",
    "substeps", "barrier", "sensitivities",
)  # fmt: skip
SOFT_BOUNDS_SCHEMA: dict[str, Any] = {
    "type": "array",
    "items": {"type": "array", "items": {"type": "number"}, "minItems": 3, "maxItems": 3},
}
SOFT_PENALTY_SCHEMA: dict[str, Any] = {
    "type": "array", "items": {"type": "number", "minimum": 0, "maximum": limits.MAX_SOFT_PENALTY},
    "minItems": 2, "maxItems": 2,
}  # fmt: skip
EQUILIBRIA: tuple[str, ...] = ("upright", "hanging")
DEFAULT_EQUILIBRIUM = "upright"
DEFAULT_R = 1.0  # LQR weight of u²; the default Q is the identity
# A sampling period and the output interval must be whole multiples of one another, to this
# relative tolerance, so that every sampling instant or every sample is a stop of the other.
COMMENSURATE_TOLERANCE = 1e-9

WEIGHTS_SCHEMA: dict[str, Any] = {
    "oneOf": [
        {"type": "array", "items": {"type": "number", "minimum": 0}, "minItems": 4},
        {"type": "array", "items": {"type": "array", "items": {"type": "number"}}, "minItems": 4},
    ]
}
EQUILIBRIUM_SCHEMA: dict[str, Any] = {
    "oneOf": [
        {"type": "string", "enum": list(EQUILIBRIA)},
        {"type": "array", "items": {"type": "number"}, "minItems": 2},
    ]
}


def _per_state(value: Any, info: ValidationInfo, expected: str) -> dict[str, Any] | None:
    """The context once `value` is an array of 2·(links + 1) entries (θ0.. then θ̇0..), or None
    before [system] is known; `expected` (with {size}) is the message for a non-array."""
    context = context_of(info, "count")
    if context is None:
        return None
    size = 2 * context["count"]
    if not isinstance(value, list):
        refuse(expected.format(size=size, type=type_name(value)))
    check_count(value, size, f"2 · (links + 1) = {size}: θ0.. then θ̇0..")
    return context


def weights(value: Any, info: ValidationInfo) -> list[list[float]] | list[float] | None:
    """q: diagonal weights (size numbers >= 0) or a symmetric positive semidefinite matrix."""
    context = _per_state(value, info, "expected an array of {size} weights or a {size} × {size} matrix")
    if context is None:
        return None
    if all(isinstance(row, list) for row in value) and value:
        return _matrix(value, len(value), context, getattr(info, "field_name", None) or "q")
    return [at(i, _weight, item, context) for i, item in enumerate(value)]


def _weight(item: Any, context: dict[str, Any]) -> float:
    weight = number(item)
    if weight < 0:
        refuse("weights must be >= 0")
    return weight


def _matrix(rows: list[Any], size: int, context: dict[str, Any], key: str = "q") -> list[list[float]]:
    """A symmetric positive semidefinite `size` × `size` matrix of the key `key` (q or p)."""
    def row_of(row: list[Any], _: dict[str, Any]) -> list[float]:
        check_count(row, size, f"a {size} × {size} matrix")
        return [at(j, number, item, context) for j, item in enumerate(row)]

    matrix = [at(i, row_of, row, context) for i, row in enumerate(rows)]
    scale = max(1.0, max(abs(x) for row in matrix for x in row))
    for i in range(size):
        for j in range(i):
            if abs(matrix[i][j] - matrix[j][i]) > 1e-12 * scale:
                refuse_key(
                    f" = {matrix[i][j]:g} differs from {key}[{j}][{i}] = {matrix[j][i]:g}: "
                    f"{key.upper()} must be symmetric",
                    index=(i, j),
                )
    import numpy as np

    smallest = float(np.min(np.linalg.eigvalsh(np.array(matrix))))
    if smallest < -1e-12 * scale:
        refuse_key(f": {key.upper()} must be positive semidefinite (smallest eigenvalue {smallest:.3g})")
    return matrix


def gain_values(value: Any, info: ValidationInfo) -> list[float] | None:
    """gain: the 2·(links + 1) finite entries of K."""
    expected = "expected an array of the {size} entries of K (θ0.. then θ̇0..), got {type}"
    context = _per_state(value, info, expected)
    if context is None:
        return None
    return [at(i, number, item, context) for i, item in enumerate(value)]


def equilibrium(value: Any, info: ValidationInfo) -> str | list[float]:
    """ "upright", "hanging" or the dof angles [θ0, θ1, ...], each link at a multiple of π."""
    context = context_of(info, "count")
    if context is None:
        return "upright"
    dof = context["count"]
    expected = f"{one_of(EQUILIBRIA)}, or an array of {dof} angles [θ0, θ1, ...]"
    if isinstance(value, str):
        if value not in EQUILIBRIA:
            refuse(f"expected {expected}")
        return value
    if not isinstance(value, list):
        refuse(f"expected {expected}, got {type_name(value)}")
    check_count(value, dof, "θ0 and one angle per link")
    angles = [at(i, number, item, context) for i, item in enumerate(value)]
    for i, angle in enumerate(angles[1:], start=1):
        if not rests(angle):
            refuse(
                "a link rests only upright or hanging: at a multiple of π (3.141592653589793) "
                "in the scene's angles (0 upright in ipgen's; 0 hanging where they count from it)",
                key="equilibrium",
                index=(i,),
                value=value[i],
            )
    return angles


def soft_bounds(value: Any, info: ValidationInfo) -> list[tuple[int, float, float]] | None:
    """mpc's soft_bounds: [[index, min, max], ...], index a whole number into x (2·(links + 1)
    entries), min < max, each index once."""
    context = context_of(info, "count")
    if context is None:
        return None
    size = 2 * context["count"]
    if not isinstance(value, list):
        refuse(
            f"expected an array of [index, min, max] (index 0 .. {size - 1} into x), got {type_name(value)}"
        )

    def bound(item: Any, context: dict[str, Any]) -> tuple[int, float, float]:
        if not isinstance(item, list):
            refuse(f"expected [index, min, max], got {type_name(item)}")
        check_count(item, 3, "index, min, max")
        index, lo, hi = (at(j, number, entry, context) for j, entry in enumerate(item))
        if index != int(index) or not 0 <= index < size:
            refuse(f"the index must be a whole number in 0 .. {size - 1} (into x = [θ, θ̇])", value=item[0])
        if not lo < hi:
            refuse(f"expected min < max, got {format_number(lo)} >= {format_number(hi)}")
        return int(index), lo, hi

    bounds = [at(i, bound, item, context) for i, item in enumerate(value)]
    indices = [b[0] for b in bounds]
    if len(set(indices)) != len(indices):
        refuse(BOUNDED_TWICE)
    return bounds


def soft_penalty(value: Any, info: ValidationInfo) -> tuple[float, float]:
    """mpc's soft_penalty: [ρ1, ρ2], ρ1 >= 0, ρ2 > 0."""
    if not isinstance(value, list):
        refuse(f"expected [ρ1, ρ2] (a violation s costs ρ1 s + ρ2 s²), got {type_name(value)}")
    check_count(value, 2, "ρ1, ρ2")
    linear, quadratic = (at(i, number, item, {}) for i, item in enumerate(value))
    if not (0 <= linear <= limits.MAX_SOFT_PENALTY and 0 < quadratic <= limits.MAX_SOFT_PENALTY):
        refuse(f"expected 0 <= ρ1 <= {limits.MAX_SOFT_PENALTY:g} and 0 < ρ2 <= {limits.MAX_SOFT_PENALTY:g}")
    return linear, quadratic


def relations(table: Any, context: dict[str, Any]) -> None:
    """A gain given exactly for kind "gain"; no other input than zero; a period in (0, t_end],
    commensurate with the output sample."""
    given = table.model_fields_set
    if table.kind == "gain":
        if table.gain is None:
            refuse(
                'kind = "gain" runs the gain K you give: add gain = [...] (2 · (links + 1) entries)',
                key="kind",
                value=table.kind,
            )
        for key in ("q", "r") if given & {"q", "r"} else ():
            if key in given:
                refuse(
                    'weights the LQR design; kind = "gain" takes K as given: remove it',
                    key=key,
                    value=getattr(table, key),
                )
    elif "gain" in given:
        refuse(
            f'is for kind = "gain"; kind = "{table.kind}" computes '
            + ("K" if table.kind == "lqr" else "its input")
            + ' from q and r: remove gain or set kind = "gain"',
            key="gain",
            value=table.gain,
        )
    if table.kind == "mpc":
        _mpc_relations(table, given)
    else:
        for key in MPC_KEYS:
            if key in given:
                refuse(
                    'is for kind = "mpc": remove it or set kind = "mpc"', key=key, value=getattr(table, key)
                )
    input_kind = context["input_kind"]
    if input_kind != "zero":
        refuse(
            f'the controller sets u, but [input] kind "{input_kind}" drives it too; '
            'remove [input] (or set kind = "zero")',
            key="kind",
            value=table.kind,
        )
    if table.period is None:
        return
    span = limits.MAX_MPC_SPAN
    if table.kind == "mpc" and table.horizon is not None and table.horizon * float(table.period) > span:
        refuse(f"horizon · period is beyond {span:g} s", key="horizon", value=table.horizon)
    sampling_period(table.period, context["t_end"], context["sample"], "> 0 s and ")


def sampling_period(period: Any, t_end: float, sample: float, positive: str = "") -> None:
    """A controller's sampling period: in (0, t_end] (`positive` says "> 0 s and " where no type
    bound said it), at most `limits.MAX_SAMPLES` of them in t_end (each is a stop of the
    integrator), and a whole multiple or fraction of the output sample (to a relative 1e-9)."""
    period_ = float(period)
    if not 0 < period_ <= t_end:
        refuse(f"must be {positive}<= t_end ({format_number(t_end)} s)", key="period", value=period)
    if t_end / period_ > limits.MAX_SAMPLES:
        refuse(
            f"t_end / period = {t_end / period_:.3g} controller periods, more than the "
            f"{limits.MAX_SAMPLES:.0e} the simulator accepts: a longer period or a shorter t_end",
            key="period",
            value=period,
        )
    ratio = max(period_, sample) / min(period_, sample)
    if abs(ratio - round(ratio)) > COMMENSURATE_TOLERANCE * ratio:
        refuse(
            f"must be a whole multiple or a whole fraction of simulation.sample ({format_number(sample)} s)",
            key="period",
            value=period,
        )


def _mpc_relations(table: Any, given: set[str]) -> None:
    """kind = "mpc": a period and u_max (the bound on u), no saturation (u_max is its bound)."""
    if "saturation" in given:
        refuse('kind = "mpc" bounds u by u_max: remove saturation', key="saturation", value=table.saturation)
    if table.u_max is None:
        refuse('kind = "mpc" needs u_max, the bound on |u|: add u_max = ...', key="kind", value=table.kind)
    if table.period is None:
        refuse('kind = "mpc" is sampled: add period = ... (s)', key="kind", value=table.kind)
    if "soft_penalty" in given and not table.soft_bounds:
        refuse(
            PENALTY_WITHOUT_BOUNDS,
            key="soft_penalty",
            value=table.soft_penalty,
        )
