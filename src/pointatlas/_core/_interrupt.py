"""A process-wide "the user asked to stop" flag, read before an output replaces a file.

The command line sets it from its SIGINT handler. A numba kernel cannot be
interrupted, and an interrupt that arrives while one runs may surface later as a
``SystemError`` or be swallowed by library code; the flag makes the request
stick, so that :func:`pointatlas.io.atomic_write` refuses to move a new file over
an old one once it is set, whatever happened to the ``KeyboardInterrupt``.
"""

from __future__ import annotations

import threading

__all__ = ["clear_interrupt", "interrupt_requested", "request_interrupt"]

_REQUESTED = threading.Event()


def request_interrupt() -> None:
    """Record that the user asked to stop (called from a signal handler)."""
    _REQUESTED.set()


def clear_interrupt() -> None:
    """Forget an earlier request (at the start of a command)."""
    _REQUESTED.clear()


def interrupt_requested() -> bool:
    """True once :func:`request_interrupt` was called and not cleared since."""
    return _REQUESTED.is_set()
