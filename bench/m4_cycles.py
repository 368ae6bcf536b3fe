"""Instructions executed and cycles estimated per call of generated C on a Cortex-M4F.

There is no cycle-accurate Cortex-M4 model on this machine, so the count is made in two steps:

1. QEMU's `mps2-an386` machine (a Cortex-M4 with the FPv4-SP FPU) runs the call bare-metal,
   one instruction per translation block (`-singlestep -d exec,nochain`): every executed
   instruction is one trace line, so the instructions per call are counted exactly, for the
   instruction stream the M4 would execute (the same ELF: `arm-none-eabi-gcc -mcpu=cortex-m4
   -mfloat-abi=hard -Os`, newlib's sinf/cosf).
2. Each executed instruction is weighted with its cycle count from the Cortex-M4 Technical
   Reference Manual (r0p1, tables 3-1 and 7-1), assuming zero-wait-state memory: data
   processing, multiply, FP add/multiply/convert/move 1; loads and stores 2 (the upper value:
   back-to-back loads pipeline to 1); LDM/STM/PUSH/POP and their VFP forms 1 + registers; FP
   multiply-accumulate 3; VDIV and VSQRT 14; SDIV/UDIV 12 (the upper value); a taken branch
   1 + 2 (pipeline refill: 1 to 3 in the manual). The cycles are therefore an estimate for a
   part with zero-wait-state flash (e.g. an STM32F4 below its flash's wait-state frequency or
   running from its ART accelerator's hits), not a measurement.

`count(header, call, calls)` builds and runs one program and returns the per-call counts.
"""

from __future__ import annotations

import re
import subprocess
import tempfile
from dataclasses import dataclass
from pathlib import Path

QEMU = "qemu-system-arm"
MACHINE = "mps2-an386"
CC = "arm-none-eabi-gcc"
OBJDUMP = "arm-none-eabi-objdump"
TARGET = ["-mcpu=cortex-m4", "-mthumb", "-mfloat-abi=hard", "-mfpu=fpv4-sp-d16", "-Os"]
BRANCH_REFILL = 2  # cycles added by a taken branch (the manual: 1 to 3)

LINKER_SCRIPT = """\
MEMORY { CODE (rx) : ORIGIN = 0x00000000, LENGTH = 4M
         RAM (rwx) : ORIGIN = 0x20000000, LENGTH = 4M }
ENTRY(reset)
SECTIONS {
  .text : { KEEP(*(.vectors)) *(.text*) *(.rodata*) } > CODE
  .data : { *(.data*) } > RAM
  .bss : { *(.bss*) *(COMMON) } > RAM
  end = .;
}
"""

# The program around the call: a vector table, a reset handler that enables the FPU, runs
# bench_call(k) for k = 0 .. CALLS - 1 and leaves QEMU by semihosting (SYS_EXIT).
PROGRAM = """\
%(prelude)s
void reset(void);
__attribute__((section(".vectors"), used)) const void *vectors[2] = {(void *)0x20400000, (void *)reset};
__attribute__((noipa)) void bench_call(long k) {
%(call)s
}
void reset(void) {
  long k;
  *(volatile unsigned *)0xE000ED88u |= 0xFu << 20;  /* CPACR: CP10, CP11 (the FPU) */
  __asm__ volatile("dsb\\n isb");
  for (k = 0; k < %(calls)d; ++k) bench_call(k);
  /* semihosting SYS_EXIT (r0 = 0x18), ADP_Stopped_ApplicationExit (r1 = 0x20026) */
  __asm__ volatile("movs r0, #0x18\\n movw r1, #0x0026\\n movt r1, #0x0002\\n bkpt 0xab" : : : "r0", "r1");
  for (;;) {}
}
"""

_TRACE = re.compile(r"^Trace \d+: 0x[0-9a-f]+ \[[0-9a-f]+/([0-9a-f]+)/")
_INSTRUCTION = re.compile(r"^\s*([0-9a-f]+):\s+((?:[0-9a-f]{4} ?){1,2})\s+(\S+)\s*(.*)$")


@dataclass(frozen=True)
class Instruction:
    size: int  # bytes
    cycles: int  # not counting a taken branch's refill
    branch: bool  # may change the flow (its refill is added when the next PC is not sequential)


@dataclass(frozen=True)
class CallCounts:
    """Per call: instructions executed and cycles estimated (module docstring)."""

    instructions: tuple[int, ...]
    cycles: tuple[int, ...]
    # With `profile`: the instructions of the calls after the first, by the function addr2line
    # names for each address (the innermost inlined one), most first.
    functions: tuple[tuple[str, int], ...] = ()


def _registers(operands: str) -> int:
    """Registers in a {…} list: {r4, r5, lr} → 3, {s16-s23} → 8."""
    inside = operands[operands.find("{") + 1 : operands.find("}")]
    total = 0
    for part in inside.split(","):
        part = part.strip()
        if "-" in part:
            low, high = (int(re.sub(r"\D", "", end)) for end in part.split("-"))
            total += high - low + 1
        elif part:
            total += 1
    return max(total, 1)


def cycles_of(mnemonic: str, operands: str) -> tuple[int, bool]:
    """(cycles, is a branch) of one instruction (module docstring's table)."""
    base = mnemonic.split(".")[0]
    if base in ("vdiv", "vsqrt"):
        return 14, False
    if base in ("vmla", "vmls", "vnmla", "vnmls", "vfma", "vfms", "vfnma", "vfnms"):
        return 3, False
    if base in ("vpush", "vpop") or base.startswith(("vldm", "vstm")):
        return 1 + _registers(operands), False
    if base.startswith(("vldr", "vstr")):
        return 2, False
    if base in ("push", "pop") or base.startswith(("ldm", "stm")):
        return 1 + _registers(operands), base == "pop" and "pc" in operands
    if base.startswith(("ldr", "str")):
        return 2, "pc" in operands.split(",")[0]
    if base in ("sdiv", "udiv"):
        return 12, False
    branch = base in ("bl", "blx", "bx", "cbz", "cbnz", "tbb", "tbh") or re.fullmatch(r"b(?:[a-z]{2})?", base)
    return 1, bool(branch)


def _disassembly(elf: Path) -> dict[int, Instruction]:
    text = subprocess.run([OBJDUMP, "-d", str(elf)], capture_output=True, text=True, check=True).stdout
    table: dict[int, Instruction] = {}
    for line in text.splitlines():
        match = _INSTRUCTION.match(line)
        if match and not match.group(3).startswith("."):
            cycles, branch = cycles_of(match.group(3), match.group(4))
            size = len(match.group(2).replace(" ", "")) // 2
            table[int(match.group(1), 16)] = Instruction(size, cycles, branch)
    return table


def _symbol(elf: Path, name: str) -> tuple[int, int]:
    """(address, size in bytes) of a function in `elf`."""
    nm = ["arm-none-eabi-nm", "-S", str(elf)]
    for line in subprocess.run(nm, capture_output=True, text=True, check=True).stdout.splitlines():
        fields = line.split()
        if len(fields) == 4 and fields[3] == name:
            return int(fields[0], 16) & ~1, int(fields[1], 16)
    raise LookupError(name)


def _functions(elf: Path, executed: dict[int, int]) -> tuple[tuple[str, int], ...]:
    """The executed instructions by function: addr2line (-f, the innermost inlined frame) of each
    address, summed, most first."""
    addresses = sorted(executed)
    out = subprocess.run(
        ["arm-none-eabi-addr2line", "-f", "-e", str(elf), *(hex(a) for a in addresses)],
        check=True, capture_output=True, text=True,
    ).stdout.splitlines()  # fmt: skip
    totals: dict[str, int] = {}
    for i, address in enumerate(addresses):
        totals[out[2 * i]] = totals.get(out[2 * i], 0) + executed[address]
    return tuple(sorted(totals.items(), key=lambda item: -item[1]))


def count(header: Path, prelude: str, call: str, calls: int, profile: bool = False) -> CallCounts:
    """Build `prelude` + a `bench_call(long k)` with body `call` against the folder of `header`
    and run it `calls` times on QEMU's Cortex-M4; the per-call counts (`profile`: and where the
    calls after the first go, by function; built with -g, which changes no instruction)."""
    with tempfile.TemporaryDirectory(prefix="ipgen-m4.") as folder:
        work = Path(folder)
        (work / "link.ld").write_text(LINKER_SCRIPT)
        (work / "main.c").write_text(PROGRAM % {"prelude": prelude, "call": call, "calls": calls})
        elf = work / "main.elf"
        subprocess.run(
            [CC, "-std=c99", *TARGET, "-Wall", "-Wextra", "-Werror", "-nostartfiles",
             *(["-g"] if profile else []), "-T", str(work / "link.ld"), f"-I{header.parent}",
             str(work / "main.c"), "-o", str(elf), "-lm", "-lc", "-lgcc"],
            check=True, capture_output=True, text=True,
        )  # fmt: skip
        table = _disassembly(elf)
        entry, _ = _symbol(elf, "bench_call")
        reset, reset_size = _symbol(elf, "reset")
        process = subprocess.Popen(
            [QEMU, "-M", MACHINE, "-nographic", "-semihosting-config", "enable=on,target=native",
             "-kernel", str(elf), "-singlestep", "-d", "exec,nochain", "-D", "/dev/stdout"],
            stdout=subprocess.PIPE, text=True,
        )  # fmt: skip
        instructions: list[int] = []
        cycles: list[int] = []
        previous: Instruction | None = None
        previous_pc = -1
        executed: dict[int, int] = {}  # address -> times, the calls after the first (profile)
        assert process.stdout is not None
        for line in process.stdout:
            match = _TRACE.match(line)
            if not match:
                continue
            pc = int(match.group(1), 16)
            if previous is not None and previous.branch and pc != previous_pc + previous.size and cycles:
                cycles[-1] += BRANCH_REFILL
            if pc == entry:
                instructions.append(0)
                cycles.append(0)
            if reset <= pc < reset + reset_size:  # the loop in reset: not part of a call
                previous = None
                continue
            step = table.get(pc)
            if step is not None and instructions:
                instructions[-1] += 1
                cycles[-1] += step.cycles
                if profile and len(instructions) > 1:
                    executed[pc] = executed.get(pc, 0) + 1
            previous, previous_pc = step, pc
        if process.wait(timeout=600) != 0:
            raise RuntimeError(f"{QEMU} exited with status {process.returncode}")
        functions = _functions(elf, executed) if profile else ()
    if len(instructions) != calls:
        raise RuntimeError(f"counted {len(instructions)} calls, expected {calls}")
    return CallCounts(tuple(instructions), tuple(cycles), functions)
