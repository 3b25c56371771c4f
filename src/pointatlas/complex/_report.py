"""Topology reports of complexes and the geometric realisation as a mesh (Defs 7-14)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import sparse
from scipy.sparse import csgraph

from .._core import readonly
from ._clouds import CloudComplex
from ._complex import SurfaceComplex
from ._surface import SurfaceReport, surface_report_core

__all__ = ["CurveReport", "curve_report", "realize_complex", "surface_report"]


def _edge_ids(edges: np.ndarray, a: np.ndarray, b: np.ndarray, n_vertices: int) -> np.ndarray:
    """Row of ``edges`` (sorted pairs, sorted rows) of every pair (a, b)."""
    codes = edges[:, 0] * n_vertices + edges[:, 1]
    return np.searchsorted(codes, np.minimum(a, b) * n_vertices + np.maximum(a, b))


def _triangle_half_edges(triangles: np.ndarray, edges: np.ndarray, n_vertices: int):
    f = np.repeat(np.arange(triangles.shape[0], dtype=np.int64), 3)
    src = triangles.reshape(-1)
    dst = triangles[:, [1, 2, 0]].reshape(-1)
    return f, _edge_ids(edges, src, dst, n_vertices), src, dst


def _triangle_edges(triangles: np.ndarray) -> np.ndarray:
    pairs = np.concatenate([triangles[:, [0, 1]], triangles[:, [1, 2]], triangles[:, [0, 2]]])
    pairs = np.sort(pairs, axis=1)
    return np.unique(pairs, axis=0).reshape(-1, 2)


def _as_triangles(faces, n_vertices) -> tuple[np.ndarray, int]:
    arr = np.asarray(faces)
    if arr.dtype.kind not in "iu":
        raise TypeError(f"faces must be integer vertex indices; got dtype {arr.dtype}")
    if arr.ndim != 2 or arr.shape[1] != 3:
        raise ValueError(f"faces must have shape (F, 3); got {arr.shape}")
    arr = arr.astype(np.int64)
    if arr.size and arr.min() < 0:
        raise ValueError(f"faces must hold indices >= 0; got {int(arr.min())}")
    n = int(arr.max()) + 1 if arr.size else 0
    if n_vertices is not None:
        if n > n_vertices:
            raise ValueError(f"faces must hold indices in [0, {n_vertices}); got {n - 1}")
        n = int(n_vertices)
    if arr.size and (np.diff(np.sort(arr, axis=1), axis=1) == 0).any():
        raise ValueError("faces must have three distinct vertices each")
    return arr, n


def surface_report(complex_or_faces, *, n_vertices: int | None = None) -> SurfaceReport:
    """Simplicial-surface conditions and topology of a complex (Defs 7, 8, 13, 14).

    Parameters
    ----------
    complex_or_faces : CloudComplex, SurfaceComplex or array_like of shape (F, 3), int
        A cloud complex (Chapter A), the surface-like complex K' of a segmentation
        (Chapter B; its faces are the boundary cycles), or triangles of a mesh.
    n_vertices : int, optional
        For triangles only: the number of vertices (default largest index + 1).

    Returns
    -------
    report : SurfaceReport
        Def 7 i)-iii) and Def 8 with the offending simplices, closedness, boundary
        loops, components, Euler characteristic, orientability with a coherent
        orientation (``face_flip``) and genus.

    Raises
    ------
    TypeError
        Not a complex and not integer triangles.
    ValueError
        Triangles of the wrong shape, negative or repeated indices.

    Notes
    -----
    One set of checks serves both chapters: the faces are described by half-edges,
    triangles for a cloud complex and polygons (boundary cycles) for K'. Def 7 iii)
    asks for a sequence of the faces at a vertex in which consecutive faces share an
    edge; where every edge at the vertex lies in at most two faces this is "the
    faces at the vertex are edge-connected", otherwise a Hamiltonian path is searched.
    Orientability (Def 14) propagates an orientation over a spanning forest of the
    face adjacency and checks the remaining adjacencies (decision record in
    docs/decisions/cloud_surfaces.md).

    Examples
    --------
    The boundary of a tetrahedron is a closed sphere:

    >>> r = surface_report([[0, 1, 2], [0, 3, 1], [0, 2, 3], [1, 3, 2]])
    >>> r.is_closed, r.euler_characteristic, r.is_orientable, r.genus
    (True, 2, True, 0)
    """
    if isinstance(complex_or_faces, CloudComplex):
        K = complex_or_faces
        n = K.n_clouds
        present = np.ones(n, dtype=bool)
        present[K.empty_clouds] = False
        f, e, src, dst = _triangle_half_edges(K.triangles, K.edges, n)
        return surface_report_core(
            n,
            K.edges,
            f,
            e,
            src,
            dst,
            n_faces=K.triangles.shape[0],
            present=present,
            simplices_above_2=K.simplices_above_2,
            dimension=K.dimension,
        )
    if isinstance(complex_or_faces, SurfaceComplex):
        K = complex_or_faces
        f = np.concatenate(
            [np.full(c.size, i, dtype=np.int64) for i, c in enumerate(K.cycle_edges)]
            or [np.zeros(0, np.int64)]
        )
        e = np.concatenate(list(K.cycle_edges) or [np.zeros(0, np.int64)]).astype(np.int64)
        src = np.concatenate(list(K.cycles) or [np.zeros(0, np.int64)]).astype(np.int64)
        dst = np.concatenate([np.roll(c, -1) for c in K.cycles] or [np.zeros(0, np.int64)])
        return surface_report_core(
            K.n_vertices, K.edges, f, e, src, dst.astype(np.int64), n_faces=K.n_cycles
        )
    tri, n = _as_triangles(complex_or_faces, n_vertices)
    edges = _triangle_edges(tri)
    f, e, src, dst = _triangle_half_edges(tri, edges, n)
    present = np.zeros(n, dtype=bool)
    present[tri.reshape(-1)] = True
    return surface_report_core(n, edges, f, e, src, dst, n_faces=tri.shape[0], present=present)


def realize_complex(cloud_complex: CloudComplex, report: SurfaceReport | None = None):
    """Geometric realisation of a cloud complex as a triangle mesh (Def. 10).

    Parameters
    ----------
    cloud_complex : CloudComplex
        The complex; its ``cloud_points`` are the mesh vertices.
    report : SurfaceReport, optional
        Its `surface_report` (computed when not given).

    Returns
    -------
    vertices : ndarray of shape (C, 3), float64
        The cloud points (one per cloud; empty clouds keep their row, unreferenced).
    faces : ndarray of shape (F, 3), int64
        The triangles, coherently oriented where the complex is orientable (Def. 14)
        and, per component of a closed surface, with outward normals (positive
        signed volume).

    Examples
    --------
    >>> from pointatlas.complex import cloud_complex
    >>> K = cloud_complex([[0, 3], [1, 3], [2, 3]], [[0, 0, 0], [2, 0, 0], [0, 2, 0], [0, 0, 0]])
    >>> v, f = realize_complex(K)
    >>> f.tolist()
    [[0, 1, 2]]
    """
    if not isinstance(cloud_complex, CloudComplex):
        raise TypeError(f"cloud_complex must be a CloudComplex; got {type(cloud_complex).__name__}")
    rep = surface_report(cloud_complex) if report is None else report
    faces = cloud_complex.triangles.copy()
    flip = np.asarray(rep.face_flip, dtype=bool)
    faces[flip] = faces[flip][:, [0, 2, 1]]
    verts = np.array(cloud_complex.cloud_points, dtype=np.float64)
    if rep.is_orientable and faces.shape[0] and rep.boundary_edges.shape[0] == 0:
        n = cloud_complex.n_clouds
        g = sparse.csr_array(
            (
                np.ones(cloud_complex.edges.shape[0]),
                (cloud_complex.edges[:, 0], cloud_complex.edges[:, 1]),
            ),
            shape=(n, n),
        )
        comp = csgraph.connected_components(g, directed=False)[1][faces[:, 0]]
        a, b, c = (np.nan_to_num(verts[faces[:, i]]) for i in range(3))
        vol = np.einsum("ij,ij->i", a, np.cross(b, c))
        signed = np.bincount(comp, weights=vol)
        outward = signed[comp] >= 0
        faces[~outward] = faces[~outward][:, [0, 2, 1]]
    return verts, faces


@dataclass(frozen=True, slots=True)
class CurveReport:
    """Whether a cloud complex in the plane is a 1-manifold (curves, Prop. 5, Fig. 2.14).

    Attributes
    ----------
    n_vertices, n_edges, n_triangles : int
        Simplex counts.
    dimension : int
        Largest simplex dimension (1 for a curve).
    vertices_bad_degree : ndarray of int64
        Vertices on more than two edges or on none.
    triangles : ndarray of shape (k, 3), int64
        2-simplices (three clouds meeting): none allowed on a curve.
    n_components : int
        Connected components.
    n_endpoints : int
        Vertices on exactly one edge (ends of open curves).
    euler_characteristic : int
        V - E (+ F, were there triangles).
    """

    n_vertices: int
    n_edges: int
    n_triangles: int
    dimension: int
    vertices_bad_degree: np.ndarray
    triangles: np.ndarray
    n_components: int
    n_endpoints: int
    euler_characteristic: int

    def __post_init__(self):
        readonly(self.vertices_bad_degree)
        readonly(self.triangles)

    @property
    def is_one_manifold(self) -> bool:
        """Every vertex on one or two edges and no triangle."""
        return self.n_edges > 0 and self.vertices_bad_degree.size == 0 and self.n_triangles == 0

    @property
    def is_closed(self) -> bool:
        """A 1-manifold without endpoints (disjoint closed curves)."""
        return self.is_one_manifold and self.n_endpoints == 0

    def summary(self) -> dict:
        """A JSON-friendly dict of the report."""
        return {
            "n_vertices": self.n_vertices,
            "n_edges": self.n_edges,
            "n_triangles": self.n_triangles,
            "dimension": self.dimension,
            "is_one_manifold": self.is_one_manifold,
            "is_closed": self.is_closed,
            "n_components": self.n_components,
            "n_endpoints": self.n_endpoints,
            "euler_characteristic": self.euler_characteristic,
            "vertices_bad_degree": [int(v) for v in self.vertices_bad_degree],
            "triangles": [[int(x) for x in t] for t in self.triangles],
        }

    def table(self) -> str:
        """A readable two-column table of the report."""
        return "\n".join(f"{k:<28} {v}" for k, v in self.summary().items()) + "\n"


def curve_report(cloud_complex: CloudComplex) -> CurveReport:
    """Whether a cloud complex is a 1-manifold (a curve's cover, thesis 2.2.2).

    Parameters
    ----------
    cloud_complex : CloudComplex
        The cloud complex of a 2-D cover (`pointatlas.cover.ball_cover`, ``dim=2``).

    Returns
    -------
    report : CurveReport
        Degrees, offending vertices and triangles, components, endpoints, V - E + F.

    Examples
    --------
    >>> from pointatlas.complex import cloud_complex
    >>> K = cloud_complex([[0, 1], [1, 2], [2, 3], [3, 0]], n_points=4)
    >>> r = curve_report(K)
    >>> r.is_one_manifold, r.is_closed, r.n_components
    (True, True, 1)
    """
    if not isinstance(cloud_complex, CloudComplex):
        raise TypeError(f"cloud_complex must be a CloudComplex; got {type(cloud_complex).__name__}")
    n = cloud_complex.n_clouds
    present = np.ones(n, dtype=bool)
    present[cloud_complex.empty_clouds] = False
    deg = np.bincount(cloud_complex.edges.reshape(-1), minlength=n)
    bad = np.flatnonzero(present & ((deg > 2) | (deg == 0)))
    g = sparse.csr_array(
        (
            np.ones(cloud_complex.edges.shape[0]),
            (cloud_complex.edges[:, 0], cloud_complex.edges[:, 1]),
        ),
        shape=(n, n),
    )
    comp = csgraph.connected_components(g, directed=False)[1]
    n_v = int(present.sum())
    return CurveReport(
        n_vertices=n_v,
        n_edges=int(cloud_complex.edges.shape[0]),
        n_triangles=int(cloud_complex.triangles.shape[0]),
        dimension=cloud_complex.dimension,
        vertices_bad_degree=bad,
        triangles=cloud_complex.triangles.copy(),
        n_components=int(np.unique(comp[present]).size),
        n_endpoints=int((present & (deg == 1)).sum()),
        euler_characteristic=n_v
        - int(cloud_complex.edges.shape[0])
        + int(cloud_complex.triangles.shape[0]),
    )
