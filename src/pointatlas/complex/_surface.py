"""Simplicial-surface checks (Defs 7, 8, 13, 14) and the topology report.

One set of checks serves both complexes of the package: the cloud complex of
Chapter A (faces are triangles) and the surface-like complex K' of Chapter B (faces
are boundary cycles, i.e. polygons). Both are described by *half-edges*: one row per
side of a face, ``(face, edge, from, to)``. Everything here assumes validated input
(vertex ids in [0, V), edges sorted pairs, half-edge endpoints equal to the edge's).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from scipy import sparse
from scipy.sparse import csgraph

from .._core import readonly
from .._core.tolerances import FAN_EXACT_MAX

__all__ = ["SurfaceReport", "has_hamiltonian_path", "incidence_checks", "surface_report_core"]


def has_hamiltonian_path(n: int, adj: list[set]) -> bool:
    """Whether the small graph ``adj`` (n nodes) has a path visiting every node once."""
    if n <= 1:
        return True
    if n > FAN_EXACT_MAX:  # fall back to the fan criterion: connected, degrees <= 2
        seen, stack = {0}, [0]
        while stack:
            x = stack.pop()
            for y in adj[x]:
                if y not in seen:
                    seen.add(y)
                    stack.append(y)
        return len(seen) == n and all(len(a) <= 2 for a in adj)

    def dfs(x, visited):
        if len(visited) == n:
            return True
        for y in adj[x]:
            if y not in visited:
                visited.add(y)
                if dfs(y, visited):
                    return True
                visited.remove(y)
        return False

    return any(dfs(s, {s}) for s in range(n))


def _pair_groups(keys: np.ndarray, members: np.ndarray):
    """All unordered pairs of distinct ``members`` that share a key.

    Returns (a, b, key) arrays; groups of two (the usual case) are vectorised,
    larger groups enumerated.
    """
    if keys.size == 0:
        z = np.zeros(0, np.int64)
        return z, z, z
    order = np.lexsort((members, keys))
    k, m = keys[order], members[order]
    starts = np.flatnonzero(np.r_[True, k[1:] != k[:-1]])
    sizes = np.diff(np.r_[starts, k.size])
    two = starts[sizes == 2]
    a, b, kk = [m[two]], [m[two + 1]], [k[two]]
    for s, size in zip(starts[sizes > 2].tolist(), sizes[sizes > 2].tolist(), strict=True):
        grp = m[s : s + size]
        ii, jj = np.triu_indices(size, 1)
        a.append(grp[ii])
        b.append(grp[jj])
        kk.append(np.full(ii.size, k[s]))
    a, b, kk = np.concatenate(a), np.concatenate(b), np.concatenate(kk)
    keep = a != b
    return a[keep], b[keep], kk[keep]


def incidence_checks(n_vertices: int, edges: np.ndarray, he_face: np.ndarray, he_edge: np.ndarray):
    """Def 7 i)-iii) on faces given by the edges they use.

    Parameters
    ----------
    n_vertices : int
        Number of vertices V.
    edges : ndarray of shape (E, 2), int64
        Edges as vertex pairs.
    he_face, he_edge : ndarray of shape (H,), int64
        One row per use of an edge by a face (a half-edge).

    Returns
    -------
    edge_face_count : ndarray of shape (E,), int64
        Number of face sides on every edge.
    vertices_without_face : ndarray of int64
        Def 7 i): vertices in no face.
    vertices_not_fan : ndarray of int64
        Def 7 iii): vertices whose faces cannot be arranged in a sequence in which
        consecutive faces share an edge at that vertex.
    """
    n_edges = int(edges.shape[0])
    edge_face_count = np.bincount(he_edge, minlength=n_edges).astype(np.int64)
    n_faces = int(he_face.max()) + 1 if he_face.size else 0
    # incidences (vertex, edge, face): both endpoints of every edge use
    v_inc = np.concatenate([edges[he_edge, 0], edges[he_edge, 1]])
    e_inc = np.concatenate([he_edge, he_edge])
    f_inc = np.concatenate([he_face, he_face])
    has_face = np.zeros(n_vertices, dtype=bool)
    has_face[v_inc] = True
    if v_inc.size == 0:
        return edge_face_count, np.flatnonzero(~has_face), np.zeros(0, np.int64)
    node_keys, node_id = np.unique(v_inc * n_faces + f_inc, return_inverse=True)
    node_id = node_id.reshape(-1)
    node_v = node_keys // n_faces
    n_nodes = node_keys.size
    # two faces at v are adjacent when they share an edge at v
    a, b, _ = _pair_groups(v_inc * n_edges + e_inc, node_id)
    pairs = np.unique(np.stack([np.minimum(a, b), np.maximum(a, b)], axis=1), axis=0)
    graph = sparse.csr_array(
        (np.ones(pairs.shape[0]), (pairs[:, 0], pairs[:, 1])), shape=(n_nodes, n_nodes)
    )
    comp = csgraph.connected_components(graph, directed=False)[1]
    n_comp = np.bincount(np.unique(node_v * n_nodes + comp) // n_nodes, minlength=n_vertices)
    degree = np.bincount(pairs.ravel(), minlength=n_nodes)
    max_deg = np.zeros(n_vertices, dtype=np.int64)
    np.maximum.at(max_deg, node_v, degree)
    not_fan = n_comp > 1
    # an edge in three or more faces at v: decide the sequence exactly
    for v in np.flatnonzero((n_comp == 1) & (max_deg > 2)).tolist():
        nodes = np.flatnonzero(node_v == v)
        local = {int(x): i for i, x in enumerate(nodes)}
        sel = np.isin(pairs[:, 0], nodes)
        adj: list[set] = [set() for _ in nodes]
        for x, y in pairs[sel].tolist():
            adj[local[x]].add(local[y])
            adj[local[y]].add(local[x])
        if not has_hamiltonian_path(len(nodes), adj):
            not_fan[v] = True
    return edge_face_count, np.flatnonzero(~has_face), np.flatnonzero(not_fan)


def _orientation(n_faces: int, he_face, he_edge, he_from, he_to):
    """Def 14: propagate a coherent orientation; returns (orientable, flip, incoherent).

    Faces sharing an edge are coherent when they run through it in opposite
    directions (Def 13). A spanning forest of the face adjacency graph fixes the flips
    (root faces keep theirs, smaller id first); every remaining adjacency is then
    checked. ``incoherent`` lists the face pairs (F_i, F_j) that stay incoherent.
    """
    flip = np.zeros(n_faces, dtype=bool)
    same_dir = he_from < he_to
    a, b, e = _pair_groups(he_edge, np.arange(he_edge.size))
    fa, fb = he_face[a], he_face[b]
    need = (same_dir[a] == same_dir[b]).astype(np.int8)  # 1: one of them must flip
    keep = fa != fb
    fa, fb, need = fa[keep], fb[keep], need[keep]
    if fa.size == 0:
        return True, flip, np.zeros((0, 2), np.int64)
    lo, hi = np.minimum(fa, fb), np.maximum(fa, fb)
    # a virtual root (id n_faces) joined to the first face of every component makes
    # one BFS tree per component
    adj = sparse.csr_array((np.ones(lo.size), (lo, hi)), shape=(n_faces, n_faces))
    comp = csgraph.connected_components(adj, directed=False)[1]
    _, firsts = np.unique(comp, return_index=True)
    root = n_faces
    rows = np.concatenate([lo, hi, np.full(firsts.size, root)])
    cols = np.concatenate([hi, lo, firsts])
    g = sparse.csr_array((np.ones(rows.size), (rows, cols)), shape=(n_faces + 1, n_faces + 1))
    _, pred = csgraph.breadth_first_order(g, root, directed=True, return_predecessors=True)
    pred = pred[:n_faces].astype(np.int64)
    # parity of each tree edge (pred -> face); faces hanging on the root get 0
    key = lo * (n_faces + 1) + hi
    order = np.argsort(key, kind="stable")
    key_s, need_s = key[order], need[order]
    is_top = pred == root
    p = np.where(is_top, 0, pred)
    f = np.arange(n_faces)
    tkey = np.minimum(p, f) * (n_faces + 1) + np.maximum(p, f)
    pos = np.clip(np.searchsorted(key_s, tkey), 0, max(key_s.size - 1, 0))
    acc = np.where(is_top, 0, need_s[pos]).astype(np.int8)
    anc = np.where(is_top, f, pred)
    while True:  # pointer jumping: parity from every face to its tree's top face
        nxt = anc[anc]
        acc = acc ^ acc[anc]
        if np.array_equal(nxt, anc):
            break
        anc = nxt
    flip = acc.astype(bool)
    bad = (flip[fa] ^ flip[fb]) != need.astype(bool)
    incoherent = np.unique(np.stack([lo[bad], hi[bad]], axis=1), axis=0)
    return not bad.any(), flip, incoherent.astype(np.int64)


def _boundary_loops(n_vertices: int, boundary: np.ndarray):
    """Connected components of the boundary edges; each traced in order when it is a cycle."""
    if boundary.shape[0] == 0:
        return ()
    g = sparse.csr_array(
        (np.ones(boundary.shape[0]), (boundary[:, 0], boundary[:, 1])),
        shape=(n_vertices, n_vertices),
    )
    g = (g + g.T).tocsr()
    comp = csgraph.connected_components(g, directed=False)[1]
    verts = np.unique(boundary)
    loops = []
    deg = np.diff(g.indptr)
    for c in np.unique(comp[verts]).tolist():
        members = verts[comp[verts] == c]
        if (deg[members] == 2).all():
            start = int(members.min())
            seq, prev, cur = [start], -1, start
            while True:
                nb = g.indices[g.indptr[cur] : g.indptr[cur + 1]]
                nxt = int(nb[0]) if int(nb[0]) != prev else int(nb[1])
                if nxt == start:
                    break
                seq.append(nxt)
                prev, cur = cur, nxt
            loops.append(np.asarray(seq, dtype=np.int64))
        else:
            loops.append(members.astype(np.int64))
    loops.sort(key=lambda arr: int(arr.min()))
    return tuple(loops)


@dataclass(frozen=True, slots=True)
class SurfaceReport:
    """Simplicial-surface conditions (Defs 7, 8) and topology (Defs 13, 14) of a complex.

    Simplices are named by their vertices (cloud ids for a cloud complex, vertex ids
    of K' for the surface-like complex); ``faces`` are triangles or polygons.

    Attributes
    ----------
    n_vertices, n_edges, n_faces : int
        Counts of the vertices (in at least one simplex), edges and faces (2-cells).
    dimension : int
        Largest simplex dimension (Prop. 1); 2 for a surface, -1 for an empty complex.
    vertices_not_in_face : ndarray of int64
        Def 7 i): vertices in no face.
    edges_in_many_faces : ndarray of shape (k, 2), int64
        Def 7 ii): edges in more than two faces.
    vertices_not_fan : ndarray of int64
        Def 7 iii): vertices whose faces do not form one edge-connected sequence.
    simplices_above_2 : tuple of tuple of int
        Def 8 (no four clouds meet, Fig. 1.3): inclusion-maximal simplices with four
        or more vertices.
    edges_not_in_face : ndarray of shape (k, 2), int64
        Def 8: edges in no face.
    boundary_edges : ndarray of shape (k, 2), int64
        Edges in exactly one face.
    boundary_loops : tuple of ndarray of int64
        Connected pieces of the boundary, in traversal order when a piece is a
        cycle (its vertex set otherwise).
    n_components : int
        Connected components (vertices joined by edges).
    euler_characteristic : int
        V - E + F.
    is_orientable : bool
        Def 14: the faces can be oriented so that faces sharing an edge are coherent.
    face_flip : ndarray of shape (F,), bool
        The coherent orientation found: reverse these faces (a best effort when not
        orientable).
    incoherent_faces : ndarray of shape (k, 2), int64
        Face pairs left incoherent (empty when orientable).
    genus : int or None
        Where defined (a surface, Def 7): orientable -> the total genus
        (2c - chi - b) / 2 over its c components; non-orientable and connected -> the
        non-orientable genus 2 - chi - b; None otherwise.
    """

    n_vertices: int
    n_edges: int
    n_faces: int
    dimension: int
    vertices_not_in_face: np.ndarray
    edges_in_many_faces: np.ndarray
    vertices_not_fan: np.ndarray
    simplices_above_2: tuple
    edges_not_in_face: np.ndarray
    boundary_edges: np.ndarray
    boundary_loops: tuple
    n_components: int
    euler_characteristic: int
    is_orientable: bool
    face_flip: np.ndarray
    incoherent_faces: np.ndarray
    genus: int | None

    def __post_init__(self):
        for name in (
            "vertices_not_in_face",
            "edges_in_many_faces",
            "vertices_not_fan",
            "edges_not_in_face",
            "boundary_edges",
            "face_flip",
            "incoherent_faces",
        ):
            readonly(getattr(self, name))
        for arr in self.boundary_loops:
            readonly(arr)

    @property
    def is_surface(self) -> bool:
        """Def 7: an abstract simplicial surface (conditions i-iii)."""
        return (
            self.n_faces > 0
            and self.vertices_not_in_face.size == 0
            and self.edges_in_many_faces.shape[0] == 0
            and self.vertices_not_fan.size == 0
        )

    @property
    def is_cloud_surface(self) -> bool:
        """Def 8: a surface with no simplex above dimension 2 and no edge outside faces."""
        return (
            self.is_surface and not self.simplices_above_2 and self.edges_not_in_face.shape[0] == 0
        )

    @property
    def is_closed(self) -> bool:
        """Def 7: a surface whose every edge lies in exactly two faces."""
        return self.is_surface and self.boundary_edges.shape[0] == 0

    @property
    def n_boundary_loops(self) -> int:
        """Number of boundary loops."""
        return len(self.boundary_loops)

    def summary(self) -> dict:
        """A JSON-friendly dict of every number and condition (offending simplices listed)."""

        def rows(arr):
            return [[int(x) for x in r] for r in np.asarray(arr).reshape(-1, 2)]

        return {
            "n_vertices": self.n_vertices,
            "n_edges": self.n_edges,
            "n_faces": self.n_faces,
            "dimension": self.dimension,
            "is_surface": self.is_surface,
            "is_cloud_surface": self.is_cloud_surface,
            "is_closed": self.is_closed,
            "n_boundary_loops": self.n_boundary_loops,
            "boundary_loop_lengths": [int(b.size) for b in self.boundary_loops],
            "n_components": self.n_components,
            "euler_characteristic": self.euler_characteristic,
            "is_orientable": self.is_orientable,
            "genus": self.genus,
            "conditions": {
                "def7_i_vertices_not_in_face": [int(v) for v in self.vertices_not_in_face],
                "def7_ii_edges_in_many_faces": rows(self.edges_in_many_faces),
                "def7_iii_vertices_not_fan": [int(v) for v in self.vertices_not_fan],
                "def8_simplices_above_2": [list(s) for s in self.simplices_above_2],
                "def8_edges_not_in_face": rows(self.edges_not_in_face),
                "def14_incoherent_faces": rows(self.incoherent_faces),
            },
        }

    def table(self) -> str:
        """A readable two-column table of the report."""
        s = self.summary()
        cond = s.pop("conditions")
        lines = [f"{k:<28} {v}" for k, v in s.items()]
        for k, v in cond.items():
            shown = v[:8]
            more = f" ... ({len(v)} in all)" if len(v) > 8 else ""
            lines.append(f"{k:<28} {shown if v else 'none'}{more}")
        return "\n".join(lines) + "\n"


def surface_report_core(
    n_vertices: int,
    edges: np.ndarray,
    he_face: np.ndarray,
    he_edge: np.ndarray,
    he_from: np.ndarray,
    he_to: np.ndarray,
    *,
    n_faces: int,
    present: np.ndarray | None = None,
    simplices_above_2: tuple = (),
    dimension: int | None = None,
) -> SurfaceReport:
    """Build a `SurfaceReport` from half-edges (validated input assumed).

    ``present`` marks the vertices that exist (a cloud with points); absent ids are
    not counted and not reported.
    """
    present = np.ones(n_vertices, dtype=bool) if present is None else present
    count, no_face, not_fan = incidence_checks(n_vertices, edges, he_face, he_edge)
    no_face = no_face[present[no_face]]
    ok, flip, incoherent = _orientation(n_faces, he_face, he_edge, he_from, he_to)
    boundary = edges[count == 1]
    loops = _boundary_loops(n_vertices, boundary)
    g = sparse.csr_array(
        (np.ones(edges.shape[0]), (edges[:, 0], edges[:, 1])), shape=(n_vertices, n_vertices)
    )
    comp = csgraph.connected_components(g, directed=False)[1]
    n_comp = int(np.unique(comp[present]).size)
    n_v = int(present.sum())
    chi = n_v - int(edges.shape[0]) + int(n_faces)
    if dimension is None:
        dimension = 2 if n_faces else (1 if edges.shape[0] else (0 if n_v else -1))
    report = SurfaceReport(
        n_vertices=n_v,
        n_edges=int(edges.shape[0]),
        n_faces=int(n_faces),
        dimension=int(dimension),
        vertices_not_in_face=no_face,
        edges_in_many_faces=edges[count > 2].reshape(-1, 2),
        vertices_not_fan=not_fan,
        simplices_above_2=tuple(simplices_above_2),
        edges_not_in_face=edges[count == 0].reshape(-1, 2),
        boundary_edges=boundary.reshape(-1, 2),
        boundary_loops=loops,
        n_components=n_comp,
        euler_characteristic=chi,
        is_orientable=bool(ok),
        face_flip=flip,
        incoherent_faces=incoherent,
        genus=None,
    )
    if report.is_surface:
        b = len(loops)
        if ok:
            genus = (2 * n_comp - chi - b) // 2
        elif n_comp == 1:
            genus = 2 - chi - b
        else:
            genus = None
        report = replace(report, genus=genus)
    return report
