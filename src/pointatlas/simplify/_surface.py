"""The simplified mesh of a labelled triangle mesh: one face per region (private).

The robust path beside the thesis' surface-like complex
(docs/decisions/simplify.md). When the input is a triangle mesh its faces already
form a surface, so the segmentation runs on the faces (VSA with face normals, area
weights and the edge adjacency of the faces) and every region is a connected set of
faces. Its boundary is a set of closed loops of mesh edges; the loops split into
arcs at *anchors* (mesh vertices where three or more regions meet, the input's
boundary counting as a region) and every arc is simplified once, by Douglas-Peucker
with a chord tolerance, so that the two regions beside it share the same chord
vertices. Each region then becomes one face: its loops projected to the region's
plane and triangulated (earcut). Nothing is invented: every output vertex is an
input vertex, so the output is a closed manifold whenever each region's projected
loops bound a valid planar polygon. Where they do not, the region's arcs are refined
(tolerance halved, down to the full arcs) and, if that is not enough, the region
keeps its input triangles — in the worst case the output is the input.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._core import as_float, as_points, readonly
from ._arcs import (
    MAX_REFINE,
    full_arc,
    refine_arc,
    region_loops,
    separate_parallel_chords,
    simplify_arc,
    split_arcs,
)
from ._crossings import crossing_pairs
from ._distance import back_distances
from ._mesh import unique_ints, unique_pairs
from ._place import FLAT_RTOL, flat_planes, place_on_planes, plane_fits, triangle_normals
from ._polygons import PLANAR_RTOL, face_polygons
from ._surface_faces import bad_regions, face_of_loops, loop_vertices
from ._triangles import _Surface, _surface

__all__ = ["SurfaceSimplification", "simplify_surface"]


@dataclass(frozen=True, slots=True)
class SurfaceSimplification:
    """A simplified polygon mesh of a triangle mesh and its quality report.

    Attributes
    ----------
    vertices : ndarray of shape (V, 3), float64
        Output vertices (a subset of the input vertices, unmoved).
    vertex_source : ndarray of shape (V,), int64
        Input vertex of every output vertex.
    polygons : tuple of ndarray of int64
        Polygons to write, each simple (distinct vertices, no hole) and planar
        (`face_polygons`): one per region face where its loop is both; else the
        face's triangles grouped into such pieces (a face with a hole, a pinched
        face, a curved region).
    polygon_face : ndarray of shape (P,), int64
        Face of every polygon.
    polygon_planarity : ndarray of shape (P,), float64
        Largest distance of each polygon's vertices to their least-squares plane.
    face_region : ndarray of shape (F,), int64
        Region of every face (F = number of regions; on the points path a flat
        face's triangles that kept it bent are a second face of its region, its
        *companion*, not flat: `_planar.bent_apart`).
    face_loops : tuple of tuple of ndarray of int64
        Per face: the outer loop then the holes (output vertex ids).
    face_kept_input : ndarray of shape (F,), bool
        The region's projected loops did not bound a planar polygon even with full
        arcs, so it kept its input triangles.
    planarity_error : ndarray of shape (F,), float64
        Largest distance of each face's vertices (all of its triangles') to their
        least-squares plane: the whole face, also where it is written in pieces (a
        curved region's face bends; its pieces are each planar).
    face_flat : ndarray of shape (F,), bool
        The face's region is flat in the input (its vertices within ``FLAT_RTOL`` of
        the diagonal of their plane, `flat_planes`; on the points path, the points'
        region lies near its plane): its face is meant to be planar.
    triangles : ndarray of shape (T, 3), int64
        Triangulation of all faces, oriented as the input.
    triangle_face : ndarray of shape (T,), int64
        Face of every triangle.
    is_closed, is_manifold, is_oriented : bool
        As `mesh_checks`.
    euler_characteristic : int
        V - E + F of the triangulation.
    face_labels : ndarray of shape (F_in,), int64
        Region of every input triangle.
    distances : ndarray of shape (N_in,), float64
        Distance of every input vertex to the output triangles (`simplify_mesh`: NaN
        for a vertex on no input triangle).
    distance_mean, distance_max : float
        Mean and largest of ``distances`` (NaN entries left out).
    back_distance_mean, back_distance_max : float
        Mean and largest distance of the output's vertices and a seeded area sample
        of its triangles to the input (`back_distances`): the other way round, which
        sees a spike. The two-sided Hausdorff distance is the larger of the maxima.
    chord_tolerance : float
        Chord tolerance used (input units).
    n_refined : int
        Regions whose arcs had to be refined beyond the chord tolerance.
    """

    vertices: np.ndarray
    vertex_source: np.ndarray
    polygons: tuple
    polygon_face: np.ndarray
    polygon_planarity: np.ndarray
    face_region: np.ndarray
    face_loops: tuple
    face_kept_input: np.ndarray
    planarity_error: np.ndarray
    face_flat: np.ndarray
    triangles: np.ndarray
    triangle_face: np.ndarray
    is_closed: bool
    is_manifold: bool
    is_oriented: bool
    euler_characteristic: int
    face_labels: np.ndarray
    distances: np.ndarray
    distance_mean: float
    distance_max: float
    back_distance_mean: float
    back_distance_max: float
    chord_tolerance: float
    n_refined: int

    def __post_init__(self):
        for name in (
            "vertices",
            "vertex_source",
            "polygon_face",
            "polygon_planarity",
            "face_region",
            "face_kept_input",
            "planarity_error",
            "face_flat",
            "triangles",
            "triangle_face",
            "face_labels",
            "distances",
        ):
            readonly(getattr(self, name))
        for p in self.polygons:
            readonly(p)

    @property
    def n_vertices(self) -> int:
        """Number of output vertices."""
        return int(self.vertices.shape[0])

    @property
    def n_faces(self) -> int:
        """Number of faces (one per region)."""
        return int(self.face_region.shape[0])

    @property
    def n_holes(self) -> np.ndarray:
        """Number of holes of every face, shape (F,)."""
        return np.array([max(len(lp) - 1, 0) for lp in self.face_loops], dtype=np.int64)

    @property
    def n_flat_faces_bent(self) -> int:
        """Faces of flat regions whose vertices lie farther than 1e-6 of the
        diagonal (of the output's box) from their least-squares plane."""
        diag = float(np.linalg.norm(np.ptp(self.vertices, axis=0))) if self.n_vertices else 0.0
        return int((self.face_flat & (self.planarity_error > 1e-6 * diag)).sum())

    @property
    def n_triangles_set_apart(self) -> int:
        """Triangles of the companions of flat faces: faces not flat of a region that
        has a flat face (`_planar.bent_apart`)."""
        companion = ~self.face_flat & np.isin(self.face_region, self.face_region[self.face_flat])
        return int(companion[self.triangle_face].sum())

    @property
    def hausdorff(self) -> float:
        """The two-sided Hausdorff distance: the larger of ``distance_max`` (the input
        to the output) and ``back_distance_max`` (the output back to the input)."""
        return max(self.distance_max, self.back_distance_max)

    @property
    def self_intersections(self) -> np.ndarray:
        """Pairs of output triangles that pass through each other, shape (P, 2)
        (`self_intersections`): what "closed, manifold, oriented" cannot see."""
        return crossing_pairs(self.vertices, self.triangles)

    def summary(self) -> dict:
        """A JSON-friendly report of the mesh and its quality."""
        return {
            "path": "surface",
            "n_vertices": self.n_vertices,
            "n_faces": self.n_faces,
            "n_polygons": len(self.polygons),
            "n_triangles": int(self.triangles.shape[0]),
            "n_faces_with_holes": int((self.n_holes > 0).sum()),
            "n_faces_kept_as_input_triangles": int(self.face_kept_input.sum()),
            "faces_kept_as_input_triangles": [int(x) for x in np.flatnonzero(self.face_kept_input)],
            "n_regions_refined": self.n_refined,
            "chord_tolerance": self.chord_tolerance,
            "is_closed": self.is_closed,
            "is_manifold": self.is_manifold,
            "is_oriented": self.is_oriented,
            "euler_characteristic": self.euler_characteristic,
            "n_self_intersections": int(self.self_intersections.shape[0]),
            "max_planarity_error": float(self.planarity_error.max(initial=0.0)),
            "max_polygon_planarity_error": float(self.polygon_planarity.max(initial=0.0)),
            "planarity_error": [float(x) for x in self.planarity_error],
            "n_flat_faces": int(self.face_flat.sum()),
            "max_flat_planarity_error": float(
                self.planarity_error[self.face_flat].max(initial=0.0)
            ),
            "n_flat_faces_bent": self.n_flat_faces_bent,
            "n_triangles_set_apart": self.n_triangles_set_apart,
            "distance_mean": self.distance_mean,
            "distance_max": self.distance_max,
            "back_distance_mean": self.back_distance_mean,
            "back_distance_max": self.back_distance_max,
            "hausdorff": self.hausdorff,
            "n_regions": self.n_faces,
        }


# --------------------------------------------------------------------------- the path


def _vertex_label_count(s: _Surface, labels: np.ndarray) -> np.ndarray:
    """Number of distinct regions around every vertex (the input's boundary counts one)."""
    n = s.vertices.shape[0]
    t = s.triangles
    pairs = unique_pairs(np.stack([t.reshape(-1), np.repeat(labels, 3)], axis=1))
    count = np.bincount(pairs[:, 0], minlength=n)
    open_edges = s.edge_verts[s.edge_faces[:, 1] < 0]
    on_border = np.zeros(n, dtype=bool)
    on_border[open_edges.reshape(-1)] = True
    return count + on_border


def _plane_offsets(s: _Surface, labels: np.ndarray, normals: np.ndarray) -> np.ndarray:
    """d_r of every region's plane N_r . x = d_r through its area-weighted centroid."""
    n_regions = normals.shape[0]
    w = s.areas + 1e-300
    wsum = np.bincount(labels, weights=w, minlength=n_regions)
    cen = (
        np.stack(
            [
                np.bincount(labels, weights=w * s.centroids[:, d], minlength=n_regions)
                for d in range(3)
            ],
            axis=1,
        )
        / np.maximum(wsum, 1e-300)[:, None]
    )
    return np.einsum("ij,ij->i", normals, cen)


def _planarize(v0, tri, tface, kept, normals, offsets, bound, *, weight=1e-3, rounds=4):
    """Move every vertex towards the planes of its planar faces (least squares with a
    small pull ``weight`` to where it was), by at most ``bound``.

    A vertex on three or more planes goes to (near) their intersection, on two to the
    nearest point of their line, on one onto the plane; vertices of regions that kept
    their input triangles only keep their place. A triangle that would flip or
    collapse against its face's normal puts its vertices back (repeated ``rounds``
    times), so the faces stay as valid as before.
    """
    n_v = v0.shape[0]
    planar = ~kept[tface]
    pv = tri[planar].reshape(-1)
    pf = np.repeat(tface[planar], 3)
    key = unique_ints(pv * (int(tface.max(initial=0)) + 1) + pf)
    pv, pf = key // (int(tface.max(initial=0)) + 1), key % (int(tface.max(initial=0)) + 1)
    nrm = normals[pf]
    mat = np.zeros((n_v, 3, 3))
    rhs = weight * v0
    mat[:, [0, 1, 2], [0, 1, 2]] = weight
    np.add.at(mat, pv, nrm[:, :, None] * nrm[:, None, :])
    np.add.at(rhs, pv, nrm * offsets[pf][:, None])
    x = np.linalg.solve(mat, rhs[:, :, None])[:, :, 0]
    disp = x - v0
    length = np.linalg.norm(disp, axis=1)
    scale = np.where(length > bound, bound / np.maximum(length, 1e-300), 1.0)
    x = v0 + disp * scale[:, None]
    x[length <= 1e-12 * max(bound, 1e-300)] = v0[length <= 1e-12 * max(bound, 1e-300)]
    before = triangle_normals(v0, tri)
    face_n = normals[tface]
    for _ in range(rounds):
        after = triangle_normals(x, tri)
        ok_before = np.einsum("ij,ij->i", before, face_n) > 0.0
        bad = ok_before & ~(np.einsum("ij,ij->i", after, face_n) > 0.0)
        if not bad.any():
            break
        back = unique_ints(tri[bad])
        x[back] = v0[back]
    return x


def simplify_surface(
    vertices,
    triangles,
    labels,
    proxy_normals,
    *,
    chord_tolerance: float,
    planarize: bool = False,
    flat_tolerance: float | None = None,
) -> SurfaceSimplification:
    """Build the simplified polygon mesh of a labelled triangle mesh (private API).

    ``labels`` (F,) are regions of the triangles, connected in the edge graph and
    numbered 0..R-1; ``proxy_normals`` (R, 3) their planes' normals;
    ``chord_tolerance`` the largest distance of a boundary arc's vertices to its
    chords (input units); ``planarize`` moves the output vertices towards the
    planes of their faces (at most ``chord_tolerance`` each, see `_planarize`);
    otherwise vertices are placed on the planes of their flat regions (those whose
    vertices lie within ``flat_tolerance`` of their plane, default ``FLAT_RTOL`` of
    the diagonal; `place_on_planes`). The polygons are simple and planar
    (`face_polygons`).
    """
    verts = as_points(vertices, name="vertices")
    tri = np.asarray(triangles, dtype=np.int64)
    lab = np.asarray(labels, dtype=np.int64)
    normals = np.asarray(proxy_normals, dtype=np.float64)
    tol = as_float(chord_tolerance, "chord_tolerance", lo=0.0)
    s = _surface(verts, tri)
    closed_input = bool((s.edge_faces >= 0).all())
    run = _RegionFaces(s, lab, normals, tol)
    run.refine()
    all_t, all_f, loops_out = run.settle(closed_input)
    used = unique_ints(all_t)
    remap = np.full(verts.shape[0], -1, dtype=np.int64)
    remap[used] = np.arange(used.size)
    out_t = remap[all_t]
    out_v = verts[used]
    diag = float(np.linalg.norm(np.ptp(out_v, axis=0))) if out_v.size else 0.0
    flat_tol = FLAT_RTOL * diag if flat_tolerance is None else flat_tolerance
    planes = flat_planes(verts, tri, lab, run.n_regions, flat_tol)
    if planarize and tol > 0.0:
        offsets = _plane_offsets(s, lab, normals)
        out_v = _planarize(out_v, out_t, all_f, run.kept_input, normals, offsets, tol)
    elif out_t.size:
        bound, exact = max(tol, 1e-3 * diag), 0.01 * PLANAR_RTOL * diag
        out_v = place_on_planes(out_v, out_t, all_f, *planes, bound, exact)
    face_loops = [tuple(remap[lp] for lp in loops) for loops in loops_out]
    diag = float(np.linalg.norm(np.ptp(out_v, axis=0))) if out_v.size else 0.0
    return surface_result(
        verts,
        tri,
        out_v,
        out_t,
        all_f,
        used,
        face_loops,
        labels=lab,
        kept_input=run.kept_input,
        flat=planes[2],
        planar_tol=PLANAR_RTOL * diag,
        chord_tolerance=run.tol,
        n_refined=len(run.refined),
    )


class _RegionFaces:
    """The steps of `simplify_surface` from the labels to one face per region: the
    boundary arcs (split at anchors and simplified once, so neighbours share their
    chords), the faces built from them, the arcs refined where a face fails, and the
    regions that keep their input triangles (private)."""

    def __init__(self, s: _Surface, lab: np.ndarray, normals: np.ndarray, tol: float):
        self.s, self.lab, self.normals, self.tol = s, lab, normals, tol
        verts = s.vertices
        loops = region_loops(s, lab)
        counts = _vertex_label_count(s, lab)
        self.arcs, self.loops_of_region = split_arcs(loops, counts, s, lab, tol)
        for arc in self.arcs:
            simplify_arc(arc, verts)
        separate_parallel_chords(self.arcs, verts)
        self.n_regions = n_regions = int(lab.max()) + 1 if lab.size else 0
        self.arcs_of = {
            r: sorted({aid for loop in self.loops_of_region[r] for aid, _ in loop})
            for r in self.loops_of_region
        }
        self.kept_input = np.zeros(n_regions, dtype=bool)
        no_boundary = [r for r in range(n_regions) if r not in self.loops_of_region]
        self.kept_input[no_boundary] = True
        self.refined: set[int] = set()
        self.faces: dict[int, tuple] = {}
        # per region the loops its face was last built from and the result (or None):
        # `face_of_loops` depends on nothing else, so a rebuild of unchanged loops
        # (settle rebuilds every region) reuses it
        self._built: dict[int, tuple] = {}

    def loops_of(self, r):
        """Region ``r``'s loops as lists of kept arc vertices."""
        return [loop_vertices(uses, self.arcs) for uses in self.loops_of_region[r]]

    def build(self, regions) -> list[int]:
        """Build the faces of ``regions`` (not kept as input); returns those that fail."""
        failed = []
        for r in regions:
            if self.kept_input[r]:
                continue
            loops = self.loops_of(r)
            key = tuple(tuple(loop) for loop in loops)
            cached = self._built.get(r)
            if cached is not None and cached[0] == key:  # same loops: the same face
                got = cached[1]
            else:
                got = face_of_loops(loops, self.s.vertices, self.normals[r])
                self._built[r] = (key, got)
            if got is None:
                failed.append(r)
            else:
                self.faces[r] = got
        return failed

    def keep_input(self, regions) -> set[int]:
        """Give regions their input triangles and full arcs; returns the neighbours."""
        arcs = self.arcs
        touched = set()
        for r in regions:
            self.kept_input[r] = True
            for aid in self.arcs_of.get(r, []):
                if len(arcs[aid].kept) != len(arcs[aid].verts):
                    full_arc(arcs[aid])
                    touched.update(x for x in arcs[aid].regions if x >= 0 and x != r)
        return touched

    def refine(self) -> None:
        """Build every face; refine the arcs of failing regions (tolerance halved, up
        to `MAX_REFINE` times) and rebuild them and their neighbours; regions that
        still fail keep their input triangles."""
        arcs, verts = self.arcs, self.s.vertices
        todo = sorted(self.loops_of_region)
        for _ in range(MAX_REFINE + 2):
            failed = self.build(todo)
            if not failed:
                break
            touched: set[int] = set()
            for r in failed:
                self.refined.add(r)
                progressed = False
                for aid in self.arcs_of[r]:
                    if refine_arc(arcs[aid]):
                        simplify_arc(arcs[aid], verts)
                        progressed = True
                        touched.update(x for x in arcs[aid].regions if x >= 0)
                if not progressed:
                    touched |= self.keep_input([r])
            separate_parallel_chords(arcs, verts)
            todo = sorted(touched | set(failed))
        else:
            self.keep_input([r for r in todo if r not in self.faces])

    def settle(self, closed_input: bool):
        """Rebuild until every face is valid and the faces together are manifold
        (neighbours of regions that took their input triangles see full arcs now);
        returns (triangles, their regions, loops of every region) in input vertices."""
        tri, lab = self.s.triangles, self.lab
        while True:
            todo = sorted(r for r in range(self.n_regions) if not self.kept_input[r])
            failed = self.build(todo)
            if failed:
                self.keep_input(failed)
                continue
            tris, tface, loops_out = [], [], []
            for r in range(self.n_regions):
                if self.kept_input[r]:
                    tris.append(tri[lab == r])
                    loops_out.append(
                        tuple(np.asarray(lp, dtype=np.int64) for lp in self.loops_of(r))
                        if r in self.loops_of_region
                        else ()
                    )
                else:
                    loops_out.append(self.faces[r][0])
                    tris.append(self.faces[r][1])
                tface.append(np.full(tris[-1].shape[0], r, dtype=np.int64))
            all_t = np.concatenate(tris) if tris else np.zeros((0, 3), np.int64)
            all_f = np.concatenate(tface) if tface else np.zeros(0, np.int64)
            bad = [r for r in bad_regions(all_t, all_f, closed_input) if not self.kept_input[r]]
            if not bad:
                return all_t, all_f, loops_out
            self.keep_input(bad)


def face_planarity(vertices, triangles, triangle_face, n_faces: int) -> np.ndarray:
    """(F,): the largest distance of each face's vertices (those of its triangles) to
    their least-squares plane (`plane_fits`; 0 for a face of three vertices).

    Examples
    --------
    >>> v = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0.2], [0, 1, 0.0]])
    >>> t = np.array([[0, 1, 2], [0, 2, 3]])
    >>> face_planarity(v, t, np.zeros(2, np.int64), 1).round(3).tolist()
    [0.05]
    """
    return plane_fits(vertices, triangles, triangle_face, n_faces)[2]


def surface_result(
    verts,
    tri,
    out_v,
    out_t,
    tface,
    used,
    face_loops,
    *,
    labels,
    kept_input,
    flat,
    planar_tol,
    chord_tolerance,
    n_refined,
    distances=None,
):
    """The `SurfaceSimplification` of output triangles labelled by face (``tface``;
    ``flat`` (F,): which are flat regions): the faces' simple planar polygons
    (``planar_tol``), their planarity, the checks, and the distances
    both ways against the input (``verts``, ``tri``), or ``distances`` (there, back)
    as given (the points path measures against the points); shared by every mesh
    path."""
    from ._mesh import mesh_checks, point_mesh_distance, unique_pairs

    n_regions = len(face_loops)
    polygons, polygon_face, polygon_planarity = face_polygons(
        out_v, out_t, tface, face_loops, planar_tol
    )
    planarity = face_planarity(out_v, out_t, tface, n_regions)
    closed, manifold, oriented = mesh_checks(out_v.shape[0], out_t)
    und = np.sort(np.concatenate([out_t[:, [0, 1]], out_t[:, [1, 2]], out_t[:, [2, 0]]]), 1)
    n_edges = unique_pairs(und).shape[0]
    if distances is None:
        distances = (
            point_mesh_distance(verts, out_v, out_t),
            back_distances(out_v, out_t, verts, tri),
        )
    dist, back = distances
    return SurfaceSimplification(
        vertices=out_v,
        vertex_source=used,
        polygons=polygons,
        polygon_face=polygon_face,
        polygon_planarity=polygon_planarity,
        face_region=np.arange(n_regions, dtype=np.int64),
        face_loops=tuple(face_loops),
        face_kept_input=kept_input.copy(),
        planarity_error=planarity,
        face_flat=np.asarray(flat, dtype=bool).copy(),
        triangles=out_t,
        triangle_face=tface,
        is_closed=closed,
        is_manifold=manifold,
        is_oriented=oriented,
        euler_characteristic=int(out_v.shape[0] - n_edges + out_t.shape[0]),
        face_labels=labels.copy(),
        distances=dist,
        distance_mean=float(dist.mean()) if dist.size else 0.0,
        distance_max=float(dist.max()) if dist.size else 0.0,
        back_distance_mean=float(back.mean()) if back.size else 0.0,
        back_distance_max=float(back.max()) if back.size else 0.0,
        chord_tolerance=chord_tolerance,
        n_refined=n_refined,
    )
