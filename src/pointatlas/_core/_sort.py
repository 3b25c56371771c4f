"""Sorting kernels shared by several rooms (numba)."""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["stable_argsort"]


@njit(cache=True)
def stable_argsort(values):
    """``np.argsort(values, kind="stable")`` for float64 without NaN, by LSD radix sort.

    Keys are the IEEE bit patterns mapped to unsigned integers in the order of
    the values (-0.0 first made +0.0, so that it ties with +0.0 as in a
    comparison sort); four stable passes of 16 bits, a pass skipped when every
    key has the same digit. Same result as the stable comparison sort, about
    twice as fast on millions of keys.
    """
    n = values.shape[0]
    canon = values + 0.0
    bits = canon.view(np.uint64)
    sign = np.uint64(1) << np.uint64(63)
    keys = np.empty(n, dtype=np.uint64)
    for i in range(n):
        b = bits[i]
        keys[i] = ~b if b & sign else b | sign
    order = np.arange(n)
    keys2 = np.empty(n, dtype=np.uint64)
    order2 = np.empty(n, dtype=np.int64)
    count = np.empty(65537, dtype=np.int64)
    mask = np.uint64(0xFFFF)
    for shift in range(0, 64, 16):
        sh = np.uint64(shift)
        count[:] = 0
        for i in range(n):
            count[((keys[i] >> sh) & mask) + 1] += 1
        if count.max() == n:
            continue
        for d in range(65536):
            count[d + 1] += count[d]
        for i in range(n):
            d = (keys[i] >> sh) & mask
            pos = count[d]
            count[d] = pos + 1
            keys2[pos] = keys[i]
            order2[pos] = order[i]
        keys, keys2 = keys2, keys
        order, order2 = order2, order
    return order
