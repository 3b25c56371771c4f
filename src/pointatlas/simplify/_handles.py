"""Small handles of the voxel surface cut and capped (private): the robust path's
`_reconstruct.reconstruct_surface` runs it on a closed surface.

Where two sheets of a shape come within a grid step of each other (an arm along a
body, a slot narrower than a step) the field's sign in the gap is noise, and the
surface bridges the gap in places: each bridge is a small handle, and the output's
Euler characteristic falls by two per bridge. Found as Guskov and Wood do
("Topological noise removal", 2001): a region grown from a vertex in order of its
distance along the edges stays a disc (Euler characteristic 1) until its front meets
itself around a handle; where it is no longer a disc within `HANDLE_STEPS` grid steps
of its seed, and still not one a further `HANDLE_MARGIN` steps on (a front that
meets itself across a pocket closes it again), the region holds a handle of that
size. Cutting the region out leaves loops; when the surface left stays in one piece
around them (a loop around a neck or a finger would cut a piece off: not a handle),
each loop is closed by a fan around its centroid. The smallest handles go first,
regions that overlap a cut one are left alone. Decisions: docs/decisions/simplify.md,
"The points path's robust path".
"""

from __future__ import annotations

import numpy as np
from numba import get_num_threads, njit, prange

from ._mesh import unique_pairs, used_only, vertex_triangles

__all__ = ["HANDLE_MARGIN", "HANDLE_STEPS", "HANDLE_STRIDE", "cut_handles"]

#: A handle is cut when a region grown from one of its vertices stops being a disc
#: within this many grid steps (bridges across a sub-step gap: 1-2.3 steps on every
#: 3rd collection model; the smallest true holes there: from 2.2 steps, all of them
#: loops whose cut would cut a piece off) ...
HANDLE_STEPS = 3.0
#: ... and is still not a disc this many steps further on.
HANDLE_MARGIN = 1.0
#: Regions are grown from every this-th vertex (a handle is found from any vertex
#: near it; every vertex found the same handles on the models measured but one).
HANDLE_STRIDE = 4


def _graph(verts, tri):
    """Edge lengths by vertex (CSR ``vv_ptr``, ``vv_idx``, ``vv_len``), triangles
    by vertex (CSR ``vt_ptr``, ``vt_idx``), each triangle's three edge ids and the
    number of edges."""
    n = verts.shape[0]
    sides = np.sort(np.stack([tri, np.roll(tri, -1, axis=1)], axis=2).reshape(-1, 2), axis=1)
    edges, inv = unique_pairs(sides, return_inverse=True)
    tri_e = np.ascontiguousarray(inv.reshape(tri.shape), dtype=np.int64)
    both = np.concatenate([edges, edges[:, ::-1]])
    both = both[np.lexsort((both[:, 1], both[:, 0]))]
    a, b = both[:, 0], np.ascontiguousarray(both[:, 1])
    vv_ptr = np.concatenate([[0], np.cumsum(np.bincount(a, minlength=n))]).astype(np.int64)
    vv_len = np.linalg.norm(verts[a] - verts[b], axis=1)
    vt_ptr, vt_idx = vertex_triangles(tri, n)
    return (vv_ptr, b, vv_len, vt_ptr, vt_idx, tri_e, edges.shape[0])


@njit(cache=True)
def _grow(seeds, radius, margin, vv_ptr, vv_idx, vv_len, vt_ptr, vt_idx, tri, tri_e, n_e, region):
    """For each seed, the distance along the edges at which the region grown from it
    stops being a disc (its triangles' Euler characteristic V - E + F below 1), when
    it is still not one ``margin`` further (at most ``radius``); -1 otherwise. The
    last seed's region (its vertices, -1 after them: ``region`` holds one more than
    the vertices) is left in ``region``."""
    n = vv_ptr.shape[0] - 1
    dist = np.full(n, np.inf)
    inside = np.zeros(n, dtype=np.bool_)
    v_use = np.zeros(n, dtype=np.int64)
    e_use = np.zeros(n_e, dtype=np.int64)
    heap_d = np.empty(vv_idx.shape[0] + 1)
    heap_v = np.empty(vv_idx.shape[0] + 1, dtype=np.int64)
    touched = np.empty(n, dtype=np.int64)
    found = np.full(seeds.shape[0], -1.0)
    for s in range(seeds.shape[0]):
        seed = seeds[s]
        n_touched = 1
        touched[0] = seed
        dist[seed] = 0.0
        heap_d[0] = 0.0
        heap_v[0] = seed
        size = 1
        n_v = n_e_in = n_f = 0
        chi = 1
        detect = -1.0
        limit = radius
        n_in = 0
        while size > 0:
            d, v = heap_d[0], heap_v[0]
            size -= 1
            last_d, last_v = heap_d[size], heap_v[size]
            i = 0
            while True:  # sift the last entry down from the root
                c = 2 * i + 1
                if c >= size:
                    break
                if c + 1 < size and heap_d[c + 1] < heap_d[c]:
                    c += 1
                if heap_d[c] >= last_d:
                    break
                heap_d[i], heap_v[i] = heap_d[c], heap_v[c]
                i = c
            heap_d[i], heap_v[i] = last_d, last_v
            if inside[v] or d > dist[v]:
                continue
            if d > limit:
                break
            inside[v] = True
            region[n_in] = v
            n_in += 1
            for a in range(vt_ptr[v], vt_ptr[v + 1]):
                t = vt_idx[a]
                if not (inside[tri[t, 0]] and inside[tri[t, 1]] and inside[tri[t, 2]]):
                    continue
                n_f += 1
                for c in range(3):
                    if e_use[tri_e[t, c]] == 0:
                        n_e_in += 1
                    e_use[tri_e[t, c]] += 1
                    if v_use[tri[t, c]] == 0:
                        n_v += 1
                    v_use[tri[t, c]] += 1
            chi = n_v - n_e_in + n_f if n_f > 0 else 1
            if chi < 1 and detect < 0.0:
                detect = d
                limit = min(radius, d + margin)
            for a in range(vv_ptr[v], vv_ptr[v + 1]):
                u = vv_idx[a]
                nd = d + vv_len[a]
                if nd < dist[u]:
                    if dist[u] == np.inf:
                        touched[n_touched] = u
                        n_touched += 1
                    dist[u] = nd
                    i = size  # sift up
                    size += 1
                    while i > 0 and heap_d[(i - 1) // 2] > nd:
                        heap_d[i], heap_v[i] = heap_d[(i - 1) // 2], heap_v[(i - 1) // 2]
                        i = (i - 1) // 2
                    heap_d[i], heap_v[i] = nd, u
        if detect >= 0.0 and chi < 1:
            found[s] = detect
        region[n_in] = -1
        for b in range(n_touched):
            u = touched[b]
            dist[u] = np.inf
            inside[u] = False
            v_use[u] = 0
            for a in range(vt_ptr[u], vt_ptr[u + 1]):
                for c in range(3):
                    e_use[tri_e[vt_idx[a], c]] = 0
    return found


@njit(cache=True, parallel=True)
def _grow_all(
    seeds, radius, margin, vv_ptr, vv_idx, vv_len, vt_ptr, vt_idx, tri, tri_e, n_e, n_chunks
):
    """`_grow` of every seed, in ``n_chunks`` interleaved chunks on the threads."""
    found = np.empty(seeds.shape[0])
    for c in prange(n_chunks):
        mine = seeds[c::n_chunks]
        region = np.empty(vv_ptr.shape[0], dtype=np.int64)
        got = _grow(
            mine, radius, margin, vv_ptr, vv_idx, vv_len, vt_ptr, vt_idx, tri, tri_e, n_e, region
        )
        found[c::n_chunks] = got
    return found


def _loops(tri, gone, n):
    """The loops around the triangles ``gone`` (a bool mask) of a closed, oriented
    surface of ``n`` vertices, each in the direction of the triangles around it (a
    cap over it is the reversed loop); None where a vertex lies on a loop twice."""
    cut = tri[gone]
    inward = np.concatenate([cut[:, [1, 0]], cut[:, [2, 1]], cut[:, [0, 2]]])
    outward = np.concatenate([cut[:, [0, 1]], cut[:, [1, 2]], cut[:, [2, 0]]])
    # a side of a cut triangle whose reverse is not a side of another cut triangle
    border = inward[~np.isin(inward[:, 0] * n + inward[:, 1], outward[:, 0] * n + outward[:, 1])]
    if border.shape[0] == 0 or np.unique(border[:, 0]).size != border.shape[0]:
        return None
    after = dict(zip(border[:, 0].tolist(), border[:, 1].tolist(), strict=True))
    loops = []
    while after:
        start, nxt = after.popitem()
        loop = [start]
        while nxt != start:
            loop.append(nxt)
            nxt = after.pop(nxt, None)
            if nxt is None:
                return None
        if len(loop) < 3:
            return None
        loops.append(np.array(loop, dtype=np.int64))
    return loops


@njit(cache=True)
def _region_triangles(inner, mine, tri, vt_ptr, vt_idx):
    """The triangles whose three vertices are in the region (``mine``), found around
    its vertices ``inner`` (the same as ``mine[tri].all(axis=1)``, without a pass
    over every triangle)."""
    out = np.zeros(tri.shape[0], dtype=np.bool_)
    for v in inner:
        for a in range(vt_ptr[v], vt_ptr[v + 1]):
            t = vt_idx[a]
            if mine[tri[t, 0]] and mine[tri[t, 1]] and mine[tri[t, 2]]:
                out[t] = True
    return out


@njit(cache=True, inline="always")
def _visit(u, seen, queue, tail) -> int:
    """``u`` onto the search's ``queue`` unless ``seen``; the queue's new length."""
    if u < 0 or seen[u]:
        return tail
    seen[u] = True
    queue[tail] = u
    return tail + 1


@njit(cache=True)
def _one_piece(starts, tri, vt_ptr, vt_idx, removed, ring):
    """Whether cutting the region out and capping its loops leaves them joined: a
    breadth-first search from the first loop's vertex ``starts[0]`` over the
    triangles not ``removed`` (the cut ones and the region's) and the caps, its own
    and the earlier cuts' (``ring``: each loop vertex's successor on its loop, -1
    elsewhere; a cap's fan joins its loop's vertices), stopped when it has reached
    every loop (``starts``: a vertex of each; they go around a handle) or has
    nothing left (a loop around a neck or a finger: the cut would cut a piece off).
    The same answer as the pieces of the whole surface after the cut
    (`vertex_pieces`; the plain version in tests/simplify/test_handles.py), without
    a pass over all of it."""
    n = ring.shape[0]
    seen = np.zeros(n, dtype=np.bool_)
    goal = np.zeros(n, dtype=np.bool_)
    goal[starts[1:]] = True
    left = starts.shape[0] - 1
    queue = np.empty(n, dtype=np.int64)
    tail = _visit(starts[0], seen, queue, 0)
    head = 0
    while head < tail and left > 0:
        v = queue[head]
        head += 1
        if goal[v]:
            left -= 1
        tail = _visit(ring[v], seen, queue, tail)
        for a in range(vt_ptr[v], vt_ptr[v + 1]):
            t = vt_idx[a]
            if not removed[t]:
                for c in range(3):
                    tail = _visit(tri[t, c], seen, queue, tail)
    return left == 0


def cut_handles(verts, tri, step: float):
    """The closed, oriented surface ``verts``, ``tri`` with its handles smaller than
    `HANDLE_STEPS` grid steps (``step``) cut and capped (module docstring). Returns
    ``(verts, tri, n_cut)``; unused vertices are dropped when something was cut.

    Regions are grown on the input's triangles: a region that meets no cut one
    grows alike on the surface after the cuts (cut regions are skipped)."""
    radius, margin = HANDLE_STEPS * step, HANDLE_MARGIN * step
    n = verts.shape[0]
    graph = _graph(verts, tri)
    seeds = np.arange(0, n, HANDLE_STRIDE, dtype=np.int64)
    found = _grow_all(seeds, radius, margin, *graph[:5], tri, *graph[5:], 4 * get_num_threads())
    order = np.argsort(found, kind="stable")
    order = order[found[order] >= 0.0]
    done = np.zeros(n, dtype=bool)
    gone = np.zeros(tri.shape[0], dtype=bool)
    caps, centres, n_cut = [], [], 0
    ring = np.full(n, -1, dtype=np.int64)  # the caps' loops: each vertex's successor
    region = np.empty(n + 1, dtype=np.int64)
    for seed in seeds[order]:
        if done[seed]:
            continue
        _grow(np.array([seed]), radius, margin, *graph[:5], tri, *graph[5:], region)
        inner = region[: np.argmax(region < 0)]
        mine = np.zeros(n, dtype=bool)
        mine[inner] = True
        if done[mine].any():
            continue
        done[mine] = True
        here = _region_triangles(inner, mine, tri, *graph[3:5])
        loops = _loops(tri, here, n)
        if loops is None:
            continue
        # the loops join as their caps would: kept when cut, taken back when not
        # (no loop vertex lies on an earlier cut's loop: those are done)
        for loop in loops:
            ring[loop] = np.roll(loop, -1)
        starts = np.array([loop[0] for loop in loops], dtype=np.int64)
        if not _one_piece(starts, tri, *graph[3:5], gone | here, ring):
            for loop in loops:
                ring[loop] = -1
            continue
        gone |= here
        n_cut += 1
        for j, loop in enumerate(loops):
            centre = n + len(centres) + j
            caps.append(np.stack([np.roll(loop, -1), loop, np.full(loop.size, centre)], axis=1))
        centres += [verts[loop].mean(axis=0) for loop in loops]
    if not caps:
        return verts, tri, 0
    verts = np.vstack([verts, np.array(centres)])
    return (*used_only(verts, np.vstack([tri[~gone], *caps])), n_cut)
