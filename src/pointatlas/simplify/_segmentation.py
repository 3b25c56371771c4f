"""The simplified polygon mesh of a segmented point set: the thesis path (thesis 4.4).

`simplify_segmentation` runs four steps: check the input and leave out points
without a usable normal (`_usable_input`); move to the working frame and find the
start planes (`_start_planes`); clean the regions and build the surface-like complex
(section 3, Eqs. 3.1-3.2; `clean_regions`); place the vertices (4.4.1), build the
faces (4.4.2) and assemble the mesh (``_assemble.py``).

Every step runs on centred coordinates scaled by a power of two (at least the
bounding-box diagonal) and the results are mapped back, so the mesh moves with
translations and scalings of the input and all tolerances are relative to its size.
Vertex methods: (a) ``"lsq"``, least squares over all planes of a vertex with a
near-parallel guard and a distance bound (Fig. 4.11's outliers); (b)
``"optimize"``, Eq. 4.12 started from N_i and the barycentre of the C_i; (c)
``"fit"`` (beyond the thesis), Eq. 4.12's incidence constraints n_i . x_j = d_i,
|n_i| = 1 with free offsets d_i, minimising the points' mean squared distance to
their planes plus ``anchor_weight`` times the vertices' mean squared displacement
from (a). Faces: [SZP20]'s star-convex ordering or the general method of 4.4.2.
Decisions in docs/decisions/simplify.md ("The thesis path").
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._core import PointAtlasError, as_labels, as_normals, as_points, check_neighbors
from .._core._deprecation import renamed_keywords
from ..neighbors import query_knn
from ._assemble import assemble_mesh, place_vertices
from ._checks import check_memory, check_size, usable_normals
from ._frame import frame_of
from ._mesh import SimplifiedMesh
from ._proxies import check_not_parallel, region_proxies
from ._repair import clean_regions

__all__ = ["simplify_segmentation"]

_VERTEX_METHODS = ("fit", "lsq", "optimize")
_FACE_METHODS = ("general", "star")


@renamed_keywords(indices="neighbors")
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
    neighbors=None,
) -> SimplifiedMesh:
    """Build the simplified polygon mesh of a segmented point set (thesis 4.4).

    Parameters
    ----------
    points : array_like of shape (N, 3), float64
        Coordinates.
    normals : array_like of shape (N, 3), float64 or None
        Normals (rescaled to unit length); points with a zero-length or NaN/Inf one
        are left out (``n_dropped``). None: ``proxy_normals`` and ``centers`` (an
        array) are used as they are (no smoothing, merging or repair).
    labels : array_like of shape (N,), int64
        Region of every point, consecutive 0..R-1 (e.g. ``VSAResult.labels``).
    k : int
        Neighbourhood size of the region adjacency (Remark 6), 1 <= k <= points used.
    vertices : {"fit", "lsq", "optimize"}
        ``"fit"`` (default, beyond the thesis): planes refitted to their points with
        every vertex on all its planes, so every face is planar; ``"lsq"``: plane
        intersection by guarded least squares; ``"optimize"``: Eq. 4.12.
    faces : {"general", "star"}
        Faces from the boundary cycles (holes allowed), or star-convex ordering.
    centers : {"centroid", "seed"} or array_like of shape (R, 3)
        Point C_i of every proxy plane: the region centroid (default, Eq. 4.7), the
        VSA seed point, or given points.
    proxy_normals : array_like of shape (R, 3), optional
        Proxy normals N_i; by default the normalised sum of each region's normals.
    weight : float
        w~_i of Eq. 4.11 (>= 0; 1 in the thesis); ``vertices="optimize"`` only.
    anchor_weight : float, optional
        ``vertices="fit"`` only (> 0): pull of the vertices to the least-squares ones
        against the points' plane distances; default: the loosest of 0.01, 0.1, 1,
        10 with valid faces and a closed, manifold, oriented mesh.
    max_distance : float, optional
        Largest distance of a least-squares vertex from its witness points (input units;
        default: half the distance to the nearest region centroid, >= 2 x their spread).
    min_region_size : int, optional
        Smaller regions merge into their most similar neighbour (default ``k``; 1: none).
    repair : bool
        Merge regions whose boundary does not close into cycles into their most
        similar neighbour and rebuild the complex (beyond the thesis; <= 30 rounds).
    smooth : int
        Passes of a k-NN majority filter on the labels (0 keeps them as given);
        regions split by it become separate regions.
    max_boundary_fraction : float
        With ``repair``: thin strips (regions below half the largest size with more than
        this fraction of points next to another region) merge first; 1 disables.
    max_iter : int
        Iteration limit of the Eq. 4.12 optimisation.
    neighbors : ndarray of shape (N, m), int, or tuple, optional
        Precomputed neighbour table, e.g. `pointatlas.neighbors.query_knn`'s result
        (the point itself first; the first ``k`` of m >= k columns are used; checked by
        `pointatlas._core.check_neighbors`); unused if points are left out. None
        queries the k nearest neighbours. ``indices=`` is its former name (deprecated).

    Returns
    -------
    mesh : SimplifiedMesh
        The mesh, its triangulation, quality report, complex and points used.

    Raises
    ------
    ValueError, TypeError
        Bad shapes, types or options.
    PointAtlasError
        Fewer than 4 or ``k`` points, too little memory (estimated first), no usable
        normal (in a region), fewer than three regions, no vertex of three regions,
        all proxy planes parallel, or no region with a closed boundary.

    Warns
    -----
    SimplifyWarning
        ``vertices="optimize"`` or ``"fit"`` failed: plane intersection is used
        (``fallback`` True).

    Notes
    -----
    Vertices 4.4.1 (Eq. 4.12), faces 4.4.2, complex section 3. Steps, methods and
    decisions: this module's docstring and docs/decisions/simplify.md.

    Examples
    --------
    >>> from pointatlas.synth import cube
    >>> m = cube(6)
    >>> s = simplify_segmentation(m.vertices, m.normals, m.labels)
    >>> s.n_vertices, s.n_faces, s.is_closed, [len(p) for p in s.polygons]
    (8, 6, True, [4, 4, 4, 4, 4, 4])
    """
    weight, anchor_weight = _check_settings(vertices, faces, weight, anchor_weight, max_distance)
    inp = _usable_input(points, labels, normals, k, proxy_normals, centers, neighbors)
    smooth, repair, min_region_size = _clean_settings(
        normals, smooth, repair, min_region_size, inp.k
    )
    frame, q, pn0, ctr0, nbrs = _start_planes(inp, proxy_normals, centers)
    clean = clean_regions(
        q,
        inp.normals,
        inp.labels,
        nbrs,
        pn0,
        ctr0,
        k=inp.k,
        smooth=smooth,
        min_region_size=min_region_size,
        repair=repair,
        max_boundary_fraction=max_boundary_fraction,
    )
    mv, face_list, used_weight = place_vertices(
        clean,
        q,
        vertices=vertices,
        faces=faces,
        weight=weight,
        anchor_weight=anchor_weight,
        max_distance=None if max_distance is None else float(max_distance) / frame.scale,
        max_iter=max_iter,
    )
    return assemble_mesh(frame, q, clean, mv, face_list, faces, used_weight, inp)


def _check_choice(value, name, choices):
    if value not in choices:
        raise ValueError(f"{name} must be one of {', '.join(choices)}; got {value!r}")
    return value


def _check_settings(vertices, faces, weight, anchor_weight, max_distance):
    """Check the method names and numbers; returns (weight, anchor_weight) as floats."""
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
    return weight, anchor_weight


def _clean_settings(normals, smooth, repair, min_region_size, k: int):
    """(smooth, repair, min_region_size) checked; without normals the given proxies
    are used as they are and no region is merged."""
    if normals is None:
        return 0, False, 1
    if min_region_size is None:
        min_region_size = k
    if isinstance(min_region_size, bool) or int(min_region_size) < 1:
        raise ValueError(f"min_region_size must be an integer >= 1; got {min_region_size}")
    return smooth, repair, min_region_size


@dataclass(frozen=True, slots=True)
class _Input:
    """The points used (those with a usable normal), their labels and normals."""

    points: np.ndarray
    labels: np.ndarray
    normals: np.ndarray
    keep: np.ndarray  # (N_input,) bool: the point is used
    k: int
    n_regions: int
    indices: np.ndarray | None  # the given k-NN table, None when points were left out


def _usable_input(points, labels, normals, k, proxy_normals, centers, neighbors) -> _Input:
    """Check the points, labels, normals and neighbour table; leave out points without a
    usable normal."""
    pts = as_points(points)
    n_input = pts.shape[0]
    lab = as_labels(labels, n_input)
    k = check_size(n_input, k)
    indices = None if neighbors is None else check_neighbors(neighbors, n_input, k=k)
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
        pn_given = np.asarray(proxy_normals, dtype=np.float64)
        if pn_given.shape != (n_regions, 3):
            raise ValueError(
                f"proxy_normals must have shape ({n_regions}, 3); got {pn_given.shape}"
            )
        nrm, keep = as_normals(pn_given[lab]), np.ones(n_input, dtype=bool)
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
    return _Input(pts, lab, nrm, keep, k, n_regions, indices)


def _start_planes(inp: _Input, proxy_normals, centers):
    """The working frame, the points in it, the start proxy normals N_i and plane
    points C_i there, and the k-NN table (after the memory check)."""
    check_memory(inp.points.shape[0], inp.k, inp.n_regions)
    frame = frame_of(inp.points)
    q = frame.to_local(inp.points)
    proxies = region_proxies(q, inp.normals, inp.labels)
    n_regions = inp.n_regions
    if proxy_normals is None:
        pn0 = np.array(proxies.normals)
    else:
        pn0 = np.asarray(proxy_normals, dtype=np.float64)
        if pn0.shape != (n_regions, 3) or not np.isfinite(pn0).all():
            raise ValueError(f"proxy_normals must have shape ({n_regions}, 3); got {pn0.shape}")
        pn0 = pn0 / np.linalg.norm(pn0, axis=1, keepdims=True)
    ctr0 = _resolve_centers(centers, proxies, n_regions, frame)
    check_not_parallel(pn0)
    nbrs = query_knn(q, inp.k)[0] if inp.indices is None else inp.indices
    return frame, q, pn0, ctr0, np.asarray(nbrs, dtype=np.int64)


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
