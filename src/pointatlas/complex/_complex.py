"""The surface-like complex K' of a segmentation (thesis section 3, Eqs 3.1-3.2; GUIDE B1).

Construction (decisions logged in docs/decisions.md, "complex"):

* ``L(p)`` is the set of region labels among the k nearest neighbours of ``p`` (the
  point itself included, Remark 6); region i's *enlarged cloud* is {p : i in L(p)}.
* ``q_tuples`` are the inclusion-maximal sets among {L(p) : |L(p)| >= 3} (Eq. 3.1).
* Vertices of K' are kept apart in space: the points with |L(p)| >= 3 are split into
  connected components of the symmetric k-NN graph and each component is one vertex
  whose region set is the union of its points' L(p) (locally inclusion-maximal).
  Two corners with the same regions therefore stay two vertices.
* Arcs: points with exactly two regions in L(p) are grouped by their region pair and
  split into connected components in the k-NN graph (several arcs between the same
  pair stay apart). Each arc is partitioned among the vertices it touches by
  graph-geodesic Voronoi cells; two cells in contact give an abstract edge (one edge
  per separate contact). Arcs touching fewer than two vertices get vertices inserted
  at geodesically farthest points (a closed two-region boundary gets three); arcs
  that turn out to be open spurs are dropped and reported.
* Parallel edges (same two vertices) all get a vertex inserted at their midpoint, so
  the graph is simple, cycles have no chords and at least three vertices.
* Each region's boundary cycles are traced in the graph of its edges.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import sparse
from scipy.sparse import csgraph

from .._core import as_labels, as_points, readonly
from ..neighbors import query_knn
from ._surface import incidence_checks

__all__ = ["SurfaceComplex", "surface_complex"]

_EDGE_EPS = 1e-12  # added to graph weights so exact duplicates stay edges for csgraph


@dataclass(frozen=True, slots=True)
class SurfaceComplex:
    """The surface-like complex K' = V u E u F of a segmentation (Eq. 3.2).

    Attributes
    ----------
    n_points, n_regions, k : int
        Input size, number of regions (labels 0..R-1) and neighbourhood size.
    seen_indptr : ndarray of shape (N + 1,), int64
        CSR pointer into ``seen_regions``: ``L(p)`` of point p is
        ``seen_regions[seen_indptr[p]:seen_indptr[p + 1]]`` (sorted).
    seen_regions : ndarray of shape (M,), int64
        Concatenated region sets L(p) (Remark 6).
    q_tuples : tuple of tuple of int
        Eq. 3.1: the inclusion-maximal sets among {L(p) : |L(p)| >= 3}, sorted.
    vertex_regions : tuple of tuple of int
        Region set of every vertex (length >= 3; length 2 for inserted vertices).
    vertex_points : tuple of ndarray of int64
        Witness points of every vertex (its k-NN component; one point if inserted).
    vertex_anchor : ndarray of shape (V, 3), float64
        Mean of each vertex's witness points.
    vertex_is_inserted : ndarray of shape (V,), bool
        True for vertices inserted on two-region boundaries.
    edges : ndarray of shape (E, 2), int64
        Abstract edges as vertex pairs (smaller id first).
    edge_regions : ndarray of shape (E, 2), int64
        The two regions each edge separates (smaller first).
    edge_arc : ndarray of shape (E,), int64
        The arc (boundary component of a region pair) each edge lies on.
    arc_regions : ndarray of shape (A, 2), int64
        Region pair of every arc.
    arc_points : tuple of ndarray of int64
        Points of every arc (points whose L(p) is exactly that pair).
    dropped_arcs : ndarray of int64
        Arcs that are open spurs (touching fewer than two vertices, not closed).
    cycles : tuple of ndarray of int64
        Boundary cycles (vertex ids in traversal order, orientation not fixed).
    cycle_edges : tuple of ndarray of int64
        Edge ids of every cycle, ``cycle_edges[c][t]`` joins vertices t and t+1.
    cycle_region : ndarray of shape (C,), int64
        Region each cycle bounds.
    region_cycles : tuple of tuple of int
        Cycle ids per region (several for a region with holes).
    open_edges : ndarray of int64
        Edges of region boundaries that could not be closed into cycles.
    regions_open : ndarray of int64
        Regions whose boundary has edges outside every closed cycle.
    vertices_without_cycle : ndarray of int64
        Conjecture 3 i): vertices in no boundary cycle.
    edges_in_many_cycles : ndarray of int64
        Conjecture 3 ii): edges in more than two cycles.
    vertices_not_fan : ndarray of int64
        Conjecture 3 iii): vertices whose cycles cannot be arranged in a sequence
        where consecutive cycles share an edge at that vertex.
    edges_not_in_two_cycles : ndarray of int64
        Conjecture 4: edges not in exactly two cycles.
    regions_not_one_cycle : ndarray of int64
        Conjecture 4: regions not bounded by exactly one cycle.
    vertices_not_triple : ndarray of int64
        Conjecture 4: vertices whose region set does not have exactly 3 regions.
    cycles_not_simple : ndarray of int64
        Cycles whose vertices repeat or whose induced subgraph is not a cycle
        (section 3 requires an induced cycle of at least 3 vertices).
    """

    n_points: int
    n_regions: int
    k: int
    seen_indptr: np.ndarray
    seen_regions: np.ndarray
    q_tuples: tuple
    vertex_regions: tuple
    vertex_points: tuple
    vertex_anchor: np.ndarray
    vertex_is_inserted: np.ndarray
    edges: np.ndarray
    edge_regions: np.ndarray
    edge_arc: np.ndarray
    arc_regions: np.ndarray
    arc_points: tuple
    dropped_arcs: np.ndarray
    cycles: tuple
    cycle_edges: tuple
    cycle_region: np.ndarray
    region_cycles: tuple
    open_edges: np.ndarray
    regions_open: np.ndarray
    vertices_without_cycle: np.ndarray
    edges_in_many_cycles: np.ndarray
    vertices_not_fan: np.ndarray
    edges_not_in_two_cycles: np.ndarray
    regions_not_one_cycle: np.ndarray
    vertices_not_triple: np.ndarray
    cycles_not_simple: np.ndarray

    def __post_init__(self):
        for name in (
            "seen_indptr",
            "seen_regions",
            "vertex_anchor",
            "vertex_is_inserted",
            "edges",
            "edge_regions",
            "edge_arc",
            "arc_regions",
            "dropped_arcs",
            "cycle_region",
            "open_edges",
            "regions_open",
            "vertices_without_cycle",
            "edges_in_many_cycles",
            "vertices_not_fan",
            "edges_not_in_two_cycles",
            "regions_not_one_cycle",
            "vertices_not_triple",
            "cycles_not_simple",
        ):
            readonly(getattr(self, name))
        for name in ("vertex_points", "arc_points", "cycles", "cycle_edges"):
            for arr in getattr(self, name):
                readonly(arr)

    @property
    def n_vertices(self) -> int:
        """Number of abstract vertices (q-tuple vertices plus inserted ones)."""
        return len(self.vertex_regions)

    @property
    def n_edges(self) -> int:
        """Number of abstract edges."""
        return int(self.edges.shape[0])

    @property
    def n_cycles(self) -> int:
        """Number of boundary cycles."""
        return len(self.cycles)

    @property
    def is_surface_like(self) -> bool:
        """Conjecture 3 i)-iii) hold (and every cycle is a simple induced cycle)."""
        return (
            self.vertices_without_cycle.size == 0
            and self.edges_in_many_cycles.size == 0
            and self.vertices_not_fan.size == 0
            and self.cycles_not_simple.size == 0
        )

    @property
    def is_dual_to_cloud_surface(self) -> bool:
        """The duality conditions of Conjecture 4 hold."""
        return (
            self.edges_not_in_two_cycles.size == 0
            and self.regions_not_one_cycle.size == 0
            and self.vertices_not_triple.size == 0
        )

    def seen(self, point: int) -> np.ndarray:
        """Region set L(p) of one point (sorted int64 array)."""
        return self.seen_regions[self.seen_indptr[point] : self.seen_indptr[point + 1]]

    def summary(self) -> dict:
        """A JSON-friendly report of sizes and of the Conjecture 3/4 conditions."""

        def ids(arr):
            return [int(x) for x in arr]

        return {
            "n_regions": self.n_regions,
            "n_vertices": self.n_vertices,
            "n_inserted_vertices": int(self.vertex_is_inserted.sum()),
            "n_edges": self.n_edges,
            "n_arcs": int(self.arc_regions.shape[0]),
            "n_cycles": self.n_cycles,
            "n_q_tuples": len(self.q_tuples),
            "q_tuple_sizes": sorted({len(t) for t in self.q_tuples}),
            "dropped_arcs": ids(self.dropped_arcs),
            "open_edges": ids(self.open_edges),
            "regions_open": ids(self.regions_open),
            "conjecture3": {
                "holds": self.is_surface_like,
                "vertices_without_cycle": ids(self.vertices_without_cycle),
                "edges_in_many_cycles": ids(self.edges_in_many_cycles),
                "vertices_not_fan": ids(self.vertices_not_fan),
                "cycles_not_simple": ids(self.cycles_not_simple),
            },
            "conjecture4": {
                "holds": self.is_dual_to_cloud_surface,
                "edges_not_in_two_cycles": ids(self.edges_not_in_two_cycles),
                "regions_not_one_cycle": ids(self.regions_not_one_cycle),
                "vertices_not_triple": ids(self.vertices_not_triple),
            },
        }


# ----------------------------------------------------------------------------------
# helpers (validated input assumed)


def _region_sets(labels: np.ndarray, indices: np.ndarray):
    """Sorted distinct labels per row: (indptr, regions, counts, padded rows)."""
    s = np.sort(labels[indices], axis=1)
    new = np.ones(s.shape, dtype=bool)
    new[:, 1:] = s[:, 1:] != s[:, :-1]
    counts = new.sum(axis=1).astype(np.int64)
    indptr = np.zeros(s.shape[0] + 1, dtype=np.int64)
    np.cumsum(counts, out=indptr[1:])
    regions = s[new].astype(np.int64)
    padded = np.where(new, s, -1)
    padded = -np.sort(-padded, axis=1)  # distinct labels first (descending), -1 last
    return indptr, regions, counts, padded


def _maximal_sets(sets: list[frozenset]) -> tuple:
    """Inclusion-maximal members of a list of sets (Eq. 3.1), sorted."""
    uniq = sorted(set(sets), key=lambda s: (-len(s), sorted(s)))
    out: list[frozenset] = []
    for s in uniq:
        if not any(s <= t for t in out):
            out.append(s)
    return tuple(sorted(tuple(sorted(int(x) for x in s)) for s in out))


def _sym_graph(points: np.ndarray, indices: np.ndarray) -> sparse.csr_array:
    """Symmetric k-NN graph with distances (+ a tiny epsilon so duplicates stay edges)."""
    n, k = indices.shape
    rows = np.repeat(np.arange(n, dtype=np.int64), k - 1)
    cols = indices[:, 1:].ravel()
    keep = rows != cols
    a = sparse.csr_array((np.ones(int(keep.sum())), (rows[keep], cols[keep])), shape=(n, n))
    a = (a + a.T).tocsr()
    a.sum_duplicates()
    a.sort_indices()
    r = np.repeat(np.arange(n, dtype=np.int64), np.diff(a.indptr))
    c = a.indices.astype(np.int64)
    d = np.linalg.norm(points[r] - points[c], axis=1) + _EDGE_EPS
    return sparse.csr_array((d, c, a.indptr.copy()), shape=(n, n))


def _components_on(graph: sparse.csr_array, mask_edges: np.ndarray, n: int):
    coo = graph.tocoo()
    r, c = coo.row[mask_edges], coo.col[mask_edges]
    sub = sparse.csr_array((np.ones(r.size), (r, c)), shape=(n, n))
    return csgraph.connected_components(sub, directed=False)[1].astype(np.int64)


def _relabel_by_first(comp: np.ndarray, members: np.ndarray) -> np.ndarray:
    """Renumber component ids of ``members`` 0.. in order of their smallest point."""
    c = comp[members]
    _, first = np.unique(c, return_index=True)
    order = np.argsort(members[first], kind="stable")
    uniq = c[first][order]
    lut = {int(u): i for i, u in enumerate(uniq)}
    return np.array([lut[int(x)] for x in c], dtype=np.int64)


class _Builder:
    """Mutable state while building the vertex/edge structure (private)."""

    def __init__(self, points, graph):
        self.points = points
        self.graph = graph
        self.vregions: list[tuple] = []
        self.vpoints: list[np.ndarray] = []
        self.vinserted: list[bool] = []
        # edges: [u, v, lo, hi, arc, mid_point]
        self.edges: list[list[int]] = []

    def add_vertex(self, regions, pts, inserted):
        self.vregions.append(tuple(int(r) for r in regions))
        self.vpoints.append(np.asarray(pts, dtype=np.int64))
        self.vinserted.append(bool(inserted))
        return len(self.vregions) - 1


def _process_arc(b: _Builder, arc_id, pair, arc_pts, endpoint_src):
    """Split one arc among its vertices; append edges to ``b``. Returns False if spur.

    ``endpoint_src`` maps vertex id -> its witness points adjacent to the arc.
    """
    lo, hi = pair
    src_pts = (
        np.concatenate([endpoint_src[v] for v in sorted(endpoint_src)])
        if endpoint_src
        else np.zeros(0, np.int64)
    )
    src_vert = (
        np.concatenate([np.full(endpoint_src[v].size, v) for v in sorted(endpoint_src)])
        if endpoint_src
        else np.zeros(0, np.int64)
    )
    nodes = np.concatenate([arc_pts, src_pts])
    n_arc = arc_pts.size
    sub = b.graph[nodes][:, nodes]
    node_vertex = np.full(nodes.size, -1, dtype=np.int64)
    node_vertex[n_arc:] = src_vert
    sources = list(range(n_arc, nodes.size))
    n_vert = len(endpoint_src)
    inserted_here = []
    # too few vertices on this arc: insert at geodesically farthest points
    while n_vert < 2:
        if n_arc < 3:
            return False
        start = sources if sources else [0]
        dist = csgraph.dijkstra(sub, directed=False, indices=start, min_only=True)
        dist_arc = np.where(np.isfinite(dist[:n_arc]), dist[:n_arc], -1.0)
        far = int(np.argmax(dist_arc))
        if not sources:
            # a closed boundary without vertices: restart from the far point
            sources = [far]
            dist = csgraph.dijkstra(sub, directed=False, indices=sources, min_only=True)
            dist_arc = np.where(np.isfinite(dist[:n_arc]), dist[:n_arc], -1.0)
            far = int(np.argmax(dist_arc))
            v0 = b.add_vertex(pair, [arc_pts[sources[0]]], True)
            node_vertex[sources[0]] = v0
            inserted_here.append(v0)
            n_vert = 1
        if far in sources or dist_arc[far] <= 0:
            return _undo(b, inserted_here)
        v = b.add_vertex(pair, [arc_pts[far]], True)
        node_vertex[far] = v
        inserted_here.append(v)
        sources.append(far)
        n_vert += 1
    dist, _, src = csgraph.dijkstra(
        sub, directed=False, indices=sources, min_only=True, return_predecessors=True
    )
    reach = src >= 0
    cell = np.full(nodes.size, -1, dtype=np.int64)
    cell[reach] = node_vertex[src[reach]]
    coo = sub.tocoo()
    r, c = coo.row, coo.col
    cross = (cell[r] >= 0) & (cell[c] >= 0) & (cell[r] != cell[c]) & (r < c)
    contacts = []
    if cross.any():
        ca, cb = cell[r[cross]], cell[c[cross]]
        pa, pb = np.minimum(ca, cb), np.maximum(ca, cb)
        rr, cc = r[cross], c[cross]
        for key in np.unique(np.stack([pa, pb], axis=1), axis=0):
            sel = (pa == key[0]) & (pb == key[1])
            touched = np.unique(np.concatenate([rr[sel], cc[sel]]))
            # one ring inside the two cells bridges gaps in a ragged contact zone
            ring_mask = np.zeros(nodes.size, dtype=bool)
            ring_mask[touched] = True
            near = np.isin(cell, key)
            ring = (ring_mask[r] | ring_mask[c]) & near[r] & near[c]
            zone = np.zeros(nodes.size, dtype=bool)
            zone[r[ring]] = True
            zone[c[ring]] = True
            keep_e = zone[r] & zone[c]
            zsub = sparse.csr_array(
                (np.ones(int(keep_e.sum())), (r[keep_e], c[keep_e])), shape=sub.shape
            )
            comp = csgraph.connected_components(zsub, directed=False)[1]
            comp_t = comp[touched]
            for cid in np.unique(comp_t):
                members = touched[comp_t == cid]
                members_arc = members[members < n_arc]
                pick = members_arc if members_arc.size else members
                mid = pick[int(np.argmax(dist[pick]))]
                contacts.append((int(key[0]), int(key[1]), int(nodes[mid])))
    if len(inserted_here) and len(contacts) < 2:
        # an open spur or open segment, not a loop: drop it
        return _undo(b, inserted_here)
    for u, v, mid in contacts:
        b.edges.append([u, v, lo, hi, arc_id, mid])
    return True


def _undo(b: _Builder, inserted):
    for _ in inserted:
        b.vregions.pop()
        b.vpoints.pop()
        b.vinserted.pop()
    return False


def _trace_region(edges_of_region, edges):
    """Trace closed walks in one region's edge graph. Returns (cycles, open_edges)."""
    adj: dict[int, list[int]] = {}
    for e in edges_of_region:
        u, v = int(edges[e, 0]), int(edges[e, 1])
        adj.setdefault(u, []).append(e)
        adj.setdefault(v, []).append(e)
    for lst in adj.values():
        lst.sort()
    used: set[int] = set()
    cycles, open_edges = [], []
    for e0 in sorted(edges_of_region):
        if e0 in used:
            continue
        start = int(edges[e0, 0])
        verts, path = [start], [e0]
        used.add(e0)
        cur = int(edges[e0, 1])
        closed = False
        while True:
            if cur == start:
                closed = True
                break
            nxt = [e for e in adj[cur] if e not in used]
            if not nxt:
                break
            e = nxt[0]
            used.add(e)
            verts.append(cur)
            path.append(e)
            cur = int(edges[e, 1]) if int(edges[e, 0]) == cur else int(edges[e, 0])
        if closed:
            cycles.append((np.array(verts, dtype=np.int64), np.array(path, dtype=np.int64)))
        else:
            open_edges.extend(path)
    return cycles, open_edges


def surface_complex(points, labels, *, k: int = 8, indices=None) -> SurfaceComplex:
    """Build the surface-like complex K' of a segmentation (thesis section 3).

    Parameters
    ----------
    points : array_like of shape (N, 3), float64
        Coordinates.
    labels : array_like of shape (N,), int64
        Region of every point, 0..R-1 (every point assigned).
    k : int
        Neighbourhood size including the point itself (Remark 6; thesis uses 8).
    indices : ndarray of shape (N, k), int64, optional
        Precomputed `pointatlas.neighbors.query_knn` indices.

    Returns
    -------
    complex : SurfaceComplex
        q-tuples, vertices, edges, arcs, boundary cycles per region and the
        conditions of Conjectures 3 and 4 with the offending elements.

    Raises
    ------
    ValueError
        Bad shapes, non-finite points, negative labels, bad ``indices``.
    PointAtlasError
        ``k`` larger than the number of points.

    Notes
    -----
    Eq. 3.1 gives ``q_tuples``; Eq. 3.2 gives K' = V u E u F. The GUIDE (B1) fixes
    the edge rule (shared region pairs on a common boundary arc, not any shared
    index) and asks for several arcs between the same pair to stay apart. Vertices
    are the connected k-NN components of points seeing >= 3 regions; vertices are
    inserted on boundaries with fewer than three vertices per cycle (see module
    docstring and docs/decisions.md).

    Examples
    --------
    >>> from pointatlas.synth import cube
    >>> m = cube(6)
    >>> K = surface_complex(m.vertices, m.labels, k=8)
    >>> K.n_vertices, K.n_edges, K.n_cycles, K.is_dual_to_cloud_surface
    (8, 12, 6, True)
    """
    pts = as_points(points, min_points=1)
    n = pts.shape[0]
    lab = as_labels(labels, n)
    if (lab < 0).any():
        raise ValueError(
            f"labels must be >= 0 (every point in a region); "
            f"{int((lab < 0).sum())} points are unassigned"
        )
    if indices is None:
        idx, _ = query_knn(pts, k)
    else:
        idx = np.asarray(indices)
        if idx.ndim != 2 or idx.shape != (n, k):
            raise ValueError(f"indices must have shape ({n}, {k}); got {idx.shape}")
        if idx.dtype.kind not in "iu" or idx.size and (idx.min() < 0 or idx.max() >= n):
            raise ValueError(f"indices must be integers in [0, {n}); got out-of-range values")
        idx = idx.astype(np.int64)
    n_regions = int(lab.max()) + 1
    seen_indptr, seen_regions, counts, padded = _region_sets(lab, idx)

    # Eq. 3.1 (global inclusion-maximal sets)
    big = np.flatnonzero(counts >= 3)
    rows = np.unique(padded[big], axis=0) if big.size else np.zeros((0, idx.shape[1]))
    q_tuples = _maximal_sets([frozenset(int(x) for x in r if x >= 0) for r in rows])

    graph = _sym_graph(pts, idx)
    coo = graph.tocoo()
    gr, gc = coo.row.astype(np.int64), coo.col.astype(np.int64)

    b = _Builder(pts, graph)
    # vertices: k-NN components of points with the same L(p), |L(p)| >= 3, kept when
    # no adjacent component sees a strict superset (Eq. 3.1 applied locally)
    zone_vertex = np.full(n, -1, dtype=np.int64)
    vr_codes = np.zeros(0, dtype=np.int64)
    if big.size:
        set_rows, set_id_big = np.unique(padded[big], axis=0, return_inverse=True)
        set_id = np.full(n, -1, dtype=np.int64)
        set_id[big] = set_id_big.reshape(-1)
        zone = set_id >= 0
        comp = _components_on(graph, zone[gr] & zone[gc] & (set_id[gr] == set_id[gc]), n)
        comp_id = np.full(n, -1, dtype=np.int64)
        comp_id[big] = _relabel_by_first(comp, big)
        n_comp = int(comp_id.max()) + 1
        comp_set_id = np.zeros(n_comp, dtype=np.int64)
        comp_set_id[comp_id[big]] = set_id[big]
        sets = [frozenset(int(x) for x in row if x >= 0) for row in set_rows]
        cross = zone[gr] & zone[gc] & (comp_id[gr] != comp_id[gc])
        pairs = np.unique(np.stack([comp_id[gr[cross]], comp_id[gc[cross]]], 1), axis=0)
        keep = np.ones(n_comp, dtype=bool)
        parent = np.arange(n_comp)
        comp_size = np.bincount(comp_id[big], minlength=n_comp)
        for c, d in pairs.tolist():
            if sets[comp_set_id[c]] < sets[comp_set_id[d]]:
                keep[c] = False
                # a small non-maximal piece is part of the superset's corner; a long
                # one (a thin region seen across) is left to the arcs
                if comp_size[c] <= 2 * idx.shape[1] and parent[c] == c:
                    parent[c] = d
        root = np.arange(n_comp)
        for c in range(n_comp):
            r, steps = c, 0
            while parent[r] != r and steps < n_comp:
                r, steps = parent[r], steps + 1
            root[c] = r
        new_id = np.full(n_comp, -1, dtype=np.int64)
        new_id[keep] = np.arange(int(keep.sum()))
        zone_vertex[big] = new_id[root[comp_id[big]]]
        in_vertex = np.flatnonzero(zone_vertex >= 0)
        order = np.argsort(zone_vertex[in_vertex], kind="stable")
        members = np.split(in_vertex[order], np.cumsum(np.bincount(zone_vertex[in_vertex]))[:-1])
        codes = []
        for v, c in enumerate(np.flatnonzero(keep)):
            regs = sorted(sets[comp_set_id[c]])
            b.add_vertex(regs, members[v], False)
            codes.extend(v * n_regions + r for r in regs)
        vr_codes = np.unique(np.asarray(codes, dtype=np.int64))

    # arcs: points seeing >= 2 regions outside vertex zones, keyed by their own region
    # and the nearest other region among their neighbours (a contact pair), split into
    # k-NN components per pair
    foreign = lab[idx] != lab[:, None]
    nearest_foreign = lab[idx[np.arange(n), np.argmax(foreign, axis=1)]]
    two = (counts >= 2) & (zone_vertex < 0)
    lo_all = np.where(two, np.minimum(lab, nearest_foreign), -1)
    hi_all = np.where(two, np.maximum(lab, nearest_foreign), -1)
    pair_code = np.where(two, lo_all * n_regions + hi_all, -1)
    arc_idx = np.flatnonzero(two)
    arc_regions_list, arc_points_list, dropped = [], [], []
    if arc_idx.size:
        same = two[gr] & two[gc] & (pair_code[gr] == pair_code[gc])
        comp = _components_on(graph, same, n)
        arc_of = np.full(n, -1, dtype=np.int64)
        arc_of[arc_idx] = _relabel_by_first(comp, arc_idx)
        n_arcs = int(arc_of.max()) + 1
        order = np.argsort(arc_of[arc_idx], kind="stable")
        arc_members = np.split(arc_idx[order], np.cumsum(np.bincount(arc_of[arc_idx]))[:-1])
        # arc point -> adjacent zone point whose vertex contains the arc's pair
        touch = two[gr] & (zone_vertex[gc] >= 0)
        tr, tc = gr[touch], gc[touch]
        tv = zone_vertex[tc]
        ok = np.isin(tv * n_regions + lo_all[tr], vr_codes) & np.isin(
            tv * n_regions + hi_all[tr], vr_codes
        )
        tr, tc, tv = tr[ok], tc[ok], tv[ok]
        ta = arc_of[tr]
        order_t = np.lexsort((tc, tv, ta))
        ta, tv, tc = ta[order_t], tv[order_t], tc[order_t]
        bounds = np.searchsorted(ta, np.arange(n_arcs + 1))
        for a in range(n_arcs):
            pts_a = arc_members[a]
            pair = (int(lo_all[pts_a[0]]), int(hi_all[pts_a[0]]))
            arc_regions_list.append(pair)
            arc_points_list.append(pts_a)
            s, e = bounds[a], bounds[a + 1]
            src = {}
            for v in np.unique(tv[s:e]):
                src[int(v)] = np.unique(tc[s:e][tv[s:e] == v])
            if not _process_arc(b, a, pair, pts_a, src):
                dropped.append(a)

    # parallel edges: insert a vertex into every edge of a group, so the graph is
    # simple and no cycle has a chord (section 3 asks for induced cycles)
    edges_final = []
    groups: dict[tuple, list] = {}
    for ed in b.edges:
        groups.setdefault((min(ed[0], ed[1]), max(ed[0], ed[1])), []).append(ed)
    for key in sorted(groups):
        grp = groups[key]
        if len(grp) == 1:
            edges_final.append(grp[0])
            continue
        for ed in grp:
            u, v, lo, hi, arc, mid = ed
            m = b.add_vertex((lo, hi), [mid], True)
            edges_final.append([u, m, lo, hi, arc, mid])
            edges_final.append([m, v, lo, hi, arc, mid])
    if edges_final:
        E = np.array([[min(e[0], e[1]), max(e[0], e[1])] for e in edges_final], dtype=np.int64)
        ER = np.array([[e[2], e[3]] for e in edges_final], dtype=np.int64)
        EA = np.array([e[4] for e in edges_final], dtype=np.int64)
        order = np.lexsort((E[:, 1], E[:, 0]))
        E, ER, EA = E[order], ER[order], EA[order]
    else:
        E = np.zeros((0, 2), np.int64)
        ER = np.zeros((0, 2), np.int64)
        EA = np.zeros(0, np.int64)

    # boundary cycles per region
    n_v = len(b.vregions)
    cycles, cycle_edges, cycle_region, open_edges, regions_open = [], [], [], [], []
    region_cycles: list[list[int]] = [[] for _ in range(n_regions)]
    for i in range(n_regions):
        eid = np.flatnonzero((ER[:, 0] == i) | (ER[:, 1] == i)).tolist()
        if not eid:
            continue
        cyc, opn = _trace_region(eid, E)
        for verts, path in cyc:
            region_cycles[i].append(len(cycles))
            cycles.append(verts)
            cycle_edges.append(path)
            cycle_region.append(i)
        open_edges.extend(opn)
        if opn:
            regions_open.append(i)

    # conditions of Conjectures 3 and 4: the simplicial-surface checks of Def 7 on the
    # cycles as faces (shared with the cloud complex, ._surface)
    he_face = np.concatenate(
        [np.full(p.size, c, dtype=np.int64) for c, p in enumerate(cycle_edges)]
        or [np.zeros(0, np.int64)]
    )
    he_edge = np.concatenate(cycle_edges or [np.zeros(0, np.int64)]).astype(np.int64)
    edge_count, no_cycle, not_fan = incidence_checks(n_v, E, he_face, he_edge)
    edge_set = {(int(u), int(v)) for u, v in E}
    not_simple = []
    for c, verts in enumerate(cycles):
        vs = set(verts.tolist())
        induced = sum(1 for u, v in edge_set if u in vs and v in vs)
        if len(vs) != verts.size or verts.size < 3 or induced != verts.size:
            not_simple.append(c)
    n_cyc_region = np.array([len(rc) for rc in region_cycles], dtype=np.int64)

    vpoints = [np.asarray(p, dtype=np.int64) for p in b.vpoints]
    anchor = np.array([pts[p].mean(axis=0) for p in vpoints]) if vpoints else np.zeros((0, 3))
    arr = np.asarray
    return SurfaceComplex(
        n_points=n,
        n_regions=n_regions,
        k=int(idx.shape[1]),
        seen_indptr=seen_indptr,
        seen_regions=seen_regions,
        q_tuples=q_tuples,
        vertex_regions=tuple(b.vregions),
        vertex_points=tuple(vpoints),
        vertex_anchor=anchor,
        vertex_is_inserted=arr(b.vinserted, dtype=bool).reshape(-1),
        edges=E,
        edge_regions=ER,
        edge_arc=EA,
        arc_regions=arr(arc_regions_list, dtype=np.int64).reshape(-1, 2),
        arc_points=tuple(arc_points_list),
        dropped_arcs=arr(dropped, dtype=np.int64),
        cycles=tuple(cycles),
        cycle_edges=tuple(cycle_edges),
        cycle_region=arr(cycle_region, dtype=np.int64),
        region_cycles=tuple(tuple(rc) for rc in region_cycles),
        open_edges=np.unique(arr(open_edges, dtype=np.int64)),
        regions_open=arr(regions_open, dtype=np.int64),
        vertices_without_cycle=no_cycle,
        edges_in_many_cycles=np.flatnonzero(edge_count > 2),
        vertices_not_fan=not_fan,
        edges_not_in_two_cycles=np.flatnonzero(edge_count != 2),
        regions_not_one_cycle=np.flatnonzero(n_cyc_region != 1),
        vertices_not_triple=arr([v for v in range(n_v) if len(b.vregions[v]) != 3], dtype=np.int64),
        cycles_not_simple=arr(not_simple, dtype=np.int64),
    )
