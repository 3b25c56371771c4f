"""The steps of `surface_complex` (private; validated input assumed).

Each step reads the state built so far (`_Builder`: vertices and edges) and the
symmetric k-NN graph; the order is that of the module docstring of `_complex`:
vertices, arcs and their edges, parallel edges split, boundary cycles, checks.
"""

from __future__ import annotations

import numpy as np
from scipy import sparse
from scipy.sparse import csgraph

from ._surface import incidence_checks

_EDGE_EPS = 1e-12  # added to graph weights so exact duplicates stay edges for csgraph


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


def add_vertices(b: _Builder, big, padded, gr, gc, n: int, n_regions: int, n_cols: int):
    """Vertices: k-NN components of points with the same L(p), |L(p)| >= 3.

    A component is kept when no adjacent component sees a strict superset (Eq. 3.1
    applied locally); a small non-maximal one joins the superset's corner. Returns
    ``zone_vertex`` (N,) (the vertex of each point, -1 outside vertex zones) and
    ``vr_codes`` (sorted codes ``vertex * n_regions + region``).
    """
    graph = b.graph
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
                if comp_size[c] <= 2 * n_cols and parent[c] == c:
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
    return zone_vertex, vr_codes


def add_arcs(b: _Builder, lab, idx, counts, zone_vertex, vr_codes, gr, gc, n_regions: int):
    """Arcs and their edges: points seeing >= 2 regions outside vertex zones.

    Returns ``arc_regions_list``, ``arc_points_list`` and the ``dropped`` arcs.
    """
    graph = b.graph
    n = lab.shape[0]
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
    return arc_regions_list, arc_points_list, dropped


def split_parallel_edges(b: _Builder):
    """Edges (E, ER, EA) sorted, every group of parallel edges split at its midpoints."""
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
    return E, ER, EA


def boundary_cycles(E, ER, n_regions: int):
    """Closed walks per region: cycles, their edges and regions, open edges."""
    # boundary cycles per region
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
    return cycles, cycle_edges, cycle_region, open_edges, regions_open, region_cycles


def cycle_checks(n_v: int, E, cycles, cycle_edges):
    """Def 7 on the cycles as faces: edge counts, vertices without cycle or fan, not simple."""
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
    return edge_count, no_cycle, not_fan, not_simple
