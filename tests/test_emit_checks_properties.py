"""Property (issue 31): what a model may emit is checked in one place (`codegen.emit.unsupported`),
so a scene's `emit = [...]` key and the `--emit` option (or `write_header(emit=...)`) meet the
same refusals: an FMU with a dc_motor or an acceleration actuator, specialise with an
acceleration actuator, an FMU in the rig's coordinates. Before, `--emit fmu` on the command line
wrote an FMU whose input is the force for a scene whose input is volts."""

from __future__ import annotations

import contextlib
import io
from pathlib import Path

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from ipgen.codegen.emit import FMU_TARGETS, TARGETS
from ipgen.command.cli import run
from ipgen.errors import Error
from ipgen.pipeline import job

ACTUATORS = {
    "direct": "",
    "dc_motor": '[actuator]\nkind = "dc_motor"\nRm = 8.4\nkt = 0.042\nkm = 0.042\n',
    "acceleration": '[actuator]\nkind = "acceleration"\n',
}


def _scene(actuator: str, zero: str, specialise: bool, emit: tuple[str, ...] | None) -> str:
    keys = [f'zero = "{zero}"', f"specialise = {'true' if specialise else 'false'}"]
    if emit is not None:
        keys.append(f"emit = [{', '.join(repr(t).replace(chr(39), chr(34)) for t in emit)}]")
    return (
        '[system]\ntype = "rotary"\nlinks = 1\nname = "rsip"\n' + "\n".join(keys) + "\n\n"
        "[parameters]\nm = [0.5, 0.275]\nl = [0.6, 0.5]\ndelta = [0.3, 0.011458]\n\n"
        + ACTUATORS[actuator]
        + '\n[input]\nkind = "zero"\n\n[simulation]\nt_end = 1.0\n'
    )


def _outcome(call: object) -> str:
    """The string "ok", or the one-line message of the refusal."""
    try:
        call()  # type: ignore[operator]
    except Error as e:
        return str(e).split(".toml: ", 1)[-1]  # a scene's message starts with its path
    return "ok"


TARGET_SETS = st.lists(st.sampled_from(list(TARGETS)), min_size=1, max_size=3)


@settings(max_examples=80, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(
    actuator=st.sampled_from(sorted(ACTUATORS)),
    zero=st.sampled_from(["upright", "hanging"]),
    specialise=st.booleans(),
    targets=TARGET_SETS,
)
def test_the_option_and_the_key_meet_the_same_check(
    tmp_path: Path, actuator: str, zero: str, specialise: bool, targets: list[str]
) -> None:
    if "fmu" in targets:  # fmu and fmu3 both write NAME.fmu: refused by parse_emit, another class
        targets = [target for target in targets if target != "fmu3"]
    if "c" in targets:  # so do c and library NAME.h
        targets = [target for target in targets if target != "library"]
    emit = tuple(dict.fromkeys(targets))
    keyed, plain = tmp_path / "keyed.toml", tmp_path / "plain.toml"
    keyed.write_text(_scene(actuator, zero, specialise, emit))
    plain.write_text(_scene(actuator, zero, specialise, None))
    by_key = _outcome(lambda: job.plan(tmp_path / "o", scene=keyed))
    by_option = _outcome(lambda: job.plan(tmp_path / "o", scene=plain, emit=emit))
    if _outcome(lambda: job.plan(tmp_path / "o", scene=plain)) != "ok":
        return  # the scene itself is refused (acceleration with specialise): no emit to compare
    assert by_key == by_option
    fmu = any(t in FMU_TARGETS for t in emit)
    refused = fmu and (actuator != "direct" or zero != "upright")
    assert (by_option != "ok") == refused, (actuator, zero, specialise, emit, by_option)
    if refused:  # and on the command line: one line, exit 2, nothing written
        err = io.StringIO()
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
            status = run(["--scene", str(plain), "--emit", ",".join(emit), "-o", str(tmp_path / "cli")])
        assert status == 2 and err.getvalue().count("\n") == 1 and "FMU" in err.getvalue()
        assert not (tmp_path / "cli").exists()


def test_the_reported_examples_are_refused() -> None:
    root = Path(__file__).resolve().parent.parent / "scenes"
    for scene, target in (("rigs/ip02_sip_identify.toml", "fmu"), ("acin_double_accel.toml", "fmu3")):
        path = next(root.glob(f"**/{Path(scene).name}"))
        message = _outcome(lambda path=path, target=target: job.plan("out", scene=path, emit=target))
        assert "is not supported" in message and "FMU" in message, message
