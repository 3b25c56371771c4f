"""Threads: a loop of independent chunks run on Python threads, each chunk one call of
a serial ``nogil`` numba kernel (the parallel loop of a kernel without numba's
``parallel=True``, whose first compile costs several CPU-seconds per kernel:
docs/decisions/cli.md, "First run"); and one numba thread for small inputs on a busy
machine (speed only; the same output)."""

from __future__ import annotations

import os
import threading
from concurrent.futures import Future, ThreadPoolExecutor
from contextlib import contextmanager

import numba

__all__ = ["machine_busy", "on_thread", "one_thread_if", "query_workers", "run_chunks"]


def machine_busy() -> bool:
    """True when the 1-minute load average reaches the number of CPUs (Unix; else False)."""
    try:
        load = os.getloadavg()[0]
    except (AttributeError, OSError):
        return False
    return load >= (os.cpu_count() or 1)


def on_thread(fn, *args, **kwargs) -> Future:
    """``fn(*args, **kwargs)`` started on a thread of its own, to overlap work that
    releases the GIL (a ``nogil`` kernel, numpy, a k-d tree query) with the caller's;
    ``.result()`` waits for its value (or raises its exception)."""
    pool = ThreadPoolExecutor(max_workers=1)
    try:
        return pool.submit(fn, *args, **kwargs)
    finally:
        pool.shutdown(wait=False)


#: A k-d tree query of fewer entries (rows x neighbours) runs in its caller: scipy's
#: ``cKDTree.query(workers=-1)`` starts a Python thread per worker per call (about 0.3
#: ms on two cores), more than such a query takes (200 rows of 8: 0.38 ms on one
#: thread, 0.77 ms on two; 3,000 of 16: 13.9 ms against 7.4 ms).
THREADED_ENTRIES = 4096


def query_workers(n_rows: int, k: int = 1) -> int:
    """``workers`` for a ``cKDTree.query`` of ``n_rows`` rows of ``k`` neighbours: all
    cores (-1), or the caller's thread alone (1) below `THREADED_ENTRIES` entries.
    The answer is the same either way.

    Examples
    --------
    >>> query_workers(200, 8), query_workers(20000, 1)
    (1, -1)
    """
    return 1 if n_rows * k < THREADED_ENTRIES else -1


@contextmanager
def one_thread_if(condition: bool):
    """Run the enclosed numba parallel regions in one thread when ``condition`` holds.

    Sets numba's thread count to 1 for the calling thread (numba's setting is
    thread-local) and restores it on exit; otherwise changes nothing. Callers pass
    "small input and `machine_busy`": a parallel region loses more than its second
    thread gains when that thread waits for a busy core. Results must not depend on it.
    """
    if not condition:
        yield
        return
    before = numba.get_num_threads()
    numba.set_num_threads(1)
    try:
        yield
    finally:
        numba.set_num_threads(before)


#: pieces handed out per thread: a thread that finishes early (its points were
#: cheap, or its core busy) takes the next piece; each piece is one kernel call
#: (about 10 microseconds of dispatch)
_PIECES_PER_THREAD = 8


def run_chunks(kernel, n_items: int, args: tuple, min_piece: int = 1) -> None:
    """Call ``kernel(*args, i0, i1)`` for pieces ``[i0, i1)`` covering ``range(n_items)``,
    of at least ``min_piece`` items (where items are cheap, fewer calls: each costs
    about 10 microseconds of dispatch).

    ``kernel`` is a serial numba kernel compiled with ``nogil=True`` whose calls for
    different pieces write disjoint parts of its outputs, so the result does not
    depend on the number of threads or on which thread runs which piece. The pieces
    run on ``numba.get_num_threads()`` threads (the calling thread's setting: one
    thread runs everything in the caller), the calling thread among them; a thread
    takes the next piece when it is done with one. An exception of a piece is raised
    in the caller once every thread has stopped.
    """
    n_pieces = min(n_items // max(min_piece, 1), _PIECES_PER_THREAD * numba.get_num_threads())
    n_threads = min(numba.get_num_threads(), n_pieces)
    if n_threads <= 1:
        kernel(*args, 0, n_items)
        return
    lock = threading.Lock()
    state = {"next": 0, "error": None}

    def work() -> None:
        while True:
            with lock:
                piece = state["next"]
                if piece >= n_pieces or state["error"] is not None:
                    return
                state["next"] = piece + 1
            try:
                kernel(*args, piece * n_items // n_pieces, (piece + 1) * n_items // n_pieces)
            except BaseException as exc:  # re-raised in the caller below
                with lock:
                    if state["error"] is None:
                        state["error"] = exc
                return

    helpers = [_helpers().submit(work) for _ in range(n_threads - 1)]
    work()
    for helper in helpers:
        helper.result()
    if state["error"] is not None:
        raise state["error"]


#: (process id, pool) of `_helpers`
_POOL: list = [None, None]


def _helpers() -> ThreadPoolExecutor:
    """The threads that help `run_chunks`' callers, started once per process: a thread
    started per call cost about 0.1 ms, which a segmentation making hundreds of
    small passes paid hundreds of times (VSA on a 21,568-triangle mesh: 0.084 s on
    two threads, 0.055 s on one). A helper never waits for another helper (each
    caller runs pieces itself until none is left), so a busy pool only delays one.
    A forked child starts its own (the parent's threads are not in it)."""
    if _POOL[0] != os.getpid():
        _POOL[:] = [os.getpid(), ThreadPoolExecutor(os.cpu_count() or 1, "run_chunks")]
    return _POOL[1]
