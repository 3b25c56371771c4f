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
