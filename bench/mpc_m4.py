"""One real-time iteration of the MPC on a Cortex-M4F, counted under QEMU (issue 47).

    .venv/bin/python -m bench.mpc_m4 [--samples K] [--out docs/bench/mpc.md]

Also DFKI's pendubot: scenes/rigs/pendubot_mpc.toml's chain and [controller] (N = 40 samples of
10 ms, |u| <= 6 N m) without its [swingup], holding the upright from 0.14 rad off at rest, its
header's `ipgen_pendubot_mpc_step` on the simulator's states mapped to the header's coordinates.

The preset scenes/rigs/qube_servo2_mpc.toml (the QUBE-Servo 2 in volts, ±10 V, the arm within
±1 rad, N = 30 samples of 10 ms) with emit = ["c"]: its generated C header in float
(IPGEN_SCALAR = float: ipgen_mpc.h printed whole, the header's own model as the callback) is
compiled for the Cortex-M4F (bench/m4_cycles.py: arm-none-eabi-gcc -mcpu=cortex-m4
-mfloat-abi=hard -O3, newlib: the header fixes the sizes at compile time and -O3 unrolls
the loops over them) and `ipgen_qube_servo2_mpc_mpc_step` is called on the first K state
estimates of the simulator's own run of the preset (its hat_* columns: the cold first step, then
the real-time iteration along the closed loop, where u reaches its bound and the arm its
travel). Twice: with the preset's method (the interior point to its tolerance, RK4's exact
sensitivities) and with the microcontroller's (FAST: `barrier = 1e-3`, `qp_iterations = 1`,
`sensitivities = "frozen"` added to its [controller]); each run on its own simulator run's
estimates. Then the QUBE swing-up's MPC: the preset qube_servo2_mpc_swingup_fast's [controller]
(two Newton steps a sample, the arm's soft bound besides its hard one) in place of
qube_servo2_mpc's, on the same hold, and with one Newton step; both also without the soft bound; and
qube_servo2_mpc_swingup_m4f's [controller] (two Newton steps on shifted sensitivities, no soft bound),
and that preset on its own catch (its header, the estimates of its swing-up from the catch on). QEMU
counts the instructions of each call exactly; the cycles are bench/m4_cycles.py's
estimate (each instruction weighted by the Cortex-M4 TRM's cycle count, zero-wait-state memory,
a taken branch 1 + 2), µs at 168 MHz (an STM32F405/407's clock). RAM: the MPC's state (its
workspace, IPGEN_MPC_WORK reals, and its info) from the ELF's symbol, plus the stack of the call
(gcc -fstack-usage); flash: the ELF's text (the whole program: the step, the model, newlib's
sqrtf/sinf/cosf) and bench_call's own size.

--profile adds where the RTI steps' instructions go (for each method), by function (addr2line's name of each
executed address, the innermost inlined function; the ELF built with -g, which changes no
instruction). Replaces the section between the markers below in --out (docs/bench/mpc.md).
"""

from __future__ import annotations

import argparse
import io
import re
import statistics
import subprocess
import tempfile
import tomllib
from contextlib import redirect_stderr, redirect_stdout
from pathlib import Path

import numpy as np

from bench import m4_cycles
from bench.report import ROOT

CLOCK_MHZ = 168.0
# The microcontroller's method (docs/mpc.md), lines added to the preset's [controller].
FAST = 'barrier = 0.001\nqp_iterations = 1\nsensitivities = "frozen"\n'
METHODS = (
    ("the interior point (the preset's method)", ""),
    ("FAST: one barrier Newton step, frozen sensitivities", FAST),
)
# The QUBE swing-up's MPC: qube_servo2_mpc_swingup_fast's [controller] (its method: two Newton steps
# a sample at κ = 0.1; the arm's hard bound at 0.98 rad and soft bound at 0.9 rad) in place of
# qube_servo2_mpc's, on that preset's hold; and the same with one Newton step; and both without
# the soft bound (the hard one only: docs/mpc.md's designs of 99.0 and 98.6 %).
SWINGUP_FAST = "qube_servo2_mpc_swingup_fast"
# ... and qube_servo2_mpc_swingup_m4f's: two Newton steps on shifted sensitivities, no soft bound.
SWINGUP_M4F = "qube_servo2_mpc_swingup_m4f"
M4F_METHODS = (("its method: two barrier Newton steps, shifted sensitivities, no soft bound", ""),)
SWINGUP_METHODS = (
    ("its method: two barrier Newton steps (κ = 0.1)", ""),
    ("one barrier Newton step (κ = 0.1)", "qp_iterations = 1\n"),
    ("without the soft bound, two barrier Newton steps", "soft_bounds = []\n"),
    ("without the soft bound, one barrier Newton step", "soft_bounds = []\nqp_iterations = 1\n"),
)
BEGIN, END = "<!-- bench.mpc_m4: begin -->", "<!-- bench.mpc_m4: end -->"
NAME = "qube_servo2_mpc"
# DFKI's pendubot (scenes/rigs/pendubot_mpc.toml's chain and MPC, N = 40) holding the upright from
# a tilt: the preset without its [swingup], started 0.14 rad off (DFKI's coordinates), run 2 s.
PENDUBOT = "pendubot"
STATE = ("theta0", "theta1", "dtheta0", "dtheta1")  # the CSV's columns of x


def _run_scene(folder: Path, text: str, name: str) -> Path:
    """`ipgen --scene` (the C header) and `ipgen run` of the scene `text`; the run's CSV."""
    from ipgen.command.cli import run

    scene = folder / f"{name}.toml"
    scene.write_text(text)
    generate = ["--scene", str(scene), "-o", str(folder)]
    for argv in (generate, ["run", str(scene), "-o", str(folder / "run"), "--no-plot"]):
        with redirect_stdout(io.StringIO()), redirect_stderr(io.StringIO()) as err:
            if run(argv) != 0:
                raise SystemExit(err.getvalue())
    return folder / "run" / f"{name}.csv"


def _cells(csv: Path) -> dict[str, list[str]]:
    """The CSV's columns by name, as text."""
    header, *rows = csv.read_text().splitlines()
    cells = [row.split(",") for row in rows]
    return {name: [row[i] for row in cells] for i, name in enumerate(header.split(","))}


def _columns(csv: Path | dict[str, list[str]], names: tuple[str, ...]) -> np.ndarray:
    """The columns `names` (rows × names) of the CSV or of its `_cells`, as numbers."""
    cells = _cells(csv) if isinstance(csv, Path) else csv
    return np.array([[float(value) for value in cells[name]] for name in names]).T


def _scene(folder: Path, controller: str = "") -> tuple[Path, np.ndarray]:
    """The preset with emit = ["c"] (and `controller`'s lines added to its [controller]): its
    header's path and the simulator's state estimates."""
    text = (ROOT / "scenes" / "rigs" / f"{NAME}.toml").read_text()
    return _qube(folder, text.replace("\n[controller]\n", f"\n[controller]\n{controller}", 1))


def _qube(folder: Path, text: str) -> tuple[Path, np.ndarray]:
    """NAME's scene `text` with emit = ["c"]: its header's path and the simulator's state estimates."""
    csv = _run_scene(folder, text.replace(f'name = "{NAME}"', f'name = "{NAME}"\nemit = ["c"]'), NAME)
    return folder / f"{NAME}.h", _columns(csv, tuple(f"hat_{n}" for n in STATE))


def _table(scene: str, name: str) -> tuple[list[str], list[str], list[str]]:
    """scenes/rigs/SCENE.toml's lines before the table [NAME]'s header, its rows (up to the next
    table's header), and the lines from that header on."""
    lines = (ROOT / "scenes" / "rigs" / f"{scene}.toml").read_text().splitlines()
    header = re.compile(rf"^\[{name}\]\s*(#.*)?$")
    start = next(i for i, line in enumerate(lines) if header.match(line))
    end = next((i for i in range(start + 1, len(lines)) if lines[i].startswith("[")), len(lines))
    return lines[:start], lines[start + 1 : end], lines[end:]


def _swingup_mpc(folder: Path, controller: str = "", preset: str = SWINGUP_FAST) -> tuple[Path, np.ndarray]:
    """`preset`'s [controller] in place of NAME's (`controller`'s keys replacing its own): the
    header's path and the simulator's state estimates of NAME's hold."""
    rows = _table(preset, "controller")[1]
    for line in controller.splitlines():
        key = line.split("=")[0].strip()
        found = [i for i, row in enumerate(rows) if row.split("=")[0].strip() == key]
        if not found:
            raise SystemExit(f"bench.mpc_m4: {preset}'s [controller] has no {key} to replace")
        rows[found[0]] = line
    before, _, after = _table(NAME, "controller")
    return _qube(folder, "\n".join([*before, "[controller]", *rows, *after]))


def _m4f_mpc(folder: Path, controller: str = "") -> tuple[Path, np.ndarray]:
    """SWINGUP_M4F's [controller] on NAME's hold (as _swingup_mpc)."""
    return _swingup_mpc(folder, controller, SWINGUP_M4F)


def _m4f_catch(folder: Path, controller: str = "") -> tuple[Path, np.ndarray]:
    """SWINGUP_M4F's own run from hanging (its C header, `controller`'s lines added to its
    [controller]): the estimates at its MPC's samples from the catch on, the link's angle taken
    from the upright it was caught at (θ1 − 2πk, as the loop hands it to the MPC)."""
    text = (ROOT / "scenes" / "rigs" / f"{SWINGUP_M4F}.toml").read_text()
    text = text.replace(f'name = "{SWINGUP_M4F}"', f'name = "{SWINGUP_M4F}"\nemit = ["c"]')
    text = text.replace("\n[controller]\n", f"\n[controller]\n{controller}", 1)
    cells = _cells(_run_scene(folder, text, SWINGUP_M4F))
    scene = tomllib.loads(text)
    every = round(scene["controller"]["period"] / scene["simulation"]["sample"])  # the MPC's samples
    first = cells["phase"].index("hold")
    states = _columns(cells, tuple(f"hat_{n}" for n in STATE))[first::every]
    states[:, 1] -= 2 * np.pi * np.round(states[:, 1] / (2 * np.pi))
    return folder / f"{SWINGUP_M4F}.h", states


def _pendubot(folder: Path, controller: str = "") -> tuple[Path, np.ndarray]:
    """PENDUBOT's scene (and `controller`'s lines): its header's path and the simulator's states
    at its samples in the header's (canonical) coordinates."""
    from ipgen.control.fixed_linear import canonical_states
    from ipgen.model.fixed import FixedPendulum

    text = (ROOT / "scenes" / "rigs" / "pendubot_mpc.toml").read_text()
    text = text.split("[swingup]")[0] + "[controller]" + text.split("[controller]")[1]
    text = text.replace("\ntheta = [0.0, 0.0]", "\ntheta = [3.0, 0.1]").replace("t_end = 10.0", "t_end = 2.0")
    text = text.replace("sample = 0.002", "sample = 0.01")
    text = text.replace("\n[controller]\n", f"\n[controller]\n{controller}", 1)
    text = text.replace('type = "fixed"\n', f'type = "fixed"\nname = "{PENDUBOT}"\nemit = ["c"]\n', 1)
    csv = _run_scene(folder, text, PENDUBOT)
    chain = FixedPendulum.from_scene(folder / f"{PENDUBOT}.toml")
    states = canonical_states(chain, _columns(csv, STATE))
    return folder / f"{PENDUBOT}.h", states


def _prelude(states: np.ndarray, name: str = NAME) -> str:
    rows = ",\n  ".join("{" + ", ".join(f"{v!r}f" for v in row) + "}" for row in states.tolist())
    return (
        "#define IPGEN_SCALAR float\n"
        f'#include "{name}.h"\n'
        f"ipgen_{name}_mpc_state bench_mpc;\n"
        "volatile float bench_sink;\n"
        f"static const float bench_states[{len(states)}][4] = {{\n  {rows}\n}};\n"
    )


def _call(name: str = NAME) -> str:
    return f"  bench_sink = ipgen_{name}_mpc_step(&bench_mpc, bench_states[k]);"


def _call_tree(
    elf: Path, usage: dict[str, int], name: str, root: str = "bench_call"
) -> tuple[int, set[str]]:
    """The stack of `root` and its deepest chain of calls (gcc -fstack-usage per function; a call
    is a bl or a branch, conditional too, to a function's symbol in the disassembly, a blx
    through a register one to the MPC's model callback; newlib's functions, without .su, count 0)
    and the functions of the program's own source that `root` reaches (itself included)."""
    disassembly = [m4_cycles.OBJDUMP, "-d", str(elf)]
    text = subprocess.run(disassembly, capture_output=True, text=True, check=True).stdout
    calls: dict[str, set[str]] = {}
    current = ""
    # bl, or a (conditional) branch to a function's entry: a tail call
    conditions = "eq|ne|cs|cc|hs|lo|mi|pl|vs|vc|hi|ls|ge|lt|gt|le"
    branch = re.compile(rf"\s(?:bl|b(?:{conditions})?(?:\.w|\.n)?)\s+[0-9a-f]+ <([^>+]+)>$")
    for line in text.splitlines():
        if match := re.match(r"^[0-9a-f]+ <([^>]+)>:$", line):
            current = match.group(1)
            calls.setdefault(current, set())
        elif (match := branch.search(line)) and match.group(1) != current:
            calls[current].add(match.group(1))
        elif re.search(r"\sblx\s+(?:r\d+|fp|ip|sl|lr)$", line):  # through a pointer: the model callback
            calls[current].add(f"ipgen_{name}_mpc_dynamics")
    reached: set[str] = set()

    def own(name: str) -> str:  # gcc's clone `f.constprop.0` is `f.constprop` in its .su file
        return re.sub(r"\.\d+$", "", name)

    def depth(name: str, seen: frozenset[str]) -> int:
        if own(name) in usage:
            reached.add(name)
        below = [depth(c, seen | {c}) for c in calls.get(name, ()) if c not in seen]
        return usage.get(own(name), 0) + max(below, default=0)

    return depth(root, frozenset({root})), reached


def _sizes(header: Path, prelude: str, name: str) -> dict[str, int]:
    """RAM and flash of the counting program (the same build as m4_cycles.count)."""
    with tempfile.TemporaryDirectory(prefix="ipgen-m4-size.") as folder:
        work = Path(folder)
        (work / "link.ld").write_text(m4_cycles.LINKER_SCRIPT)
        program = m4_cycles.PROGRAM % {"prelude": prelude, "call": _call(name), "calls": 1}
        (work / "main.c").write_text(program)
        elf = work / "main.elf"
        subprocess.run(
            [m4_cycles.CC, "-std=c99", *m4_cycles.TARGET, "-fstack-usage", "-nostartfiles", "-T",
             str(work / "link.ld"), f"-I{header.parent}", str(work / "main.c"), "-o", str(elf), "-lm", "-lc",
             "-lgcc"],
            check=True, capture_output=True, text=True, cwd=work,
        )  # fmt: skip
        usage = {}
        for su in work.glob("*.su"):
            for line in su.read_text().splitlines():
                fields = line.split("\t")
                usage[fields[0].rsplit(":", 1)[-1]] = int(fields[1])
        size = subprocess.run(["arm-none-eabi-size", "-A", str(elf)], capture_output=True, text=True).stdout
        sections = {m.group(1): int(m.group(2)) for m in re.finditer(r"^(\.\w+)\s+(\d+)", size, re.M)}
        nm = subprocess.run(["arm-none-eabi-nm", "-S", str(elf)], capture_output=True, text=True).stdout
        symbols = {f[3]: int(f[1], 16) for f in (line.split() for line in nm.splitlines()) if len(f) == 4}
        stack, own = _call_tree(elf, usage, name)
        return {
            "state": symbols.get("bench_mpc", 0),
            "stack": stack,
            "step": sum(symbols.get(name, 0) for name in own),
            "text": sections.get(".text", 0),
            "states_table": symbols.get("bench_states", 0),
        }


def _profile_lines(functions: tuple[tuple[str, int], ...]) -> list[str]:
    """With --profile: the RTI steps' instructions by function (the innermost inlined one)."""
    if not functions:
        return []
    total = sum(n for _, n in functions)
    shown = [(name, n) for name, n in functions if n >= 0.01 * total]
    shares = ", ".join(f"`{name}` {100 * n / total:.0f} %" for name, n in shown)
    head = "Where the RTI steps' instructions go (`--profile`, by function, those of 1 % and more)"
    return ["", f"{head}: {shares}."]


# (the header's name, what the rows say, the scene maker, its methods)
CASES = (
    (NAME, "the QUBE", _scene, METHODS),
    (NAME, "the QUBE swing-up's MPC", _swingup_mpc, SWINGUP_METHODS),
    (NAME, "the QUBE swing-up's MPC for the M4F", _m4f_mpc, M4F_METHODS),
    (SWINGUP_M4F, "qube_servo2_mpc_swingup_m4f on its own catch", _m4f_catch, (("its method", ""),)),
    (PENDUBOT, "DFKI's pendubot", _pendubot, METHODS),
)


def _method(name: str, controller: str, args: argparse.Namespace, case: tuple) -> tuple[list[str], list[str]]:
    """The table rows and the paragraph (RAM, flash, profile) of one method on one case."""
    model, what, scene, _ = case
    name = f"{what}, {name}"
    with tempfile.TemporaryDirectory(prefix="ipgen-mpc-m4.") as folder:
        header, states = scene(Path(folder), controller)
        states = states[: args.samples]
        prelude = _prelude(states, model)
        counts = m4_cycles.count(header, prelude, _call(model), len(states), profile=args.profile)
        sizes = _sizes(header, prelude, model)
    rti_i, rti_c = counts.instructions[1:], counts.cycles[1:]
    us = [c / CLOCK_MHZ for c in rti_c]
    rows = [
        f"| {name}: RTI step, median of {len(rti_c)} | {int(statistics.median(rti_i)):,} "
        f"| {int(statistics.median(rti_c)):,} | {statistics.median(us):.0f} |",
        f"| {name}: RTI step, largest | {max(rti_i):,} | {max(rti_c):,} | {max(us):.0f} |",
        f"| {name}: cold first step (10 SQP iterations) | {counts.instructions[0]:,} | {counts.cycles[0]:,} "
        f"| {counts.cycles[0] / CLOCK_MHZ:.0f} |",
    ]
    text = [
        "",
        f"{name}: cycles per instruction (the estimate's) "
        f"{statistics.median(rti_c) / statistics.median(rti_i):.2f} ({args.opt}). "
        f"RAM: the MPC's state {sizes['state']:,} bytes (its workspace in float and its info) plus "
        f"{sizes['stack']:,} bytes of stack for the call (gcc -fstack-usage: bench_call and its deepest "
        f"chain of calls, newlib's not counted); flash: the program's text {sizes['text']:,} bytes (the "
        f"step, the model, newlib's math; the {sizes['states_table']:,}-byte table of test states "
        f"included), of which the step and the model (bench_call and the functions of the header it "
        f"calls) {sizes['step']:,}.",
        *_profile_lines(counts.functions),
    ]
    return rows, text


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=21, help="calls counted (the first is the cold start)")
    parser.add_argument("--out", type=Path, default=ROOT / "docs" / "bench" / "mpc.md")
    parser.add_argument("--opt", default="-O3", help="the optimisation flag (-O3: unrolls fixed sizes)")
    parser.add_argument("--profile", action="store_true", help="and the RTI steps' instructions by function")
    args = parser.parse_args()
    m4_cycles.TARGET[:] = [args.opt if flag.startswith("-O") else flag for flag in m4_cycles.TARGET]
    rows, texts = [], []
    for case in CASES:
        *_, methods = case
        for name, controller in methods:
            method_rows, text = _method(name, controller, args, case)
            rows += method_rows
            texts += text
    lines = [
        BEGIN,
        "## One RTI step on a Cortex-M4F (QEMU)",
        "",
        "Made by `.venv/bin/python -m bench.mpc_m4` (bench/mpc_m4.py; what it counts and how is its",
        "docstring and bench/m4_cycles.py's): the preset scenes/rigs/qube_servo2_mpc.toml's C header in",
        f"float, N = 30, `ipgen_{NAME}_mpc_step` on the first {args.samples} state estimates of the",
        "simulator's closed loop (the first call cold: 10 SQP iterations; then one a sample); and DFKI's",
        "pendubot (scenes/rigs/pendubot_mpc.toml's chain and MPC, N = 40, without its swing-up: holding",
        "the upright from 0.14 rad off at rest, the simulator's states mapped to the header's",
        "coordinates); with the preset's",
        "method and with FAST (`barrier = 0.001`, `qp_iterations = 1`, `sensitivities = \"frozen\"` in",
        "its [controller]); and the QUBE swing-up's MPC: qube_servo2_mpc_swingup_fast's [controller]",
        "(two Newton steps a sample at `barrier = 0.1`, the arm's hard bound at 0.98 rad and soft bound",
        "at 0.9 rad, r = 0.3) on qube_servo2_mpc's hold, and the same with one Newton step, and both",
        "without the soft bound; and qube_servo2_mpc_swingup_m4f's (two Newton steps on shifted",
        "sensitivities, no soft bound) on the same hold, and on its own catch (the estimates of its",
        "swing-up from hanging at the MPC's samples from the catch on: in float its QP's residual is",
        "below the RTI tolerance 1e-4 after the first Newton step there, which ends the step early);",
        f"arm-none-eabi-gcc {args.opt}, QEMU mps2-an386.",
        "Cycles: the TRM's per-instruction counts, zero-wait-state memory, a taken branch 3 (an",
        f"estimate, not a measurement); µs at {CLOCK_MHZ:g} MHz.",
        "",
        "| method: what | instructions | cycles (estimate) | µs at 168 MHz |",
        "| --- | ---: | ---: | ---: |",
        *rows,
        *texts,
        END,
    ]
    text = args.out.read_text() if args.out.exists() else ""
    section = "\n".join(lines)
    if BEGIN in text:
        text = text.split(BEGIN)[0] + section + text.split(END, 1)[1]
    else:
        text = text.rstrip("\n") + "\n\n" + section + "\n"
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(text)
    print(section)


if __name__ == "__main__":
    main()
