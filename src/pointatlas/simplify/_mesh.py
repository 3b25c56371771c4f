"""The simplified polygon mesh of a segmentation (thesis 4.4, GUIDE B3)."""

from __future__ import annotations

import dataclasses
import warnings
from dataclasses import dataclass

import numpy as np

from .._core import PointAtlasError, as_labels, as_normals, as_points, readonly
from ..complex import SurfaceComplex
from ..neighbors import point_mesh_distance, query_knn
from ._checks import check_memory, check_size, usable_normals
from ._faces import general_faces, plane_deviation, star_faces
from ._frame import frame_of
from ._proxies import check_not_parallel, region_proxies
from ._repair import clean_regions
from ._vertices import (
    MeshVertices,
    SimplifyWarning,
    fit_vertices,
    lsq_vertices,
    optimize_vertices,
)

__all__ = [
    "SimplifiedMesh",
    "mesh_checks",
    "point_mesh_distance",
    "simplify_segmentation",
]

_VERTEX_METHODS = ("fit", "lsq", "optimize")
_FACE_METHODS = ("general", "star")


@dataclass(frozen=True, slots=True)
class SimplifiedMesh:
    """A simplified polygon mesh with one face per region, and its quality report.

    Attributes
    ----------
    vertices : ndarray of shape (V, 3), float64
        Mesh vertices (the used vertices of the surface-like complex).
    vertex_ids : ndarray of shape (V,), int64
        Complex vertex of every mesh vertex.
    polygons : tuple of ndarray of int64
        Polygon faces to write (OBJ/PLY): one polygon per region face; a face with
        holes is written as its triangles (file formats have no holes).
    polygon_face : ndarray of shape (P,), int64
        Face each polygon belongs to.
    face_region : ndarray of shape (F,), int64
        Region of every face.
    face_loops : tuple of tuple of ndarray of int64
        Per face: outer loop (counter-clockwise about the plane normal) then holes.
    face_ok : ndarray of shape (F,), bool
        False where the face's triangulation does not match its cycles (a
        self-intersecting projection, a hole outside the outer loop, or vertices
        that are not star-convex about the centroid for ``faces="star"``).
    planarity_error : ndarray of shape (F,), float64
        Largest distance of a face's vertices to their least-squares plane.
    triangles : ndarray of shape (T, 3), int64
        Triangulation of all faces, counter-clockwise about the plane normals.
    triangle_face : ndarray of shape (T,), int64
        Face of every triangle.
    is_closed, is_manifold, is_oriented : bool
        Every edge in exactly two triangles; edges in at most two triangles and one
        triangle fan per vertex; no directed edge used twice.
    distances : ndarray of shape (M,), float64
        Distance of every point used (``point_index``) to the triangulated mesh.
    mean_distance, max_distance : float
        Mean and largest of ``distances``.
    vertex_method, face_method : str
        Methods used (``vertex_method`` is ``"lsq"`` after a fallback).
    fallback : bool
        The optimisation failed and plane intersection was used.
    constraint_violation : float
        Final Eq. 4.12 constraint violation (NaN for least squares).
    n_guarded : int
        Vertices whose position was guarded (near-parallel planes / distance bound).
    regions_without_face : ndarray of int64
        Regions with no closed boundary cycle (no face).
    plane_normals : ndarray of shape (R, 3), float64
        Plane normal per region (proxy normals, or the corrected n~_i).
    plane_offsets : ndarray of shape (R,), float64
        d_i of every region's plane ``plane_normals[i] . x = d_i``.
    labels : ndarray of shape (M,), int64
        Region of every point used (``point_index``) after merging (face regions
        refer to these).
    region_map : ndarray of shape (R_in,), int64
        Input region -> region of ``labels`` holding most of its points (several
        map together when merged).
    complex : SurfaceComplex
        The surface-like complex the mesh was built from.
    anchor_weight : float
        Anchor weight ``vertices="fit"`` used (NaN for the other methods).
    point_index : ndarray of shape (M,), int64
        Input index of every point used; ``labels`` and ``distances`` follow it.
        Points without a usable normal (zero-length or NaN/Inf) are left out.
    n_dropped : int
        Number of input points left out for want of a usable normal.
    regions_report : tuple of dict
        One entry per input region (of the ``labels`` given): ``region``,
        ``n_points`` (points used), ``became_face`` (bool), ``final_region`` (region
        of ``labels`` holding most of its points, or -1) and ``reason`` (why it did or
        did not become a face of its own).
    """

    vertices: np.ndarray
    vertex_ids: np.ndarray
    polygons: tuple
    polygon_face: np.ndarray
    face_region: np.ndarray
    face_loops: tuple
    face_ok: np.ndarray
    planarity_error: np.ndarray
    triangles: np.ndarray
    triangle_face: np.ndarray
    is_closed: bool
    is_manifold: bool
    is_oriented: bool
    distances: np.ndarray
    mean_distance: float
    max_distance: float
    vertex_method: str
    face_method: str
    fallback: bool
    constraint_violation: float
    n_guarded: int
    regions_without_face: np.ndarray
    plane_normals: np.ndarray
    plane_offsets: np.ndarray
    labels: np.ndarray
    region_map: np.ndarray
    complex: SurfaceComplex
    anchor_weight: float = float("nan")
    point_index: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(0, np.int64))
    n_dropped: int = 0
    regions_report: tuple = ()

    def __post_init__(self):
        for name in (
            "vertices",
            "vertex_ids",
            "polygon_face",
            "face_region",
            "face_ok",
            "planarity_error",
            "triangles",
            "triangle_face",
            "distances",
            "regions_without_face",
            "plane_normals",
            "plane_offsets",
            "labels",
            "region_map",
            "point_index",
        ):
            readonly(getattr(self, name))
        for p in self.polygons:
            readonly(p)

    @property
    def n_vertices(self) -> int:
        """Number of mesh vertices."""
        return int(self.vertices.shape[0])

    @property
    def n_faces(self) -> int:
        """Number of faces (one per region with a boundary)."""
        return int(self.face_region.shape[0])

    @property
    def n_holes(self) -> np.ndarray:
        """Number of holes of every face, shape (F,)."""
        return np.array([len(lp) - 1 for lp in self.face_loops], dtype=np.int64)

    def summary(self) -> dict:
        """A JSON-friendly report of the mesh and its quality."""
        return {
            "n_vertices": self.n_vertices,
            "n_faces": self.n_faces,
            "n_triangles": int(self.triangles.shape[0]),
            "n_faces_with_holes": int((self.n_holes > 0).sum()),
            "vertex_method": self.vertex_method,
            "face_method": self.face_method,
            "fallback": self.fallback,
            "constraint_violation": (
                None if np.isnan(self.constraint_violation) else float(self.constraint_violation)
            ),
            "n_guarded_vertices": self.n_guarded,
            "is_closed": self.is_closed,
            "is_manifold": self.is_manifold,
            "is_oriented": self.is_oriented,
            "faces_not_ok": [int(x) for x in np.flatnonzero(~self.face_ok)],
            "max_planarity_error": float(self.planarity_error.max(initial=0.0)),
            "mean_distance": self.mean_distance,
            "max_distance": self.max_distance,
            "regions_without_face": [int(x) for x in self.regions_without_face],
            "anchor_weight": None if np.isnan(self.anchor_weight) else self.anchor_weight,
            "n_input_regions": int(self.region_map.shape[0]),
            "n_regions": int(self.labels.max()) + 1 if self.labels.size else 0,
            "n_dropped_points": self.n_dropped,
            "regions_report": [dict(r) for r in self.regions_report],
        }


def mesh_checks(n_vertices: int, triangles) -> tuple[bool, bool, bool]:
    """Closed, manifold and consistently oriented tests of a triangle mesh.

    Parameters
    ----------
    n_vertices : int
        Number of vertices.
    triangles : array_like of shape (T, 3), int64
        Vertex indices.

    Returns
    -------
    is_closed : bool
        Every undirected edge lies in exactly two triangles.
    is_manifold : bool
        Every edge lies in at most two triangles and the triangles around every
        used vertex form a single edge-connected fan.
    is_oriented : bool
        No directed edge occurs twice (neighbouring triangles agree on orientation).

    Examples
    --------
    >>> tet = [[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]]
    >>> mesh_checks(4, tet)
    (True, True, True)
    """
    tri = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
    if tri.size == 0:
        return False, False, False
    if tri.min() < 0 or tri.max() >= n_vertices:
        raise ValueError(f"triangles must index vertices 0..{n_vertices - 1}")
    d = np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]])
    und = np.sort(d, axis=1)
    _, cnt = np.unique(und, axis=0, return_counts=True)
    closed = bool((cnt == 2).all())
    _, dcnt = np.unique(d, axis=0, return_counts=True)
    oriented = bool((dcnt == 1).all())
    manifold = bool((cnt <= 2).all())
    if manifold:
        # link of every vertex: the opposite edges of its triangles must form one
        # path or cycle (connected, degrees <= 2)
        link: dict[int, list[tuple[int, int]]] = {}
        for a, b, c in tri.tolist():
            link.setdefault(a, []).append((b, c))
            link.setdefault(b, []).append((c, a))
            link.setdefault(c, []).append((a, b))
        for edges in link.values():
            deg: dict[int, int] = {}
            parent: dict[int, int] = {}

            def find(x, parent=parent):
                while parent.setdefault(x, x) != x:
                    parent[x] = parent[parent[x]]
                    x = parent[x]
                return x

            for p, q in edges:
                deg[p] = deg.get(p, 0) + 1
                deg[q] = deg.get(q, 0) + 1
                parent[find(p)] = find(q)
            roots = {find(x) for x in deg}
            if len(roots) != 1 or max(deg.values()) > 2:
                manifold = False
                break
    return closed, manifold, oriented


def _planarity(vertices, loops):
    return plane_deviation(vertices[np.concatenate(loops)])


def _check_choice(value, name, choices):
    if value not in choices:
        raise ValueError(f"{name} must be one of {', '.join(choices)}; got {value!r}")
    return value


def _resolve_centers(centers, proxies, n_regions, frame):
    """Proxy plane points C_i in working coordinates (given ones are mapped there)."""
    if centers is None or (isinstance(centers, str) and centers == "centroid"):
        return np.array(proxies.centroids)
    if isinstance(centers, str):
        if centers == "seed":
            return np.array(proxies.seed_points)
        raise ValueError(f"centers must be 'centroid', 'seed' or an (R, 3) array; got {centers!r}")
    arr = as_points(centers, name="centers")
    if arr.shape[0] != n_regions:
        raise ValueError(f"centers must have one row per region ({n_regions}); got {arr.shape[0]}")
    return frame.to_local(arr)


#: anchor weights tried by ``vertices="fit"`` with ``anchor_weight=None``, loosest first
FIT_ANCHOR_WEIGHTS = (0.01, 0.1, 1.0, 10.0)


def _fit_with_valid_faces(
    cplx, points, labels, pn, ctr, lsq, anchor_weight, max_iter, builder, centroids
):
    """``fit_vertices`` and faces; with ``anchor_weight=None`` the loosest weight of
    `FIT_ANCHOR_WEIGHTS` whose faces are all valid and whose mesh is closed, manifold
    and oriented (else the best by: no fallback, closed/manifold/oriented, fewest
    invalid faces, looser weight). Returns (MeshVertices, faces, weight used)."""
    schedule = FIT_ANCHOR_WEIGHTS if anchor_weight is None else (float(anchor_weight),)
    best = None
    caught_best: list = []
    for aw in schedule:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", SimplifyWarning)
            mv = fit_vertices(cplx, points, labels, pn, ctr, lsq=lsq, weight=aw, max_iter=max_iter)
        face_list = builder(cplx, np.asarray(mv.positions), np.asarray(mv.plane_normals), centroids)
        tris = [f.triangles for f in face_list if f.triangles.size]
        good = bool(tris) and all(mesh_checks(cplx.n_vertices, np.concatenate(tris)))
        key = (mv.fallback, not good, sum(not f.ok for f in face_list))
        if best is None or key < best[0]:
            best, caught_best = (key, mv, face_list, aw), caught
        if key == (False, False, 0):
            break
    for w in caught_best:  # the chosen solve's warnings (a fallback to plane intersection)
        warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    _, mv, face_list, aw = best
    return mv, face_list, (float("nan") if mv.fallback else aw)


def simplify_segmentation(
    points,
    normals,
    labels,
    *,
    k: int = 8,
    vertices: str = "fit",
    faces: str = "general",
    centers="centroid",
    proxy_normals=None,
    weight: float = 1.0,
    anchor_weight: float | None = None,
    max_distance: float | None = None,
    min_region_size: int | None = None,
    repair: bool = True,
    smooth: int = 2,
    max_boundary_fraction: float = 0.95,
    max_iter: int = 3000,
    indices=None,
) -> SimplifiedMesh:
    """Build the simplified polygon mesh of a segmented point set (thesis 4.4).

    Parameters
    ----------
    points : array_like of shape (N, 3), float64
        Coordinates.
    normals : array_like of shape (N, 3), float64 or None
        Normals (rescaled to unit length), used for the proxy normals. Points
        whose normal is zero-length or has a NaN/Inf entry are left out (counted in
        ``n_dropped``). May be None when ``proxy_normals`` and ``centers`` (an
        array) are given; regions are then used as they are (no smoothing, merging
        or repair).
    labels : array_like of shape (N,), int64
        Region of every point, consecutive 0..R-1 (e.g. ``VSAResult.labels``).
    k : int
        Neighbourhood size for the region adjacency (Remark 6); 1 <= k <= the
        number of points used.
    vertices : {"fit", "lsq", "optimize"}
        ``"fit"`` (default, beyond the thesis): planes refitted to their points under
        the constraint that every vertex lies on all its planes, so every face is
        planar; ``"lsq"``: plane intersection by guarded least squares (faces where
        more than three planes meet are not planar); ``"optimize"``: Eq. 4.12.
    faces : {"general", "star"}
        Faces from the boundary cycles (holes allowed), or star-convex ordering.
    centers : {"centroid", "seed"} or array_like of shape (R, 3)
        Point of every proxy plane (C_i): the region centroid (default, the plane
        of Eq. 4.7), the VSA seed point, or given points.
    proxy_normals : array_like of shape (R, 3), optional
        Proxy normals N_i; by default the normalised sum of each region's normals.
    weight : float
        w~_i of Eq. 4.11 (>= 0; 1 in the thesis, 3 for its coarsest sphere); only
        for ``vertices="optimize"``.
    anchor_weight : float, optional
        ``vertices="fit"`` only (> 0): weight of the vertices' mean squared
        displacement from the least-squares vertices against the mean squared
        point-to-plane distance (both in units of the points' RMS radius). By
        default the loosest of 0.01, 0.1, 1, 10 whose faces are all valid and
        whose mesh is closed, manifold and oriented (`FIT_ANCHOR_WEIGHTS`; else the
        best of them, see ``docs/decisions/simplify.md``).
    max_distance : float, optional
        Bound on the distance of a least-squares vertex from its witness points
        (input units); by default half the distance to the nearest contributing
        region centroid, at least twice the witness points' spread.
    min_region_size : int, optional
        Regions with fewer points are merged into their most similar neighbour
        before meshing (default ``k``; 1 keeps every region).
    repair : bool
        Merge regions whose boundary does not close into cycles into their most
        similar neighbour and rebuild the complex (beyond the thesis, which fixed
        such faces by hand; up to 30 rounds).
    smooth : int
        Passes of a k-NN majority filter on the labels before meshing (straightens
        ragged region boundaries; 0 keeps the labels as given). Regions split by
        it become separate regions.
    max_boundary_fraction : float
        With ``repair``, regions smaller than half the largest region in which more than
        this fraction of the points have another region among their k neighbours
        (thin strips) are merged into their most similar neighbour first (1
        disables).
    max_iter : int
        Iteration limit of the Eq. 4.12 optimisation.
    indices : ndarray of shape (N, k), int64, optional
        Precomputed `pointatlas.neighbors.query_knn` indices (ignored, and
        recomputed, when points are left out).

    Returns
    -------
    mesh : SimplifiedMesh
        Polygon mesh, triangulation, per-face planarity error, closed/manifold
        flags, point-to-mesh distances, the complex, and the points used
        (``point_index``, ``n_dropped``).

    Raises
    ------
    ValueError
        Bad shapes or options.
    TypeError
        Non-numeric arrays, non-integer ``k``.
    PointAtlasError
        Too few points (fewer than 4, or fewer than ``k``; "simplify needs at
        least ..."), more memory than available for this ``k`` (estimated before
        any work), no point (or a whole region without a point) with a usable
        normal, or degenerate input: fewer than three regions, no vertex where
        three regions meet, all proxy planes parallel, or no region with a closed
        boundary.

    Warns
    -----
    SimplifyWarning
        ``vertices="optimize"`` or ``"fit"`` failed; plane intersection was used
        instead (``fallback`` is True in the result).

    Notes
    -----
    Vertices one per vertex of the surface-like complex (section 3, GUIDE B1);
    (a) least squares over all q planes with near-parallel guard and distance bound
    (Fig. 4.11's outliers), (b) Eq. 4.12 with ``scipy.optimize.minimize(method=
    "trust-constr")`` started from N_i and the barycentre of the C_i, (c) beyond
    the thesis, ``"fit"``: Eq. 4.12's incidence constraints n_i . x_j = d_i,
    |n_i| = 1 with free offsets d_i, minimising the points' mean squared distance
    to their planes plus ``anchor_weight`` times the vertices' mean squared
    displacement from (a); started from (a) and the proxy planes. Faces:
    [SZP20]'s star-convex ordering or the general method of 4.4.2. Every step
    runs on centred coordinates scaled by a power of two (at least the bounding-box
    diagonal) and the results are mapped back, so the mesh moves with translations
    and scalings of the input and all tolerances are relative to its size.
    Decisions in docs/decisions/simplify.md ("The thesis path").

    Examples
    --------
    >>> from pointatlas.synth import cube
    >>> m = cube(6)
    >>> s = simplify_segmentation(m.vertices, m.normals, m.labels)
    >>> s.n_vertices, s.n_faces, s.is_closed, [len(p) for p in s.polygons]
    (8, 6, True, [4, 4, 4, 4, 4, 4])
    """
    pts = as_points(points)
    n_input = pts.shape[0]
    lab = as_labels(labels, n_input)
    k = check_size(n_input, k)
    _check_choice(vertices, "vertices", _VERTEX_METHODS)
    _check_choice(faces, "faces", _FACE_METHODS)
    weight = float(weight)
    if not np.isfinite(weight) or weight < 0:
        raise ValueError(f"weight must be finite and >= 0; got {weight}")
    if anchor_weight is not None:
        anchor_weight = float(anchor_weight)
        if not np.isfinite(anchor_weight) or anchor_weight <= 0:
            raise ValueError(f"anchor_weight must be finite and > 0; got {anchor_weight}")
    if max_distance is not None and not (np.isfinite(max_distance) and max_distance > 0):
        raise ValueError(f"max_distance must be positive; got {max_distance}")
    if (lab < 0).any():
        raise ValueError(f"labels must be >= 0; {int((lab < 0).sum())} points are unassigned")
    n_regions = int(lab.max()) + 1
    if n_regions < 3:
        raise PointAtlasError(
            f"simplification needs at least 3 regions (three planes meeting at a vertex); "
            f"got {n_regions}"
        )
    if normals is None:
        if proxy_normals is None or centers is None or isinstance(centers, str):
            raise ValueError("normals must be given unless proxy_normals and centers are")
        # no normals: the given proxies are used as they are and no region is merged
        pn_given = np.asarray(proxy_normals, dtype=np.float64)
        if pn_given.shape != (n_regions, 3):
            raise ValueError(
                f"proxy_normals must have shape ({n_regions}, 3); got {pn_given.shape}"
            )
        nrm, keep = as_normals(pn_given[lab]), np.ones(n_input, dtype=bool)
        smooth, repair, min_region_size = 0, False, 1
    else:
        nrm, keep = usable_normals(normals, n_input)
    if not keep.all():  # points without a usable normal are left out (n_dropped)
        pts, lab, indices = pts[keep], lab[keep], None
        k = check_size(pts.shape[0], k)
        emptied = np.bincount(lab, minlength=n_regions) == 0
        if emptied.any():
            raise PointAtlasError(
                f"regions {np.flatnonzero(emptied)[:5].tolist()} keep no point with a "
                "usable normal (all their normals are zero-length or non-finite)"
            )
    if min_region_size is None:
        min_region_size = k
    if isinstance(min_region_size, bool) or int(min_region_size) < 1:
        raise ValueError(f"min_region_size must be an integer >= 1; got {min_region_size}")
    check_memory(pts.shape[0], k, n_regions)
    frame = frame_of(pts)
    q = frame.to_local(pts)
    proxies = region_proxies(q, nrm, lab)
    if proxy_normals is None:
        pn0 = np.array(proxies.normals)
    else:
        pn0 = np.asarray(proxy_normals, dtype=np.float64)
        if pn0.shape != (n_regions, 3) or not np.isfinite(pn0).all():
            raise ValueError(f"proxy_normals must have shape ({n_regions}, 3); got {pn0.shape}")
        pn0 = pn0 / np.linalg.norm(pn0, axis=1, keepdims=True)
    ctr0 = _resolve_centers(centers, proxies, n_regions, frame)
    check_not_parallel(pn0)
    if indices is None:
        indices, _ = query_knn(q, k)
    indices = np.asarray(indices, dtype=np.int64)
    clean = clean_regions(
        q,
        nrm,
        lab,
        indices,
        pn0,
        ctr0,
        k=k,
        smooth=smooth,
        min_region_size=min_region_size,
        repair=repair,
        max_boundary_fraction=max_boundary_fraction,
    )
    mv, face_list, used_weight = _place_vertices(
        clean,
        q,
        vertices=vertices,
        faces=faces,
        weight=weight,
        anchor_weight=anchor_weight,
        max_distance=None if max_distance is None else float(max_distance) / frame.scale,
        max_iter=max_iter,
    )
    mesh = _assemble(
        frame, q, clean, mv, face_list, faces, used_weight, np.flatnonzero(keep), n_input
    )
    return dataclasses.replace(mesh, regions_report=regions_report(lab, clean, face_list))


def regions_report(labels, clean, face_list) -> tuple:
    """Which input regions became faces and why the others did not (private).

    An input region becomes a face when the final region holding most of its points
    has a face and the region is that final region's largest input region; a region
    merged into another keeps the first reason recorded by `clean_regions`.
    """
    n_in = int(labels.max()) + 1
    n_fin = int(clean.labels.max()) + 1
    both = np.zeros((n_in, n_fin), dtype=np.int64)
    np.add.at(both, (labels, clean.labels), 1)
    n_points = np.bincount(labels, minlength=n_in)
    final = np.where(both.any(axis=1), both.argmax(axis=1), -1)
    # main input region of every final region: most points, then smaller id
    main = np.argmax(both, axis=0)
    faces = {f.region: f for f in face_list}
    cplx = clean.complex
    reasons = clean.input_reasons or ("",) * n_in
    out = []
    for r in range(n_in):
        f = int(final[r])
        face = faces.get(f) if f >= 0 else None
        became = face is not None and int(main[f]) == r
        if f < 0:
            why = "every point was relabelled by the majority filter (smooth)"
        elif became:
            merged = [int(x) for x in np.flatnonzero(both[:, f]) if x != r]
            why = "face" + (f" (with points of input regions {merged})" if merged else "")
            if not face.ok:
                why += "; not valid: " + (face.note or "triangulation differs from its cycles")
        elif reasons[r]:
            why = reasons[r]
        elif face is not None:
            why = f"merged into the face of input region {int(main[f])}"
        elif not cplx.region_cycles[f]:
            why = "no closed boundary cycle in the complex"
        else:
            why = "no valid boundary loop"
        out.append(
            {
                "region": r,
                "n_points": int(n_points[r]),
                "became_face": bool(became),
                "final_region": f,
                "reason": why,
            }
        )
    return tuple(out)


def _place_vertices(
    clean, q, *, vertices, faces, weight, anchor_weight, max_distance, max_iter
) -> tuple[MeshVertices, list, float]:
    """Vertices by the chosen method and the faces (working coordinates; private)."""
    cplx, pn, ctr = clean.complex, clean.proxy_normals, clean.centers
    lsq = lsq_vertices(cplx, q, pn, ctr, max_distance=max_distance)
    builder = general_faces if faces == "general" else star_faces
    if vertices == "fit":
        return _fit_with_valid_faces(
            cplx,
            q[clean.fit_mask],
            clean.labels[clean.fit_mask],
            pn,
            ctr,
            lsq,
            anchor_weight,
            max_iter,
            builder,
            clean.centroids,
        )
    mv = lsq
    if vertices == "optimize":
        mv = optimize_vertices(cplx, q, pn, ctr, weight=weight, max_iter=max_iter, lsq=lsq)
    face_list = builder(
        cplx, np.asarray(mv.positions), np.asarray(mv.plane_normals), clean.centroids
    )
    return mv, face_list, float("nan")


def _assemble(frame, q, clean, mv, face_list, faces, used_weight, point_index, n_input):
    """The SimplifiedMesh in input coordinates from the working-frame results (private)."""
    cplx = clean.complex
    if not face_list:
        raise PointAtlasError(
            "no region has a closed boundary cycle; cannot build faces "
            f"({cplx.n_vertices} vertices, {cplx.n_edges} edges)"
        )
    positions = np.asarray(mv.positions)
    plane_n = np.asarray(mv.plane_normals)
    used = np.unique(np.concatenate([np.concatenate(f.loops) for f in face_list]))
    remap = np.full(cplx.n_vertices, -1, dtype=np.int64)
    remap[used] = np.arange(used.size)
    verts = positions[used]
    face_loops, polygons, polygon_face, tris, tri_face = [], [], [], [], []
    for fi, f in enumerate(face_list):
        loops = tuple(remap[lp] for lp in f.loops)
        face_loops.append(loops)
        t = remap[f.triangles] if f.triangles.size else np.zeros((0, 3), np.int64)
        tris.append(t)
        tri_face.append(np.full(t.shape[0], fi, dtype=np.int64))
        if len(loops) == 1:
            polygons.append(loops[0])
            polygon_face.append(fi)
        else:
            for row in t:
                polygons.append(row.copy())
                polygon_face.append(fi)
    triangles = np.concatenate(tris).astype(np.int64) if tris else np.zeros((0, 3), np.int64)
    triangle_face = np.concatenate(tri_face) if tri_face else np.zeros(0, np.int64)
    closed, manifold, oriented = mesh_checks(verts.shape[0], triangles)
    if triangles.shape[0]:
        dist = point_mesh_distance(q, verts, triangles) * frame.scale
    else:
        dist = np.full(q.shape[0], np.inf)
    with_face = {f.region for f in face_list}
    n_regions = plane_n.shape[0]
    return SimplifiedMesh(
        vertices=frame.to_input(verts),
        vertex_ids=used.astype(np.int64),
        polygons=tuple(np.asarray(p, dtype=np.int64) for p in polygons),
        polygon_face=np.asarray(polygon_face, dtype=np.int64),
        face_region=np.array([f.region for f in face_list], dtype=np.int64),
        face_loops=tuple(face_loops),
        face_ok=np.array([f.ok for f in face_list], dtype=bool),
        planarity_error=np.array([_planarity(verts, lp) for lp in face_loops]) * frame.scale,
        triangles=triangles,
        triangle_face=triangle_face,
        is_closed=closed,
        is_manifold=manifold,
        is_oriented=oriented,
        distances=dist,
        mean_distance=float(dist.mean()),
        max_distance=float(dist.max()),
        vertex_method=mv.method,
        face_method=faces,
        fallback=mv.fallback,
        constraint_violation=float(mv.constraint_violation),
        n_guarded=int(mv.guarded[used].sum()),
        regions_without_face=np.array(
            [i for i in range(n_regions) if i not in with_face], dtype=np.int64
        ),
        plane_normals=plane_n,
        plane_offsets=frame.offsets_to_input(plane_n, mv.plane_offsets),
        labels=clean.labels,
        region_map=clean.input_map,
        complex=dataclasses.replace(cplx, vertex_anchor=frame.to_input(cplx.vertex_anchor)),
        anchor_weight=used_weight,
        point_index=point_index,
        n_dropped=int(n_input - point_index.size),
    )
