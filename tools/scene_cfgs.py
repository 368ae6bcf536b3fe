"""Write the simulator's .cfg of every shipped scene (scenes/*.toml, scenes/rigs/*.toml) into a folder.

Run it before and after a change to the scene layer and compare the folders (`diff -r`): the
.cfg files must stay byte-identical (the CSVs follow from them).

    python tools/scene_cfgs.py OUT_DIR
"""

from __future__ import annotations

import sys
from pathlib import Path

from ipgen.common.presets import presets
from ipgen.experiment.config import resolved_config
from ipgen.experiment.scene import load_scene

ROOT = Path(__file__).resolve().parent.parent


def main(out: Path) -> None:
    out.mkdir(parents=True, exist_ok=True)
    # the shipped scenes as ipgen lists them (scenes/ and scenes/rigs/), read by their path
    # relative to the checkout, as before
    # (not the fixed-pivot presets: the simulator does not take them yet)
    shipped = (p for p in presets() if not p.system.startswith("fixed"))
    for relative in sorted(preset.path.relative_to(ROOT) for preset in shipped):
        scene = load_scene(relative)
        name = relative.as_posix().replace("/", "__").removesuffix(".toml") + ".cfg"
        (out / name).write_text(resolved_config(scene), encoding="utf-8")
        print(name)


if __name__ == "__main__":
    main(Path(sys.argv[1]))
