"""The package's stages import only earlier stages, and no module imports itself back.

Every import of an ipgen module counts, those under `if TYPE_CHECKING:` and inside functions too:
a circle that only typing or a lazy import hides is still a circle a reader has to untangle.
"""

from __future__ import annotations

import ast
from pathlib import Path

PACKAGE = Path(__file__).resolve().parent.parent / "generator"

# The stages in order: a module may import its own stage and the stages before it.
# plots (pictures of runs: matplotlib) comes after control, before the stages that use it;
# identification (fitting parameters to measurements) between control, whose models it uses, and plots.
# estimation (what a sampled loop knows of the state: sensors, Kalman filters) uses control's models;
# the C header (codegen) prints its numbers.
STAGES = (
    "errors",
    "common",
    "model",
    "control",
    "estimation",
    "identification",
    "plots",
    "codegen",
    "scene",
    "command",
    "ipgen",
)


def _module_name(path: Path) -> str:
    parts = path.relative_to(PACKAGE).with_suffix("").parts
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(("ipgen", *parts))


def _modules() -> dict[str, Path]:
    return {_module_name(path): path for path in PACKAGE.rglob("*.py")}


def _imports(path: Path, modules: dict[str, Path]) -> set[str]:
    """The ipgen modules `path` imports (a `from package import submodule` names the submodule)."""
    found: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names if alias.name.startswith("ipgen"))
        elif isinstance(node, ast.ImportFrom) and node.module and node.module.startswith("ipgen"):
            for alias in node.names:
                submodule = f"{node.module}.{alias.name}"
                found.add(submodule if submodule in modules else node.module)
    return found


def _stage(module: str) -> str:
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else "ipgen"


def _graph() -> dict[str, set[str]]:
    modules = _modules()
    return {name: _imports(path, modules) - {name} for name, path in modules.items()}


def test_every_import_names_a_module_of_the_package() -> None:
    modules = _modules()
    for name, targets in _graph().items():
        unknown = {t for t in targets if t not in modules}
        assert not unknown, f"{name} imports {unknown}, which are not modules of ipgen"


def test_stages_import_only_earlier_stages() -> None:
    for name, targets in _graph().items():
        if name == "ipgen" or name == "ipgen.__main__":
            continue  # the public API and `python -m ipgen` front every stage
        rank = STAGES.index(_stage(name))
        later = sorted(t for t in targets if STAGES.index(_stage(t)) > rank)
        assert not later, f"{name} (stage {_stage(name)}) imports later stages: {later}"


def test_no_import_circle() -> None:
    graph = _graph()
    state: dict[str, int] = {}  # 1: on the current path, 2: done

    def visit(node: str, path: list[str]) -> None:
        state[node] = 1
        for target in sorted(graph.get(node, ())):
            if state.get(target) == 1:
                circle = [*path[path.index(target) :], target]
                raise AssertionError("import circle: " + " -> ".join(circle))
            if target not in state:
                visit(target, [*path, target])
        state[node] = 2

    for node in sorted(graph):
        if node not in state:
            visit(node, [node])


def test_the_checker_finds_a_circle(tmp_path: Path) -> None:
    """The circle finder above is not vacuous: two modules importing each other are caught."""
    (tmp_path / "a.py").write_text("from ipgen.b import x\n")
    (tmp_path / "b.py").write_text("if False:\n    from ipgen.a import y\n")
    modules = {"ipgen.a": tmp_path / "a.py", "ipgen.b": tmp_path / "b.py"}
    graph = {name: _imports(path, modules) for name, path in modules.items()}
    assert graph == {"ipgen.a": {"ipgen.b"}, "ipgen.b": {"ipgen.a"}}
