"""The room's one priority queue: a 4-ary min-heap of (key, code) int64 rows.

An entry is one 16-byte row: the key, a non-negative double stored as its IEEE
bits (for non-negative doubles without -0.0 the int64 bits order as the values
do), and an int64 code that breaks ties. Rows compare lexicographically, so
distinct entries pop in one fixed order whatever the heap's shape. The flood
(`flood`) and the merge (`greedy_merge`) queue through it.

The heap is an (capacity + 8, 2) array whose logical node 0 sits at row
``base`` (`heap_base`), chosen so that the four children of every node share one
64-byte cache line; the sift-down prefetches the grandchildren's lines one level
ahead. Prefetches are hints only: the pop order is that of a plain heap.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ..._core._prefetch import prefetch_row as _prefetch

#: arity of the heap; entries are 16 bytes, so one node's children fill one
#: 64-byte cache line when the array is aligned (see `heap_base`)
ARITY = 4
#: rows beyond the capacity: room for the alignment offset of `heap_base` (< 8)
_SLACK = 8


@njit(cache=True)
def heap_base(heap):
    """Row of logical node 0 such that the children d i + 1 .. d i + d of every
    node start on a 64-byte boundary (rows are 16 bytes)."""
    lead = (heap.ctypes.data // 16) % 4  # rows before the first aligned row
    return (4 - lead) % 4 + (ARITY - 1)


@njit(cache=True)
def heap_new(capacity):
    """An empty heap with room for ``capacity`` entries: (array, base)."""
    heap = np.empty((capacity + _SLACK, 2), dtype=np.int64)
    return heap, heap_base(heap)


def key_buffer():
    """A one-double buffer and its int64 view: store a key as ``bits[0] = value``
    and read its bits as ``bits_i[0]``. Made by numpy and passed to the kernels that
    queue keys: numba's ``view`` compiles for a tenth of a second per dtype pair."""
    bits = np.empty(1, dtype=np.float64)
    return bits, bits.view(np.int64)


@njit(cache=True, inline="always")
def less_entry(ka, pa, kb, pb):
    """(ka, pa) < (kb, pb) lexicographically."""
    return ka < kb or (ka == kb and pa < pb)


@njit(cache=True)
def sift_up(heap, base, pos):
    """Move logical node ``pos`` up to its place."""
    key = heap[base + pos, 0]
    pair = heap[base + pos, 1]
    while pos > 0:
        parent = (pos - 1) // ARITY
        pk = heap[base + parent, 0]
        if key < pk or (key == pk and pair < heap[base + parent, 1]):
            heap[base + pos, 0] = pk
            heap[base + pos, 1] = heap[base + parent, 1]
            pos = parent
        else:
            break
    heap[base + pos, 0] = key
    heap[base + pos, 1] = pair


@njit(cache=True)
def sift_down(heap, base, size, pos):
    """Move logical node ``pos`` down to its place among ``size`` entries; the
    children of pos are d pos + 1 .. d pos + d (one cache line), and the
    grandchildren's lines are prefetched one level ahead."""
    key = heap[base + pos, 0]
    pair = heap[base + pos, 1]
    while True:
        first = ARITY * pos + 1
        if first >= size:
            break
        grand = ARITY * first + 1
        if grand + ARITY * (ARITY - 1) < size:
            # the children's children: one line each, needed on the next level
            for c in range(ARITY):
                _prefetch(heap, base + grand + ARITY * c)
        child = first
        ckey = heap[base + first, 0]
        cpair = heap[base + first, 1]
        last = min(first + ARITY, size)
        for c in range(first + 1, last):
            k = heap[base + c, 0]
            if k < ckey or (k == ckey and heap[base + c, 1] < cpair):
                child = c
                ckey = k
                cpair = heap[base + c, 1]
        if ckey < key or (ckey == key and cpair < pair):
            heap[base + pos, 0] = ckey
            heap[base + pos, 1] = cpair
            pos = child
        else:
            break
    heap[base + pos, 0] = key
    heap[base + pos, 1] = pair


@njit(cache=True, inline="always")
def heap_push(heap, base, size, key, code):
    """Add (key, code) to a heap of ``size`` entries; the rows double when full.

    Returns the (possibly new) array and its base; the caller counts size + 1.
    """
    if size == heap.shape[0] - _SLACK:
        grown = np.empty((2 * size + _SLACK, 2), dtype=np.int64)
        grown_base = heap_base(grown)
        for r in range(size):  # a loop: a slice assignment compiles numba's shape checks
            grown[grown_base + r, 0] = heap[base + r, 0]
            grown[grown_base + r, 1] = heap[base + r, 1]
        heap = grown
        base = grown_base
    heap[base + size, 0] = key
    heap[base + size, 1] = code
    sift_up(heap, base, size)
    return heap, base


@njit(cache=True, inline="always")
def heap_pop(heap, base, size):
    """Remove the top of a heap of ``size`` >= 1 entries (read it first); the
    caller counts size - 1."""
    last = size - 1
    if last > 0:
        heap[base, 0] = heap[base + last, 0]
        heap[base, 1] = heap[base + last, 1]
        sift_down(heap, base, last, 0)
