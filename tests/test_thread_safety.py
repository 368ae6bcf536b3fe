"""Independent controllers in threads and forked processes do not interfere (a thread-safety
audit, 2026-12-01): Python's warning filters survive threads building controllers, a loaded
model's lookup does not wait for another model's build, and a child forked while a thread held
a library lock is not stuck on it."""

from __future__ import annotations

import os
import sys
import threading
import time
import warnings
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor

import pytest

import ipgen
from ipgen.common import loop_runtime, quiet
from ipgen.control import mpc as mpc_module
from ipgen.control.linear import EquilibriumWarning

pytestmark = pytest.mark.skipif(not hasattr(os, "fork"), reason="needs os.fork")


def test_warning_filters_survive_threads_building_controllers() -> None:
    """`warnings.catch_warnings` is not thread-safe before Python 3.14: four threads building MPCs
    (each silencing a warning around a step of its design) left `ignore EquilibriumWarning` in the
    process's filters, and the user's own warnings were dropped for good."""
    qube, ip02 = ipgen.Pendulum.preset("qube_servo2"), ipgen.Pendulum.preset("ip02_sip")
    ipgen.mpc(qube, u_max=10.0, horizon=5)  # libraries built and loaded before the threads
    ipgen.mpc(ip02, u_max=10.0, horizon=5)

    def build(i: int) -> None:
        for _ in range(40):
            ipgen.mpc(qube if i % 2 else ip02, u_max=10.0, horizon=5)

    interval = sys.getswitchinterval()
    with warnings.catch_warnings():
        warnings.simplefilter("always", EquilibriumWarning)
        before = list(warnings.filters)
        sys.setswitchinterval(1e-6)  # threads switch often: an interleaving is likely
        try:
            for _ in range(3):
                with ThreadPoolExecutor(4) as pool:
                    list(pool.map(build, range(4)))
                assert warnings.filters == before, [f for f in warnings.filters if f not in before]
        finally:
            sys.setswitchinterval(interval)
        with warnings.catch_warnings(record=True) as seen:
            warnings.simplefilter("always", EquilibriumWarning)
            ipgen.linearize(qube, q=[0.0, 0.3], qd=[0.5, 0.0], u=0.0)  # not a rest
        assert any(w.category is EquilibriumWarning for w in seen)


def test_a_loaded_model_does_not_wait_for_another_models_build(monkeypatch: pytest.MonkeyPatch) -> None:
    """The MPC module held one lock through a whole model library's compile: a lookup of a model
    already loaded waited 0.33 s on another model's build."""
    from ipgen.pipeline import model_library

    slow = ipgen.Pendulum("rotary", 3, m=[1, 1, 1, 1], l=[1, 1, 1, 1], delta=[0, 0, 0, 0])
    loaded = ipgen.Pendulum("classical", 3, m=[1, 1, 1, 1], l=[0, 1, 1, 1], delta=[0, 0, 0, 0])
    monkeypatch.setitem(mpc_module._models, loaded.system, "the loaded library")
    started = threading.Event()

    def compile_slowly(system: object) -> str:
        started.set()
        time.sleep(1.5)
        return "the new library"

    monkeypatch.setattr(model_library, "compiled_model_library", compile_slowly)
    monkeypatch.delitem(mpc_module._models, slow.system, raising=False)
    builder = threading.Thread(target=mpc_module.model_library, args=(slow,))
    builder.start()
    try:
        assert started.wait(10)
        begun = time.monotonic()
        assert mpc_module.model_library(loaded) == "the loaded library"
        assert time.monotonic() - begun < 0.5
        assert mpc_module.model_library(slow) == "the new library"  # waits for that build only
    finally:
        builder.join()
        mpc_module._models.pop(slow.system, None)


def _fork_and_check(child: Callable[[], bool]) -> None:
    """Fork; the child exits 0 if `child()` is true (within 10 s, else it is killed)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)  # 3.12+: fork with threads running
        pid = os.fork()
    if pid == 0:  # the child: exit at once
        os._exit(0 if child() else 1)
    deadline = time.monotonic() + 10
    while True:
        done, status = os.waitpid(pid, os.WNOHANG)
        if done:
            break
        if time.monotonic() > deadline:
            os.kill(pid, 9)
            os.waitpid(pid, 0)
            pytest.fail("the forked child did not exit")
        time.sleep(0.05)
    assert os.waitstatus_to_exitcode(status) == 0


@pytest.mark.parametrize(
    ("module", "name"),
    [(mpc_module, "_lock"), (loop_runtime, "_lock"), (quiet, "_LOCK")],
    ids=["mpc", "loop", "quiet"],
)
def test_a_child_forked_while_a_thread_holds_the_lock_is_not_stuck(module: object, name: str) -> None:
    """A process forked while another thread held a lock of ipgen's (compiling a library, or
    inside a silenced call: quiet's) inherited the lock held, by a thread it does not have: its
    first controller waited for good."""
    holding, release = threading.Event(), threading.Event()

    def hold() -> None:
        with getattr(module, name):
            holding.set()
            release.wait(10)

    holder = threading.Thread(target=hold)
    holder.start()
    try:
        assert holding.wait(10)
        _fork_and_check(lambda: getattr(module, name).acquire(timeout=2))
    finally:
        release.set()
        holder.join()


def test_a_child_forked_during_a_build_builds_for_itself() -> None:
    """The lock held through a compile is the library's own (`mpc._building`): a child forked
    while a thread compiles gets its own, and its request for that library is answered."""
    store: dict[object, object] = {}
    building, release = threading.Event(), threading.Event()

    def make() -> str:
        building.set()
        release.wait(10)
        return "the parent's"

    builder = threading.Thread(target=mpc_module._once, args=(store, "key", make))
    builder.start()
    try:
        assert building.wait(10)
        _fork_and_check(lambda: mpc_module._once(store, "key", lambda: "the child's") == "the child's")
    finally:
        release.set()
        builder.join()
    assert store["key"] == "the parent's"


def test_the_equations_documents_keep_their_escaping_in_threads() -> None:
    """The Markdown and TeX renders set one shared environment's `escape_text` filter in turn:
    rendered from threads, a .md came out with TeX's escapes (50\\%)."""
    from ipgen.codegen import equations
    from ipgen.codegen.header import HeaderRequest
    from ipgen.model.coordinates import Coordinates
    from ipgen.model.derivation import derive
    from ipgen.model.specialise import Specialisation
    from ipgen.model.system import System

    eqs = derive(System("rotary", 1))
    request = HeaderRequest(
        "m", "ipgen 50% & #1", Specialisation(), None, (), (), None, Coordinates(), None, "direct"
    )
    alone = equations.render_equations(eqs, request)
    assert "50%" in alone[".md"] and "50\\%" in alone[".tex"]

    def render(_: int) -> dict[str, str]:
        return equations.render_equations(eqs, request)

    interval = sys.getswitchinterval()
    sys.setswitchinterval(1e-6)
    try:
        with ThreadPoolExecutor(8) as pool:
            results = list(pool.map(render, range(200)))
    finally:
        sys.setswitchinterval(interval)
    assert all(result == alone for result in results)
