"""Chunks of a serial kernel on Python threads (`pointatlas._core._threads.run_chunks`)."""

from __future__ import annotations

import numba
import numpy as np
import pytest
from numba import njit

from pointatlas._core._threads import run_chunks


@njit(nogil=True)
def _squares(x, out, i0, i1):
    for i in range(i0, i1):
        out[i] = x[i] * x[i]


def _count_visits(visits, pieces, i0, i1):
    visits[i0:i1] += 1
    pieces.append((i0, i1))


def _threads_available():
    return sorted({1, min(2, numba.config.NUMBA_NUM_THREADS), numba.config.NUMBA_NUM_THREADS})


@pytest.mark.parametrize("n", [0, 1, 7, 1000])
@pytest.mark.parametrize("threads", _threads_available())
def test_every_item_is_in_exactly_one_piece(n, threads):
    visits = np.zeros(n, dtype=np.int64)
    pieces = []
    before = numba.get_num_threads()
    numba.set_num_threads(threads)
    try:
        run_chunks(_count_visits, n, (visits, pieces))
    finally:
        numba.set_num_threads(before)
    assert np.array_equal(visits, np.ones(n, dtype=np.int64))
    assert all(i0 < i1 for i0, i1 in pieces) or n == 0
    assert len(pieces) == (1 if threads == 1 or n <= 1 else min(n, 8 * min(threads, n)))


@pytest.mark.parametrize("n", [0, 5, 100, 1000])
def test_pieces_hold_at_least_min_piece_items(n):
    visits = np.zeros(n, dtype=np.int64)
    pieces = []
    before = numba.get_num_threads()
    numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
    try:
        run_chunks(_count_visits, n, (visits, pieces), 300)
    finally:
        numba.set_num_threads(before)
    assert np.array_equal(visits, np.ones(n, dtype=np.int64))
    # one piece (the whole range) when n < 2 x 300, else each piece at least 300
    assert all(i1 - i0 >= 300 for i0, i1 in pieces) or pieces == [(0, n)]
    expected = max(1, min(n // 300, 8 * numba.config.NUMBA_NUM_THREADS))
    assert len(pieces) == expected


def test_the_helper_threads_are_started_once_per_process():
    import os
    import threading

    from pointatlas._core import _threads

    x = np.arange(1000.0)
    out = np.empty_like(x)
    run_chunks(_squares, x.size, (x, out))
    first = _threads._helpers()
    before = threading.active_count()
    for _ in range(20):
        run_chunks(_squares, x.size, (x, out))
    assert _threads._helpers() is first
    assert threading.active_count() == before
    assert _threads._POOL[0] == os.getpid()


def test_a_forked_child_runs_chunks_on_its_own_helpers():
    import multiprocessing

    x = np.arange(1000.0)
    run_chunks(_squares, x.size, (x, np.empty_like(x)))  # the parent's helpers started
    ctx = multiprocessing.get_context("fork")
    with ctx.Pool(1) as pool:
        out = pool.apply_async(_squares_in_child, (x,)).get(timeout=60)
    assert np.array_equal(out, x * x)


def _squares_in_child(x):
    before = numba.get_num_threads()
    numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
    try:
        out = np.full(x.size, np.nan)
        run_chunks(_squares, x.size, (x, out))
    finally:
        numba.set_num_threads(before)
    return out


@pytest.mark.parametrize("threads", _threads_available())
def test_a_nogil_kernel_gives_the_same_output_on_any_number_of_threads(threads):
    x = np.random.default_rng(0).normal(size=10_001)
    out = np.full(x.size, np.nan)
    before = numba.get_num_threads()
    numba.set_num_threads(threads)
    try:
        run_chunks(_squares, x.size, (x, out))
    finally:
        numba.set_num_threads(before)
    assert np.array_equal(out, x * x)


def test_an_error_in_a_piece_is_raised_in_the_caller():
    def fail_on_the_last_piece(n, i0, i1):
        if i1 == n:
            raise ValueError(f"piece {i0}..{i1} failed")

    with pytest.raises(ValueError, match="failed"):
        run_chunks(fail_on_the_last_piece, 100, (100,))


def test_one_thread_if_sets_one_thread_inside_and_restores_it():
    import numba

    from pointatlas._core._threads import machine_busy, one_thread_if

    threads = numba.get_num_threads()
    with one_thread_if(True):
        assert numba.get_num_threads() == 1
    assert numba.get_num_threads() == threads
    with one_thread_if(False):
        assert numba.get_num_threads() == threads
    try:  # restored when the body raises
        with one_thread_if(True):
            raise KeyError("x")
    except KeyError:
        pass
    assert numba.get_num_threads() == threads
    assert isinstance(machine_busy(), bool)
