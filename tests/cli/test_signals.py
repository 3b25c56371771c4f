"""SIGTERM stops a command as Ctrl-C does: one line, exit 143, earlier outputs kept
(issue 28 item 8; the tiled runs are tried in tests/batch/test_tiles_signals.py)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys

import pytest

from pointatlas.io import write_point_set

from .helpers import run, sphere_points


class _SignalReachedTheTest(Exception):
    pass


@pytest.fixture
def sigterm_caught():
    """A SIGTERM that no command handles fails the test instead of ending pytest."""

    def caught(signum, frame):
        raise _SignalReachedTheTest

    previous = signal.signal(signal.SIGTERM, caught)
    yield
    signal.signal(signal.SIGTERM, previous)


@pytest.mark.parametrize(
    ("signum", "code", "line"),
    [(signal.SIGTERM, 143, "error: terminated"), (signal.SIGINT, 130, "error: interrupted")],
    ids=["sigterm", "sigint"],
)
def test_a_signal_during_a_command_says_so_and_keeps_outputs(
    tmp_path, monkeypatch, sigterm_caught, signum, code, line
):
    from pointatlas.cli.jobs import _normals

    src, out = tmp_path / "in.ply", tmp_path / "out.ply"
    write_point_set(src, sphere_points(200))
    out.write_bytes(b"previous")
    real = _normals.estimate_normals

    def signalled(*args, **kw):
        os.kill(os.getpid(), signum)  # the handler runs when this returns
        return real(*args, **kw)

    monkeypatch.setattr(_normals, "estimate_normals", signalled)
    before = signal.getsignal(signal.SIGINT)  # Python's, or what an earlier test left
    result = run("normals", src, out, "--k", "8")
    assert result.exit_code == code, result.output
    assert result.stderr.strip() == line
    assert out.read_bytes() == b"previous"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["in.ply", "out.ply"]
    # the command put the handlers back
    assert signal.getsignal(signal.SIGINT) is before
    assert signal.getsignal(signal.SIGTERM).__name__ == "caught"


_STUCK = """
import signal, sys, threading, time
from pointatlas._core import interrupts_deferred
from pointatlas.cli import _signals
_signals.GRACE_S, _signals.GRACE_ROUNDS = 1.0, 4
held = threading.Lock()
held.acquire()  # as a library lock left held by an interrupt between acquire and try
with _signals.stop_signals_handled():
    try:
        signal.raise_signal(signal.SIG{name})
    except KeyboardInterrupt:
        pass
    if "{mode}" == "stuck":
        held.acquire()  # never released: the command cannot end on its own
    if "{mode}" == "clean-up":
        with interrupts_deferred():
            time.sleep(2.5)  # longer than GRACE_S: a cluster closing
time.sleep(3.0)  # after the command: a watchdog that fired now would be wrong
print("ended")
"""


def _run_stuck(name: str, mode: str):
    return subprocess.run(
        [sys.executable, "-c", _STUCK.format(name=name, mode=mode)],
        capture_output=True,
        text=True,
        timeout=120,
    )


@pytest.mark.parametrize(
    ("name", "code", "line"),
    [("INT", 130, "error: interrupted"), ("TERM", 143, "error: terminated")],
)
def test_a_command_stuck_after_a_signal_is_ended_by_the_watchdog(name, code, line):
    stuck = _run_stuck(name, "stuck")
    assert (stuck.returncode, stuck.stderr.strip(), stuck.stdout) == (code, line, "")
    for mode in ("ends", "clean-up"):  # the watchdog stands down; waits for a clean-up
        ended = _run_stuck(name, mode)
        assert (ended.returncode, ended.stderr, ended.stdout) == (0, "", "ended\n"), mode
