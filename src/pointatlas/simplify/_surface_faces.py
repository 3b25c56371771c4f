"""One planar face per region of a labelled triangle mesh, and the checks of the
faces (the mesh path, docs/decisions/simplify.md; private).

A region's boundary loops (chains of kept arc vertices) are projected to the
region's plane and triangulated by earcut; the face is accepted only when its
triangulation covers the loops' area once and its boundary is exactly the loops'
edges (`face_of_loops`). `bad_regions` finds the regions whose faces break the
output's manifoldness.
"""

from __future__ import annotations

import mapbox_earcut
import numpy as np

from ._faces import _signed_area
from ._mesh import link_is_one_fan, plane_basis, unique_ints, vertex_links

__all__ = ["bad_regions", "face_of_loops", "loop_vertices"]


def loop_vertices(uses, arcs) -> list[int]:
    out: list[int] = []
    for aid, rev in uses:
        kept = arcs[aid].kept
        seq = kept[::-1] if rev else kept
        out.extend(seq[:-1])
    return out


def _segments_cross(xy_loops) -> bool:
    """True when two edges of the loops (not sharing an end) touch or cross."""
    segs, ids = [], []
    for lp in xy_loops:
        m = lp.shape[0]
        segs.append(np.stack([lp, np.roll(lp, -1, axis=0)], axis=1))
        ids.append(np.arange(m))
    p = np.concatenate(segs)
    m = p.shape[0]
    if m > 4000:  # too many pairs to test: not a face worth making
        return True
    a, b = p[:, 0], p[:, 1]
    i, j = np.triu_indices(m, 1)
    a1, b1, a2, b2 = a[i], b[i], a[j], b[j]
    shares = np.all(a1 == a2, 1) | np.all(a1 == b2, 1) | np.all(b1 == a2, 1) | np.all(b1 == b2, 1)

    def orient(p0, p1, q):
        return (p1[:, 0] - p0[:, 0]) * (q[:, 1] - p0[:, 1]) - (p1[:, 1] - p0[:, 1]) * (
            q[:, 0] - p0[:, 0]
        )

    d1, d2 = orient(a1, b1, a2), orient(a1, b1, b2)
    d3, d4 = orient(a2, b2, a1), orient(a2, b2, b1)
    proper = (d1 * d2 < 0) & (d3 * d4 < 0)
    return bool((proper & ~shares).any())


def _edges_match(tri: np.ndarray, loops) -> bool:
    """The triangles' boundary is exactly the loops' edges, in the loops' direction, and
    every inner edge joins two triangles in opposite directions."""
    d = np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]])
    want = np.concatenate([np.stack([lp, np.roll(lp, -1)], 1) for lp in loops])
    n = int(max(d.max(initial=0), want.max(initial=0))) + 1
    dk = d[:, 0] * n + d[:, 1]
    rk = d[:, 1] * n + d[:, 0]
    wk = want[:, 0] * n + want[:, 1]
    if unique_ints(dk).size != dk.size or unique_ints(wk).size != wk.size:
        return False
    inner = np.isin(dk, rk)
    return bool(np.array_equal(np.sort(dk[~inner]), np.sort(wk)))


def _twice_areas(pts2: np.ndarray, tri: np.ndarray) -> np.ndarray:
    """Twice the signed area of each 2-D triangle ``pts2[tri]`` (counter-clockwise
    positive)."""
    p0, p1, p2 = pts2[tri[:, 0]], pts2[tri[:, 1]], pts2[tri[:, 2]]
    return (p1[:, 0] - p0[:, 0]) * (p2[:, 1] - p0[:, 1]) - (p1[:, 1] - p0[:, 1]) * (
        p2[:, 0] - p0[:, 0]
    )


def face_of_loops(loops_v, positions, normal, every_vertex: bool = False):
    """Triangulate one region's loops in its plane; None when they bound no polygon.

    A loop may touch itself or another loop at a vertex (a region pinched at a
    vertex); the triangulation is accepted when its boundary is exactly the loops'
    edges and it covers the loops' area once. earcut leaves out a vertex on the
    straight line of its two neighbours (exactly, in the plane's coordinates);
    ``every_vertex``: those are put back (`_put_back`), else the face is None.
    """
    if any(len(lp) < 3 for lp in loops_v):
        return None
    flat = np.concatenate([np.asarray(lp, dtype=np.int64) for lp in loops_v])
    u, v = plane_basis(normal)
    origin = positions[flat].mean(axis=0)
    xy = [
        np.stack([(positions[lp] - origin) @ u, (positions[lp] - origin) @ v], 1) for lp in loops_v
    ]
    areas = np.array([_signed_area(c) for c in xy])
    outer = int(np.argmax(areas))
    if areas[outer] <= 0.0 or (np.delete(areas, outer) >= 0.0).any():
        return None  # the region folds over in its plane: no single outer loop
    if _segments_cross(xy):
        return None
    order = [outer] + [t for t in range(len(loops_v)) if t != outer]
    loops_o = [np.asarray(loops_v[t], dtype=np.int64) for t in order]
    xy_o = [xy[t] for t in order]
    ends = np.cumsum([len(lp) for lp in loops_o]).astype(np.uint32)
    pts2 = np.concatenate(xy_o)
    tri = np.asarray(mapbox_earcut.triangulate_float64(pts2, ends), dtype=np.int64).reshape(-1, 3)
    if tri.shape[0] == 0:
        return None
    cross = _twice_areas(pts2, tri)
    flip = cross < 0
    tri[flip] = tri[flip][:, [0, 2, 1]]
    if every_vertex and unique_ints(tri).size < pts2.shape[0]:
        tri = _put_back(tri, pts2, ends)
        if tri is None:
            return None
        cross = _twice_areas(pts2, tri)
        if (cross <= 0.0).any():
            return None
    covered = np.abs(cross).sum() / 2.0
    want = areas[outer] + areas[np.arange(areas.size) != outer].sum()
    if abs(covered - want) > 1e-9 * max(areas[outer], 1e-300):
        return None
    ids = np.concatenate(loops_o)[tri]
    if not _edges_match(ids, loops_o):
        return None
    return tuple(loops_o), ids


def _put_back(tri: np.ndarray, pts2: np.ndarray, ends: np.ndarray):
    """``tri`` (earcut's, counter-clockwise) with the loops' vertices it left out put
    back: a run of them between two vertices it kept, ``a`` and ``b``, in order along
    the straight edge ``a b``, splits the triangle on that edge into a fan from its
    third corner. None where a run does not lie in order between its ends or no
    triangle has the edge ``a b`` in the loop's direction."""
    used = np.zeros(pts2.shape[0], dtype=bool)
    used[tri] = True
    by_edge = {(int(t[i]), int(t[(i + 1) % 3])): k for k, t in enumerate(tri) for i in range(3)}
    out = tri.tolist()
    gone = set()
    start = 0
    for end in ends.tolist():
        ring = np.arange(start, end)
        start = end
        kept = ring[used[ring]]
        if kept.size == ring.size:
            continue
        if kept.size < 2:
            return None
        for i in np.flatnonzero(used[ring]).tolist():  # each kept vertex and its run
            run = []
            j = (i + 1) % ring.size
            while not used[ring[j]]:
                run.append(int(ring[j]))
                j = (j + 1) % ring.size
            if not run:
                continue
            a, b = int(ring[i]), int(ring[j])
            k = by_edge.get((a, b))
            ab = pts2[b] - pts2[a]
            along = np.concatenate([[0.0], (pts2[run] - pts2[a]) @ ab, [ab @ ab]])
            if k is None or k in gone or not (np.diff(along) > 0.0).all():
                return None
            c = [v for v in tri[k].tolist() if v not in (a, b)][0]
            chain = [a, *run, b]
            gone.add(k)
            out.extend([chain[s], chain[s + 1], c] for s in range(len(chain) - 1))
    return np.array([row for k, row in enumerate(out) if k not in gone], dtype=np.int64)


def bad_regions(tri: np.ndarray, tface: np.ndarray, closed_input: bool) -> set[int]:
    """Regions owning a triangle at a non-manifold (or, for closed inputs, open) edge or
    at a vertex whose triangles do not form one fan."""
    d = np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]])
    owner = np.concatenate([tface, tface, tface])
    und = np.sort(d, axis=1)
    _, inv, cnt = np.unique(und, axis=0, return_inverse=True, return_counts=True)
    inv = inv.reshape(-1)
    bad_edge = (cnt > 2) | ((cnt != 2) if closed_input else np.zeros_like(cnt, dtype=bool))
    bad = set(owner[bad_edge[inv]].tolist())
    _, dcnt_inv, dcnt = np.unique(d, axis=0, return_inverse=True, return_counts=True)
    bad |= set(owner[(dcnt > 1)[dcnt_inv.reshape(-1)]].tolist())
    for edges in vertex_links(tri).values():
        if not link_is_one_fan(edges):
            bad |= {int(tface[t]) for _, _, t in edges}
    return bad
