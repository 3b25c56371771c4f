"""Sorting kernels shared by several rooms (numba)."""

from __future__ import annotations

import math

import numpy as np
from numba import njit

__all__ = [
    "morton_bits",
    "morton_order",
    "permute_table",
    "radix_sort_payload",
    "sorted_key_runs",
    "spatial_renumbering",
    "stable_argsort",
]

#: bits per radix digit: 256 buckets keep the scatter targets in L1 (the fastest of
#: 8, 11 and 16 bits; measured when the sort was written; see git history)
_DIGIT_BITS = 8
_N_PASSES = 8  # 64 / 8


@njit(cache=True)
def stable_argsort(values):
    """``np.argsort(values, kind="stable")`` for float64 without NaN, by LSD radix sort.

    Keys are the IEEE bit patterns mapped to unsigned integers in the order of
    the values (-0.0 first made +0.0, so that it ties with +0.0 as in a
    comparison sort), sorted with the indices as payload by `radix_sort_payload`
    (eight stable passes of 8 bits, a pass skipped when every key has the same
    digit, e.g. the sign and high exponent bits of keys in a narrow range).
    Same result as the stable comparison sort, several times faster on millions
    of keys.
    """
    n = values.shape[0]
    canon = values + 0.0
    bits = canon.view(np.uint64)
    sign = np.uint64(1) << np.uint64(63)
    keys = np.empty(n, dtype=np.uint64)
    for i in range(n):
        b = bits[i]
        keys[i] = ~b if b & sign else b | sign
    _, order = radix_sort_payload(
        keys, np.arange(n), np.empty(n, dtype=np.uint64), np.empty(n, dtype=np.int64)
    )
    return order


@njit(cache=True)
def radix_sort_payload(keys, payload, keys2, payload2):
    """``keys`` (uint64) and ``payload`` in stable order of the keys, by LSD radix sort.

    One read of the keys counts the digits of every pass; a pass is skipped
    when all keys share its digit. ``keys2`` and ``payload2`` are work space of the
    same length and dtypes; all four arrays are overwritten, and the returned
    (keys, payload) are two of them. Used by the orientation forest (edge keys with
    packed edge ends) and the merge (cost bits with pair codes).
    """
    n = keys.shape[0]
    mask = np.uint64((1 << _DIGIT_BITS) - 1)
    n_buckets = 1 << _DIGIT_BITS
    count = np.zeros((_N_PASSES, n_buckets + 1), dtype=np.int64)
    for i in range(n):
        key = keys[i]
        for p in range(_N_PASSES):
            count[p, ((key >> np.uint64(_DIGIT_BITS * p)) & mask) + 1] += 1
    for p in range(_N_PASSES):
        c = count[p]
        one_bucket = False  # all keys share the digit: the pass keeps the order
        for d in range(n_buckets + 1):  # a loop: numba's c.max() compiles for a second
            one_bucket = one_bucket or c[d] == n
        if one_bucket:
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
            payload2[pos] = payload[i]
        keys, keys2 = keys2, keys
        payload, payload2 = payload2, payload
    return keys, payload


def sorted_key_runs(keys):
    """``(sorted_keys, order, first)`` of non-negative int64 ``keys``, from numpy.

    `radix_sort_payload` on the keys' uint64 view with the indices as payload
    (stable: ``order`` is ``np.argsort(keys, kind="stable")``), and ``first[i]`` true
    where ``sorted_keys[i]`` starts a run of equal keys. ``keys`` is overwritten.
    Shared by the grid k-NN's cells and the segmentation's region pairs: called
    from Python, it compiles no ``view`` or ``np.unique`` in a kernel (each compiles
    for a tenth of a second to seconds; docs/decisions/cli.md, "First run").
    """
    n = keys.shape[0]
    sorted_keys, order = radix_sort_payload(
        keys.view(np.uint64),
        np.arange(n, dtype=np.int64),
        np.empty(n, dtype=np.uint64),
        np.empty(n, dtype=np.int64),
    )
    sorted_keys = sorted_keys.view(np.int64)
    first = np.ones(n, dtype=np.bool_)
    np.not_equal(sorted_keys[1:], sorted_keys[:-1], out=first[1:])
    return sorted_keys, order, first


@njit(cache=True, inline="always", error_model="numpy")
def _spread3(x):
    """Bits 0..9 of ``x`` moved to bits 0, 3, 6, ... (Morton interleave helper)."""
    x &= 0x3FF
    x = (x | (x << 16)) & 0x30000FF
    x = (x | (x << 8)) & 0x300F00F
    x = (x | (x << 4)) & 0x30C30C3
    x = (x | (x << 2)) & 0x9249249
    return x


@njit(cache=True)
def morton_bits(n):
    """Grid bits per axis for `morton_order` of ``n`` points: about 16 points per
    cell, between 1 and 7 bits."""
    bits = math.ceil(math.log2(max(n, 2) / 16.0) / 3.0)
    return min(max(bits, 1), 7)


@njit(cache=True, error_model="numpy")
def morton_order(points, bits):
    """A cache-friendly processing order: points bucketed by Morton-ordered grid cells.

    Counting sort on a 2^bits per axis grid (bits <= 10) over the bounding box of
    the finite points (O(N)); within a cell points keep their index order.
    Points processed in this order reuse their neighbours' coordinates from
    cache, which matters when the input order is spatially random. Non-finite
    points go last. Serial: about 0.04 s for 10^6 points, a small part of any
    caller's run, and a parallel loop would cost seconds of numba's compile.
    """
    n = points.shape[0]
    n_cells = 1 << (3 * bits)
    lo = np.empty(3)  # np.empty + a loop, not np.full: one spelling less to compile
    hi = np.empty(3)
    for d in range(3):
        lo[d] = np.inf
        hi[d] = -np.inf
    for i in range(n):
        x = points[i, 0]
        y = points[i, 1]
        z = points[i, 2]
        if math.isfinite(x) and math.isfinite(y) and math.isfinite(z):
            lo[0] = min(lo[0], x)
            lo[1] = min(lo[1], y)
            lo[2] = min(lo[2], z)
            hi[0] = max(hi[0], x)
            hi[1] = max(hi[1], y)
            hi[2] = max(hi[2], z)
    scale = np.empty(3)
    side = 1 << bits
    for d in range(3):
        ext = hi[d] - lo[d]
        scale[d] = side / ext if ext > 0 else 0.0
    key = np.empty(n, dtype=np.int64)
    start = np.zeros(n_cells + 2, dtype=np.int64)
    for i in range(n):
        code = n_cells
        x = points[i, 0]
        y = points[i, 1]
        z = points[i, 2]
        if math.isfinite(x) and math.isfinite(y) and math.isfinite(z):
            qx = min(max(int((x - lo[0]) * scale[0]), 0), side - 1)
            qy = min(max(int((y - lo[1]) * scale[1]), 0), side - 1)
            qz = min(max(int((z - lo[2]) * scale[2]), 0), side - 1)
            code = _spread3(qx) | (_spread3(qy) << 1) | (_spread3(qz) << 2)
        key[i] = code
        start[code + 1] += 1
    for cell in range(n_cells + 1):
        start[cell + 1] += start[cell]
    order = np.empty(n, dtype=np.int64)
    for i in range(n):
        code = key[i]
        order[start[code]] = i
        start[code] += 1
    return order


def _python(kernel):
    """The Python function of a numba kernel (the kernel itself with the JIT off)."""
    return getattr(kernel, "py_func", kernel)


def _morton_order_numpy(points, bits):
    """`morton_order` in numpy around the shared radix sort (its bit interleave and
    `morton_bits` run as Python on numpy arrays), the same order bit for bit
    (tests/_core/test_sort.py): what `spatial_renumbering` calls, so that a command
    whose kernels do not call `morton_order` does not compile it (about 1.3
    CPU-seconds, docs/decisions/cli.md "First run")."""
    n = points.shape[0]
    n_cells = 1 << (3 * bits)
    side = 1 << bits
    finite = np.isfinite(points).all(axis=1)
    code = np.full(n, n_cells, dtype=np.int64)
    if finite.any():
        pts = points[finite]
        lo = pts.min(axis=0)
        ext = pts.max(axis=0) - lo
        scale = np.zeros(3)
        np.divide(side, ext, out=scale, where=ext > 0)
        q = ((pts - lo) * scale).astype(np.int64)
        np.clip(q, 0, side - 1, out=q)
        spread = _python(_spread3)  # the kernel's helper, run by numpy on int64 columns
        code[finite] = spread(q[:, 0]) | (spread(q[:, 1]) << 1) | (spread(q[:, 2]) << 2)
    _, order = radix_sort_payload(
        code.view(np.uint64),
        np.arange(n, dtype=np.int64),
        np.empty(n, dtype=np.uint64),
        np.empty(n, dtype=np.int64),
    )
    return order


def spatial_renumbering(points):
    """``(order, inv)``: new point r is old point ``order[r]`` (`morton_order` with
    `morton_bits`), old point i is new point ``inv[i]``.

    Kernels whose work follows graph edges (spanning forests, region growing and
    merging) run much faster on renumbered points, whose neighbours then sit close
    in memory, than on a spatially random input order.
    """
    order = _morton_order_numpy(points, _python(morton_bits)(points.shape[0]))
    inv = np.empty(order.shape[0], dtype=np.int64)
    inv[order] = np.arange(order.shape[0])
    return order, inv


@njit(cache=True)
def permute_table(table, order, inv):
    """Row r of the result is row ``order[r]`` of ``table`` with every entry j >= 0
    replaced by ``inv[j]`` (entries < 0 kept): the neighbour table of the points
    renumbered by `spatial_renumbering` (serial: 0.03 s for 10^6 rows of 8; numpy's
    gather and select take several times that)."""
    n, c = table.shape
    out = np.empty((n, c), dtype=np.int64)
    for r in range(n):
        src = order[r]
        for t in range(c):
            j = table[src, t]
            out[r, t] = inv[j] if j >= 0 else j
    return out
