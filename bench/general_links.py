"""The links as built (issue 21) against the paper's rods: operation counts and generation time.

    python -m bench.general_links                 # writes docs/bench/general_links.md
    python -m bench.general_links --rounds 3 --out /tmp/g
    python -m bench.general_links --golden        # writes tests/data/rod_golden.json (once)

The generator of BASELINE (the commit before the links as built: every link a homogeneous rod)
is materialised from git (`git archive`, into build/bench/general-links-BASELINE/) and run next
to this checkout's, in the same run, alternating in every round so that both see the same load:

- **operations** of `forward_dynamics` (the `Cost:` the header states: count_operations over its
  statements, the L D Lᵀ solve excluded) of the general header, n = 2, 3, 5. The general
  header reads com and J with a fallback to the rod default (`given ? p.com[i] : l_i/2`); the
  table gives both paths: "given" (every entry set: the fallback is not evaluated) and "rod
  defaults" (entries left unset: the fallback's operations counted too);
- **folded**: the header with --fix of every m, l (and, new, com, J, J_axial, tip at the rod
  values): both generators must give the same count;
- **generation time**: derivation and rendering of the general header in a fresh process
  (imports excluded), median over the rounds.

`--golden` evaluates BASELINE's M, bias, T and V at fixed random states and parameters and
writes them for tests/test_links_as_built.py (the rod defaults must reproduce them).
"""

from __future__ import annotations

import argparse
import json
import os
import re
import statistics
import subprocess
from pathlib import Path

from tqdm import tqdm

from bench.against_baseline import materialise
from bench.report import PYTHON, ROOT, machine

BASELINE = "67de603"  # main before issue 21: the paper's rods only
SYSTEMS = (
    ("classical", 2, "pivot"),
    ("classical", 3, "pivot"),
    ("classical", 5, "pivot"),
    ("rotary", 2, "pivot"),
    ("rotary", 3, "pivot"),
    ("rotary", 5, "pivot"),
    ("rotary", 2, "full"),
    ("rotary", 3, "full"),
    ("rotary", 5, "full"),
)
ROUNDS = 5
TARGET_OPERATIONS = 1.10
TARGET_TIME = 1.20
GOLDEN = ROOT / "tests" / "data" / "rod_golden.json"
GOLDEN_SYSTEMS = (
    ("classical", 1, "pivot"),
    ("classical", 2, "pivot"),
    ("classical", 3, "pivot"),
    ("rotary", 1, "pivot"),
    ("rotary", 2, "pivot"),
    ("rotary", 2, "full"),
    ("rotary", 3, "full"),
)

# Run in a fresh process of either checkout (same API in both): JSON on stdout.
_MEASURE = """
import json, sys, time
from fractions import Fraction
from ipgen.codegen.header import HeaderRequest, function_bodies, poly_keys, render_header
from ipgen.model.derivation import derive
from ipgen.model.specialise import Specialisation, specialise
from ipgen.model.system import System
kind, links, inertia = sys.argv[1], int(sys.argv[2]), sys.argv[3]
system = System(kind, links, inertia)
start = time.perf_counter()
equations = derive(system)
render_header(equations, HeaderRequest("m", "timing"))
elapsed = time.perf_counter() - start
body = function_bodies(equations, ("forward_dynamics",))["forward_dynamics"]
lines = [*body.prelude, *body.temporaries, *body.outputs]
fixed = {f"m{i}": Fraction(3, 10 + i) for i in range(links + 1)}
fixed |= {f"l{i}": Fraction(1, 2 + i) for i in range(links + 1) if i or kind == "rotary"}
if "com1" in equations.algebra._index:  # the links as built: their rod values, folded too
    for i in range(1, links + 1):
        fixed[f"com{i}"] = fixed[f"l{i}"] / 2
        fixed[f"J{i}"] = fixed[f"m{i}"] * fixed[f"l{i}"] ** 2 / 12
        fixed[f"tip{i}"] = Fraction(0)
        if kind == "rotary" and inertia == "full":
            fixed[f"J_axial{i}"] = Fraction(0)
    if kind == "rotary":
        fixed["J0"] = fixed["m0"] * fixed["l0"] ** 2 / 3
spec = Specialisation(fixed=tuple(fixed.items()), outputs=("forward_dynamics",))
folded = function_bodies(specialise(equations, spec, poly_keys(spec.outputs)), spec.outputs)
print(json.dumps({"seconds": elapsed, "lines": lines, "folded": folded["forward_dynamics"].operations}))
"""

_GOLDEN = """
import json, sys
import numpy as np, sympy as sp
from ipgen.model.derivation import derive
from ipgen.model.system import System
out = []
for kind, links, inertia in json.loads(sys.argv[1]):
    eqs = derive(System(kind, links, inertia))
    sym = eqs.symbols
    args = (sym.q, sym.qd, (sym.m, sym.l, sym.delta, sym.g))
    views = (eqs.mass_matrix, eqs.bias, eqs.kinetic_energy, eqs.potential_energy)
    functions = [sp.lambdify(args, e, "numpy") for e in views]
    rng = np.random.default_rng(21 + links)
    size = links + 1
    for _ in range(4):
        q, qd = list(rng.uniform(-3, 3, size)), list(rng.uniform(-3, 3, size))
        params = [list(rng.uniform(0.1, 2, size)), list(rng.uniform(0.2, 1.5, size))]
        params += [list(rng.uniform(0, 0.5, size)), float(rng.uniform(1, 20))]
        values = [np.asarray(f(q, qd, params), dtype=float).tolist() for f in functions]
        out.append({"system": [kind, links, inertia], "q": q, "qd": qd, "params": params,
                    "M": values[0], "bias": values[1], "T": values[2], "V": values[3]})
print(json.dumps(out))
"""


def _run(code: str, arguments: list[str], path: Path | None) -> object:
    """JSON printed by `code` in a fresh process importing ipgen from `path` (None: here)."""
    env = dict(os.environ)
    if path is None:
        env.pop("PYTHONPATH", None)
    else:
        env["PYTHONPATH"] = str(path)
    done = subprocess.run(
        [PYTHON, "-c", code, *arguments], cwd=ROOT, env=env, capture_output=True, text=True, check=False
    )
    if done.returncode:
        raise SystemExit(f"bench.general_links: {done.stderr.strip()}")
    return json.loads(done.stdout)


_CONDITIONAL = re.compile(r" = (.*?) \? (.*?) : (.*);")


def given_path(lines: list[str]) -> int:
    """Operations when every com and J entry is given: `c ? given : default` counts as `given`."""
    from ipgen.codegen.functions import count_operations

    return sum(count_operations(_CONDITIONAL.sub(lambda m: f" = {m.group(2)};", line)) for line in lines)


def measure(rounds: int) -> list[dict]:
    from ipgen.codegen.functions import count_operations

    baseline = materialise(BASELINE, "general-links")
    rows = []
    for kind, links, inertia in tqdm(SYSTEMS, desc="general links", unit="system"):
        arguments = [kind, str(links), inertia]
        old_s, new_s = [], []
        for _ in range(rounds):
            old = _run(_MEASURE, arguments, baseline)
            new = _run(_MEASURE, arguments, None)
            old_s.append(old["seconds"])  # type: ignore[index]
            new_s.append(new["seconds"])  # type: ignore[index]
        rows.append(
            {
                "system": f"{kind}{links}" + (f" {inertia}" if kind == "rotary" else ""),
                "old": sum(count_operations(line) for line in old["lines"]),  # type: ignore[index]
                "given": given_path(new["lines"]),  # type: ignore[index]
                "defaults": sum(count_operations(line) for line in new["lines"]),  # type: ignore[index]
                "old_folded": old["folded"],  # type: ignore[index]
                "new_folded": new["folded"],  # type: ignore[index]
                "old_s": statistics.median(old_s),
                "new_s": statistics.median(new_s),
            }
        )
    return rows


def _ratio(new: float, old: float) -> str:
    return f"{new / old:.3f}"


def markdown(rows: list[dict], rounds: int) -> str:
    lines = [
        "# Links as built against the paper's rods",
        "",
        f"Written by `python -m bench.general_links` (part of `make bench`): this checkout against "
        f"`{BASELINE}` (every link a homogeneous rod), in the same run.",
        "",
        *machine(),
        "",
        "`forward_dynamics` operations of the general header (count_operations over its statements, "
        "the L D Lᵀ solve excluded). *given*: every com and J entry set; *rod defaults*: entries left "
        "unset, their fallback l/2, m l²/12 (J0: m0 l0²/3) counted too. *folded*: --fix of every m, l "
        "(and com, J, J_axial, tip, J0 at the rod values).",
        "",
        "| system | rods | given | ratio | rod defaults | ratio | folded: rods | folded: new |",
        "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |",
    ]
    for r in rows:
        lines.append(
            f"| {r['system']} | {r['old']} | {r['given']} | {_ratio(r['given'], r['old'])} | "
            f"{r['defaults']} | {_ratio(r['defaults'], r['old'])} | {r['old_folded']} | {r['new_folded']} |"
        )
    lines += [
        "",
        f"Generation time (derivation and the general header's rendering, imports excluded; median of "
        f"{rounds} fresh processes each, alternating):",
        "",
        "| system | rods [ms] | links as built [ms] | ratio |",
        "| --- | ---: | ---: | ---: |",
    ]
    for r in rows:
        lines.append(
            f"| {r['system']} | {1000 * r['old_s']:.1f} | {1000 * r['new_s']:.1f} | "
            f"{_ratio(r['new_s'], r['old_s'])} |"
        )
    given = max(r["given"] / r["old"] for r in rows)
    defaults = max(r["defaults"] / r["old"] for r in rows)
    time_ratio = max(r["new_s"] / r["old_s"] for r in rows)
    fewer = all(r["new_folded"] <= r["old_folded"] for r in rows)
    lines += [
        "",
        f"Targets: operations ≤ {TARGET_OPERATIONS:.2f}× — given: worst {given:.3f}× "
        f"({'met' if given <= TARGET_OPERATIONS else 'missed'}), rod defaults: worst {defaults:.3f}× "
        f"({'met' if defaults <= TARGET_OPERATIONS else 'missed'}); generation time ≤ {TARGET_TIME:.2f}×: "
        f"worst {time_ratio:.3f}× ({'met' if time_ratio <= TARGET_TIME else 'missed'}); folded to rod "
        f"values: {'no more than the rods' if fewer else 'some count is higher than the rods'} "
        "(tests/test_links_as_built.py: classical the same count as this generator's rod equations "
        "folded alike, rotary no more).",
        "",
        "The times are wall clock under the load stated above: on a shared machine, repeated runs "
        "move these medians by tens of percent (the operation counts are exact).",
        "",
        "This checkout writes the Rayleigh damping with the joint torques r_i = δ_i ω_i, each "
        'computed once (docs/model.md, "Rayleigh dissipation function"), which the rods\' '
        "generator (the commit above) predates: one or two operations fewer per joint in every "
        "column of this checkout (folded included), not only in the links as built.",
        "",
        "*Rod defaults* is the price of `Params{m, l, delta}` keeping its meaning (the paper's rods): "
        "its com and J entries are NaN, and every call computes their rod values from that call's m "
        "and l, l_i/2 (1 operation) and m_i l_i²/12 (3), per link (the arm's J0, m0 l0²/3: 3 more). "
        "It cannot be computed once when Params is made: Params is a plain aggregate whose m and l "
        "may be assigned after it is made (member by member, or changed between calls), and a value "
        "computed at construction would then silently stay the old one. The fallback is not cheaper "
        "per combination either: each of com and J may be given alone (com given, J the rod's about "
        "the CoG), so J's default needs m_i l_i² whatever com is. Code that gives com and J (the "
        "rods' values, once: `with_rod_links(p)` in C++, `ipgen_NAME_rod_links` in C) runs the "
        "*given* column (the simulator does this once per run); a header with them folded (`--fix`, a "
        "specialised scene) runs the *folded* one.",
        "",
    ]
    return "\n".join(lines)


def write_golden() -> None:
    """BASELINE's equations at fixed random states, for tests/test_links_as_built.py."""
    data = _run(_GOLDEN, [json.dumps(GOLDEN_SYSTEMS)], materialise(BASELINE, "general-links"))
    GOLDEN.write_text(json.dumps({"commit": BASELINE, "cases": data}, indent=None) + "\n")
    print(f"wrote {GOLDEN.relative_to(ROOT)}")


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(
        prog="python -m bench.general_links", description=__doc__.splitlines()[0]
    )
    parser.add_argument("--rounds", type=int, default=ROUNDS)
    parser.add_argument("--out", type=Path, default=ROOT / "docs" / "bench")
    parser.add_argument("--golden", action="store_true", help=f"write {GOLDEN.relative_to(ROOT)} and stop")
    options = parser.parse_args(argv)
    if options.golden:
        write_golden()
        return
    rows = measure(options.rounds)
    options.out.mkdir(parents=True, exist_ok=True)
    text = markdown(rows, options.rounds)
    (options.out / "general_links.md").write_text(text)
    print(text)


if __name__ == "__main__":
    main()
