"""Boundary loops of face regions and their arcs, shared by the regions beside them (private).

Part of the mesh path (`_surface.py`): a region's boundary half-edges are chained
into loops (turning around each vertex inside the region, which untangles pinch
vertices), the loops are split into arcs at anchors (vertices where three or more
regions meet), and each arc is simplified once by Douglas-Peucker so that both
regions beside it use the same chords.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from .._core import PointAtlasError

if TYPE_CHECKING:  # pragma: no cover
    from ._triangles import _Surface

__all__ = [
    "MAX_REFINE",
    "Arc",
    "full_arc",
    "refine_arc",
    "region_loops",
    "separate_parallel_chords",
    "simplify_arc",
    "split_arcs",
]

#: Halvings of the chord tolerance tried before a region keeps its input triangles.
MAX_REFINE = 12


def half_edge_faces(s: _Surface) -> dict:
    """Directed edge (u, v) -> the face that holds it."""
    t = s.triangles
    n = s.vertices.shape[0]
    keys = np.concatenate([t[:, 0] * n + t[:, 1], t[:, 1] * n + t[:, 2], t[:, 2] * n + t[:, 0]])
    faces = np.tile(np.arange(t.shape[0], dtype=np.int64), 3)
    return dict(zip(keys.tolist(), faces.tolist(), strict=True))


def region_loops(s: _Surface, labels: np.ndarray) -> dict[int, list[list[int]]]:
    """Boundary loops of every region as vertex cycles, the region on the left.

    A boundary half-edge (u, v) of a face with label a has no face of label a across
    it. The next one starts at v: turn around v through the faces of label a until
    the face across is another region (or none), which also untangles pinch vertices.
    """
    t = s.triangles
    n = s.vertices.shape[0]
    hef = half_edge_faces(s)
    lab = labels
    boundary = []
    for j in range(3):
        u, v = t[:, j], t[:, (j + 1) % 3]
        across = np.array([hef.get(k, -1) for k in (v * n + u).tolist()], dtype=np.int64)
        is_b = (across < 0) | (lab[np.maximum(across, 0)] != lab)
        for f in np.flatnonzero(is_b).tolist():
            boundary.append((int(u[f]), int(v[f]), f))
    nxt: dict[tuple[int, int], tuple[int, int]] = {}
    for u, v, f in boundary:
        a = lab[f]
        face = f
        # rotate around v inside region a: in ``face`` the edge leaving v is (v, w)
        for _ in range(256):
            tri = t[face].tolist()
            w = tri[(tri.index(v) + 1) % 3]
            g = hef.get(w * n + v, -1)
            if g < 0 or lab[g] != a:
                nxt[(u, v)] = (v, w)
                break
            face = g
        else:  # pragma: no cover - a fan of more than 256 faces of one region
            raise PointAtlasError("a vertex has more than 256 faces of one region")
    loops: dict[int, list[list[int]]] = {}
    seen: set[tuple[int, int]] = set()
    region_of = {(u, v): int(lab[f]) for u, v, f in boundary}
    for u, v, _ in boundary:
        if (u, v) in seen:
            continue
        loop = []
        e = (u, v)
        while e not in seen:
            seen.add(e)
            loop.append(e[0])
            e = nxt[e]
        loops.setdefault(region_of[(u, v)], []).append(loop)
    return loops


# --------------------------------------------------------------------------- arcs


def douglas_peucker(pts: np.ndarray, tol: float) -> np.ndarray:
    """Indices kept by Douglas-Peucker on a 3-D polyline (ends always kept)."""
    m = pts.shape[0]
    keep = np.zeros(m, dtype=bool)
    keep[0] = keep[-1] = True
    stack = [(0, m - 1)]
    while stack:
        i, j = stack.pop()
        if j <= i + 1:
            continue
        a, b = pts[i], pts[j]
        seg = b - a
        q = pts[i + 1 : j] - a
        ll = float(seg @ seg)
        if ll > 0.0:
            tt = np.clip(q @ seg / ll, 0.0, 1.0)
            d = np.linalg.norm(q - tt[:, None] * seg, axis=1)
        else:
            d = np.linalg.norm(q, axis=1)
        k = int(np.argmax(d))
        if d[k] > tol:
            keep[i + 1 + k] = True
            stack.append((i, i + 1 + k))
            stack.append((i + 1 + k, j))
    return np.flatnonzero(keep)


@dataclass
class Arc:
    """One boundary arc, canonical direction, and its kept vertices (private)."""

    verts: list  # vertex ids in canonical direction, closed arcs repeat the first at the end
    regions: tuple  # (left region of the canonical direction, right region or -1)
    tol: float
    kept: list | None = None


def split_arcs(loops, labels_of_vertex, s: _Surface, labels, tol):
    """Split every region loop at anchors into arcs shared by the regions beside them.

    Returns the arcs and, per region, its loops as lists of (arc id, reversed).
    """
    n = s.vertices.shape[0]
    hef = half_edge_faces(s)
    lab = labels

    def other_side(u, v):
        g = hef.get(v * n + u, -1)
        return -1 if g < 0 else int(lab[g])

    arcs: list[Arc] = []
    arc_of_edge: dict[tuple[int, int], tuple[int, bool]] = {}
    region_loops: dict[int, list[list[tuple[int, bool]]]] = {}
    for region in sorted(loops):
        for loop in loops[region]:
            anchor = [labels_of_vertex[x] >= 3 for x in loop]
            uses = []
            if any(anchor):
                start = anchor.index(True)
                order = loop[start:] + loop[:start]
                flags = anchor[start:] + anchor[:start]
                pieces, cur = [], [order[0]]
                for x, fl in zip(order[1:], flags[1:], strict=True):
                    cur.append(x)
                    if fl:
                        pieces.append(cur)
                        cur = [x]
                cur.append(order[0])
                pieces.append(cur)
            else:
                start = int(np.argmin(loop))
                order = loop[start:] + loop[:start]
                pieces = [order + [order[0]]]
            for piece in pieces:
                key = (piece[0], piece[1])
                if key in arc_of_edge:
                    uses.append(arc_of_edge[key])
                    continue
                rkey = (piece[1], piece[0])
                if rkey in arc_of_edge:  # pragma: no cover - same direction twice
                    uses.append(arc_of_edge[rkey])
                    continue
                other = other_side(piece[0], piece[1])
                aid = len(arcs)
                arcs.append(Arc(piece, (region, other), tol))
                # the other side walks the same edges backwards
                if len(piece) >= 2:
                    arc_of_edge[(piece[-1], piece[-2])] = (aid, True)
                arc_of_edge[key] = (aid, False)
                uses.append((aid, False))
            region_loops.setdefault(region, []).append(uses)
    return arcs, region_loops


def simplify_arc(arc: Arc, positions: np.ndarray) -> None:
    verts = arc.verts
    pts = positions[verts]
    closed = verts[0] == verts[-1]
    if arc.tol <= 0.0:
        arc.kept = list(verts)
        return
    if closed:
        # a closed loop without anchors: split at the vertex farthest from the start,
        # simplify both halves, keep at least three vertices
        d = np.linalg.norm(pts - pts[0], axis=1)
        far = int(np.argmax(d))
        left = douglas_peucker(pts[: far + 1], arc.tol)
        right = far + douglas_peucker(pts[far:], arc.tol)
        idx = np.unique(np.concatenate([left, right]))
        if idx.size < 4:  # start, far, start again: add the farthest of each half
            extra = []
            for lo, hi in ((0, far), (far, len(verts) - 1)):
                if hi - lo >= 2:
                    seg = pts[lo : hi + 1]
                    a, b = seg[0], seg[-1]
                    ab = b - a
                    ll = float(ab @ ab) or 1.0
                    q = seg - a
                    dist = np.linalg.norm(q - np.outer(np.clip(q @ ab / ll, 0, 1), ab), axis=1)
                    extra.append(lo + int(np.argmax(dist)))
            idx = np.unique(np.concatenate([idx, np.asarray(extra, dtype=np.int64)]))
        arc.kept = [verts[i] for i in idx.tolist()]
        return
    idx = douglas_peucker(pts, arc.tol)
    arc.kept = [verts[i] for i in idx.tolist()]


def refine_arc(arc: Arc) -> bool:
    """Halve the tolerance of an arc; False when it is already the full arc."""
    if arc.tol <= 0.0 or arc.kept is not None and len(arc.kept) == len(arc.verts):
        return False
    arc.tol = arc.tol / 2.0 if arc.tol > 1e-300 else 0.0
    arc.kept = None
    return True


def full_arc(arc: Arc) -> None:
    arc.tol = 0.0
    arc.kept = list(arc.verts)


def separate_parallel_chords(arcs: list[Arc], positions) -> None:
    """Two arcs simplified to the same chord would glue three faces on one edge."""
    for _ in range(MAX_REFINE + 4):
        clash = _clashing_arcs(arcs)
        if not clash.size:
            return
        for aid in clash.tolist():  # each arc on its own: the order does not matter
            arc = arcs[aid]
            if not refine_arc(arc):
                full_arc(arc)
            else:
                simplify_arc(arc, positions)


def _clashing_arcs(arcs: list[Arc]) -> np.ndarray:
    """Ids (sorted) of the arcs that share a chord with another arc, or whose two
    kept vertices coincide: every arc of a chord (unordered vertex pair) used by two
    or more arcs. Vectorised over all chords (one sort)."""
    lens = np.fromiter((len(arc.kept) for arc in arcs), dtype=np.int64, count=len(arcs))
    total = int(lens.sum())
    flat = np.fromiter(
        itertools.chain.from_iterable(arc.kept for arc in arcs), dtype=np.int64, count=total
    )
    aid = np.repeat(np.arange(len(arcs), dtype=np.int64), lens)
    has_next = np.ones(total, dtype=np.bool_)
    has_next[np.cumsum(lens)[lens > 0] - 1] = False  # an arc's last vertex starts no chord
    e = np.flatnonzero(has_next)
    lo = np.minimum(flat[e], flat[e + 1])
    hi = np.maximum(flat[e], flat[e + 1])
    own = aid[e]
    order = np.lexsort((own, hi, lo))
    lo, hi, own = lo[order], hi[order], own[order]
    start = np.ones(lo.size, dtype=np.bool_)
    start[1:] = (lo[1:] != lo[:-1]) | (hi[1:] != hi[:-1])
    group = np.cumsum(start) - 1
    first = np.flatnonzero(start)
    last = np.append(first[1:], lo.size) - 1 if first.size else first
    shared = own[first] != own[last]  # own sorted within a chord: two arcs or more
    clash = own[shared[group]]
    ends, two = np.cumsum(lens), np.flatnonzero(lens == 2)
    degenerate = two[flat[ends[two] - 2] == flat[ends[two] - 1]]
    return np.unique(np.concatenate([clash, degenerate]))
