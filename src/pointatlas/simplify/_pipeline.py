"""Segment with VSA, then simplify (the thesis' pipeline, Fig. 4.4 and 4.4)."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from .._core import PointAtlasError, as_float, as_int, as_labels, readonly
from ._checks import STRAY_DROP, STRAY_NOISE
from ._mesh import SimplifiedMesh
from ._points_input import PreparedPoints, prepare_points
from ._proxies import region_proxies
from ._reconstruct import robust_mesh
from ._segmentation import simplify_segmentation
from ._surface import SurfaceSimplification

if TYPE_CHECKING:  # pragma: no cover
    from ..segment import VSAOptions, VSAResult

__all__ = ["PointSimplification", "simplify_points"]


@dataclass(frozen=True, slots=True)
class PointSimplification:
    """Result of `simplify_points`: the VSA segmentation and the simplified mesh.

    Attributes
    ----------
    segmentation : VSAResult or None
        VSA segmentation of the points used (``point_index``); None when the
        labels were given.
    mesh : SimplifiedMesh
        The simplified mesh; its ``point_index`` and ``n_dropped`` refer to the
        input points too.
    point_index : ndarray of shape (M,), int64
        Input index of every point used: points whose normal is zero-length or
        has a NaN/Inf entry are left out, and so are repeated positions
        (``n_repeated``) and points far off the surface the others sample
        (``n_off_surface``).
    n_dropped : int
        Number of input points left out.
    path : str
        ``"thesis"`` (the surface-like complex, thesis 4.4: ``mesh`` is a
        `SimplifiedMesh`) or ``"robust"`` (the points' surface by inside/outside on a
        voxel grid, then the mesh path: ``mesh`` is a `SurfaceSimplification` whose
        ``distances`` are the points').
    reason : str
        Why the robust path was taken ("" on the thesis path).
    labels : ndarray of shape (M,), int64
        Face region of every point used (the thesis' ``mesh.labels``, or the region
        of the point's nearest triangle on the robust path).
    n_turned : int
        Normals turned to the outside before anything else: where the normals'
        dipole sum says open but their outward sides, asked of a voxel grid, make
        the sample closed (estimated normals whose orientation crossed a thin wall;
        that vote checked by `outward_normals`' steps, whose turns it replaces;
        docs/decisions/simplify.md, "Normals turned to the outside"), or every
        normal where they close the sample but enclose a negative volume.
    n_off_surface : int
        Points left out because they lie far off the surface the others sample
        (outliers: the median of their heights over their 8 nearest points' tangent
        planes over `_checks.OFF_SURFACE` point spacings; on the robust path also
        stray returns its voxel surface does not reach, `_checks.STRAY_DROP`); counted
        in ``n_dropped``.
    n_repeated : int
        Points left out because an earlier point has the same position (a merged
        scan's overlap, mesh vertices written once per face; the first one's normal is
        used); counted in ``n_dropped``.
    """

    segmentation: VSAResult | None
    mesh: SimplifiedMesh | SurfaceSimplification
    point_index: np.ndarray
    n_dropped: int
    path: str = "thesis"
    reason: str = ""
    labels: np.ndarray | None = None
    n_turned: int = 0
    n_off_surface: int = 0
    n_repeated: int = 0

    def __post_init__(self):
        readonly(self.point_index)
        if self.labels is None:
            object.__setattr__(self, "labels", np.asarray(self.mesh.labels))
        readonly(self.labels)

    def summary(self) -> dict:
        """The mesh's report with the path taken and why."""
        return {
            **self.mesh.summary(),
            "path": self.path,
            "path_reason": self.reason,
            "normals_turned": self.n_turned,
            "points_off_surface": self.n_off_surface,
            "points_repeated": self.n_repeated,
        }


def simplify_points(
    points,
    normals,
    *,
    vsa: VSAOptions | None = None,
    rng=None,
    vertices: str = "fit",
    faces: str = "general",
    centers: str = "centroid",
    weight: float = 1.0,
    anchor_weight: float | None = None,
    min_region_size: int | None = None,
    repair: bool = True,
    smooth: int = 2,
    max_boundary_fraction: float = 0.95,
    path: str = "auto",
    labels=None,
    max_error: float | None = None,
    max_triangles: int | None = None,
    **vsa_settings,
) -> PointSimplification:
    """Segment a point set by VSA and build its simplified polygon mesh.

    Parameters
    ----------
    points : array_like of shape (N, 3), float64
        Coordinates.
    normals : array_like of shape (N, 3), float64
        Oriented normals. Points whose normal is zero-length or has a NaN/Inf entry,
        or at an earlier point's position, are left out (``n_dropped``).
    vsa : VSAOptions, optional
        The segmentation's settings (`pointatlas.segment.VSAOptions`, default
        ``VSAOptions()``); its ``k`` (thesis: 8; 12 with noise; 1 <= k <= the
        number of points used) is also the neighbourhood size of the complex.
    rng : None, int or numpy.random.Generator
        Passed to `pointatlas.segment.vsa_segment` (draws a number of random seeds).
    vertices, faces, centers, weight, anchor_weight, min_region_size, repair, smooth,
    max_boundary_fraction
        Passed to `simplify_segmentation`; ``centers="seed"`` uses the VSA seed
        points C_i.
    path : {"auto", "thesis", "robust"}
        ``"thesis"``: the surface-like complex only (errors as
        `simplify_segmentation`). ``"robust"``: the points' surface on a voxel grid
        (marching cubes), fitted to the points' tangent planes and decimated as on
        the mesh path (docs/decisions/simplify.md). ``"auto"`` (default): the robust
        one above `AUTO_THESIS_POINTS` points or `AUTO_THESIS_REGIONS` regions, or for
        a level of detail; else the thesis path, and the robust one when its mesh
        fails, is not manifold and oriented with valid faces, is open where the
        points' surface is closed or is far from the points; ``path`` and ``reason``
        say which and why.
    labels : array_like of shape (N,), int, optional
        A segmentation to use instead of VSA's (e.g. the ``label`` field written by
        ``pointatlas segment``): regions are renumbered 0..R-1 in order of their
        values and their proxy planes computed (`region_proxies`);
        ``segmentation`` is then None. Labels must be >= 0.
    **vsa_settings
        Fields of `pointatlas.segment.VSAOptions` given one by one (``k``,
        ``seeds``, ``eta``, ``max_angle``, ``split``, ``merge``, ``switch``,
        ``classic``, ``weights``, ``max_iter``); they override those of ``vsa``.
    max_error, max_triangles : float, int, optional
        Robust path: largest distance both ways (points to the output, its samples to
        the points' tangent discs; default 0.5 % of the diagonal, or what the points'
        surface itself reaches), or a triangle budget instead.

    Returns
    -------
    result : PointSimplification
        ``segmentation`` (VSAResult), ``mesh`` (SimplifiedMesh, or
        SurfaceSimplification on the robust path), ``path``, ``reason``, ``labels``,
        ``point_index`` and ``n_dropped`` (points left out: without a usable normal,
        repeated, ``n_repeated``, or off the surface, ``n_off_surface``).

    Raises
    ------
    ValueError
        Bad shapes or options.
    TypeError
        Non-numeric arrays, non-integer ``k``.
    PointAtlasError
        Too few points ("simplify needs at least 4 points", or fewer than ``k``),
        points on one line, more memory than available for this ``k`` (estimated
        before any work), no point with a usable normal, or a degenerate
        segmentation (see `simplify_segmentation`).

    Notes
    -----
    Thesis Fig. 4.4: segmentation (4.2-4.3), complex (3), vertices (4.4.1), faces
    (4.4.2). The proxy planes are the VSA proxies (normal N_i through the centroid,
    Eq. 4.7, or through the seed point C_i). The neighbourhoods of the meshing
    steps are found in the room's working coordinates (centred and scaled, see
    `simplify_segmentation`); VSA itself sees the points as given.

    Examples
    --------
    >>> from pointatlas.synth import cube
    >>> m = cube(6)
    >>> r = simplify_points(m.vertices, m.normals, max_angle=0.3)
    >>> r.mesh.n_faces, r.mesh.n_vertices, r.mesh.is_closed, r.n_dropped
    (6, 8, True, 0)
    """
    level = _level(max_error, max_triangles)
    path, reason = _path_of(path, level)
    inp, first = _surface_first(path, points, normals, vsa, vsa_settings)
    seg, seg_labels, seg_normals, ctr = _segment(inp, labels, centers, rng)
    path, reason = _auto_choice(path, reason, inp.points.shape[0], seg_labels)
    settings = {
        "vertices": vertices,
        "faces": faces,
        "centers": ctr,
        "weight": weight,
        "anchor_weight": anchor_weight,
        "min_region_size": min_region_size,
        "repair": repair,
        "smooth": smooth,
        "max_boundary_fraction": max_boundary_fraction,
    }
    mesh, reason = _thesis_mesh(inp, seg_labels, seg_normals, path, reason, settings)
    if mesh is not None and not reason:
        return _result(inp, seg, mesh)
    return _robust_result(inp, seg, seg_labels, seg_normals, mesh, reason, level, first)


#: ``path="auto"`` tries the thesis path first up to this many points (with normals);
#: beyond, the robust path at once: on every 3rd collection model sampled with 20,000
#: points the thesis path's mesh was kept on none of 50 and took about half the time.
#: The thesis' own inputs (the bundled synth:octahedron's 16,386 points, fandisk's
#: 12,494 vertices in the demo) stay below.
AUTO_THESIS_POINTS = 17_000

#: The thesis path's mesh stands only within this share of the diagonal of the points,
#: both ways (else the robust path: 100 sparse sphere points gave a closed 6-face mesh
#: 13 % of the diagonal off; fandisk's and the noisy dodecahedron's are 3-4 % off).
THESIS_HAUSDORFF = 0.05


def _path_of(path: str, level: dict) -> tuple[str, str]:
    """The path to take and why the robust one (a level of detail is the robust
    path's)."""
    if path not in ("auto", "thesis", "robust"):
        raise ValueError(f"path must be 'auto', 'thesis' or 'robust'; got {path!r}")
    if path == "auto" and any(v is not None for v in level.values()):
        return "robust", "a level of detail was asked for (the robust path's)"
    return path, "path='robust' was asked for"


#: ... and with more than this many regions (VSA's, or the labels given) the robust
#: path at once: over the bundled models and every 25th collection model sampled with
#: 2,000-16,000 points the thesis mesh was kept with at most 116 regions and never
#: with more, and a failed attempt took a median 67 % of its run (23-94 %)
#: (benchmarks/bench_simplify_auto.py, docs/decisions/simplify.md).
AUTO_THESIS_REGIONS = 128


def _auto_choice(path: str, reason: str, n_points: int, labels) -> tuple[str, str]:
    """``auto`` goes to the robust path at once above `AUTO_THESIS_POINTS` points or
    `AUTO_THESIS_REGIONS` regions."""
    n_regions = int(labels.max()) + 1 if labels.size else 0
    if path == "auto" and n_points > AUTO_THESIS_POINTS:
        return "robust", (
            f"{n_points:,} points: the thesis path is tried up to "
            f"{AUTO_THESIS_POINTS:,} (path='thesis' forces it)"
        )
    if path == "auto" and n_regions > AUTO_THESIS_REGIONS:
        return "robust", (
            f"{n_regions} regions: the thesis path is tried up to {AUTO_THESIS_REGIONS} "
            "(path='thesis' forces it)"
        )
    return path, reason


def _level(max_error, max_triangles) -> dict:
    """The robust path's level of detail, checked."""
    if max_error is not None and max_triangles is not None:
        raise ValueError("give at most one of max_error and max_triangles")
    if max_error is not None:
        max_error = as_float(max_error, "max_error", lo=0.0, lo_open=True)
    if max_triangles is not None:
        max_triangles = as_int(max_triangles, "max_triangles", lo=1)
    return {"max_error": max_error, "max_triangles": max_triangles}


def _result(inp: PreparedPoints, seg, mesh, **robust) -> PointSimplification:
    """The `PointSimplification` of ``mesh`` with the points used."""
    point_index = inp.point_index
    return PointSimplification(
        segmentation=seg,
        mesh=mesh,
        point_index=point_index,
        n_dropped=inp.n_input - point_index.size,
        n_turned=inp.n_turned,
        n_off_surface=inp.n_off_surface,
        n_repeated=inp.n_repeated,
        **robust,
    )


def _surface_first(path: str, points, normals, vsa, vsa_settings):
    """``(inp, first)``: the input prepared (`prepare_points`) and, on the robust path
    (``path`` "robust", or "auto" above `AUTO_THESIS_POINTS` points), its voxel surface
    (`reconstruct_surface`) built before the points are segmented, with its tree and
    `PointSurface`; where it leaves stray returns it does not reach (`lost_strays`),
    the input prepared again without them and the surface moved into its working
    frame. Elsewhere ``first`` is None."""
    inp = prepare_points(points, normals, vsa, vsa_settings)
    if not (path == "robust" or (path == "auto" and inp.points.shape[0] > AUTO_THESIS_POINTS)):
        return inp, None
    from scipy.spatial import cKDTree

    from ._distance import PointSurface
    from ._reconstruct import reconstruct_surface
    from ._voxel_grid import LOST_LINK, lost_strays, point_spacing

    q, nrm = inp.q, inp.normals
    tree = cKDTree(q)
    surface = PointSurface(q, nrm, tree, inp.radius)
    rec = reconstruct_surface(q, nrm, inp.areas, tree, surface, inp.off_planes)
    off = inp.ratio > max(STRAY_DROP, STRAY_NOISE * float(np.median(inp.ratio)))
    link = LOST_LINK * point_spacing(q, tree)
    strays = lost_strays(q, rec.vertices, rec.triangles, rec.step, off, link, rec.distance_index())
    if not strays.any():
        return inp, (tree, surface, rec)
    mask = np.zeros(inp.n_input, dtype=bool)
    mask[inp.point_index[strays]] = True
    out = prepare_points(points, normals, vsa, vsa_settings, strays=mask)
    # the surface does not reach the strays: it stands, in the new working frame
    old, new = inp.frame, out.frame
    rec = dataclasses.replace(
        rec,
        vertices=new.to_local(old.to_input(rec.vertices)),
        step=rec.step * old.scale / new.scale,
    )
    tree = cKDTree(out.q)
    return out, (tree, PointSurface(out.q, out.normals, tree, out.radius), rec)


def _segment(inp: PreparedPoints, labels, centers, rng):
    """VSA (or the given labels): (VSAResult or None, labels, proxy normals, centers)."""
    from ..segment import vsa_segment

    if not (isinstance(centers, str) and centers in ("seed", "centroid")):
        raise ValueError(f"centers must be 'centroid' or 'seed'; got {centers!r}")

    if labels is None:
        # the k-NN table of `prepare_points` (the working frame's: the same as VSA's own)
        seg = vsa_segment(
            inp.points, inp.normals, options=inp.options, rng=rng, neighbors=inp.indices
        )
        seg_labels, seg_normals = np.asarray(seg.labels), np.asarray(seg.proxy_normals)
        if centers == "seed":
            ctr = seg.seed_points
        else:
            ctr = _centroids(
                inp.frame, inp.q, inp.normals, seg, inp.options.weights, inp.k, inp.indices
            )
        return seg, seg_labels, seg_normals, ctr
    given = as_labels(labels, inp.n_input)
    if (given < 0).any():
        raise ValueError(f"labels must be >= 0; {int((given < 0).sum())} points are unassigned")
    _, seg_labels = np.unique(given[inp.keep], return_inverse=True)
    seg_labels = seg_labels.reshape(-1).astype(np.int64)
    prox = region_proxies(inp.q, inp.normals, seg_labels)
    ctr = inp.frame.to_input(prox.seed_points) if centers == "seed" else "centroid"
    return None, seg_labels, np.asarray(prox.normals), ctr


def _thesis_mesh(inp: PreparedPoints, seg_labels, seg_normals, path, reason, settings):
    """The thesis path's mesh and why it is not kept: (mesh or None, reason; "" when
    it is kept); (None, ``reason``) on the robust path."""
    if path == "robust":
        return None, reason
    try:
        mesh = simplify_segmentation(
            inp.points,
            inp.normals,
            seg_labels,
            k=inp.k,
            proxy_normals=seg_normals,
            neighbors=inp.indices,
            **settings,
        )
    except PointAtlasError as exc:
        if path == "thesis":
            raise
        return None, f"thesis path: {exc}"
    point_index = inp.point_index
    mesh = dataclasses.replace(
        mesh, point_index=point_index, n_dropped=inp.n_input - point_index.size
    )
    # Eq. 4.12 (``vertices="optimize"``) pulls vertices to the region centres by
    # design (the thesis' own result shrinks): its distance is not a flaw
    far = settings["vertices"] != "optimize"
    return mesh, (_thesis_flaw(mesh, far) if path == "auto" else "")


def _robust_result(
    inp: PreparedPoints, seg, seg_labels, seg_normals, mesh, reason, level, first=None
):
    """The robust path's result, or the open thesis mesh where the points' surface is
    open too and the thesis mesh is as near to the points (``first``: the voxel
    surface found already, `_surface_first`)."""
    try:
        res, rec, point_labels = robust_mesh(
            inp.q,
            inp.normals,
            seg_labels,
            seg_normals,
            inp.frame,
            areas=inp.areas,
            neighbors=inp.indices,
            radius=inp.radius,
            off=inp.off_planes,
            first=first,
            **level,
        )
    except PointAtlasError as exc:
        if mesh is None or "degenerate" in reason or not mesh.is_closed:
            raise PointAtlasError(f"{exc}; and {reason}") from None
        import warnings

        from ._vertices import SimplifyWarning

        warnings.warn(f"{reason}, kept: {exc}", SimplifyWarning, stacklevel=3)
        return _result(inp, seg, mesh)
    if (
        mesh is not None
        and reason.startswith("open")
        and rec.n_trimmed > 0
        and mesh.distance_mean <= res.distance_mean
    ):
        # the points' surface is open too, and the thesis mesh is as near: it stands
        return _result(inp, seg, mesh)
    if reason.startswith("open") and rec.n_trimmed == 0:
        reason = "thesis path: the mesh has boundary edges where the points' surface is closed"
    elif reason.startswith("open"):
        reason = "thesis path: the open mesh is farther from the points than the robust one"
    if rec.n_handles:
        reason += (
            f"; {rec.n_handles} small handle{'s' * (rec.n_handles > 1)} of the points' "
            "surface cut (a gap thinner than its grid step bridged)"
        )
    if rec.uneven > 1.0:
        reason += (
            f"; the points are sampled unevenly: the grid's spacing {rec.uneven:.2f} x "
            "their median one"
        )
    if rec.n_trimmed:  # an open sample (a sheet, a scan that misses a side)
        reason += "; the points close no surface: the mesh is open, cut where they end"
    return _result(inp, seg, res, path="robust", reason=reason, labels=point_labels)


def _thesis_flaw(mesh: SimplifiedMesh, far: bool = True) -> str:
    """Why a thesis-path mesh is not kept ("" when it is); ``far``: also when it is
    farther than `THESIS_HAUSDORFF` from the points."""
    if not (mesh.is_manifold and mesh.is_oriented):
        return "thesis path: the mesh is not manifold and oriented"
    if not mesh.face_ok.all():
        return f"thesis path: {int((~mesh.face_ok).sum())} faces are not valid polygons"
    v, t = np.asarray(mesh.vertices), np.asarray(mesh.triangles)
    diag = float(np.linalg.norm(np.ptp(v, axis=0))) if v.size else 0.0
    area = 0.5 * np.linalg.norm(np.cross(v[t[:, 1]] - v[t[:, 0]], v[t[:, 2]] - v[t[:, 0]]), axis=1)
    if (area <= 1e-12 * diag**2).any():
        return f"thesis path: {int((area <= 1e-12 * diag**2).sum())} degenerate triangles"
    off = mesh.hausdorff
    if far and off > THESIS_HAUSDORFF * diag:
        return (
            f"thesis path: the mesh is {100 * off / diag:.2g} % of the diagonal from the "
            f"points (more than {100 * THESIS_HAUSDORFF:g} %)"
        )
    if not mesh.is_closed:
        return "open: the thesis mesh has boundary edges"
    return ""


def _centroids(frame, q, normals, seg, weights, k, indices):
    """The VSA regions' (weighted) centroids, summed in the working frame.

    ``VSAResult.centroids`` sums the coordinates as given: far from the origin
    (1e8) the sums lose ~1e-8 absolute accuracy, which would move the mesh. Uniform
    weights: ``"centroid"`` (`simplify_segmentation` sums in its frame itself);
    other weights: the same weighted means in the frame, mapped back.
    """
    if isinstance(weights, str) and weights == "uniform":
        return "centroid"
    if isinstance(weights, str) and weights == "area":
        from ..segment import area_weights

        w = area_weights(q, k=k, neighbors=indices)
    else:
        w = np.asarray(weights, dtype=np.float64)
    return frame.to_input(region_proxies(q, normals, seg.labels, weights=w).centroids)
