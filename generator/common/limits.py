"""The limits on input that ipgen and the simulator share, in one place.

The C++ simulator has the same numbers in `cpp/include/ipsim/limits.hpp`;
`tests/test_bad_input_properties.py` parses that header and fails when the two differ, so a
scene the generator accepts is never refused by the simulator for a limit.

Why these values:

- `MIN_T_END`: a run lasts at least a nanosecond (1e-9 s). CVODE refuses a stop time of 1e-200 s
  as "behind the current t = 0"; shorter than a nanosecond is no simulation of a pendulum.
- `MAX_SAMPLES`: t_end / sample output samples at most. The simulator writes one CSV row per
  sample as the run reaches it (its memory does not grow with the samples; a C++ caller of
  ipsim::simulate without a sink keeps them, 2 kDof + 1 doubles each): 1e7 samples of a double
  pendulum are about 1.4 GB of CSV; more is a typo (t_end = 1e7 s with the default sample
  0.01 s asks for 1e9) rather than an experiment.
- `RTOL_MIN`: a relative tolerance below 1e-15 is below double precision's resolution
  (2.2e-16 per step, accumulated): CVODE and ARKODE cannot meet it. rtol must also be < 1.
- `MAX_SCENE_BYTES` (256 KiB), `MAX_SCENE_NESTING`, `MAX_DOTTED_KEY_PARTS`: checked before the TOML
  parser sees a scene. A scene is a few hundred bytes with tables one level deep; tomllib recurses
  once per nested array (a RecursionError past ~1,000 levels) and spends memory quadratic in a
  dotted key's length (2.4 GB for 20,000 parts).
- `MAX_NAME_LENGTH`, `MAX_STEM_LENGTH`: a model name becomes a C identifier (C99 guarantees
  63 significant characters) and file names `<name>.hpp`, `<stem>.cfg`, `<stem>.csv` plus the
  simulator's temporary files, which must stay below the file system's 255 bytes.
- `FOLD_*`: a value folded into a specialised header is an exact rational; its decimal exponent
  must lie in [FOLD_MIN_EXPONENT, FOLD_MAX_EXPONENT] and it may have at most FOLD_MAX_DIGITS
  significant digits (a double needs 17), so that the rational arithmetic stays small
  (1e-99999999 would carry a hundred-million-digit denominator through the derivation).
- `MAX_SIMULATED_LINKS`: the simulator compiled once holds a model of up to this many links in
  stack arrays of a fixed capacity (`IPGEN_MAX_DOF` - 1 in cpp/include/ipgen_model.h: no
  allocation per right-hand side); a larger chain's header still compiles into a simulator of its
  own (CMake's `ipgen_add_simulator`). It bounds the numeric API too (`Pendulum`, and
  `FixedPendulum` at one more link: a chain on a fixed pivot has no base coordinate): linearize,
  lqr, mpc, kalman and the gym derive the model per call, and 1000 links ran out of memory (or
  FLINT aborted the process) instead of being refused.
- `LINKS_WITHOUT_FORCE`: more links than this cost minutes and gigabytes to derive; the command
  needs --force for them and `ipgen.derive` force=True.
- `MAX_INTEGER_SETTING`: the largest seed and max_steps, 2^63 − 1024, the largest double below
  2^63: the simulator checks its rules on doubles (and keeps the value in a 64-bit long), so a
  larger integer rounded to 2^63 there and was refused after ipgen had taken it.
- `MAX_DELAY_PERIODS`, `DELAY_TOLERANCE`: sensors.delay is a whole number k of sampling periods,
  k <= 1e6 (a longer delay is a unit slip and would hold a queue of that many outputs), with
  k = round(delay / period) and |delay − k · period| <= DELAY_TOLERANCE · max(delay, period).
  The scene layer (`experiment.loop`) and the simulator (`ipsim/scene.hpp`) apply this one rule.
- `MESSAGE_VALUE_CHARS`, `MESSAGE_PATH_CHARS`: a value (a path) quoted in a message is cut to
  this many characters, in the middle.
- `MAX_MPC_BARRIER`: the MPC's barrier weight (`[controller] barrier`, `ipgen.mpc(barrier=)`) is
  in the cost's units; 1e6 is far above any cost's scale and finite in float, where the C header's
  step may run (a larger one would turn into inf there and every step refuse its settings).
- `MAX_SAMPLE_GROWTH`: a mode growing more than 1e8-fold over one sample (|eig A_d|, A_d =
  e^(A T)) cannot be estimated or held in double precision: the Riccati equation's numbers span
  more than its digits (a 10 nm link at 10 ms: 4e172; a 0.5 m cart pendulum at 100 s: 1e244; at
  1 s, 276, is still designed). The Kalman filter refuses such a period; a sampled LQR that
  cannot be designed names it as the cause.
- `MAX_MPC_SPAN`, `MIN_MPC_PERIOD`: an MPC predicts at most 1000 s ahead (horizon · period) and
  is sampled at most every microsecond, in a scene and in `ipgen.mpc` alike.
"""

from __future__ import annotations

from typing import Any

MAX_SAMPLES = 10_000_000
MIN_T_END = 1e-9
MAX_SIMULATED_LINKS = 40
MAX_SAMPLE_GROWTH = 1e8
MAX_FIXED_LINKS = MAX_SIMULATED_LINKS + 1  # the same degrees of freedom, none of them a base
LINKS_WITHOUT_FORCE = 30
RTOL_MIN = 1e-15
MAX_SCENE_BYTES = 1 << 18
MAX_SCENE_NESTING = 16
MAX_DOTTED_KEY_PARTS = 16
MAX_NAME_LENGTH = 63
MAX_STEM_LENGTH = 100
FOLD_MIN_EXPONENT = -30
FOLD_MAX_EXPONENT = 30
FOLD_MAX_DIGITS = 30
MAX_INTEGER_SETTING = 2**63 - 1024
MAX_DELAY_PERIODS = 1_000_000
DELAY_TOLERANCE = 1e-9
MESSAGE_VALUE_CHARS = 60
MESSAGE_PATH_CHARS = 240
MAX_MPC_BARRIER = 1e6
# An MPC's soft-bound penalty ρ1, ρ2 at most: its QP breaks down from about 1e12 (docs/mpc.md);
# the default 1000 is an exact penalty on the QUBE's arm
MAX_SOFT_PENALTY = 1e6
# An MPC's horizon and its iteration budgets at most (as a scene's [controller])
MAX_MPC_HORIZON = 1000
MAX_MPC_ITERATIONS = 1000
# An MPC's prediction, horizon · period, at most [s]; and its period at least [s] (below it the
# discretisation's Riccati equation loses its digits: no pendulum is sampled that fast)
MAX_MPC_SPAN = 1000.0
MIN_MPC_PERIOD = 1e-6


# An exact rational of a decimal costs time and memory with its exponent (1e-99999999 as a
# Fraction: minutes): what becomes one exactly stays within these.
EXACT_MAX_EXPONENT = 400
EXACT_MAX_DIGITS = 1000


def exact_problem(value: Any) -> str | None:
    """Why the decimal `value` (a Decimal or its text) is too large to be made an exact rational
    cheaply, or None (also for what is no decimal: that is another check's)."""
    from decimal import Decimal, InvalidOperation

    try:
        number = value if isinstance(value, Decimal) else Decimal(str(value).strip())
    except (InvalidOperation, ValueError):
        return None
    if not number.is_finite() or number == 0:
        return None
    if abs(number.adjusted()) > EXACT_MAX_EXPONENT or len(number.as_tuple().digits) > EXACT_MAX_DIGITS:
        return (
            f"outside 1e-{EXACT_MAX_EXPONENT} .. 1e{EXACT_MAX_EXPONENT} or over {EXACT_MAX_DIGITS} digits"
        )
    return None


def fold_problem(text: str) -> str | None:
    """Why the number `text` (a decimal such as 0.275 or 1e-3, or a fraction p/q) cannot be
    folded into a header as an exact rational, or None. Checked on the text, before any
    rational is formed, so that 1e-99999999 costs nothing."""
    from decimal import Decimal, InvalidOperation

    parts = text.strip().split("/")
    if len(parts) > 2:
        return "is not a number"
    for part in parts:
        try:
            value = Decimal(part.strip())
        except InvalidOperation:
            return "is not a number"
        if not value.is_finite():
            return "must be finite"
        digits = "".join(map(str, value.as_tuple().digits)).strip("0")
        if len(parts) == 2 and value.as_tuple().exponent != 0:
            return "a fraction p/q takes integers p and q"
        exponent = value.as_tuple().exponent
        assert isinstance(exponent, int)  # finite
        if not FOLD_MIN_EXPONENT - FOLD_MAX_DIGITS <= exponent <= FOLD_MAX_EXPONENT:  # 0e-999999999 too
            return (
                f"is outside what folding accepts: 0, or at most {FOLD_MAX_DIGITS} significant digits "
                f"with a magnitude from 1e{FOLD_MIN_EXPONENT} to 1e{FOLD_MAX_EXPONENT}"
            )
        if value == 0:
            continue
        if not FOLD_MIN_EXPONENT <= value.adjusted() <= FOLD_MAX_EXPONENT or len(digits) > FOLD_MAX_DIGITS:
            return (
                f"is outside what folding accepts: 0, or at most {FOLD_MAX_DIGITS} significant digits "
                f"with a magnitude from 1e{FOLD_MIN_EXPONENT} to 1e{FOLD_MAX_EXPONENT}"
            )
    return None
