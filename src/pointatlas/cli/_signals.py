"""Ctrl-C (SIGINT) and SIGTERM while a command runs: recorded, then one line.

The handlers record the request (`pointatlas._core.request_interrupt`) and raise
``KeyboardInterrupt``; `pointatlas.cli._app.guarded` turns it into the line and
exit status of `STOPPED`. Kept apart from ``_app`` so that ``cli/__init__.py``
reads the table before the heavy imports.

A ``KeyboardInterrupt`` raised between a library's lock acquire and the ``try``
that releases it leaves the lock held, and a thread that then waits for it (rich's
refresh thread, joined when a progress bar closes) never ends: a watchdog thread,
started with the command, sees the request and, if the command has not ended
`GRACE_S` seconds later, writes the line itself and leaves with the same exit
status. No output has replaced a file by then: ``atomic_write`` refuses once the
request is recorded. A clean-up that must not be cut short
(``interrupts_deferred``: a tiled run's cluster closing, its temporary folder
removed) gets up to `GRACE_ROUNDS` grace periods.
"""

from __future__ import annotations

import contextlib
import os
import signal
import sys
import threading

from .._core import (
    STOP_SIGNALS,
    clear_interrupt,
    interrupt_requested,
    interrupt_signal,
    interrupts_deferred_now,
    request_interrupt,
)

__all__ = ["GRACE_ROUNDS", "GRACE_S", "STOPPED", "stop_signals_handled", "stopped_line"]

#: What a command says, and its exit status, when a signal stopped it (128 + the
#: signal's number, as a shell reports a process that signal killed).
STOPPED = {
    signal.SIGINT: ("interrupted", 130),
    signal.SIGTERM: ("terminated", 143),
}


def stopped_line() -> tuple[str, int]:
    """The message and exit status of the recorded request (SIGINT's by default)."""
    return STOPPED[interrupt_signal() or signal.SIGINT]


#: Seconds a stopped command has to end on its own before the watchdog ends it ...
GRACE_S = 10.0
#: ... or this many times as long while an ``interrupts_deferred`` block runs.
GRACE_ROUNDS = 6

#: How often the watchdog looks for a request (seconds).
_POLL_S = 0.1


def _watch(ended: threading.Event) -> None:
    """The command's watchdog (a thread started with it, not by the signal handler:
    a handler that starts a thread can itself meet a lock the interrupted code
    holds): once a stop is requested, the command has `GRACE_S` seconds to end
    (``ended``), more while an ``interrupts_deferred`` block runs; then the line and
    the exit status without the interpreter's teardown."""
    while not interrupt_requested():
        if ended.wait(_POLL_S):
            return
    for _ in range(GRACE_ROUNDS):
        if ended.wait(GRACE_S):
            return
        if not interrupts_deferred_now():
            break
    line, code = stopped_line()
    os.write(2, f"error: {line}\n".encode())  # no Python-level lock: one may be held
    os._exit(code)


def _on_stop_signal(signum, frame):
    request_interrupt(signum)
    raise KeyboardInterrupt


def _quiet_interrupts(previous):
    """An ``unraisablehook`` that drops the ``KeyboardInterrupt`` our handler raised
    inside a finaliser (e.g. llvmlite's while numba compiles): the request is
    recorded, so the command still ends with the one "interrupted" line."""

    def hook(unraisable):
        if unraisable.exc_type is KeyboardInterrupt and interrupt_requested():
            return
        previous(unraisable)

    return hook


@contextlib.contextmanager
def stop_signals_handled():
    """Record SIGINT and SIGTERM while a command runs (main thread only), then put
    the previous handlers back and forget the request, which belonged to it."""
    clear_interrupt()
    previous = {}
    previous_hook = sys.unraisablehook
    ended, watchdog = threading.Event(), None
    if threading.current_thread() is threading.main_thread():
        watchdog = threading.Thread(target=_watch, args=(ended,), name="stop-watchdog")
        watchdog.daemon = True
        watchdog.start()
        previous = {s: signal.signal(s, _on_stop_signal) for s in STOP_SIGNALS}
        sys.unraisablehook = _quiet_interrupts(previous_hook)
    try:
        yield
    finally:
        for signum, handler in previous.items():
            if handler is not None:  # None: installed from C, cannot be put back
                signal.signal(signum, handler)
        if previous:
            sys.unraisablehook = previous_hook
        ended.set()  # the command ended: its watchdog stands down
        if watchdog is not None:
            watchdog.join()
        clear_interrupt()
