"""numba kernels of the normals room (validated input assumed, no checks here).

References in plain numpy: ``tests/normals/reference.py``.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from .._core._sort import morton_bits, morton_order, radix_sort_payload

__all__ = [
    "component_tops_kernel",
    "offsets_kernel",
    "pca_normals_kernel",
    "riemannian_graph_kernel",
    "spanning_forest_kernel",
    "sym3_eigen",
]

#: points per parallel block of the PCA kernel (work arrays are allocated per block)
_BLOCK = 512
#: cap on cyclic Jacobi sweeps; a 3 x 3 matrix converges in 3-6
_MAX_SWEEPS = 30
_EPS = np.finfo(np.float64).eps


@njit(cache=True)
def _rotate(a, v, p, q):
    """One Jacobi rotation zeroing a[p, q] of the symmetric 3 x 3 matrix ``a``.

    Rutishauser's formulas; ``v`` accumulates the rotations (columns = vectors).
    Returns False when a[p, q] is already negligible, relative to the diagonal
    (Demmel-Veselic criterion, which keeps small eigenvalues relatively accurate).
    """
    apq = a[p, q]
    if apq == 0.0:
        return False
    app = a[p, p]
    aqq = a[q, q]
    if abs(apq) <= _EPS * np.sqrt(abs(app * aqq)) or abs(apq) < 1e-300:
        a[p, q] = 0.0
        a[q, p] = 0.0
        return False
    theta = (aqq - app) / (2.0 * apq)
    if abs(theta) > 1e150:
        t = 0.5 / theta
    else:
        t = 1.0 / (abs(theta) + np.sqrt(theta * theta + 1.0))
        if theta < 0.0:
            t = -t
    c = 1.0 / np.sqrt(t * t + 1.0)
    s = t * c
    a[p, p] = app - t * apq
    a[q, q] = aqq + t * apq
    a[p, q] = 0.0
    a[q, p] = 0.0
    r = 3 - p - q  # the third index
    arp = a[r, p]
    arq = a[r, q]
    a[r, p] = c * arp - s * arq
    a[p, r] = a[r, p]
    a[r, q] = s * arp + c * arq
    a[q, r] = a[r, q]
    for m in range(3):
        vmp = v[m, p]
        vmq = v[m, q]
        v[m, p] = c * vmp - s * vmq
        v[m, q] = s * vmp + c * vmq
    return True


@njit(cache=True)
def sym3_eigen(a, v, w):
    """Eigen-decomposition of a symmetric 3 x 3 matrix by cyclic Jacobi sweeps.

    Parameters
    ----------
    a : ndarray of shape (3, 3), float64
        Symmetric input; overwritten (ends diagonal).
    v : ndarray of shape (3, 3), float64
        Output: eigenvectors as columns, matching ``w``.
    w : ndarray of shape (3,), float64
        Output: eigenvalues in descending order.

    Notes
    -----
    The matrix is scaled by its largest absolute entry first (no over/underflow).
    Jacobi keeps eigenvectors accurate for close and tiny eigenvalues, which the
    closed-form (trigonometric) solution does not. A zero matrix gives zero
    eigenvalues and the identity.
    """
    scale = 0.0
    for i in range(3):
        for j in range(3):
            if abs(a[i, j]) > scale:
                scale = abs(a[i, j])
    for i in range(3):
        for j in range(3):
            v[i, j] = 1.0 if i == j else 0.0
    if scale == 0.0:
        w[0] = 0.0
        w[1] = 0.0
        w[2] = 0.0
        return
    for i in range(3):
        for j in range(3):
            a[i, j] /= scale
    for _ in range(_MAX_SWEEPS):
        changed = _rotate(a, v, 0, 1)
        changed = _rotate(a, v, 0, 2) or changed
        changed = _rotate(a, v, 1, 2) or changed
        if not changed:
            break
    # sort descending (three elements: explicit comparisons, stable)
    i0, i1, i2 = 0, 1, 2
    if a[i1, i1] > a[i0, i0]:
        i0, i1 = i1, i0
    if a[i2, i2] > a[i1, i1]:
        i1, i2 = i2, i1
        if a[i1, i1] > a[i0, i0]:
            i0, i1 = i1, i0
    d0, d1, d2 = a[i0, i0], a[i1, i1], a[i2, i2]
    for m in range(3):
        x0, x1, x2 = v[m, i0], v[m, i1], v[m, i2]
        v[m, 0] = x0
        v[m, 1] = x1
        v[m, 2] = x2
    w[0] = d0 * scale
    w[1] = d1 * scale
    w[2] = d2 * scale


@njit(cache=True, parallel=True)
def pca_normals_kernel(points, indices, k, degenerate_ratio, normals, eigenvalues, degenerate):
    """PCA normal of every point from its first ``k`` neighbours (in ``indices``).

    Parameters
    ----------
    points : ndarray of shape (N, 3), float64
    indices : ndarray of shape (N, m), int64, m >= k
        Neighbour indices (column 0 is usually the point itself).
    k : int
        Number of columns used.
    degenerate_ratio : float
        lambda_2 <= degenerate_ratio * lambda_1 flags the neighbourhood.
    normals : ndarray of shape (N, 3), float64
        Output: unit eigenvector of the smallest eigenvalue; (0, 0, 1) when all
        neighbours coincide; a unit vector orthogonal to the line when collinear.
    eigenvalues : ndarray of shape (N, 3), float64
        Output: covariance eigenvalues, descending, clipped at 0.
    degenerate : ndarray of shape (N,), bool
        Output: the plane is undefined (coincident or collinear neighbours).

    Notes
    -----
    Covariance about the neighbourhood mean, computed on coordinates relative to
    the point itself (differences of nearby points are exact, so UTM-sized
    offsets lose no precision), divided by k.
    """
    n = indices.shape[0]
    n_blocks = (n + _BLOCK - 1) // _BLOCK
    for b in prange(n_blocks):
        a = np.empty((3, 3))
        v = np.empty((3, 3))
        w = np.empty(3)
        stop = min(n, (b + 1) * _BLOCK)
        for i in range(b * _BLOCK, stop):
            px = points[i, 0]
            py = points[i, 1]
            pz = points[i, 2]
            mx = 0.0
            my = 0.0
            mz = 0.0
            for j in range(k):
                q = indices[i, j]
                mx += points[q, 0] - px
                my += points[q, 1] - py
                mz += points[q, 2] - pz
            mx /= k
            my /= k
            mz /= k
            cxx = 0.0
            cxy = 0.0
            cxz = 0.0
            cyy = 0.0
            cyz = 0.0
            czz = 0.0
            for j in range(k):
                q = indices[i, j]
                dx = points[q, 0] - px - mx
                dy = points[q, 1] - py - my
                dz = points[q, 2] - pz - mz
                cxx += dx * dx
                cxy += dx * dy
                cxz += dx * dz
                cyy += dy * dy
                cyz += dy * dz
                czz += dz * dz
            a[0, 0] = cxx / k
            a[0, 1] = cxy / k
            a[0, 2] = cxz / k
            a[1, 0] = a[0, 1]
            a[1, 1] = cyy / k
            a[1, 2] = cyz / k
            a[2, 0] = a[0, 2]
            a[2, 1] = a[1, 2]
            a[2, 2] = czz / k
            sym3_eigen(a, v, w)
            for c in range(3):
                eigenvalues[i, c] = max(w[c], 0.0)
            l1 = eigenvalues[i, 0]
            is_deg = eigenvalues[i, 1] <= degenerate_ratio * l1
            degenerate[i] = is_deg
            if l1 == 0.0:
                # all neighbours coincide: no direction at all; documented fallback
                normals[i, 0] = 0.0
                normals[i, 1] = 0.0
                normals[i, 2] = 1.0
                continue
            if is_deg:
                # collinear: any direction orthogonal to the line; take the one
                # orthogonal to the line and to the coordinate axis least aligned
                # with it (deterministic, independent of Jacobi's choice)
                ux, uy, uz = v[0, 0], v[1, 0], v[2, 0]
                ax, ay, az = abs(ux), abs(uy), abs(uz)
                if ax <= ay and ax <= az:
                    nx, ny, nz = 0.0, -uz, uy  # e_x x u
                elif ay <= az:
                    nx, ny, nz = uz, 0.0, -ux  # e_y x u
                else:
                    nx, ny, nz = -uy, ux, 0.0  # e_z x u
            else:
                nx, ny, nz = v[0, 2], v[1, 2], v[2, 2]
            norm = np.sqrt(nx * nx + ny * ny + nz * nz)
            normals[i, 0] = nx / norm
            normals[i, 1] = ny / norm
            normals[i, 2] = nz / norm


@njit(cache=True, parallel=True)
def riemannian_graph_kernel(
    points, normals, indices, k, eps, penalty, keep, cols, weights, opposed
):
    """Weighted undirected k-NN graph, each edge once (CSR, upper or lower row).

    Edge {i, j} exists when j is among indices[i, 1:k] or i among indices[j, 1:k]
    (the symmetric k-NN graph). It is stored once: in row i when j is in i's list
    and j > i, or j < i and i is not in j's list (otherwise row j holds it). Self
    entries are skipped.

    The outputs are written into buffers of N (k - 1) slots (allocated by numpy:
    its large arrays get huge pages, whose first touch is several times cheaper
    than that of numba's; slots past E are never touched); the first E are the
    edges:

    - keep : ndarray of shape (N, k - 1), bool -- whether row i stores
      indices[i, c + 1] (work space);
    - cols : int64 -- the other end of each edge;
    - weights : float64 -- 1 - |n_i . n_j| + penalty (|n_i . e| + |n_j . e|) / 2
      + eps (1 + |p_i - p_j| / mean edge length), e the unit edge direction
      (the penalty term is dropped for coincident points); always > 0;
    - opposed : uint8 -- 1 where n_i . n_j < 0 (sign propagation flips there).

    Returns
    -------
    indptr : ndarray of shape (N + 1,), int64
        Row pointers into the buffers; E = indptr[N].

    Notes
    -----
    Two parallel passes over the rows, visited in Morton order of the points
    (`pointatlas._core._sort.morton_order`; each row writes its own slots, so the output does not
    depend on the order): the first selects the stored edges and sums their
    lengths per row, the second writes the weights. The mean edge length adds
    the row sums in row order, so it does not depend on the threads either (a
    parallel ``lengths.sum()`` split the sum differently from run to run, which
    moved some weights by an ulp).
    """
    n = indices.shape[0]
    visit = morton_order(points, morton_bits(n))
    counts = np.zeros(n, dtype=np.int64)
    row_length = np.zeros(n)
    for t in prange(n):
        i = visit[t]
        cnt = 0
        row_sum = 0.0
        for c in range(1, k):
            j = indices[i, c]
            keep[i, c - 1] = False
            if j == i:
                continue
            if j < i:
                mutual = False
                for c2 in range(1, k):
                    if indices[j, c2] == i:
                        mutual = True
                        break
                if mutual:
                    continue
            keep[i, c - 1] = True
            cnt += 1
            dx = points[j, 0] - points[i, 0]
            dy = points[j, 1] - points[i, 1]
            dz = points[j, 2] - points[i, 2]
            row_sum += np.sqrt(dx * dx + dy * dy + dz * dz)
        counts[i] = cnt
        row_length[i] = row_sum
    indptr = np.zeros(n + 1, dtype=np.int64)
    total = 0.0
    for i in range(n):  # serial: a fixed summation order
        indptr[i + 1] = indptr[i] + counts[i]
        total += row_length[i]
    m = indptr[n]
    mean = total / max(m, 1)
    inv = 1.0 / mean if mean > 0.0 else 0.0
    for t in prange(n):
        i = visit[t]
        pos = indptr[i]
        for c in range(1, k):
            if not keep[i, c - 1]:
                continue
            j = indices[i, c]
            dx = points[j, 0] - points[i, 0]
            dy = points[j, 1] - points[i, 1]
            dz = points[j, 2] - points[i, 2]
            length = np.sqrt(dx * dx + dy * dy + dz * dz)
            d = normals[i, 0] * normals[j, 0]
            d += normals[i, 1] * normals[j, 1]
            d += normals[i, 2] * normals[j, 2]
            w = 1.0 - min(abs(d), 1.0) + eps * (1.0 + length * inv)
            if penalty != 0.0 and length > 0.0:
                ex = dx / length
                ey = dy / length
                ez = dz / length
                a = abs(normals[i, 0] * ex + normals[i, 1] * ey + normals[i, 2] * ez)
                b = abs(normals[j, 0] * ex + normals[j, 1] * ey + normals[j, 2] * ez)
                w += 0.5 * penalty * (a + b)
            cols[pos] = j
            weights[pos] = w
            opposed[pos] = d < 0.0
            pos += 1
    return indptr


@njit(cache=True, parallel=True)
def offsets_kernel(points, targets):
    """``points[targets] - points`` without numpy's fancy-indexing copy (4x faster
    on 10^6 points; the same subtractions, so the same bits)."""
    n = points.shape[0]
    out = np.empty((n, 3))
    for i in prange(n):
        j = targets[i]
        out[i, 0] = points[j, 0] - points[i, 0]
        out[i, 1] = points[j, 1] - points[i, 1]
        out[i, 2] = points[j, 2] - points[i, 2]
    return out


@njit(cache=True)
def component_tops_kernel(z, labels, n_comp):
    """Per component the index with the largest z (ties: the smaller index).

    Returns
    -------
    roots : ndarray of shape (n_comp,), int64
        -1 for a label that does not occur.
    """
    roots = np.full(n_comp, -1, dtype=np.int64)
    for i in range(z.shape[0]):
        c = labels[i]
        r = roots[c]
        if r < 0 or z[i] > z[r]:
            roots[c] = i
    return roots


#: Filter-Kruskal: each stage sorts this share of the remaining edges, the lightest
#: (10^6-point scene: 0.2-0.3 are best, sort + Kruskal 2.5x faster than one sort)...
_LIGHT_SHARE = 0.2
#: ... until at most this many remain, which are sorted in one go
_FILTER_MIN = 100_000
#: size of the strided sample of the remaining edge keys that gives a stage's threshold
_SAMPLE = 4096
#: from this many nodes on, payloads hold edge positions, not packed edge ends
_WIDE_NODES = 2**30
_SIGN = np.uint64(1) << np.uint64(63)
_LOW31 = np.uint64(0x7FFFFFFF)


@njit(cache=True)
def _find(link, x):
    """Root of x and the parity of x's path to it, in a union-find whose entries
    are ``parent << 1 | parity to the parent`` (roots: ``x << 1``); path halving.
    """
    acc = 0
    while True:
        v = link[x]
        px = v >> 1
        if px == x:
            return x, acc
        w = link[px]
        grand = w >> 1
        f = (v ^ w) & 1  # parity x -> grandparent
        link[x] = (grand << 1) | f
        acc ^= f
        x = grand


@njit(cache=True)
def _edge(p, rows, cols, opposed, wide):
    """Ends and parity of the edge in payload ``p``: ``a << 32 | b << 1 | parity``,
    or (``wide``) the edge's position in ``cols``."""
    if wide:
        e = np.int64(p)
        return rows[e], cols[e], np.int64(opposed[e])
    return np.int64(p >> np.uint64(32)), np.int64((p >> np.uint64(1)) & _LOW31), np.int64(p & 1)


@njit(cache=True)
def _float_key(b):
    """Unsigned key, in the order of the floats, of the float64 bit pattern ``b``."""
    if b == _SIGN:
        b = np.uint64(0)  # -0.0 ties with +0.0
    return ~b if b & _SIGN else b | _SIGN


@njit(cache=True)
def _quantile_key(sample, share):
    """The ``share`` quantile of a sample of keys (sorted in place)."""
    sample.sort()
    return sample[min(int(share * sample.shape[0]), sample.shape[0] - 1)]


@njit(cache=True)
def _forest_edges(indptr, cols, weights, opposed, link, wide, light_share, filter_min, work):
    """Kruskal's minimum spanning forest in stable weight order, with parities.

    Filter-Kruskal (Osipov, Sanders, Singler 2009): a stage takes the remaining
    edges up to a sampled weight quantile (all once at most ``filter_min``
    remain), sorts them and runs Kruskal; of the heavier ones only those whose
    ends are still in different trees go on. A dropped edge would have closed a
    cycle, so the kept edges are Kruskal's over all edges in (weight, position)
    order: the ones scipy keeps. ``link``: ``2 * arange(n)``, int32 or int64
    (the id width); on return every node's entry leads to its tree's root, and
    the parities along the way add up to the parity of ``opposed`` edges on its
    tree path to the root. ``work``: scratch space of shape (6, E), uint64.
    Returns the kept edges' ends (in Kruskal's order) and their number.
    """
    n = indptr.shape[0] - 1
    m = cols.shape[0]
    rows = np.empty(m if wide else 0, dtype=np.int64)
    bits = weights.view(np.uint64)
    keys = work[0]  # heavy edges, in position order
    payload = work[1]
    light_keys = work[2]  # the stage's edges, in position order
    light_payload = work[3]
    # keys and payloads of every edge, in position order
    k = 0
    for i in range(n):
        for e in range(indptr[i], indptr[i + 1]):
            if wide:
                rows[e] = i
                p = np.uint64(e)
            else:
                p = (
                    (np.uint64(i) << np.uint64(32))
                    | (np.uint64(cols[e]) << np.uint64(1))
                    | np.uint64(opposed[e])
                )
            keys[k] = _float_key(bits[e])
            payload[k] = p
            k += 1
    n_cand = m
    kept_a = np.empty(max(n - 1, 0), dtype=np.int64)
    kept_b = np.empty(max(n - 1, 0), dtype=np.int64)
    n_kept = 0
    while n_cand > 0:
        threshold = ~np.uint64(0)
        if n_cand > filter_min:
            step = max(n_cand // _SAMPLE, 1)
            sample = np.empty((n_cand + step - 1) // step, dtype=np.uint64)
            for s in range(sample.shape[0]):
                sample[s] = keys[s * step]
            threshold = _quantile_key(sample, light_share)
        # stable partition (branch-free): light edges to the side arrays, heavy in place
        n_light = 0
        n_heavy = 0
        for s in range(n_cand):
            key = keys[s]
            p = payload[s]
            is_light = key <= threshold
            light_keys[n_light] = key
            light_payload[n_light] = p
            keys[n_heavy] = key
            payload[n_heavy] = p
            n_light += is_light
            n_heavy += 1 - is_light
        _, ordered = radix_sort_payload(
            light_keys[:n_light], light_payload[:n_light], work[4, :n_light], work[5, :n_light]
        )
        for s in range(n_light):
            if n_kept >= n - 1:
                break
            a, b, parity = _edge(ordered[s], rows, cols, opposed, wide)
            ra, fa = _find(link, a)
            rb, fb = _find(link, b)
            if ra == rb:
                continue
            if ra < rb:  # link by index
                ra, rb = rb, ra
            link[rb] = (ra << 1) | (fa ^ fb ^ parity)
            kept_a[n_kept] = a
            kept_b[n_kept] = b
            n_kept += 1
        if n_heavy == 0 or n_kept >= n - 1:
            break
        for v in range(n):  # point every node at its root
            r, f = _find(link, v)
            link[v] = (r << 1) | f
        n_cand = 0
        for s in range(n_heavy):  # filter: keep the edges between different trees
            p = payload[s]
            a, b, _ = _edge(p, rows, cols, opposed, wide)
            keys[n_cand] = keys[s]
            payload[n_cand] = p
            n_cand += (link[a] >> 1) != (link[b] >> 1)
    return kept_a, kept_b, n_kept


@njit(cache=True)
def _forest_labels(link):
    """Tree of every node (numbered by smallest member) and its path parity."""
    n = link.shape[0]
    labels = np.empty(n, dtype=np.int64)
    parity = np.empty(n, dtype=np.uint8)
    comp_of_root = np.full(n, -1, dtype=np.int64)
    n_comp = 0
    for i in range(n):
        r, f = _find(link, i)
        parity[i] = f
        if comp_of_root[r] < 0:
            comp_of_root[r] = n_comp
            n_comp += 1
        labels[i] = comp_of_root[r]
    return labels, n_comp, parity


@njit(cache=True)
def spanning_forest_kernel(indptr, cols, weights, opposed, work):
    """Minimum spanning forest (Kruskal, stable weight order) and tree parities.

    Parameters
    ----------
    indptr, cols : ndarray of int64
        CSR graph, each undirected edge stored once (as `riemannian_graph_kernel`).
    weights : ndarray of shape (E,), float64
        Edge weights, no NaN. Ties are broken by position in ``cols`` as by a
        stable sort: the order scipy's ``minimum_spanning_tree`` uses, so the
        same edges are kept (for distinct (weight, position) keys the minimum
        spanning forest is unique).
    opposed : ndarray of shape (E,), uint8
        1 where the edge's ends have opposed normals (n_i . n_j < 0), else 0.
    work : ndarray of shape (6, E), uint64
        Scratch space. Allocated by numpy, whose large arrays get huge pages:
        their first touch is several times cheaper than that of numba's.

    Returns
    -------
    kept_a, kept_b : ndarray of shape (K,), int64
        Ends of the forest's edges, in Kruskal's order.
    labels : ndarray of shape (N,), int64
        Tree of every node, numbered by smallest member index.
    n_comp : int
        Number of trees.
    parity : ndarray of shape (N,), uint8
        Parity of the number of opposed edges on the tree path from the node to
        a fixed node of its tree: the tree path between i and j crosses an odd
        number of them iff parity[i] != parity[j]. Breadth-first propagation
        from any root r (flip n_j when n_parent . n_j < 0) gives
        sign[i] = sign[r] * (-1)^(parity[i] xor parity[r]).

    Notes
    -----
    Filter-Kruskal (`_forest_edges`). Below 2**30 nodes the union-find is 32-bit
    and each edge's ends and parity are packed beside its key through the radix
    sort, so Kruskal's loop reads the edges as a stream.
    """
    n = indptr.shape[0] - 1
    if n < _WIDE_NODES:
        link32 = (2 * np.arange(n)).astype(np.int32)
        kept_a, kept_b, n_kept = _forest_edges(
            indptr, cols, weights, opposed, link32, False, _LIGHT_SHARE, _FILTER_MIN, work
        )
        labels, n_comp, parity = _forest_labels(link32)
    else:
        link64 = 2 * np.arange(n)
        kept_a, kept_b, n_kept = _forest_edges(
            indptr, cols, weights, opposed, link64, True, _LIGHT_SHARE, _FILTER_MIN, work
        )
        labels, n_comp, parity = _forest_labels(link64)
    return kept_a[:n_kept], kept_b[:n_kept], labels, n_comp, parity
