"""One line on stderr when a command waits on numba's compiler.

A command whose kernels are not in numba's cache compiles them first (a minute or
more for some commands on a fresh install). The ``pointatlas`` entry point
installs `announce_compiles`: once compiling has taken `NOTICE_AFTER_S` seconds
in total, :data:`COMPILE_NOTICE` is printed, once. Loading a kernel from the cache
is no compile (numba reports none), so a warmed install prints nothing.
"""

from __future__ import annotations

import sys
import threading
import time

from numba.core import event

__all__ = ["COMPILE_NOTICE", "NOTICE_AFTER_S", "announce_compiles"]

#: Seconds of compiling before the notice: a few stale kernels (a source edit)
#: compile within this and stay quiet; a cold cache takes far longer.
NOTICE_AFTER_S = 2.0

COMPILE_NOTICE = (
    "compiling numeric kernels once (up to a few minutes on a first run; later runs start at once)"
)


class _Notice(event.Listener):
    """A numba ``numba:compile`` listener that says `COMPILE_NOTICE` once the
    compiles (nested ones counted once) have lasted ``after`` seconds in total."""

    def __init__(self, after: float, write):
        self._after = after
        self._write = write
        self._lock = threading.Lock()
        self._depth = 0
        self._busy = 0.0  # seconds of finished compiling
        self._since = None  # start of the compile in progress
        self._timer = None
        self.said = False

    def on_start(self, ev) -> None:
        with self._lock:
            self._depth += 1
            if self._depth == 1 and not self.said:
                self._since = time.monotonic()
                self._timer = threading.Timer(max(self._after - self._busy, 0.0), self._fire)
                self._timer.daemon = True
                self._timer.start()

    def on_end(self, ev) -> None:
        with self._lock:
            self._depth -= 1
            if self._depth or self._since is None:
                return
            self._busy += time.monotonic() - self._since
            self._since = None
            self._timer.cancel()
            if self._busy >= self._after:
                self._say()

    def _fire(self) -> None:
        with self._lock:
            if self._depth:
                self._say()

    def _say(self) -> None:
        if not self.said:
            self.said = True
            self._write(COMPILE_NOTICE)


def _to_stderr(line: str) -> None:
    sys.stderr.write(line + "\n")
    sys.stderr.flush()


def announce_compiles(*, after: float = NOTICE_AFTER_S, write=_to_stderr) -> _Notice:
    """Print `COMPILE_NOTICE` (via ``write``) once numba has compiled for ``after``
    seconds in this process; returns the listener (``.said`` tells whether it spoke)."""
    notice = _Notice(after, write)
    event.register("numba:compile", notice)
    return notice
