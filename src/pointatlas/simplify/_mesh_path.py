"""`simplify_mesh`: the mesh path of `pointatlas simplify` (public entry, private module).

VSA on the input's triangles, then `simplify_surface`; regions that bound no planar
polygon are cut and the mesh rebuilt; level-of-detail searches (target face count,
largest distance). Decisions in docs/decisions/simplify.md.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
from scipy import sparse

from .._core import as_float, as_points
from ._mesh import _as_triangles, unique_ints, unique_pairs, used_vertices
from ._nonmanifold import repair_mesh_input
from ._surface import SurfaceSimplification, simplify_surface
from ._triangles import _face_graph, _Surface, _surface

__all__ = ["simplify_mesh", "surface_diagonal"]

#: Rounds of cutting the regions that kept their input triangles in two.
_SPLIT_ROUNDS = 4


#: Default chord tolerance of the mesh path, relative to the bounding-box diagonal.
CHORD_TOLERANCE = 0.005
#: Default mean normal deviation per region of the mesh path (radians, 10 degrees).
MAX_ANGLE = np.radians(10.0)
#: Neighbouring regions whose union stays this flat are merged after VSA (radians):
#: pieces of one flat CAD face that VSA's agglomeration left apart. Larger unions
#: are left to VSA (they fold over in their plane more often).
FLAT_MERGE_ANGLE = np.radians(1.0)


def _segment_faces(s: _Surface, graph, *, max_angle, eta, rng, **vsa):
    from ..segment import vsa_segment

    weights = s.areas / max(float(s.areas.mean()), np.finfo(float).tiny)
    res = vsa_segment(
        s.centroids,
        s.normals,
        weights=weights,
        neighbors=graph,
        max_angle=max_angle,
        eta=eta,
        rng=rng,
        **vsa,
    )
    return np.asarray(res.labels), np.asarray(res.proxy_normals)


def simplify_mesh(
    vertices,
    triangles,
    *,
    max_angle: float | None = None,
    eta: float | None = None,
    n_faces: int | None = None,
    max_error: float | None = None,
    max_triangles: int | None = None,
    chord_tolerance: float | None = None,
    planarize: bool = False,
    rng=None,
) -> SurfaceSimplification:
    """Simplified polygon mesh of a triangle mesh: closed and manifold for closed inputs.

    Parameters
    ----------
    vertices : array_like of shape (V, 3), float64
        Mesh vertices.
    triangles : array_like of shape (F, 3), int
        Triangles, consistently oriented (an open or closed surface).
    max_angle : float, optional
        Largest area-weighted mean normal deviation of a region (radians, in
        [0, pi]); default 10 degrees when neither ``eta`` nor a target is given.
    eta : float, optional
        VSA's L21 threshold instead, with face weights = area / mean face area
        (so eta counts "average faces", like the points of the thesis).
    n_faces : int, optional
        Target number of faces: ``max_angle`` is found by bisection (the closest
        count reached is used).
    max_error : float, optional
        Largest distance between the input and the output, both ways (input
        vertices to the output, the output's vertices and area samples to the
        input; input units): the largest ``max_angle`` that meets it is found by
        bisection, and the chord tolerance is at most half of it.
    max_triangles : int, optional
        Triangle budget: the finest level (smallest ``max_angle``) whose output has
        at most this many triangles is found by bisection (the coarsest level
        reached when none meets it).
    chord_tolerance : float, optional
        Largest distance of a boundary arc's vertices to its chords (input units);
        default 0.5 % of the bounding-box diagonal.
    planarize : bool
        Move every output vertex towards the planes of its faces (least squares, at
        most the chord tolerance, never flipping a triangle): flatter faces (the
        collection's median largest planarity error 0.93 % -> 0.77 % of the diagonal)
        for a larger distance to the input (median mean distance 0.088 % -> 0.133 %).
        Off by default: the output's vertices are then input vertices.
    rng : None, int or numpy.random.Generator
        Passed to VSA (only used with a number of random seeds).

    Returns
    -------
    result : SurfaceSimplification
        Faces (one per region), triangles, checks, distances, per-face planarity.

    Raises
    ------
    ValueError
        Bad shapes, indices or options; more than one of ``max_angle``, ``eta``,
        ``n_faces``, ``max_error``.
    TypeError
        Non-numeric arrays or options.

    Notes
    -----
    The segmentation runs on the triangles (VSA, thesis 4.2-4.3, with face
    normals, area weights and the edge adjacency), so every region is connected in
    the surface and a CAD export with few vertices on large flat faces is handled
    as well as a dense scan. The mesh is built from the regions' boundary loops,
    split into arcs at vertices where three or more regions meet and simplified by
    Douglas-Peucker (the same chords on both sides); each region's loops are
    projected to its plane and triangulated. A region whose loops do not bound a
    planar polygon gets its arcs refined, down to the full arcs, and then keeps
    its input triangles: the output is closed and manifold whenever the input
    is closed. Vertices at one position are welded first (a triangle soup, a
    flat-shaded export), triangles with a repeated corner or given twice dropped
    (their ``face_labels``: -1, or the first copy's), edges in three or more
    triangles and pinched vertices cut apart (vertex copies at the same positions,
    reported by their input ids), and
    triangles that disagree with the majority of their part are reversed
    (`repair_mesh_input`, each with a `SimplifyWarning`). Decisions in
    docs/decisions/simplify.md.

    Examples
    --------
    >>> from pointatlas.synth import cube
    >>> m = cube(6)
    >>> r = simplify_mesh(m.vertices, m.faces)
    >>> r.n_faces, r.is_closed, r.is_manifold, r.euler_characteristic
    (6, True, True, 2)
    """
    verts = as_points(vertices, name="vertices")
    tri = _as_triangles(triangles, verts.shape[0])
    given = [x is not None for x in (max_angle, eta, n_faces, max_error, max_triangles)]
    if sum(given) > 1:
        raise ValueError("give at most one of max_angle, eta, n_faces, max_error and max_triangles")
    used = used_vertices(verts.shape[0], tri)
    diag = _diagonal(verts if used.all() else verts[used])
    if chord_tolerance is None:
        tol = CHORD_TOLERANCE * diag
    else:
        tol = as_float(chord_tolerance, "chord_tolerance", lo=0.0)
    if max_angle is not None:
        max_angle = as_float(max_angle, "max_angle", lo=0.0, hi=np.pi, what="angle", unit="radians")
    if eta is not None:
        eta = as_float(eta, "eta", lo=0.0)
    run, repair = _repaired_run(verts, tri, used, tol=tol, planarize=planarize, rng=rng)
    level = {"n_faces": n_faces, "max_triangles": max_triangles, "max_error": max_error}
    res = _at_level(run, tol, max_angle, eta, **level)
    # input vertex and triangle ids again
    return res if repair is None else repair.back(res)


def _at_level(run, tol, max_angle, eta, *, n_faces, max_triangles, max_error):
    """The run at the level asked for: a target searched, or one level."""
    from .._core import as_int

    if n_faces is not None:
        return _search_faces(run, as_int(n_faces, "n_faces", lo=1))
    if max_triangles is not None:
        return _search_triangles(run, as_int(max_triangles, "max_triangles", lo=1))
    if max_error is not None:
        bound = as_float(max_error, "max_error", lo=0.0, lo_open=True)
        return _search_error(run, bound, min(tol, bound / 2.0))
    if eta is not None:
        return run(None, eta)
    return run(MAX_ANGLE if max_angle is None else max_angle)


def repaired_input(verts, tri, used):
    """The input after `repair_mesh_input`: ``(vertices, triangles, used, repair)``,
    ``used`` the repaired vertices on a triangle (None when all are), ``repair`` None
    when the input needed none; ``used`` given: the input vertices on a triangle."""
    repair = repair_mesh_input(verts, tri)
    run_used = None if used.all() else used if repair is None else used[repair.source]
    if repair is not None:
        verts, tri = repair.vertices, repair.triangles
    return verts, tri, run_used, repair


def _repaired_run(verts, tri, used, *, tol, planarize, rng):
    """The `_MeshRun` of the repaired input (`repaired_input`) and the repair."""
    verts, tri, run_used, repair = repaired_input(verts, tri, used)
    return _MeshRun(verts, tri, tol=tol, planarize=planarize, rng=rng, used=run_used), repair


def _diagonal(v: np.ndarray) -> float:
    return float(np.linalg.norm(v.max(axis=0) - v.min(axis=0))) if v.size else 0.0


def surface_diagonal(vertices: np.ndarray, triangles: np.ndarray) -> float:
    """Bounding-box diagonal of the vertices on at least one triangle.

    A stray vertex of an export moves neither the default chord tolerance nor a
    percentage.

    Parameters
    ----------
    vertices : ndarray of shape (V, 3)
        Vertex coordinates.
    triangles : ndarray of shape (T, 3)
        Vertex indices of the triangles.

    Returns
    -------
    float
        The diagonal; 0.0 when no vertex is on a triangle.

    Raises
    ------
    NonFiniteError
        NaN or Inf vertices (`pointatlas._core.NonFiniteError`).
    """
    v = as_points(vertices, name="vertices", min_points=0)
    return _diagonal(v[used_vertices(v.shape[0], triangles)])


def _unreferenced_apart(res: SurfaceSimplification, used: np.ndarray):
    """Vertices on no input triangle are no part of the surface: their ``distances``
    entry is NaN and the mean and largest distance are over the others."""
    d = res.distances.copy()
    d[~used] = np.nan
    on = d[used]
    return dataclasses.replace(
        res,
        distances=d,
        distance_mean=float(on.mean()) if on.size else 0.0,
        distance_max=float(on.max()) if on.size else 0.0,
    )


class _MeshRun:
    """One segmentation and simplification of the mesh at a level of detail (the step
    of `simplify_mesh` that its level searches repeat)."""

    def __init__(self, verts, tri, *, tol, planarize, rng, used=None):
        self.verts, self.tri, self.tol, self.planarize, self.rng = verts, tri, tol, planarize, rng
        self.used = used  # vertices on an input triangle, when not all are
        self.s = _surface(verts, tri)
        self.graph = _face_graph(self.s)
        self._built = {}  # (labels, normals, chord tolerance) -> its level
        self._regions = {}  # (angle, eta) -> its segmentation (a search counts, then builds)

    def __call__(self, angle, eta_=None, tol_=None) -> SurfaceSimplification:
        """VSA on the faces with ``max_angle=angle`` (or ``eta=eta_``), the flat
        regions merged, then `simplify_surface` with chord tolerance ``tol_`` (default
        the run's); regions that kept their input triangles are cut in two and the
        mesh rebuilt (`_SPLIT_ROUNDS` times at most, while that helps)."""
        tol_ = self.tol if tol_ is None else tol_
        labels, normals = self.regions(angle, eta_)
        key = (labels.tobytes(), normals.tobytes(), tol_)
        if key not in self._built:  # a search meets one segmentation at many angles
            self._built[key] = self._level(labels, normals, tol_)
        return self._built[key]

    def _level(self, labels, normals, tol_) -> SurfaceSimplification:
        """`simplify_surface` of one segmentation, its regions that kept their input
        triangles cut in two while that helps."""
        s, graph = self.s, self.graph
        res = self._surface(labels, normals, tol_)
        for _ in range(_SPLIT_ROUNDS):
            if not res.face_kept_input.any():
                break
            # a region whose loops bound no planar polygon (it folds over in its plane,
            # or its chords cross) is cut in two and the mesh rebuilt
            labels = _split_regions(s, graph, labels, np.flatnonzero(res.face_kept_input))
            normals = _region_normals(s, labels, int(labels.max()) + 1)
            again = self._surface(labels, normals, tol_)
            if again.face_kept_input.sum() >= res.face_kept_input.sum():
                break
            res = again
        return res

    def regions(self, angle, eta_=None) -> tuple[np.ndarray, np.ndarray]:
        """VSA's face labels and region normals at ``angle`` (or ``eta_``), flat regions
        merged: the faces of the level before any region is cut in two (made once per
        ``angle`` and ``eta_``)."""
        key = (angle, eta_)
        if key in self._regions:
            return self._regions[key]
        s, graph = self.s, self.graph
        labels, normals = _segment_faces(s, graph, max_angle=angle, eta=eta_, rng=self.rng)
        if angle is not None:
            labels = _merge_flat(s, graph, labels, min(angle, FLAT_MERGE_ANGLE))
            normals = _region_normals(s, labels, int(labels.max()) + 1)
        self._regions[key] = (labels, normals)
        return labels, normals

    def _surface(self, labels, normals, tol_) -> SurfaceSimplification:
        res = simplify_surface(
            self.verts, self.tri, labels, normals, chord_tolerance=tol_, planarize=self.planarize
        )
        return res if self.used is None else _unreferenced_apart(res, self.used)


#: Levels built at most by a face-count search (the closest region counts first).
_FACE_BUILDS = 3


def _search_faces(run, target: int) -> SurfaceSimplification:
    """Bisection of log(max_angle) on the segmentation's region count for ``target``
    faces, then the mesh built at the levels whose counts came closest (at most
    `_FACE_BUILDS`; the closest built count wins): building a level is most of its
    time (fandisk, 30 faces: 14 levels built took 30 CPU-s), and a level's faces can
    outnumber its regions (a region that bounds no planar polygon is cut in two)."""
    lo, hi = np.log(np.radians(0.05)), np.log(np.radians(80.0))
    counts = {}  # region count -> the first angle that gave it
    for _ in range(14):
        mid = 0.5 * (lo + hi)
        angle = float(np.exp(mid))
        n = int(run.regions(angle)[0].max()) + 1
        counts.setdefault(n, angle)
        if n == target:
            break
        if n > target:  # too many faces: allow more deviation
            lo = mid
        else:
            hi = mid
    best = None
    for n in sorted(counts, key=lambda n: (abs(n - target), n))[:_FACE_BUILDS]:
        res = run(counts[n])
        if best is None or (abs(res.n_faces - target), res.n_faces) < (
            abs(best.n_faces - target),
            best.n_faces,
        ):
            best = res
        if best.n_faces == target:
            break
    return best


def _search_triangles(run, budget: int) -> SurfaceSimplification:
    """Bisection of log(max_angle): the most triangles within ``budget`` (else the
    fewest reached)."""
    lo, hi = np.log(np.radians(0.05)), np.log(np.radians(80.0))
    best = None
    for _ in range(14):
        mid = 0.5 * (lo + hi)
        res = run(float(np.exp(mid)))
        n = res.triangles.shape[0]
        if best is None:
            best = res
        fits, best_fits = n <= budget, best.triangles.shape[0] <= budget
        if (fits and (not best_fits or n > best.triangles.shape[0])) or (
            not fits and not best_fits and n < best.triangles.shape[0]
        ):
            best = res
        if fits:
            hi = mid  # within budget: try finer
        else:
            lo = mid
    return best


def _search_error(run, bound: float, tol: float) -> SurfaceSimplification:
    """The largest max_angle whose output is within ``bound`` of the input both ways
    (every input vertex to the output, and the output's samples to the input)."""
    lo, hi = np.log(np.radians(0.01)), np.log(np.radians(60.0))
    best = run(float(np.exp(lo)), None, tol)
    if best.hausdorff > bound:
        return best  # even the finest segmentation misses the bound: report it
    for _ in range(12):
        mid = 0.5 * (lo + hi)
        res = run(float(np.exp(mid)), None, tol)
        if res.hausdorff <= bound:
            best, lo = res, mid
        else:
            hi = mid
    return best


def _region_normals(s: _Surface, labels: np.ndarray, n_regions: int) -> np.ndarray:
    """Area-weighted mean normal of every region (unit; the largest axis when it cancels)."""
    acc = np.zeros((n_regions, 3))
    for d in range(3):
        acc[:, d] = np.bincount(labels, weights=s.areas * s.normals[:, d], minlength=n_regions)
    length = np.linalg.norm(acc, axis=1)
    bad = length <= 1e-300
    acc[bad] = (0.0, 0.0, 1.0)
    length[bad] = 1.0
    return acc / length[:, None]


def _split_regions(s: _Surface, graph, labels: np.ndarray, regions) -> np.ndarray:
    """Cut each region in two by the plane through its centroid across its largest
    spread (as VSA's split, 4.3.3), then number the connected pieces."""
    from scipy.sparse import csgraph

    out = labels.copy()
    top = int(labels.max()) + 1
    for r in regions:
        idx = np.flatnonzero(labels == r)
        if idx.size < 2:
            continue
        w = s.areas[idx] + 1e-300
        c = s.centroids[idx]
        mean = (w[:, None] * c).sum(0) / w.sum()
        q = c - mean
        cov = (w[:, None, None] * q[:, :, None] * q[:, None, :]).sum(0)
        axis = np.linalg.eigh(cov)[1][:, -1]
        side = q @ axis > 0.0
        if side.all() or not side.any():
            continue
        out[idx[side]] = top
        top += 1
    # connected pieces of every region in the face graph
    coo = graph.tocoo()
    same = out[coo.row] == out[coo.col]
    n = out.size
    ones = np.ones(int(same.sum()), np.int8)
    g = sparse.csr_array((ones, (coo.row[same], coo.col[same])), shape=(n, n))
    _, comp = csgraph.connected_components(g, directed=False)
    _, first = np.unique(comp, return_index=True)
    order = np.argsort(first, kind="stable")
    rank = np.empty_like(order)
    rank[order] = np.arange(order.size)
    return rank[comp]


def _merge_flat(s: _Surface, graph, labels: np.ndarray, max_angle: float) -> np.ndarray:
    """Merge neighbouring regions while their union keeps a mean normal deviation of at
    most ``max_angle`` (VSA with a max_angle threshold has no final merge pass; on flat
    CAD faces its agglomeration can stop with a face in several pieces).

    Cheapest union first (largest |S| / W), with the regions' summaries W = sum w_j,
    S = sum w_j n_j (for unit normals the L^{2,1} energy of Eq. 4.4 is 2 (W - |S|));
    merged regions stay connected because only neighbours merge.
    """
    import heapq

    n_regions = int(labels.max()) + 1
    w = s.areas
    wsum = np.bincount(labels, weights=w, minlength=n_regions)
    ssum = np.stack(
        [np.bincount(labels, weights=w * s.normals[:, d], minlength=n_regions) for d in range(3)],
        axis=1,
    )
    coo = graph.tocoo()
    a, b = labels[coo.row], labels[coo.col]
    pairs = unique_pairs(np.sort(np.stack([a[a != b], b[a != b]], 1), axis=1))
    min_cos = float(np.cos(max_angle))
    # the pairs' scores as `score` gives them, bit for bit; a pair below the threshold
    # would only end the loop (the heap's top below it: so is all the rest)
    scores = _pair_scores(wsum, ssum, pairs)
    first = scores >= min_cos - 1e-15
    if not first.any():  # nothing merges
        return _first_seen_order(labels, np.arange(n_regions))
    neighbours = _Neighbours(pairs, n_regions)
    parent = list(range(n_regions))
    wsum, ssum = wsum.tolist(), ssum.tolist()

    def score(x, y):
        wt = wsum[x] + wsum[y]
        sx, sy = ssum[x], ssum[y]
        # math.sqrt and np.sqrt both round correctly: the same score, cheaper
        length = math.sqrt((sx[0] + sy[0]) ** 2 + (sx[1] + sy[1]) ** 2 + (sx[2] + sy[2]) ** 2)
        return length / wt if wt > 0 else 1.0

    candidates = zip(scores[first].tolist(), pairs[first].tolist(), strict=True)
    heap = [(-s, x, y) for s, (x, y) in candidates]
    heapq.heapify(heap)
    alive = [True] * n_regions
    while heap:
        neg, x, y = heapq.heappop(heap)
        if not (alive[x] and alive[y]):
            continue
        if -neg < min_cos - 1e-15:
            break
        if abs(-neg - score(x, y)) > 1e-15:  # stale entry
            continue
        # merge y into x
        alive[y] = False
        parent[y] = x
        wsum[x] += wsum[y]
        ssum[x] = [ssum[x][d] + ssum[y][d] for d in range(3)]
        for z in neighbours[y]:
            if z != x:
                neighbours[z].discard(y)
                neighbours[z].add(x)
                neighbours[x].add(z)
        neighbours[x].discard(y)
        for z in neighbours[x]:
            heapq.heappush(heap, (-score(x, z), min(x, z), max(x, z)))
    root = np.arange(n_regions)
    for r in range(n_regions):
        q = r
        while parent[q] != q:
            q = parent[q]
        root[r] = q
    return _first_seen_order(labels, root)


class _Neighbours(dict):
    """The regions next to each region, as sets made on first use from the pairs
    (thousands of regions, a few merges: most are never asked for)."""

    def __init__(self, pairs: np.ndarray, n_regions: int):
        super().__init__()
        both = np.concatenate([pairs, pairs[:, ::-1]])
        both = both[np.argsort(both[:, 0], kind="stable")]
        self.start = np.searchsorted(both[:, 0], np.arange(n_regions + 1))
        self.other = both[:, 1]

    def __missing__(self, x: int) -> set:
        made = set(self.other[self.start[x] : self.start[x + 1]].tolist())
        self[x] = made
        return made


def _pair_scores(wsum, ssum, pairs) -> np.ndarray:
    """`_merge_flat`'s score of every pair of regions (rows of ``pairs``): |S| / W of
    their union (1 where W = 0), in the same operations and order as its ``score``."""
    x, y = pairs[:, 0], pairs[:, 1]
    wt = wsum[x] + wsum[y]
    sx, sy = ssum[x], ssum[y]
    t0, t1, t2 = (sx[:, d] + sy[:, d] for d in range(3))
    length = np.sqrt(t0**2 + t1**2 + t2**2)
    return np.where(wt > 0, length / np.where(wt > 0, wt, 1.0), 1.0)


def _first_seen_order(labels: np.ndarray, root: np.ndarray) -> np.ndarray:
    """Every triangle's merged region ``root[labels]``, numbered 0.. in the order of
    the regions' first triangles."""
    merged = root[labels]
    _, first = np.unique(merged, return_index=True)
    order = np.argsort(first, kind="stable")
    rank = np.empty(root.size, dtype=np.int64)
    rank[unique_ints(merged)[order]] = np.arange(order.size)
    return rank[merged]
