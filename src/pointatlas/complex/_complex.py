"""The surface-like complex K' of a segmentation (thesis section 3, Eqs 3.1-3.2).

Construction (decisions in docs/decisions/complex.md; the steps in `_complex_steps`):

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

from .._core import as_labels, as_points, check_neighbors, readonly
from .._core._deprecation import renamed_keywords
from ..neighbors import query_knn
from ._complex_steps import (
    _Builder,
    _maximal_sets,
    _region_sets,
    _sym_graph,
    add_arcs,
    add_vertices,
    boundary_cycles,
    cycle_checks,
    split_parallel_edges,
)

__all__ = ["SurfaceComplex", "surface_complex"]


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


def _neighbour_table(pts: np.ndarray, k: int, neighbors) -> np.ndarray:
    """The (N, k) k-NN table of `surface_complex`: given and checked, or queried."""
    if neighbors is None:
        return query_knn(pts, k)[0]
    return check_neighbors(neighbors, pts.shape[0], k=k)


@renamed_keywords(indices="neighbors")
def surface_complex(points, labels, *, k: int = 8, neighbors=None) -> SurfaceComplex:
    """Build the surface-like complex K' of a segmentation (thesis section 3).

    Parameters
    ----------
    points : array_like of shape (N, 3), float64
        Coordinates.
    labels : array_like of shape (N,), int64
        Region of every point, 0..R-1 (every point assigned).
    k : int
        Neighbourhood size including the point itself (Remark 6; thesis uses 8).
    neighbors : ndarray of shape (N, m), int, or tuple, optional
        Precomputed neighbour table, e.g. `pointatlas.neighbors.query_knn`'s result
        (m >= k; its first k columns are used; checked by
        `pointatlas._core.check_neighbors`). None queries the k nearest neighbours.
        ``indices=`` is its former name (deprecated).

    Returns
    -------
    complex : SurfaceComplex
        q-tuples, vertices, edges, arcs, boundary cycles per region and the
        conditions of Conjectures 3 and 4 with the offending elements.

    Raises
    ------
    ValueError
        Bad shapes, non-finite points, negative labels or a bad ``neighbors`` table.
    TypeError
        A non-integer ``neighbors`` table, or both ``neighbors`` and ``indices``.
    PointAtlasError
        ``k`` larger than the number of points.

    Notes
    -----
    Eq. 3.1 gives ``q_tuples``; Eq. 3.2 gives K' = V u E u F. The edge rule is ours
    (docs/decisions/complex.md): shared region pairs on a common boundary arc, not
    any shared index, and several arcs between the same pair stay apart. Vertices
    are the connected k-NN components of points seeing >= 3 regions; vertices are
    inserted on boundaries with fewer than three vertices per cycle (see module
    docstring and docs/decisions/complex.md).

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
    idx = _neighbour_table(pts, k, neighbors)
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
    zone_vertex, vr_codes = add_vertices(b, big, padded, gr, gc, n, n_regions, idx.shape[1])
    arc_regions_list, arc_points_list, dropped = add_arcs(
        b, lab, idx, counts, zone_vertex, vr_codes, gr, gc, n_regions
    )
    E, ER, EA = split_parallel_edges(b)
    n_v = len(b.vregions)
    cycles, cycle_edges, cycle_region, open_edges, regions_open, region_cycles = boundary_cycles(
        E, ER, n_regions
    )
    edge_count, no_cycle, not_fan, not_simple = cycle_checks(n_v, E, cycles, cycle_edges)
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
