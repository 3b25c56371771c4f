"""numba kernels of the normals room (validated input assumed, no checks here).

References in plain numpy: ``tests/normals/reference.py``.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

__all__ = [
    "component_tops_kernel",
    "pca_normals_kernel",
    "propagate_signs_kernel",
    "riemannian_graph_kernel",
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


@njit(cache=True)
def propagate_signs_kernel(indptr, adj, normals, roots, root_signs):
    """Breadth-first sign propagation over a forest (Hoppe et al. 1992).

    Parameters
    ----------
    indptr, adj : ndarray of int64
        Symmetric CSR adjacency of the spanning forest.
    normals : ndarray of shape (N, 3), float64
        Unoriented normals.
    roots : ndarray of shape (C,), int64
        One root per tree, visited in this order.
    root_signs : ndarray of shape (C,), float64
        Sign (+1 or -1) given to each root.

    Returns
    -------
    signs : ndarray of shape (N,), float64
        sign[j] = sign[parent] * (+1 if n_parent . n_j >= 0 else -1), so that
        ``signs[:, None] * normals`` is consistent along every tree edge.
        Nodes unreachable from all roots keep +1.
    order : ndarray of shape (N,), int64
        Visiting order (BFS per root); unreachable nodes are not listed, the
        tail holds -1.
    """
    n = normals.shape[0]
    signs = np.ones(n)
    visited = np.zeros(n, dtype=np.bool_)
    order = np.full(n, -1, dtype=np.int64)
    head = 0
    tail = 0
    for r in range(roots.shape[0]):
        root = roots[r]
        if visited[root]:
            continue
        visited[root] = True
        signs[root] = root_signs[r]
        order[tail] = root
        tail += 1
        while head < tail:
            i = order[head]
            head += 1
            for e in range(indptr[i], indptr[i + 1]):
                j = adj[e]
                if visited[j]:
                    continue
                visited[j] = True
                d = normals[i, 0] * normals[j, 0]
                d += normals[i, 1] * normals[j, 1]
                d += normals[i, 2] * normals[j, 2]
                signs[j] = signs[i] if d >= 0.0 else -signs[i]
                order[tail] = j
                tail += 1
    return signs, order


@njit(cache=True, parallel=True)
def riemannian_graph_kernel(points, normals, indices, k, eps, penalty):
    """Weighted undirected k-NN graph, each edge once (CSR, upper or lower row).

    Edge {i, j} exists when j is among indices[i, 1:k] or i among indices[j, 1:k]
    (the symmetric k-NN graph). It is stored once: in row i when j is in i's list
    and j > i, or j < i and i is not in j's list (otherwise row j holds it). Self
    entries are skipped.

    Returns
    -------
    indptr : ndarray of shape (N + 1,), int64
    cols : ndarray of shape (E,), int64
    weights : ndarray of shape (E,), float64
        1 - |n_i . n_j| + penalty (|n_i . e| + |n_j . e|) / 2
        + eps (1 + |p_i - p_j| / mean edge length), e the unit edge direction
        (the penalty term is dropped for coincident points); always > 0.
    """
    n = indices.shape[0]
    keep = np.zeros((n, max(k - 1, 0)), dtype=np.bool_)
    counts = np.zeros(n, dtype=np.int64)
    for i in prange(n):
        cnt = 0
        for c in range(1, k):
            j = indices[i, c]
            if j == i:
                continue
            ok = True
            if j < i:
                for c2 in range(1, k):
                    if indices[j, c2] == i:
                        ok = False
                        break
            if ok:
                keep[i, c - 1] = True
                cnt += 1
        counts[i] = cnt
    indptr = np.zeros(n + 1, dtype=np.int64)
    for i in range(n):
        indptr[i + 1] = indptr[i] + counts[i]
    m = indptr[n]
    cols = np.empty(m, dtype=np.int64)
    lengths = np.empty(m)
    for i in prange(n):
        pos = indptr[i]
        for c in range(1, k):
            if keep[i, c - 1]:
                j = indices[i, c]
                dx = points[j, 0] - points[i, 0]
                dy = points[j, 1] - points[i, 1]
                dz = points[j, 2] - points[i, 2]
                cols[pos] = j
                lengths[pos] = np.sqrt(dx * dx + dy * dy + dz * dz)
                pos += 1
    mean = lengths.sum() / max(m, 1)
    inv = 1.0 / mean if mean > 0.0 else 0.0
    weights = np.empty(m)
    for i in prange(n):
        for e in range(indptr[i], indptr[i + 1]):
            j = cols[e]
            length = lengths[e]
            d = normals[i, 0] * normals[j, 0]
            d += normals[i, 1] * normals[j, 1]
            d += normals[i, 2] * normals[j, 2]
            w = 1.0 - min(abs(d), 1.0) + eps * (1.0 + length * inv)
            if penalty != 0.0 and length > 0.0:
                ex = (points[j, 0] - points[i, 0]) / length
                ey = (points[j, 1] - points[i, 1]) / length
                ez = (points[j, 2] - points[i, 2]) / length
                a = abs(normals[i, 0] * ex + normals[i, 1] * ey + normals[i, 2] * ez)
                b = abs(normals[j, 0] * ex + normals[j, 1] * ey + normals[j, 2] * ez)
                w += 0.5 * penalty * (a + b)
            weights[e] = w
    return indptr, cols, weights


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


@njit(cache=True)
def _uf_find(parent, i):
    while parent[i] != i:  # path halving
        parent[i] = parent[parent[i]]
        i = parent[i]
    return i


@njit(cache=True)
def _kruskal_core(indptr, cols, order, parent):
    """Kruskal's loop and the tree labels; ``parent`` (int32 or int64, the
    identity) sets the id width.

    The edge ends are first gathered in weight order into two plain arrays, so
    the loop reads them as a stream; ties by union size, path halving.
    """
    n = indptr.shape[0] - 1
    m = cols.shape[0]
    row = np.empty(m, dtype=parent.dtype)
    for i in range(n):
        for e in range(indptr[i], indptr[i + 1]):
            row[e] = i
    ea = np.empty(m, dtype=parent.dtype)
    eb = np.empty(m, dtype=parent.dtype)
    for s in range(m):
        e = order[s]
        ea[s] = row[e]
        eb[s] = cols[e]
    size = np.ones(n, dtype=parent.dtype)
    kept_a = np.empty(max(n - 1, 0), dtype=np.int64)
    kept_b = np.empty(max(n - 1, 0), dtype=np.int64)
    n_kept = 0
    for s in range(m):
        if n_kept == n - 1:
            break
        a = ea[s]
        b = eb[s]
        ra = _uf_find(parent, a)
        rb = _uf_find(parent, b)
        if ra == rb:
            continue
        if size[ra] < size[rb]:
            ra, rb = rb, ra
        parent[rb] = ra
        size[ra] += size[rb]
        kept_a[n_kept] = a
        kept_b[n_kept] = b
        n_kept += 1
    labels = np.empty(n, dtype=np.int64)
    comp_of_root = np.full(n, -1, dtype=np.int64)
    n_comp = 0
    for i in range(n):
        r = _uf_find(parent, i)
        if comp_of_root[r] < 0:
            comp_of_root[r] = n_comp
            n_comp += 1
        labels[i] = comp_of_root[r]
    return kept_a, kept_b, n_kept, labels, n_comp


@njit(cache=True)
def kruskal_forest_kernel(indptr, cols, order):
    """Minimum spanning forest by Kruskal's algorithm with a union-find.

    Parameters
    ----------
    indptr, cols : ndarray of int64
        CSR graph, each undirected edge stored once (as `riemannian_graph_kernel`).
    order : ndarray of shape (E,), int64
        Edge positions (into ``cols``) by increasing weight; with a stable sort of
        the weights this is the order scipy's ``minimum_spanning_tree`` uses, so
        the same edges are kept (an edge is kept iff its ends are in different
        trees when it comes up, whatever the union rule).

    Returns
    -------
    tree_indptr, tree_adj : ndarray of int64
        Symmetric CSR adjacency of the forest.
    labels : ndarray of shape (N,), int64
        Component (tree) of every node, numbered by smallest member index.
    n_comp : int
        Number of trees.
    """
    n = indptr.shape[0] - 1
    # 32-bit node ids halve the union-find's and the edge stream's memory traffic
    if n < 2**31 - 1:
        kept_a, kept_b, n_kept, labels, n_comp = _kruskal_core(
            indptr, cols, order, np.arange(n).astype(np.int32)
        )
    else:
        kept_a, kept_b, n_kept, labels, n_comp = _kruskal_core(indptr, cols, order, np.arange(n))
    deg = np.zeros(n + 1, dtype=np.int64)
    for t in range(n_kept):
        deg[kept_a[t] + 1] += 1
        deg[kept_b[t] + 1] += 1
    for i in range(n):
        deg[i + 1] += deg[i]
    fill = deg[:-1].copy()
    adj = np.empty(2 * n_kept, dtype=np.int64)
    for t in range(n_kept):
        a = kept_a[t]
        b = kept_b[t]
        adj[fill[a]] = b
        fill[a] += 1
        adj[fill[b]] = a
        fill[b] += 1
    return deg, adj, labels, n_comp
