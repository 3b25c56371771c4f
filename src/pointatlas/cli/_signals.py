"""Ctrl-C (SIGINT) and SIGTERM while a command runs: recorded, then one line.

The handlers record the request (`pointatlas._core.request_interrupt`) and raise
``KeyboardInterrupt``; `pointatlas.cli._app.guarded` turns it into the line and
exit status of `STOPPED`. Kept apart from ``_app`` so that ``cli/__init__.py``
reads the table before the heavy imports.
"""

from __future__ import annotations

import contextlib
import signal
import sys
import threading

from .._core import (
    STOP_SIGNALS,
    clear_interrupt,
    interrupt_requested,
    interrupt_signal,
    request_interrupt,
)

__all__ = ["STOPPED", "stop_signals_handled", "stopped_line"]

#: What a command says, and its exit status, when a signal stopped it (128 + the
#: signal's number, as a shell reports a process that signal killed).
STOPPED = {
    signal.SIGINT: ("interrupted", 130),
    signal.SIGTERM: ("terminated", 143),
}


def stopped_line() -> tuple[str, int]:
    """The message and exit status of the recorded request (SIGINT's by default)."""
    return STOPPED[interrupt_signal() or signal.SIGINT]


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
    if threading.current_thread() is threading.main_thread():
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
        clear_interrupt()
