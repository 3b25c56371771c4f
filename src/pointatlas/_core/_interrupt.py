"""A process-wide "the user asked to stop" flag, read before an output replaces a file.

The command line sets it from its SIGINT and SIGTERM handler. A numba kernel cannot
be interrupted, and an interrupt that arrives while one runs may surface later as a
``SystemError`` or be swallowed by library code; the flag makes the request
stick, so that :func:`pointatlas.io.atomic_write` refuses to move a new file over
an old one once it is set, whatever happened to the ``KeyboardInterrupt``.

:func:`interrupts_deferred` runs a block that a signal must not cut in half
(starting and closing a cluster of worker processes, removing a temporary folder):
the signal takes effect when the block ends.
"""

from __future__ import annotations

import contextlib
import signal
import threading

__all__ = [
    "STOP_SIGNALS",
    "clear_interrupt",
    "interrupt_requested",
    "interrupt_signal",
    "interrupts_deferred",
    "interrupts_deferred_now",
    "request_interrupt",
]

#: The signals that ask a command to stop: Ctrl-C and a polite ``kill``.
STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM)

_REQUESTED = threading.Event()
_SIGNAL = [signal.SIGINT]  # the signal of the request (one slot, set before the event)
_DEFERRING = [0]  # `interrupts_deferred` blocks running now, in any thread
_DEFERRING_LOCK = threading.Lock()


def request_interrupt(signum: int = signal.SIGINT) -> None:
    """Record that the user asked to stop (called from a signal handler).

    Parameters
    ----------
    signum : int
        The signal that asked (one of `STOP_SIGNALS`); the first request since the
        last `clear_interrupt` is the one `interrupt_signal` reports.
    """
    if not _REQUESTED.is_set():
        _SIGNAL[0] = signum
    _REQUESTED.set()


def clear_interrupt() -> None:
    """Forget an earlier request (at the start of a command).

    Notes
    -----
    After it, `interrupt_requested` is False and `interrupt_signal` None until the
    next `request_interrupt`.
    """
    _REQUESTED.clear()
    _SIGNAL[0] = signal.SIGINT


def interrupt_requested() -> bool:
    """Whether the user asked to stop.

    Returns
    -------
    requested : bool
        True once :func:`request_interrupt` was called and not cleared since.
    """
    return _REQUESTED.is_set()


def interrupt_signal() -> int | None:
    """The signal of the first request since the last clear.

    Returns
    -------
    signum : int or None
        The signal `request_interrupt` recorded first; None without a request.
    """
    return _SIGNAL[0] if _REQUESTED.is_set() else None


@contextlib.contextmanager
def interrupts_deferred(*, children: bool = False):
    """Run a block that SIGINT and SIGTERM must not cut short; they act after it.

    In the main thread the block runs with handlers that only note the signal; when
    it ends the previous handlers are put back and a noted signal is raised again,
    so it does then what it would have done (the command line's handler: "error:
    interrupted"; Python's default: ``KeyboardInterrupt``). The signals are also
    blocked in the calling thread while the block runs: threads started in it
    inherit the mask, and so do the processes those threads start (the worker
    processes of a dask ``LocalCluster``), which therefore never see a Ctrl-C meant
    for the whole process group; their parent stops them. Elsewhere than in the main
    thread of a POSIX process, the parts that cannot be done are left out.

    Parameters
    ----------
    children : bool
        The block starts processes with :mod:`multiprocessing`: its resource tracker
        is started first, because starting it unblocks the two signals in the thread
        that starts it (CPython's ``resource_tracker``).

    Yields
    ------
    None
        The block runs inside the ``with`` statement.
    """
    if children and hasattr(signal, "pthread_sigmask"):
        from multiprocessing import resource_tracker

        resource_tracker.ensure_running()
    noted = []
    previous = {}
    if threading.current_thread() is threading.main_thread():
        for signum in STOP_SIGNALS:
            previous[signum] = signal.signal(signum, lambda s, f: noted.append(s))
    mask = None
    if hasattr(signal, "pthread_sigmask"):
        mask = signal.pthread_sigmask(signal.SIG_BLOCK, STOP_SIGNALS)
    with _DEFERRING_LOCK:
        _DEFERRING[0] += 1
    try:
        yield
    finally:
        with _DEFERRING_LOCK:
            _DEFERRING[0] -= 1
        if mask is not None:  # a signal held back by the mask is noted here
            signal.pthread_sigmask(signal.SIG_SETMASK, mask)
        for signum, handler in previous.items():
            if handler is not None:  # None: installed from C, cannot be put back
                signal.signal(signum, handler)
        if noted:
            signal.raise_signal(noted[0])


def interrupts_deferred_now() -> bool:
    """Whether an `interrupts_deferred` block is running now (in any thread): a stop
    requested meanwhile waits for it (the command line's watchdog does too).

    Returns
    -------
    deferring : bool
        True while at least one such block has not ended.
    """
    return _DEFERRING[0] > 0
