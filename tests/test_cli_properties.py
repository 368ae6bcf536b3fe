"""Property-based: any combination of ipgen's options gives a header or one clean error line."""

from __future__ import annotations

import contextlib
import io
import os
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from ipgen.command.cli import run

MISSING = None
types = st.sampled_from([MISSING, "classical", "rotary", "Rotary", "cart", ""])
links = st.one_of(
    st.just(MISSING), st.integers(-3, 3).map(str), st.sampled_from(["x", "2.0", "1e1", " 2", "0x2"])
)
names = st.sampled_from([MISSING, "model_a", "m2", "2m", "class", "a-b", "__x", "Vector", "ok_name"])
inertias = st.sampled_from([MISSING, "pivot", "full", "none"])
fixes = st.sampled_from([MISSING, "m1=0.5", "m1=0", "delta1=0,g=9.81", "zz=1", "m1", "l0=1"])
outputs = st.sampled_from([MISSING, "forward_dynamics", "mass_matrix,bias", "nope", ""])


def arguments(option_values: dict[str, str | None]) -> list[str]:
    args: list[str] = []
    for option, value in option_values.items():
        if value is not MISSING:
            args += [option, value]
    return args


@settings(max_examples=80, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(types, links, names, inertias, fixes, outputs)
def test_header_or_one_line_error(
    system_type: str | None,
    link_count: str | None,
    name: str | None,
    inertia: str | None,
    fix: str | None,
    output: str | None,
) -> None:
    options = {"--type": system_type, "--links": link_count, "--name": name, "--inertia": inertia}
    args = arguments({**options, "--fix": fix, "--outputs": output})
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "out"
        stdout, stderr = io.StringIO(), io.StringIO()
        with contextlib.redirect_stdout(stdout), contextlib.redirect_stderr(stderr):
            status = run([*args, "-o", str(out)])
        if status == 0:
            headers = list(out.glob("*.hpp"))
            assert len(headers) == 1 and "#pragma once" in headers[0].read_text()
            assert stderr.getvalue() == ""
        else:
            assert status == 2, (args, status, stderr.getvalue())
            lines = stderr.getvalue().splitlines()
            assert len(lines) == 1 and lines[0].startswith("ipgen: error: "), (args, stderr.getvalue())
            assert not out.exists(), args


@pytest.mark.parametrize("signal_number", [signal.SIGINT, signal.SIGTERM])
def test_ctrl_c_leaves_no_partial_file(tmp_path: Path, signal_number: int) -> None:
    """SIGINT or SIGTERM during a derivation: exit 130 or 143, a one-line message, nothing
    written (SIGTERM ended the process at once, leaving its temporary files behind)."""
    out = tmp_path / "out"
    # Large enough to be still generating when the signal comes (it takes several seconds).
    command = ["--type", "classical", "--links", "50", "--force", "-o", str(out)]
    process = subprocess.Popen(
        [sys.executable, "-m", "ipgen", *command],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env={**os.environ, "PYTHONUNBUFFERED": "1"},
        # pytest-xdist workers ignore SIGINT, and an ignored signal stays ignored in a child:
        # give the child the default disposition, as in a terminal.
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )
    time.sleep(2.5)  # past the imports, inside the generation
    process.send_signal(signal_number)
    _, stderr = process.communicate(timeout=60)
    assert process.returncode == 128 + signal_number, stderr
    assert stderr.strip().splitlines()[-1] == "ipgen: interrupted; no file was written"
    assert "Traceback" not in stderr
    assert not out.exists() or not any(out.iterdir())


def test_huge_n_asks_for_force(tmp_path: Path) -> None:
    stderr = io.StringIO()
    with contextlib.redirect_stderr(stderr):
        assert run(["--type", "classical", "--links", "60", "-o", str(tmp_path / "o")]) == 2
    message = stderr.getvalue()
    assert message.count("\n") == 1 and "pass --force" in message and "GB" in message
    assert not (tmp_path / "o").exists()
