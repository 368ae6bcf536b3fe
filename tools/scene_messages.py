"""Every outcome of many mutated scenes, for comparing the scene layer before and after a change.

For 8 shipped scenes, every key of every table is removed or set to 22 values drawn (seeded) from
a list of hostile ones (wrong types, bounds, huge and tiny numbers, long hex, 1e9999999999999999999,
unknown keys), plus 150 random pairs of such changes per scene. Each case's outcome is written as
one line: "OK <hash of the resolved config>", "ERR <the one-line message>" or "CRASH <exception>".

    python tools/scene_messages.py ROOT OUT.txt     # ROOT: the checkout whose scenes/ to mutate

Run it on two checkouts (e.g. `git archive main | tar -x -C /tmp/base` and the work tree, each
with its own `ipgen` on the path) and compare the two files line by line: a change to the scene
layer that keeps every message changes no line but the CRASH ones it fixes.
"""

import hashlib
import json
import random
import sys
import tempfile
import tomllib
from decimal import Decimal
from pathlib import Path

from ipgen.errors import SceneError
from ipgen.experiment.config import resolved_config
from ipgen.experiment.scene import load_scene

ROOT = Path(sys.argv[1])
OUT = Path(sys.argv[2])
TABLE_KEYS = {
    "system": "type links inertia name specialise emit angles zero positive".split(),
    "parameters": "m l delta g com J J_axial tip coulomb coulomb_speed free".split(),
    "actuator": "kind Rm kt km Kg eta_g eta_m Jm r".split(),
    "initial": "theta dtheta".split(),
    "input": "kind amplitude start duration time frequency phase f0 f1 sweep f_min f_max period".split(),
    "limits": ["travel"],
    "simulation": "t_end sample method jacobian rtol atol step max_steps".split(),
    "outputs": ["energy"],
    "controller": "kind q r equilibrium saturation period".split(),
    "swingup": "method u_max x_max duration period hold".split(),
}
VALUES = [
    "0",
    "1",
    "-1",
    "2",
    "0.5",
    "-0.0",
    "1e-3",
    "1e-16",
    "1e400",
    "-1e400",
    "inf",
    "nan",
    "1e200",
    "1e-300",
    "true",
    '"x"',
    '"rotary"',
    '"classical"',
    '"full"',
    '"pulse"',
    '"sine"',
    '"chirp"',
    '"multisine"',
    '"zero"',
    '"rk4"',
    '"adams"',
    '"dq"',
    '"lqr"',
    '"hanging"',
    '"energy"',
    '"trajectory"',
    '"dc_motor"',
    '"acceleration"',
    '"relative"',
    '"hanging"',
    "[]",
    "[0,0]",
    "[0,0,0]",
    "[1,1,1]",
    "[1,1]",
    '["m0"]',
    '["g","g"]',
    '["cpp","c"]',
    '["fmu"]',
    "[1,2,3,4,5,6]",
    "[1,2,3,4]",
    "[[1,0],[0,1]]",
    '[1, "a", 3]',
    "[1e400, 1, 1]",
    "[-1, 1, 1]",
    "[0.1, -0.2, 0.3]",
    "{a=1}",
    "0.02",
    "100000",
    "20",
    "10",
    "0.011",
    "0x" + "f" * 300,
    "1" * 400,
    "1e9999999999999999999",
    "5e-324",
    "1.5",
    "3.141592653589793",
    "[0, 3.141592653589793]",
    "[0, 3.141592653589793, 0]",
    "[0.3, 0.2]",
    '"aaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaa"',
    '"2dip"',
    '"int"',
]


def dump(value):
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int, Decimal)):
        return str(value)
    if isinstance(value, str):
        return json.dumps(value)
    if isinstance(value, list):
        return "[" + ", ".join(dump(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{k} = {dump(v)}" for k, v in value.items()) + "}"
    raise TypeError(value)


def text_of(doc):
    parts = []
    for name, table in doc.items():
        if isinstance(table, dict):
            parts.append(
                f"[{name}]\n"
                + "".join(
                    f"{json.dumps(k)} = {v if isinstance(v, Raw) else dump(v)}\n" for k, v in table.items()
                )
            )
        else:
            parts.insert(0, f"{json.dumps(name)} = {table if isinstance(table, Raw) else dump(table)}\n")
    return "\n".join(parts)


class Raw(str):
    pass


def outcome(text, tmp):
    path = Path(tmp) / "s.toml"
    path.write_text(text)
    try:
        scene = load_scene(path)
        return (
            "OK "
            + hashlib.sha1(resolved_config(scene).split("\n", 1)[1].encode()).hexdigest()[:12]
            + " "
            + "|".join(scene.warnings).replace(tmp, "TMP")
        )
    except SceneError as e:
        return "ERR " + str(e).replace(tmp, "TMP")
    except Exception as e:
        return "CRASH " + type(e).__name__ + " " + str(e)[:200]


def main():
    rng = random.Random(7)
    bases = sorted(ROOT.glob("scenes/*.toml")) + sorted(ROOT.glob("scenes/rigs/*.toml"))
    bases = [
        b
        for b in bases
        if b.stem
        in (
            "cdip_lqr_tilt",
            "rsip_pulse",
            "rsip_swingup",
            "ip02_sip_identify",
            "qube_servo2_identify",
            "acin_double_accel",
            "srv02_dbip",
            "cdip_pulse",
        )
    ]
    cases = []
    for base in bases:
        doc = tomllib.loads(base.read_text(), parse_float=Decimal)
        for table, keys in TABLE_KEYS.items():
            for key in [*keys, "bogus", "m1"]:
                variants = [None, *rng.sample(VALUES, 22)]
                for value in variants:
                    d = tomllib.loads(text_of(doc), parse_float=Decimal)
                    t = d.setdefault(table, {})
                    if value is None:
                        if key not in t:
                            continue
                        del t[key]
                    else:
                        t[key] = Raw(value)
                    cases.append((f"{base.name} {table}.{key}={value}", d))
        # pairs
        for _ in range(150):
            d = tomllib.loads(text_of(doc), parse_float=Decimal)
            for _ in range(2):
                table = rng.choice([*list(TABLE_KEYS), "bogus_table"])
                key = rng.choice([*TABLE_KEYS.get(table, ["x"]), "bogus"])
                d.setdefault(table, {})[key] = Raw(rng.choice(VALUES))
            cases.append((f"{base.name} pair {_}", d))
        d = tomllib.loads(text_of(doc), parse_float=Decimal)
        d["system"] = Raw("5")
        cases.append((f"{base.name} system=5", d))
        d = tomllib.loads(text_of(doc), parse_float=Decimal)
        d["input"] = {}
        cases.append((f"{base.name} input={{}}", d))
    start = int(sys.argv[3]) if len(sys.argv) > 3 else 0
    step = int(sys.argv[4]) if len(sys.argv) > 4 else 1
    with tempfile.TemporaryDirectory() as tmp, OUT.open("w") as out:
        for name, d in cases[start::step]:
            out.write(f"{name}\t{outcome(text_of(d), tmp)}\n")


main()
