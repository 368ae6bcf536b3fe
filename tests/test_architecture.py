"""The package's stages import only earlier stages, and no module imports itself back.

Every import of an ipgen module counts, those under `if TYPE_CHECKING:` and inside functions too:
a circle that only typing or a lazy import hides is still a circle a reader has to untangle.
"""

from __future__ import annotations

import ast
import functools
from pathlib import Path

PACKAGE = Path(__file__).resolve().parent.parent / "generator"

# The stages in order: a module may import its own stage and the stages before it.
# plots (pictures of runs: matplotlib) comes after control, before the stages that use it;
# identification (fitting parameters to measurements) between control, whose models it uses, and plots.
# estimation (what a sampled loop knows of the state: sensors, Kalman filters) uses control's models;
# the C header (codegen) prints its numbers. scene reads and checks a scene file; experiment resolves
# it (the defaults, the designed gains, plans and estimators, the .cfg). pipeline puts the stages
# together (each command's work as a library function); command only parses arguments and prints.
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
    "experiment",
    "pipeline",
    "command",
    "sweeps",
    "gym",
    "ipgen",
)
# The command line's front of the sweeps (parsing and printing only): like the public API, it
# fronts a stage after its own (sweeps run scenes with the pipeline's generation and simulator cache).
FRONTS = ("ipgen", "ipgen.__main__", "ipgen.command.sweep")


# Imports that go to a later stage on purpose, each inside the one function that needs it (checked
# below) and left out of the stage and circle checks: `Pendulum.from_scene(path)` reads a scene file
# (the experiment stage builds on the model's Pendulum; this one call goes the other way, on request).
LATE_IMPORTS: dict[tuple[str, str], str] = {
    ("ipgen.model.pendulum", "ipgen.experiment.scene"): "Pendulum.from_scene reads a scene file",
    ("ipgen.model.fixed", "ipgen.scene.fixed"): "FixedPendulum.from_scene reads a fixed scene file",
    ("ipgen.control.mpc", "ipgen.pipeline.model_library"): "ipgen.mpc compiles the model library it runs on",
}
# Of those, the ones whose module also names the later stage's type at module level under
# `if TYPE_CHECKING:` (for annotations only, never run): declared here, so that no other can hide.
TYPING_LATE_IMPORTS = {("ipgen.model.pendulum", "ipgen.experiment.scene")}


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
    """Each module's imports of ipgen modules (but `LATE_IMPORTS`): a copy of `_parsed_graph`."""
    return {name: set(targets) for name, targets in _parsed_graph().items()}


@functools.cache
def _parsed_graph() -> dict[str, set[str]]:
    """The package's sources parsed once per process (three tests read the graph; the sources do
    not change during a test run)."""
    modules = _modules()
    return {
        name: {t for t in _imports(path, modules) if t != name and (name, t) not in LATE_IMPORTS}
        for name, path in modules.items()
    }


def test_late_imports_are_inside_functions() -> None:
    """Each import of `LATE_IMPORTS` exists and is made inside a function, never at module level
    (importing the module does not import the later stage)."""
    modules = _modules()
    for (source, target), why in LATE_IMPORTS.items():
        tree = ast.parse(modules[source].read_text())
        top, typing = _module_level_imports(tree)
        lazy = {
            node.module
            for function in ast.walk(tree)
            if isinstance(function, ast.FunctionDef | ast.AsyncFunctionDef)
            for node in ast.walk(function)
            if isinstance(node, ast.ImportFrom)
        }
        assert target in lazy, f"{source} no longer imports {target} ({why}): remove it from LATE_IMPORTS"
        assert target not in top, f"{source} imports {target} at module level; import it where it is used"
        declared = (source, target) in TYPING_LATE_IMPORTS
        assert (target in typing) == declared, (
            f"{source} {'no longer imports' if declared else 'imports'} {target} under TYPE_CHECKING: "
            f"{'remove it from' if declared else 'declare it in'} TYPING_LATE_IMPORTS"
        )


def _module_level_imports(tree: ast.Module) -> tuple[set[str | None], set[str | None]]:
    """The modules `tree` imports outside every function: (run on import, under TYPE_CHECKING only)."""
    run: set[str | None] = set()
    typing: set[str | None] = set()

    def visit(nodes: list[ast.stmt], guarded: bool) -> None:
        for node in nodes:
            if isinstance(node, ast.ImportFrom):
                (typing if guarded else run).add(node.module)
            elif isinstance(node, ast.If):
                checking = isinstance(node.test, ast.Name) and node.test.id == "TYPE_CHECKING"
                visit(node.body, guarded or checking)
                visit(node.orelse, guarded)
            elif isinstance(node, ast.Try | ast.With | ast.ClassDef):
                visit(node.body, guarded)

    visit(tree.body, False)
    return run, typing


def test_the_module_level_check_sees_typing_imports() -> None:
    """The check above is not vacuous: an import under `if TYPE_CHECKING:` is seen, apart."""
    tree = ast.parse("from ipgen.a import x\nif TYPE_CHECKING:\n    from ipgen.b import Y\n")
    assert _module_level_imports(tree) == ({"ipgen.a"}, {"ipgen.b"})


def test_every_import_names_a_module_of_the_package() -> None:
    modules = _modules()
    for name, targets in _graph().items():
        unknown = {t for t in targets if t not in modules}
        assert not unknown, f"{name} imports {unknown}, which are not modules of ipgen"


def test_stages_import_only_earlier_stages() -> None:
    for name, targets in _graph().items():
        if name in FRONTS:
            continue  # the public API, `python -m ipgen` and the sweep command front every stage
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


# Private names still imported across modules, to be made public or moved (none left: the
# scene layer's message helpers are public in scene/fields.py); the list may only shrink.
KNOWN_PRIVATE_SOURCES: frozenset[str] = frozenset()


def _private_imports(modules: dict[str, Path] | None = None) -> set[tuple[str, str]]:
    """(module, imported name) of every `from ipgen.x import _name` in the package (typing and
    function-level imports too)."""
    found = set()
    for name, path in (modules or _modules()).items():
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom) and node.module and node.module.startswith("ipgen"):
                for alias in node.names:
                    if alias.name.startswith("_") and not alias.name.startswith("__"):
                        found.add((name, f"{node.module}.{alias.name}"))
    return found


def test_no_private_name_is_imported_across_modules() -> None:
    found = _private_imports()
    new = sorted(
        (module, name) for module, name in found if name.rsplit(".", 1)[0] not in KNOWN_PRIVATE_SOURCES
    )
    assert not new, f"private names imported from another module (make them public or move them): {new}"
    sources = {name.rsplit(".", 1)[0] for _, name in found}
    fixed = sorted(KNOWN_PRIVATE_SOURCES - sources)
    assert not fixed, f"not imported privately any more, remove from KNOWN_PRIVATE_SOURCES: {fixed}"


def test_the_private_import_check_finds_one(tmp_path: Path) -> None:
    """The check above is not vacuous: `from ipgen.a import _hidden` is reported."""
    (tmp_path / "b.py").write_text("def f():\n    from ipgen.a import _hidden, public, __version__\n")
    assert _private_imports({"ipgen.b": tmp_path / "b.py"}) == {("ipgen.b", "ipgen.a._hidden")}


def test_the_old_coordinates_module_still_serves_its_names() -> None:
    """`ipgen.control.coordinates` (where Coordinates lived) re-exports model.coordinates' objects."""
    from ipgen.control import coordinates as old
    from ipgen.model import coordinates as new

    assert all(getattr(old, name) is getattr(new, name) for name in old.__all__)
    assert set(old.__all__) == {"ANGLES", "POSITIVE", "ZEROS", "CoordinateError", "Coordinates"}
