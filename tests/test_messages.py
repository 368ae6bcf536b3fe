"""Every message names an option (or scene key) that exists where the user reads it (issue 49).

Static, over all message templates: each `--option` in a string of the Python package is an
option of some `ipgen` command; each `--option` in a message the simulator prints about a run
(simulate.cpp's `run` and `divergence_message`, which `ipgen run` relays) is an option of
`ipgen run`. The simulator's own command-line errors (`throw UsageError`) and its usage text name
its own options: `ipgen run` never gives it a bad command line. Then `ipgen run --divergence-angle`
at work: the option the divergence message names is passed to the simulator.
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

import click
import pytest
from cxx import require_toolchain

from ipgen.command.cli import cli
from ipgen.command.cli import run as ipgen

ROOT = Path(__file__).resolve().parents[1]
OPTION = re.compile(r"(?<![\w-])--[a-z][a-z0-9-]*")


def command_options(command: click.Command) -> set[str]:
    """The long options of `command` and, for a group, of every command under it (and --help)."""
    found = {"--help"}
    for parameter in command.params:
        found |= {name for name in (*parameter.opts, *parameter.secondary_opts) if name.startswith("--")}
    if isinstance(command, click.Group):
        for sub in command.commands.values():
            found |= command_options(sub)
    return found


def python_messages() -> list[tuple[str, int, str]]:
    """(file, line, text) of every string constant of the package that is not a lone argument
    (`"--csv"` handed to a subprocess is an argument, not a message)."""
    found = []
    for path in sorted((ROOT / "generator").rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Constant) and isinstance(node.value, str):
                if OPTION.fullmatch(node.value.strip()):
                    continue
                found.append((str(path.relative_to(ROOT)), node.lineno, node.value))
    return found


def test_every_option_a_python_message_names_is_an_option_of_ipgen() -> None:
    known = command_options(cli)
    messages = python_messages()
    assert len(messages) > 500  # the package's strings were read
    unknown = [
        f"{path}:{line}: {option}"
        for path, line, text in messages
        for option in OPTION.findall(text)
        if option not in known
    ]
    assert not unknown, unknown


def _function_body(source: str, signature: str) -> str:
    """The text of the C++ function whose definition starts with `signature` (braces balanced)."""
    start = source.index(signature)
    opening = source.index("{", start)
    depth = 0
    for index in range(opening, len(source)):
        depth += {"{": 1, "}": -1}.get(source[index], 0)
        if depth == 0:
            return source[opening : index + 1]
    raise AssertionError(f"unbalanced braces after {signature!r}")


def simulator_run_messages() -> list[str]:
    """The string literals of the messages simulate.cpp prints about a run (not its own
    command-line errors)."""
    source = (ROOT / "cpp" / "src" / "simulate.cpp").read_text(encoding="utf-8")
    bodies = [
        _function_body(source, "std::string divergence_message("),
        _function_body(source, "int run(int argc, char** argv)"),
    ]
    literals = []
    for body in bodies:
        body = re.sub(r"throw UsageError\(.*?\);", "", body, flags=re.S)
        literals += re.findall(r'"((?:[^"\\\n]|\\.)*)"', body)
    return literals


def test_every_option_a_run_message_of_the_simulator_names_is_an_option_of_ipgen_run() -> None:
    """On main 1302ddc the divergence message said `--divergence-angle`, which ipgen run refused."""
    run_options = command_options(cli.commands["run"])
    literals = simulator_run_messages()
    named = {option for text in literals for option in OPTION.findall(text)}
    assert "--divergence-angle" in named  # the messages were found
    assert named <= run_options, sorted(named - run_options)


def scene_keys() -> dict[str, set[str]]:
    """The scene format's tables and their keys (its JSON Schema, `ipgen --scene-schema`)."""
    import json

    schema = json.loads((ROOT / "docs" / "scene.schema.json").read_text())

    def resolve(node: dict) -> dict:
        return resolve(schema["definitions"][node["$ref"].split("/")[-1]]) if "$ref" in node else node

    return {table: set(resolve(node).get("properties", {})) for table, node in schema["properties"].items()}


def test_every_scene_key_a_run_message_of_the_simulator_names_exists() -> None:
    """`[controller] period`, `[initial] theta`, `[swingup] u_max`: keys a user can set."""
    keys = scene_keys()
    named = []
    for text in simulator_run_messages():
        for table, key in re.findall(r"\[(\w+)\] (\w+)", text):
            named.append((table, key))
            assert table in keys, f"[{table}] is no table of a scene: {text!r}"
            assert key in keys[table], f"[{table}] {key} is no key of a scene: {text!r}"
    assert ("controller", "period") in named and ("initial", "theta") in named  # the messages were read


def test_ipgen_run_passes_the_divergence_angle_to_the_simulator(tmp_path: Path, capsys) -> None:
    """A do-nothing controller on the QUBE: the link falls from 0.1 rad and is stopped when it
    passes the angle given (exit status 3), the message naming the option and that angle."""
    require_toolchain()
    scene = (ROOT / "scenes" / "rigs" / "qube_servo2.toml").read_text()
    scene = scene.replace('kind = "lqr"', 'kind = "gain"\ngain = [0, 0, 0, 0]')
    scene = re.sub(r"\n(q|r) = .*", "", scene)
    path = tmp_path / "falling.toml"
    path.write_text(scene)
    status = ipgen(["run", str(path), "-o", str(tmp_path / "out"), "--divergence-angle", "0.2", "--no-plot"])
    err = capsys.readouterr().err
    assert status == 3, err
    assert "beyond 0.2 rad (--divergence-angle)" in err, err
    last = (tmp_path / "out" / "falling.csv").read_text().splitlines()[-1].split(",")
    assert 0.19 < abs(float(last[2])) < 0.3  # stopped near 0.2 rad, not at the default π/2


@pytest.mark.parametrize("value", ["0", "-1", "nan", "x"])
def test_a_bad_divergence_angle_is_one_line(value: str, tmp_path: Path, capsys) -> None:
    status = ipgen(["run", "--preset", "qube_servo2", "-o", str(tmp_path), "--divergence-angle", value])
    err = capsys.readouterr().err
    assert status == 2 and err.count("\n") == 1 and "--divergence-angle" in err, err
    assert not any(tmp_path.iterdir())
