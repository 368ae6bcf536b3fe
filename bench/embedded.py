"""Code size of the C header (`--emit c`) on a Cortex-M4 with a single-precision FPU.

For classical and rotary (pivot) n = 1..4, the general header and a scene-specialised one
(every parameter folded at scene-like values, only the simulator's functions emitted, as
`specialise = true` does) are cross-compiled in float mode with Debian's arm-none-eabi-gcc:

    arm-none-eabi-gcc -std=c99 -mcpu=cortex-m4 -mthumb -mfloat-abi=hard -mfpu=fpv4-sp-d16 -Os
                      -Wall -Wextra -Wpedantic -Werror -Wdouble-promotion -Wconversion -c

Each measured function is compiled alone into an object through an extern wrapper (the
static inline function and its helpers are inlined into it or kept as local copies), and the
object's .text is measured with arm-none-eabi-size: everything that function needs except
newlib's sinf/cosf, which are shared library code (their size is listed once). The controller
u = −K (x − x_eq) with saturation is the same in both headers (it reads no model parameter).

The estimators of the measured-loop scenes (ESTIMATOR_SCENES: Kalman filter, derivative filter,
EKF) are compiled the same way, `estimator_update` and, with an LQR, `loop_step`.

The swing-up scenes (scenes/rsip_swingup.toml: energy law; scenes/cdip_swingup.toml: a planned
trajectory) are read as `ipgen --scene … --emit c` reads them, and their controller
`NAME_swingup` with `NAME_swingup_init` is compiled the same way, in float and in double:
flash = .text of both functions + .rodata of the const tables they read (the plan and its
gain schedule), each table's size from arm-none-eabi-nm --size-sort; the library routines it
calls (libm, libgcc's soft double) are listed with their sizes, not counted.

Run: `python -m bench.embedded [--out docs/bench]`; `make bench-embedded` installs the
toolchain (gcc-arm-none-eabi, libnewlib-arm-none-eabi) when missing and runs it.
Writes <out>/embedded.md and prints the table.
"""

from __future__ import annotations

import argparse
import re
import shutil
import subprocess
import sys
import tempfile
from fractions import Fraction
from pathlib import Path

from bench.report import ROOT, commit, table
from ipgen.codegen.c_header import render_c_header
from ipgen.codegen.header import HeaderRequest
from ipgen.control.controller import Controller
from ipgen.model.derivation import derive
from ipgen.model.specialise import SIMULATOR_FUNCTIONS, Specialisation, check_parameter
from ipgen.model.system import (
    System,
    link_parameter_names,
    parameter_names,
    split_parameter,
    unused_parameter,
)

CC = "arm-none-eabi-gcc"
SIZE = "arm-none-eabi-size"
NM = "arm-none-eabi-nm"
TARGET = ["-mcpu=cortex-m4", "-mthumb", "-mfloat-abi=hard", "-mfpu=fpv4-sp-d16", "-Os"]
WARNINGS = ["-Wall", "-Wextra", "-Wpedantic", "-Werror", "-Wdouble-promotion", "-Wconversion"]
FLAGS = ["-std=c99", *TARGET, *WARNINGS, "-DIPGEN_SCALAR=float", "-ffunction-sections"]
LIBM = Path("/usr/lib/arm-none-eabi/lib/thumb/v7e-m+fp/hard/libm.a")
LINKS = (1, 2, 3, 4)

WRAPPERS = {
    "forward_dynamics": (
        "int bench_forward_dynamics(const float q[], const float qd[], float u, const ipgen_{n}_params *p,"
        " float qdd[]) {{ return ipgen_{n}_forward_dynamics(q, qd, u, p, qdd); }}\n"
    ),
    "control": (
        "float bench_control(const float q[], const float qd[]) {{ return ipgen_{n}_control(q, qd); }}\n"
    ),
    "swingup": (
        "IPGEN_SCALAR bench_swingup(ipgen_{n}_swingup_state *s, const IPGEN_SCALAR q[],"
        " const IPGEN_SCALAR qd[], const ipgen_{n}_params *p, const ipgen_{n}_links *links) {{"
        " return ipgen_{n}_swingup(s, q, qd, p, links); }}\n"
        "void bench_swingup_init(ipgen_{n}_swingup_state *s) {{ ipgen_{n}_swingup_init(s); }}\n"
    ),
}
SWINGUP_SCENES = ("rsip_swingup", "cdip_swingup")
# Scenes with a measured loop ([sensors], [estimator]): (scene path from the checkout, what it is).
ESTIMATOR_SCENES = (
    ("scenes/rigs/qube_servo2_sensors.toml", "QUBE LQR at 1 kHz, Kalman filter"),
    ("scenes/rigs/qube_servo2_swingup.toml", "QUBE energy swing-up, derivative filter"),
    ("bench/scenes/rsip_lqr_kalman.toml", "paper's Furuta LQR, Kalman filter"),
    ("bench/scenes/rsip_swingup_ekf.toml", "paper's Furuta energy swing-up, EKF"),
)
ESTIMATOR_WRAPPERS = {
    "update": (
        "void bench_update(ipgen_{n}_estimator_state *s, const float y[], float u) {{"
        " ipgen_{n}_estimator_update(s, y, u); }}\n"
    ),
    "update_ekf": (
        "int bench_update(ipgen_{n}_estimator_state *s, const float y[], float u, const ipgen_{n}_params *p,"
        " const ipgen_{n}_links *links) {{ return ipgen_{n}_estimator_update(s, y, u, p, links); }}\n"
    ),
    "loop_step": (
        "float bench_loop_step(ipgen_{n}_estimator_state *s, const float y[]) {{"
        " return ipgen_{n}_loop_step(s, y); }}\n"
    ),
    "step": (
        "float bench_step(ipgen_{n}_loop_state *s, const long counts[]) {{"
        " return ipgen_{n}_step(s, counts); }}\n"
    ),
}
SHOWN = {
    "update": "estimator_update",
    "update_ekf": "estimator_update",
    "loop_step": "loop_step (estimate + LQR)",
    "step": "step (counts → estimate → control, the whole loop)",
}
SCALARS = ("float", "double")


def scene_values(system: System) -> dict[str, Fraction]:
    """Scene-like parameters (the paper's scenes, their link repeated): name -> exact value."""
    n = system.links
    if system.is_rotary:
        m, lengths, delta = [0.5] + [0.275] * n, [0.6] + [0.5] * n, [0.3] + [0.011458] * n
    else:
        m, lengths, delta = [0.3] + [0.275] * n, [0.0] + [0.5] * n, [0.3] + [0.1] * n
    values = {"g": Fraction("9.81")}
    for i in range(system.dof):
        values |= {f"m{i}": Fraction(str(m[i])), f"l{i}": Fraction(str(lengths[i]))}
        values[f"delta{i}"] = Fraction(str(delta[i]))
    return values


def scene_specialisation(system: System) -> Specialisation:
    values = scene_values(system)
    fixed = tuple(
        (name, values[name])
        for name in parameter_names(system.links)
        if check_parameter(system, name, values[name]) is None
    )
    # the links as built at the rods' values, as a scene folds them (experiment/specialisation.py)
    for name in link_parameter_names(system.links):
        group, index = split_parameter(name)
        assert index is not None
        if unused_parameter(system.type, name, system.inertia):
            continue
        mass, length = values[f"m{index}"], values[f"l{index}"]
        rod = {"com": length / 2, "J": mass * length**2 / (3 if index == 0 else 12)}.get(group, Fraction(0))
        fixed += ((name, rod),)
    return Specialisation(fixed=fixed, outputs=SIMULATOR_FUNCTIONS, scene="(bench scene-like values)")


def controller(system: System) -> Controller:
    """A dense gain (every entry non-zero, so none is dropped) and a saturation."""
    size = 2 * system.dof
    gain = tuple((-1) ** i * (1.5 + 0.25 * i) for i in range(size))
    return Controller("lqr", gain, (0.0,) * size, saturation=5.0, period=0.001)


def section_bytes(obj: Path, section: str = "text") -> int:
    """Bytes of every `.<section>*` section of `obj` (arm-none-eabi-size -A)."""
    out = subprocess.run([SIZE, "-A", str(obj)], capture_output=True, text=True, check=True).stdout
    return sum(int(m.group(1)) for m in re.finditer(rf"^\.{section}\S*\s+(\d+)", out, flags=re.M))


def text_bytes(obj: Path) -> int:
    return section_bytes(obj, "text")


def compile_object(header: str, name: str, function: str, work: Path, scalar: str = "float") -> Path:
    """An object holding only `function` of the header text `header` (IPGEN_SCALAR = `scalar`)."""
    (work / f"{name}.h").write_text(header)
    source = work / f"{name}_{function}_{scalar}.c"
    source.write_text(f'#include "{name}.h"\n' + WRAPPERS[function].format(n=name))
    obj = source.with_suffix(".o")
    flags = [f"-DIPGEN_SCALAR={scalar}" if f.startswith("-DIPGEN_SCALAR=") else f for f in FLAGS]
    subprocess.run([CC, *flags, f"-I{work}", "-c", str(source), "-o", str(obj)], check=True)
    return obj


def measure(header: str, name: str, function: str, work: Path) -> int:
    """Bytes of .text of an object holding only `function` of the header text `header`."""
    return text_bytes(compile_object(header, name, function, work))


def symbols(obj: Path) -> tuple[dict[str, int], tuple[str, ...]]:
    """The object's defined symbols (name -> bytes, arm-none-eabi-nm -S --size-sort) and the
    names it needs from elsewhere (nm -u)."""

    def nm(*options: str) -> str:
        return subprocess.run([NM, *options, str(obj)], capture_output=True, text=True, check=True).stdout

    sizes = {
        parts[3]: int(parts[1], 16)
        for parts in map(str.split, nm("-S", "--size-sort").splitlines())
        if len(parts) == 4
    }
    undefined = nm("-u").split()
    return sizes, tuple(name for name in undefined if name != "U")


def library_sizes(names: set[str]) -> str:
    """Each of `names` with its bytes in newlib's libm or libgcc for this target (nm -S)."""
    libgcc = subprocess.run(
        [CC, *TARGET, "-print-libgcc-file-name"], capture_output=True, text=True
    ).stdout.strip()
    sizes: dict[str, int] = {}
    for library in (str(LIBM), libgcc):
        out = subprocess.run([NM, "-S", "--size-sort", library], capture_output=True, text=True).stdout
        for parts in map(str.split, out.splitlines()):
            if len(parts) == 4 and parts[2] in "Tt" and parts[3] in names:
                sizes.setdefault(parts[3], int(parts[1], 16))
    return ", ".join(f"{name} {sizes.get(name, '?')}" for name in sorted(names))


def swingup_header(scene_name: str) -> tuple[str, str]:
    """(model name, C header text) of a swing-up scene, as `ipgen --scene … --emit c` writes it."""
    from ipgen.experiment.scene import load_scene
    from ipgen.experiment.specialisation import from_scene

    scene = load_scene(ROOT / "scenes" / f"{scene_name}.toml")
    spec = from_scene(scene) if scene.specialise else Specialisation()
    request = HeaderRequest(scene.name, "bench", spec, scene.controller, swingup=scene.swingup)
    return scene.name, render_c_header(derive(scene.system), request)


def swingup_rows(work: Path) -> tuple[list[list[str]], dict[str, set[str]]]:
    """One row per swing-up scene and scalar: method, text, each table's rodata, flash; and the
    library routines the controllers call."""
    rows: list[list[str]] = []
    calls: dict[str, set[str]] = {scalar: set() for scalar in SCALARS}
    for scene_name in SWINGUP_SCENES:
        name, header = swingup_header(scene_name)
        method = re.search(r"\[swingup\], method (\w+)", header)
        for scalar in SCALARS:
            obj = compile_object(header, name, "swingup", work, scalar)
            text, rodata = section_bytes(obj, "text"), section_bytes(obj, "rodata")
            sizes, undefined = symbols(obj)
            calls[scalar] |= set(undefined)
            prefix = f"ipgen_{name}_swingup_"
            tables = ", ".join(
                f"{symbol.removeprefix(prefix)} {size}"
                for symbol, size in sizes.items()
                if symbol.startswith(prefix)
            )
            rows.append(
                [
                    f"{scene_name} ({name}, {method.group(1) if method else '?'})",
                    scalar,
                    str(text),
                    str(rodata),
                    tables or "none",
                    str(text + rodata),
                ]
            )
            print(" | ".join(rows[-1]), flush=True)
    return rows, calls


def scene_c_header(path: Path, work: Path) -> tuple[str, str, str]:
    """(model name, C header text, estimator kind) of a scene, as `ipgen --scene … --emit c`
    writes it."""
    from ipgen.pipeline import job

    planned = job.plan(work / path.stem, scene=path, emit=("c",), force=True)
    job.run(planned)
    assert planned.scene is not None and planned.scene.loop is not None
    header = (work / path.stem / f"{planned.name}.h").read_text()
    return planned.name, header, planned.scene.loop.estimator.kind


def estimator_rows(work: Path) -> list[list[str]]:
    """One row per measured-loop scene and function: text, rodata (the filter's tables), flash."""
    rows: list[list[str]] = []
    for relative, label in ESTIMATOR_SCENES:
        name, header, kind = scene_c_header(ROOT / relative, work)
        functions = ["update_ekf" if kind == "ekf" else "update"]
        if f"ipgen_{name}_loop_step(" in header:
            functions.append("loop_step")
        if f"ipgen_{name}_step(" in header:
            functions.append("step")
        for function in functions:
            (work / f"{name}.h").write_text(header)
            source = work / f"{name}_{function}.c"
            source.write_text(f'#include "{name}.h"\n' + ESTIMATOR_WRAPPERS[function].format(n=name))
            obj = source.with_suffix(".o")
            subprocess.run([CC, *FLAGS, f"-I{work}", "-c", str(source), "-o", str(obj)], check=True)
            text, rodata = section_bytes(obj, "text"), section_bytes(obj, "rodata")
            sizes = [str(text), str(rodata), str(text + rodata)]
            rows.append([f"`{relative}`", label, kind, SHOWN[function], *sizes])
            print(" | ".join(rows[-1]), flush=True)
    return rows


CYCLE_COLUMNS = ["scene", "loop", "estimator", "phase", "calls", "instructions (mean)", "max",
                 "cycles est. (mean)", "max", "µs at 168 MHz (max)"]  # fmt: skip
CYCLE_CALLS = 2000  # samples of each scene's run replayed on the Cortex-M4 model (2 s at 1 kHz)


def cycle_rows(work: Path) -> list[list[str]]:
    """Per measured-loop scene with `ipgen_NAME_step`: instructions and estimated cycles per call
    on QEMU's Cortex-M4F (bench/m4_cycles.py), replaying the encoder counts of the scene's own
    simulated run (its first CYCLE_CALLS samples), per phase of a swing-up."""
    import numpy as np

    from bench.m4_cycles import count
    from ipgen.command.cli import run as ipgen_run
    from ipgen.experiment.scene import load_scene

    rows: list[list[str]] = []
    for relative, label in ESTIMATOR_SCENES:
        path = ROOT / relative
        name, header, _ = scene_c_header(path, work)
        if f"ipgen_{name}_step(" not in header:
            continue
        (work / f"{name}.h").write_text(header)
        scene = load_scene(path)
        assert scene.loop is not None
        out = work / f"{path.stem}_run"
        assert ipgen_run(["run", str(path), "-o", str(out), "--force"]) == 0
        names, *lines = (out / f"{path.stem}.csv").read_text().splitlines()
        columns = names.split(",")
        values = [line.split(",") for line in lines[:CYCLE_CALLS]]
        counts = []
        sensors = scene.loop.sensors
        assert sensors is not None
        for index, step in zip(sensors.measured, sensors.steps(), strict=True):
            y = np.array([float(row[columns.index(f"y_theta{index}")]) for row in values])
            counts.append(np.rint((y - scene.theta[index]) / step).astype(int))
        table_rows = ", ".join(
            "{" + ", ".join(str(int(c[k])) for c in counts) + "}" for k in range(len(values))
        )
        prelude = (
            f'#define IPGEN_SCALAR float\n#include "{name}.h"\n'
            f"static const long counts[{len(values)}][{len(counts)}] = {{{table_rows}}};\n"
            f"static ipgen_{name}_loop_state state;\nvolatile float sink;\n"
        )
        call = (
            f"  if (k == 0) ipgen_{name}_loop_init(&state);\n"
            f"  sink = ipgen_{name}_step(&state, counts[k]);"
        )
        measured = count(work / f"{name}.h", prelude, call, len(values))
        phases = ["balance"] * len(values)
        if "phase" in columns:
            phases = [row[columns.index("phase")] for row in values]
        for phase in dict.fromkeys(phases):
            picked = [i for i, p in enumerate(phases) if p == phase]
            instructions = [measured.instructions[i] for i in picked]
            cycles = [measured.cycles[i] for i in picked]
            rows.append([
                f"`{relative}`", label, scene.loop.estimator.kind,
                phase, str(len(picked)), f"{sum(instructions) / len(picked):.0f}", str(max(instructions)),
                f"{sum(cycles) / len(picked):.0f}", str(max(cycles)),
                f"{max(cycles) / 168:.1f}",
            ])  # fmt: skip
            print(" | ".join(rows[-1]), flush=True)
    return rows


def libm_sizes() -> str:
    """sinf and cosf of newlib's libm for this target (bytes), as arm-none-eabi-nm reports them."""
    if not LIBM.is_file():
        return "libm not found"
    out = subprocess.run([NM, "-S", "--size-sort", str(LIBM)], capture_output=True, text=True).stdout
    sizes: dict[str, int] = {}
    for line in out.splitlines():
        parts = line.split()
        if (
            len(parts) == 4
            and parts[2] in "Tt"
            and parts[3]
            in ("sinf", "cosf", "__kernel_sinf", "__kernel_cosf", "__ieee754_rem_pio2f", "__kernel_rem_pio2f")
        ):
            sizes[parts[3]] = int(parts[1], 16)
    return ", ".join(f"{k} {v}" for k, v in sorted(sizes.items())) or "not found"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=ROOT / "docs" / "bench")
    args = parser.parse_args(argv)
    for tool in (CC, SIZE, NM):
        if shutil.which(tool) is None:
            print(f"bench.embedded: {tool} not found: install gcc-arm-none-eabi (make bench-embedded)")
            return 2
    rows: list[list[str]] = []
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        for kind in ("classical", "rotary"):
            for n in LINKS:
                system = System(kind, n)
                eqs = derive(system)
                name = f"{kind}{n}"
                general = render_c_header(eqs, HeaderRequest(name, "bench", controller=controller(system)))
                special = render_c_header(
                    eqs, HeaderRequest(name, "bench", scene_specialisation(system), controller(system))
                )
                sizes = [
                    measure(general, name, "forward_dynamics", work),
                    measure(special, name, "forward_dynamics", work),
                    measure(general, name, "control", work),
                    measure(special, name, "control", work),
                ]
                reduction = 1 - sizes[1] / sizes[0]
                rows.append(
                    [
                        f"{kind} n = {n}",
                        *(str(s) for s in sizes[:2]),
                        f"{100 * reduction:.0f} %",
                        *map(str, sizes[2:]),
                    ]
                )
                print(" | ".join(rows[-1]), flush=True)
        swing_rows, calls = swingup_rows(work)
        loop_rows = estimator_rows(work)
        cycles = cycle_rows(work) if shutil.which("qemu-system-arm") else []
    version = subprocess.run([CC, "--version"], capture_output=True, text=True).stdout.splitlines()[0]
    lines = [
        "# Code size of the C header on a Cortex-M4F",
        "",
        "Generated by `make bench-embedded` (`python -m bench.embedded`, bench/embedded.py). Bytes of",
        "`.text` of an object holding only the named function of `NAME.h` (float mode), compiled with",
        "",
        f"    {CC} {' '.join(FLAGS)} -c",
        "",
        f"({version}); the static inline function and the helpers it calls are included, newlib's",
        f"sinf/cosf are not (shared library code; in {LIBM.name} for this target: {libm_sizes()} bytes).",
        "General: every parameter read at run time. Specialised: every parameter folded at scene-like",
        "values (the paper's scenes with their link repeated: classical m = 0.3, 0.275…, l = 0.5…,",
        "delta = 0.3, 0.1…; rotary m = 0.5, 0.275…, l = 0.6, 0.5…, delta = 0.3, 0.011458…; g = 9.81) and",
        "only the simulator's functions emitted. The controller u = −K (x − x_eq), clipped, has a dense",
        "gain of 2 (n + 1) entries and reads no model parameter. Code size does not depend on the",
        f"machine's load; ipgen commit {commit()}.",
        "",
        *table(
            [
                "model",
                "forward_dynamics general",
                "forward_dynamics specialised",
                "saved",
                "control general",
                "control specialised",
            ],
            rows,
        ),
        "",
        "## Swing-up controllers",
        "",
        "The C header of a `[swingup]` scene (docs/swingup.md) carries its controller",
        "`ipgen_NAME_swingup_init` + `ipgen_NAME_swingup`: the energy law computed on line, or the plan",
        "(u_ref, x_ref) and its time-varying LQR gains as `static const` tables. Bytes of `.text` of both",
        "functions and `.rodata` of the tables they read (the hold gain and target are folded into",
        "the code; the energy law's text includes the mass matrix and bias it evaluates, inlined, with",
        "the parameters read at run time), compiled as above with IPGEN_SCALAR float and double; each",
        f"table's size from {NM} -S --size-sort. The plan's tables hold 4 (float) or 8 (double) ×",
        "(K + (2K + 1)·2(n + 1)) bytes for K sampling steps. Not counted: the library routines they",
        "call (linked once per program), with their bytes (nm -S of libm.a and libgcc.a): float",
        f"{library_sizes(calls['float'])}; double {library_sizes(calls['double'])}.",
        _float_note(calls["float"]),
        "",
        *table(["scene", "scalar", "text", "rodata", "tables", "flash"], swing_rows),
        "",
        "## Estimators of the measured loop",
        "",
        "A scene with `[sensors]` and `[estimator]` (docs/estimation.md) gets",
        "`ipgen_NAME_estimator_update` (one sample: predict with the previous command, correct with the",
        "measured angles) and, with an LQR `[controller]`, `ipgen_NAME_loop_step` (update, then",
        "u = −K (x̂ − x_eq), the delay line); with encoder resolutions, `ipgen_NAME_step` (counts in, the",
        "command out: for a swing-up the whole swing, catch and hold; the parameters it was designed",
        "with are `static const`): float, compiled as above. The Kalman filter's and the",
        "derivative filter's matrices are `static const` tables (.rodata); the EKF computes its",
        "Jacobians from the exact model in the code (the parameters read at run time) and keeps P in",
        "the caller's state. Cycles per call: the next section.",
        "",
        *table(["scene", "loop", "estimator", "function", "text", "rodata", "flash"], loop_rows),
        "",
        "## Instructions and cycles per call of `ipgen_NAME_step`",
        "",
        "No cycle-accurate Cortex-M4 model runs on this machine, so (bench/m4_cycles.py): QEMU's",
        "`mps2-an386` (a Cortex-M4 with FPv4-SP) runs `ipgen_NAME_step` bare-metal, one instruction per",
        "translation block, replaying the encoder counts of the scene's own simulated run (its first",
        f"{CYCLE_CALLS} samples); every executed instruction is counted (exact for this instruction",
        "stream), then weighted with the Cortex-M4 Technical Reference Manual's cycle counts assuming",
        "zero-wait-state memory (loads 2, multiply-accumulate 3, VDIV/VSQRT 14, a taken branch 3;",
        "bench/m4_cycles.py lists them): an estimate, not a measurement. Calls include newlib's",
        "sinf/cosf. µs at 168 MHz (an STM32F4) from the largest estimate per call.",
        "",
        *(
            table(CYCLE_COLUMNS, cycles)
            if cycles
            else ["(qemu-system-arm not installed: not measured)"]
        ),
        "",
    ]
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "embedded.md").write_text("\n".join(lines))
    print(f"wrote {args.out / 'embedded.md'}")
    return 0


def _float_note(float_calls: set[str]) -> str:
    """Whether the float builds call any double routine (soft double on a single-precision FPU)."""
    doubles = sorted(
        name for name in float_calls if name.startswith("__aeabi_d") or name in ("floor", "sin", "cos")
    )
    if doubles:
        return f"The float builds call double routines ({', '.join(doubles)}): software double arithmetic."
    return "The float builds call no double routine: all their arithmetic is single precision."


if __name__ == "__main__":
    sys.exit(main())
