"""Sorting kernels shared by several rooms (numba)."""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["stable_argsort"]

#: bits per radix digit: 256 buckets keep the scatter targets in L1 (measured: 8 bits
#: sort 6.2M edge weights in 0.35 s, 11 bits 0.62 s, 16 bits 0.66 s)
_DIGIT_BITS = 8
_N_PASSES = 8  # 64 / 8


@njit(cache=True)
def stable_argsort(values):
    """``np.argsort(values, kind="stable")`` for float64 without NaN, by LSD radix sort.

    Keys are the IEEE bit patterns mapped to unsigned integers in the order of
    the values (-0.0 first made +0.0, so that it ties with +0.0 as in a
    comparison sort); eight stable passes of 8 bits whose histograms are all
    counted in one read of the keys, a pass skipped when every key has the same
    digit (e.g. the sign and high exponent bits of keys in a narrow range).
    Same result as the stable comparison sort, several times faster on millions
    of keys.
    """
    n = values.shape[0]
    canon = values + 0.0
    bits = canon.view(np.uint64)
    sign = np.uint64(1) << np.uint64(63)
    mask = np.uint64((1 << _DIGIT_BITS) - 1)
    n_buckets = 1 << _DIGIT_BITS
    keys = np.empty(n, dtype=np.uint64)
    count = np.zeros((_N_PASSES, n_buckets + 1), dtype=np.int64)
    for i in range(n):
        b = bits[i]
        key = ~b if b & sign else b | sign
        keys[i] = key
        for p in range(_N_PASSES):
            count[p, ((key >> np.uint64(_DIGIT_BITS * p)) & mask) + 1] += 1
    order = np.arange(n)
    keys2 = np.empty(n, dtype=np.uint64)
    order2 = np.empty(n, dtype=np.int64)
    for p in range(_N_PASSES):
        c = count[p]
        if c.max() == n:
            continue
        for d in range(n_buckets):
            c[d + 1] += c[d]
        sh = np.uint64(_DIGIT_BITS * p)
        for i in range(n):
            key = keys[i]
            d = (key >> sh) & mask
            pos = c[d]
            c[d] = pos + 1
            keys2[pos] = key
            order2[pos] = order[i]
        keys, keys2 = keys2, keys
        order, order2 = order2, order
    return order
