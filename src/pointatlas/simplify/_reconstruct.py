"""The points path's robust step: a triangle surface from oriented points (private).

Inside/outside on a voxel grid from the oriented normals, then marching cubes
(scikit-image, Lewiner's tables); the triangles are handed to `simplify_mesh`.
Decisions in docs/decisions/simplify.md ("The points path's robust path").
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np
from scipy import ndimage
from scipy.spatial import cKDTree

from .._core import PointAtlasError
from .._core._threads import on_thread
from ._grid_knn import GridKnn
from ._handles import cut_handles
from ._mesh import split_pinches, used_only
from ._open import (
    TRIM_STEPS,
    AllBubbles,
    as_open,
    beyond_points,
    drop_strays,
    smooth_outline,
    trim,
)
from ._solid import SOLID_RADIUS, half_balls, solid_retry
from ._voxel_grid import (
    LOST_LINK,
    LOST_POINTS,
    LOST_SHARE,
    LOST_STEPS,
    THIN_SHARE,
    THIN_WALL_STEPS,
    band_steps,
    euler_characteristic,
    finer_step,
    grid_step,
    lost_points,
    thin_share,
    uneven_factor,
)
from ._winding import dipole_share

__all__ = [
    "Reconstruction",
    "reconstruct_surface",
    "robust_mesh",
]

#: A piece of the surface that fewer points than this have their nearest triangle on
#: is a spurious bubble (a sign flip of the field beside the surface), not a part.
STRAY_POINTS = 8
#: ... or whose triangles agree with their nearest points' normals less than this
#: (the area-weighted cosine; the surface itself about 0.97, spurious voids under a
#: sampled knob's faces 0.01-0.19, `_bubbles`).
BUBBLE_FACING = 0.5
#: A point set is closed when its points' discs (normal times area) sum to less
#: than this share of their area (closed: below 0.015 on every collection model
#: sampled with 20,000 points; an open sheet: about 1) ...
CLOSED_DIPOLE = 0.05
#: ... and then the field's side away from the points is the winding number's where
#: it is below this or above one minus it (on the surface it is 1/2; near an edge it
#: tends to the edge's share of the turn: 1/4 inside a convex right angle, 3/4
#: outside a concave one, and 1/4 made a spurious pocket on a sampled L-bracket) ...
WINDING_CLEAR = 0.1
#: ... computed on a lattice of at most about this many grid nodes (every 2nd node
#: or sparser; interpolated: it is smooth away from the points) ...
WINDING_NODES = 150_000
#: ... with the points grouped in cells of this many grid steps.
WINDING_CELL = 8
#: Gaussian smoothing of the field (grid steps), and at least this many point
#: spacings (at one spacing per step, one step left sign noise at edges that made
#: tunnels: sampled CAD parts came out with Euler characteristic -8 instead of 0).
SMOOTH_STEPS = 1.0
SMOOTH_SPACINGS = 1.5
#: A triangle budget on the points path is kept only while the output stays within
#: this many times the default bound of the points (never a spike).
SPIKE_FACTOR = 4.0
#: Points whose tangent planes are averaged into the field at a node.
FIELD_K = 8
#: The band nodes' nearest points are found in cells of this many point spacings
#: (`GridKnn`): per band query, on the grid of 1.5 spacings a step (fs-cover-mmu2s,
#: 299,671 nodes) 0.136 s at 3 spacings, 0.114 s at 4.5; on the finer grid of one
#: spacing (1,058,107 nodes) 0.681 s at 2, 0.448 s at 3, 0.394 s at 5 (the same
#: answers).
KNN_CELL_SPACINGS = 4.5


@dataclass(frozen=True, slots=True)
class Reconstruction:
    """Triangle surface of a point set (private): ``vertices`` (working frame),
    ``triangles`` (outward), ``step`` (grid step), ``shape`` (grid nodes),
    ``n_trimmed`` (triangles cut away beyond open boundaries: 0 for a closed one),
    ``n_handles`` (small handles cut, `_handles.cut_handles`) and ``uneven`` (the
    grid's spacing over the points' median one: `_voxel_grid.uneven_factor`)."""

    vertices: np.ndarray
    triangles: np.ndarray
    step: float
    shape: tuple
    n_trimmed: int
    n_handles: int = 0
    uneven: float = 1.0
    # `distance_index`'s, once built (a copy by `replace` shares it: the same triangles)
    _index: list = field(default_factory=list, compare=False, repr=False)

    def distance_index(self):
        """The triangles' `neighbors.MeshDistanceIndex`, built once: the lost points'
        measures (`_finer`, `_solid.solid_retry`, `_voxel_grid.lost_strays`) ask the
        same surface (0.05 s a build on a sampled CAD part's 95,572 triangles)."""
        from ..neighbors import MeshDistanceIndex

        if not self._index:
            self._index.append(MeshDistanceIndex(self.vertices, self.triangles))
        return self._index[0]


def is_closed_sample(q, normals, areas=None) -> bool:
    """Whether oriented points sample a closed surface: their `dipole_share` is at
    most `CLOSED_DIPOLE` (``areas`` as there)."""
    return dipole_share(q, normals, areas) <= CLOSED_DIPOLE


def _field(q, normals, step, spacing, origin, shape, closed, near_q):
    """Signed field on the grid nodes: tangent-plane distance in the band, +-band
    beyond it (one sign per connected region of nodes, by a vote of its band border);
    on a closed sample the winding number's side away from the points. ``near_q``:
    the points ``q`` on a `GridKnn` (`_surface_at`'s)."""
    from ._winding import far_sides, level_sides

    width = band_steps(step, spacing)
    cells = np.floor((q - origin) / step).astype(np.int64)
    occupied = np.zeros(shape, dtype=bool)
    occupied[cells[:, 0], cells[:, 1], cells[:, 2]] = True
    # the winding number needs no field: on a thread meanwhile (the band's steps
    # below leave a core free: most are numpy on one)
    sides = None
    if closed:
        sides = on_thread(_winding_sides, q, normals, occupied, step, spacing, origin)
    # the nodes within ``width`` steps (Chebyshev) of a point's cell: a cube dilation
    # ``width`` times, as one separable maximum filter
    band = ndimage.maximum_filter(occupied, size=2 * width + 1, mode="constant", cval=0)
    band[[0, -1], :, :] = band[:, [0, -1], :] = band[:, :, [0, -1]] = False
    nodes = np.argwhere(band)
    x = origin + nodes * step
    # their nearest points on a grid of cells (`KNN_CELL_SPACINGS`), not a k-d tree
    near = near_q.query(x, min(FIELD_K, q.shape[0]))
    values, thin = _band_sides(q, normals, x, near, step, spacing)
    f = np.zeros(shape, dtype=np.float64)
    f[band] = values
    # each node's distance to its nearest point (beyond the band: farther than it)
    nearest = np.full(shape, np.inf, dtype=np.float32)
    nearest[band] = near[0][:, 0]
    # regions of nodes beyond the band: one sign each, by the band nodes next to them
    comp, n_comp = ndimage.label(~band)
    votes = np.zeros(n_comp + 1)
    sign = np.where(f > 0.0, 1.0, -1.0)
    for axis in range(3):
        for shift in (1, -1):
            nb = np.roll(comp, shift, axis=axis)
            pair = band & (nb > 0)
            votes += np.bincount(nb[pair], weights=sign[pair], minlength=n_comp + 1)
    outside = np.where(votes >= 0.0, 1.0, -1.0) * (width + 1) * step
    f[~band] = outside[comp[~band]]
    # a smoothing of one grid step removes sign noise near edges and corners (which
    # gives small tunnels); a linear field (a flat face) is left as it is
    sigma = max(SMOOTH_STEPS, SMOOTH_SPACINGS * spacing / step)
    keep = _thin_keep(band, thin, values)
    raw = f[keep]
    f = ndimage.gaussian_filter(f, sigma=sigma, mode="nearest")
    # ... but a node in a thin wall or gap keeps its side: the smoothing averages a
    # wall thinner than about two of its widths away
    f[keep] = np.where(np.sign(f[keep]) == np.sign(raw), f[keep], raw)
    if sides is not None:
        lattice, sources = sides.result()
        f = far_sides(f, *lattice, WINDING_CLEAR)
        # nearer the points than the lattice reaches, at the level only: a blob the
        # planes of a face leave past a knife edge
        f = level_sides(f, nearest, sources, origin, step, WINDING_CLEAR)
    # the grid's outer layer is outside: the surface is closed inside the grid
    f[[0, -1], :, :] = f[:, [0, -1], :] = f[:, :, [0, -1]] = (width + 1) * step
    f[f == 0.0] = 1e-12 * step  # no node exactly on the level: no degenerate triangles
    return f


def _thin_keep(band, thin, values):
    """The nodes whose side the smoothing must not change: band nodes between two
    sides of a thin wall or gap (``thin``, `_kernels.thin_sides`), and the band
    nodes on the same side next to one (the wall's other nodes: one node of a wall
    in a few kept alone leaves a sieve)."""
    keep = np.zeros(band.shape, dtype=np.int8)
    keep[band] = thin
    side = np.zeros(band.shape, dtype=np.int8)
    side[band] = np.where(values < 0.0, -1, 1)
    out = keep != 0
    for s in (-1, 1):  # a dilation by the 3 x 3 x 3 cube
        near = ndimage.maximum_filter(keep == s, size=3, mode="constant", cval=0)
        out |= near & (side == s)
    return out


def _band_sides(q, normals, x, near, step, spacing):
    """The field at band nodes ``x`` (`_band_values`: `_kernels.band_field`) and
    which of them lie between two sides of a thin part that the grid resolves
    (`_kernels.thin_sides`: -1 inside a thin wall, +1 in a thin gap, else 0), from
    their `FIELD_K` nearest points ``near`` (distances, indices: nearest first)."""
    from ._kernels import band_field, thin_sides

    d, j = near[0], near[1].astype(np.int64, copy=False)
    # exp(-(d / step)^2) in one array, not four: the same bits without three
    # temporaries of the band's size (3.3 million values on a CAD part's 416,000 nodes)
    gauss = np.divide(d, step)
    np.square(gauss, out=gauss)
    np.negative(gauss, out=gauss)
    np.exp(gauss, out=gauss)
    # C arrays (the points writable copies): one compiled signature whatever the caller's
    x = np.ascontiguousarray(x, dtype=np.float64)
    q = np.array(q, dtype=np.float64, order="C")
    normals = np.array(normals, dtype=np.float64, order="C")
    values = band_field(x, d, gauss, j, q, normals, float(step), float(spacing))
    return values, thin_sides(x, d, j, q, normals, float(step), float(spacing))


def _band_values(q, normals, tree, x, step, spacing):
    """The field at nodes ``x`` anywhere (their nearest points from ``tree``): the
    Gaussian-weighted mean of the `FIELD_K` nearest points' tangent-plane distances
    n . (x - p), only the neighbours about as near as the nearest one speaking (the
    far side of a thin wall is left out); where their planes disagree on the side
    (near an edge or a corner, where a plane extended past its face is wrong), the
    distance to the nearest point with the weighted vote's sign (`band_field`;
    plain-numpy reference in tests/simplify/reference.py). `_field` finds the band
    nodes' nearest points on a grid instead (`GridKnn`: the same answer)."""
    k = min(FIELD_K, q.shape[0])
    d, j = tree.query(x, k=k, workers=-1)
    near = d.reshape(x.shape[0], k), j.reshape(x.shape[0], k)
    return _band_sides(q, normals, x, near, step, spacing)[0]


def _winding_sides(q, normals, occupied, step, spacing, origin):
    """The field's side, away from the points, by the points' winding number where it
    is clear (`_winding`): the tangent planes of the nearest points take the wrong
    side beyond a face's edge, and the vote of a region beyond the band is wrong
    where the band leaks through a sampling gap or a pocket. Only for a closed
    sampled surface (its dipoles sum to less than `CLOSED_DIPOLE` of its area: an
    open sheet has no inside). Returns ``(w, far_from, near, stride)`` for
    `_winding.far_sides`: the winding number on every ``stride``-th node, each
    node's distance from the points' cells, and the distance beyond which a node
    takes its side; and the points as `_winding.Dipoles` (`_winding.level_sides`)."""
    from ._edt import distance_to
    from ._winding import dipoles

    shape = np.array(occupied.shape)
    stride = max(2, int(np.ceil((shape.prod() / WINDING_NODES) ** (1.0 / 3.0))))
    axes = [np.arange(0, n, stride) for n in shape]
    lattice = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    sources = dipoles(q, normals, WINDING_CELL * step)
    w = sources.at(origin + lattice * step)
    if w.min() < WINDING_CLEAR - 1.0 and w.max() < 1.0 - WINDING_CLEAR:
        raise PointAtlasError(
            f"simplify could not build a surface from these {q.shape[0]} points: their "
            "winding number reads no inside on the grid (-1 at nodes, never +1): parts "
            "thinner than about two grid steps (sample them more densely), or normals "
            "pointing in"
        )
    w = w.reshape([a.size for a in axes])
    far_from = distance_to(occupied) * step
    # a node whose lattice corners are all more than a spacing from every point (near
    # the points the winding number is steep: interpolated it made tunnels)
    return (w, far_from, spacing + stride * step, stride), sources


def _bubbles(tri, far, nearest, dots, areas, closed=True):
    """Triangles of pieces (vertex-connected) that lie wholly far from the points, or
    that fewer than `STRAY_POINTS` points have their nearest triangle on (``nearest``:
    every point's nearest triangle), or whose triangles do not face as their nearest
    points do (``dots``: each triangle's normal, its length ``areas``, dotted with its
    nearest point's normal; over the piece, less than `BUBBLE_FACING` of the
    areas): small spurious surfaces where the field's sign flips, away from the
    points or tucked under the surface beside them (a void under a face faces into
    itself, away from the face's points as much as towards them; a true cavity faces
    as its points do). The facing test only for a ``closed`` sample (an open sheet's
    surface wraps both of its sides before the cut)."""
    from ._mesh import vertex_pieces

    comp = vertex_pieces(tri, int(tri.max()) + 1)
    piece = comp[tri[:, 0]]
    near = np.bincount(piece, weights=~far, minlength=comp.max() + 1)
    owned = np.bincount(piece[nearest], minlength=comp.max() + 1)
    agree = np.bincount(piece, weights=dots, minlength=comp.max() + 1)
    turned = agree < BUBBLE_FACING * np.bincount(piece, weights=areas, minlength=comp.max() + 1)
    turned &= closed
    return (near[piece] == 0) | (owned[piece] < STRAY_POINTS) | turned[piece]


def reconstruct_surface(
    q: np.ndarray, normals: np.ndarray, areas=None, tree=None, surface=None, off=None
) -> Reconstruction:
    """Triangle surface of points ``q`` (working frame) with oriented ``normals``.

    Closed where the sampled surface is closed and sampled within about two grid
    steps everywhere; cut open beyond the input's open boundaries. Where it leaves
    `LOST_POINTS` points more than `LOST_STEPS` steps off (a part thinner than the
    grid), built again on the finer grid (`finer_step`), kept when that brings most of
    them near without adding handles (or `LOST_SHARE` of the points were lost), or
    where `THIN_SHARE` of the points lie on walls or gaps thinner than
    `THIN_WALL_STEPS` steps (`thin_share`), kept when that adds no handle; where
    points are still lost on a closed sample, again with their parts made solid
    (`_solid.solid_retry`).
    ``areas``: the points' disc areas (`is_closed_sample`), ``tree``: their
    `cKDTree`, ``surface``: their `_distance.PointSurface` (an open sample is cut at
    its outline, `_open.beyond_points`); found when None. ``off``: the points off
    their neighbours' tangent planes (`_checks.STRAY_RATIO`; None: none), not counted
    as lost where alone (`_voxel_grid.not_strays`).
    """
    from ._distance import PointSurface

    tree = cKDTree(q) if tree is None else tree
    lo, hi = q.min(axis=0), q.max(axis=0)
    extent = float((hi - lo).max())
    if not extent > 0.0:
        raise PointAtlasError("simplify needs points that span a volume or a surface")
    factor = uneven_factor(q, tree)
    spacing, step, shape = grid_step(q, normals, tree, factor)
    closed = is_closed_sample(q, normals, areas)
    if not closed and surface is None:
        surface = PointSurface(q, normals, tree)
    fields = {}  # each grid's field, built once (the solid retry's is the finer one)
    grid = (spacing, step, shape)
    rec, closed, surface = _first_surface(q, normals, tree, grid, closed, surface, fields)
    fine = (spacing, *finer_step(q, spacing))
    if fine[1] < step / 1.2:
        thin = thin_share(q, normals, tree, THIN_WALL_STEPS * step) >= THIN_SHARE
        rec = _finer(q, normals, rec, fine, closed, surface, off, fields, thin)

    if closed:  # an open sample's far points lie beyond its cut outline: no inside

        def build(points, point_normals):
            solid = (points, point_normals)
            return _surface_at(q, normals, fine, closed, solid=solid, fields=fields)

        rec = solid_retry(q, normals, rec, build, step, spacing, off)
    return replace(rec, uneven=factor)


def _first_surface(q, normals, tree, grid, closed, surface, fields=None):
    """``(rec, closed, surface)``: `_surface_at` on ``grid``, or, where a sample the
    dipole test calls closed leaves every piece a bubble, the open sample it is
    (`_open.as_open`). ``fields``: `_surface_at`'s."""
    from ._distance import PointSurface

    try:
        rec = _surface_at(q, normals, grid, closed, surface=surface, fields=fields)
        return rec, closed, surface
    except AllBubbles as exc:
        if not closed:
            raise
        surface = PointSurface(q, normals, tree) if surface is None else surface
        rec = as_open(q, lambda: _surface_at(q, normals, grid, False, surface=surface), exc)
        return rec, False, surface


def _finer(q, normals, rec, fine, closed, surface, off=None, fields=None, thin=False):
    """``rec``, or the surface on the ``fine`` grid where ``rec`` lost a part thinner
    than its grid and the finer one brings most of those points near without adding
    handles, or where the sample is ``thin`` in part (`_voxel_grid.thin_share`) and
    the finer one adds no handle (``surface``: the points' `PointSurface` of an open
    sample; strays among the lost points left out: `_voxel_grid.not_strays`,
    ``off``; ``fields``: `_surface_at`'s)."""
    far, link = LOST_STEPS * rec.step, LOST_LINK * fine[0]
    lost = lost_points(q, rec.vertices, rec.triangles, far, off, link, rec.distance_index())
    if lost < LOST_POINTS and not thin:
        return rec
    try:
        finer = _surface_at(q, normals, fine, closed, surface=surface, fields=fields)
    except PointAtlasError:
        return rec
    still = lost_points(q, finer.vertices, finer.triangles, far, off, link, finer.distance_index())
    no_handle = euler_characteristic(finer.triangles) >= euler_characteristic(rec.triangles)
    # a part lost whole is worth a handle through it (a fin 0.8 steps thin)
    whole = lost >= LOST_SHARE * q.shape[0]
    found = lost >= LOST_POINTS and 2 * still <= lost and (no_handle or whole)
    return finer if found or (thin and no_handle) else rec


def _surface_at(q, normals, grid, closed, solid=None, surface=None, fields=None) -> Reconstruction:
    """`reconstruct_surface` on the grid ``(spacing, step, shape)``; ``solid``:
    (points, normals) whose half balls the field takes (`_solid.half_balls`);
    ``surface``: the points' `PointSurface` (an open sample's cut at the outline);
    ``fields``: a dict of the fields built so far, by grid and sidedness
    (`_field`, without half balls: read and filled; None: none kept)."""
    from skimage.measure import marching_cubes

    spacing, step, shape = grid
    lo = q.min(axis=0)
    origin = lo - (band_steps(step, spacing) + 2) * step
    # the points on a grid (`GridKnn`: the k-d tree's answers), for the band nodes'
    # and the triangles' nearest points
    near_q = GridKnn(q, KNN_CELL_SPACINGS * spacing)
    key = (step, tuple(shape), closed)
    f = None if fields is None else fields.get(key)
    if f is None:
        f = _field(q, normals, step, spacing, origin, shape, closed, near_q)
        if fields is not None:
            fields[key] = f
    if solid is not None:  # on a copy: the field kept is the plain one
        f = half_balls(f.copy(), origin, step, *solid, SOLID_RADIUS * step)
    if not f.min() < 0.0 < f.max():  # no inside (a few sparse points): no surface
        raise PointAtlasError(
            f"simplify could not build a surface from these {q.shape[0]} points: nothing "
            f"lies inside them on a grid of {step / spacing:.2g} point spacings (too few points, "
            "or normals "
            "that do not point out)"
        )
    verts, tri, _, _ = marching_cubes(f, level=0.0, spacing=(step, step, step), method="lewiner")
    verts = verts.astype(np.float64) + origin
    tri = tri.astype(np.int64)
    centroids = verts[tri].mean(axis=1)
    # an open sample's triangles surely beyond its points (`farther_than`) are cut
    # whatever their nearest point: that is found for the rest only
    gone = np.zeros(tri.shape[0], dtype=bool)
    if not closed:
        gone = near_q.farther_than(centroids, TRIM_STEPS * step)
    d, j = near_q.nearest_of(centroids, ~gone)
    tn = np.cross(verts[tri[:, 1]] - verts[tri[:, 0]], verts[tri[:, 2]] - verts[tri[:, 0]])
    dots, areas = np.einsum("ij,ij->i", tn, normals[j]), np.linalg.norm(tn, axis=1)
    facing = dots / (areas + 1e-300)
    # beyond an open boundary the surface folds back (far, or facing away from the
    # points) and runs on past the points' outline (a closed sample has no open
    # boundary: nothing to cut but bubbles; at a thin wall the far side's points face
    # away from a triangle a step off its own side)
    cut = np.zeros(tri.shape[0], dtype=bool)
    if not closed:
        cut = trim(tri, beyond_points(surface, centroids, d, facing, step))
        late = np.flatnonzero(gone & ~cut)  # left by the cut (a small piece)
        d_late, j_late = near_q.nearest_of(centroids, late)
        d[late], j[late] = d_late[late], j_late[late]
        dots[late] = np.einsum("ij,ij->i", tn[late], normals[j[late]])
    n_trimmed = int(cut.sum())  # the open cut (not the bubbles below)
    # bubbles among the triangles left (a cut can leave a stray triangle on its own)
    kept = np.flatnonzero(~cut)
    bubbles = np.zeros(0, dtype=bool)
    if kept.size:
        nearest = GridKnn(centroids[kept], 2.0 * step).query(q, 1)[1][:, 0]
        far = d[kept] > 2.0 * step
        bubbles = _bubbles(tri[kept], far, nearest, dots[kept], areas[kept], closed)
        cut[kept[bubbles]] = True
    if cut.any():
        verts, tri = used_only(verts, tri[~cut])
    # at a wall thinner than the grid, the other side's points are the nearest of
    # most triangles: every piece reads as a bubble
    if tri.shape[0] == 0 and bubbles.size and bubbles.all():
        raise AllBubbles(
            f"simplify could not build a surface from these {q.shape[0]} points: every "
            f"piece of their voxel surface (grid step {step / spacing:.2g} x the point "
            "spacing) faces away from its nearest points' normals, as at walls thinner "
            "than about two steps (sample the thin parts more densely)"
        )
    if tri.shape[0] == 0:
        raise PointAtlasError("simplify could not build a surface from these points")
    if cut.any():  # cutting can leave pieces touching at a vertex: give each its own
        verts, tri = split_pinches(verts, tri)
        if not closed:  # and a stray triangle, on its own then; the staircase smoothed
            verts, tri = drop_strays(q, verts, tri, STRAY_POINTS)
            verts = smooth_outline(verts, tri)
    n_handles = 0
    if closed:  # bridges across gaps thinner than a step: small handles, cut
        verts, tri, n_handles = cut_handles(verts, tri, step)
    return Reconstruction(
        vertices=verts,
        triangles=tri,
        step=step,
        shape=shape,
        n_trimmed=n_trimmed,
        n_handles=n_handles,
    )


def robust_mesh(
    q,
    normals,
    labels,
    proxy_normals,
    frame,
    *,
    max_error=None,
    max_triangles=None,
    areas=None,
    neighbors=None,
    radius=None,
    off=None,
    first=None,
):
    """The robust path: the points' surface (`reconstruct_surface`), its triangles
    labelled by the points' regions (`transfer_labels`), then the structure-aware
    decimation of the mesh path (`Decimation`), its flat regions' planes from their
    points, to the fewest triangles within ``max_error`` (input units; default
    `MAX_ERROR` of the diagonal; where the surface itself is farther, what it
    reaches there and some more, `PointDistances.floor_at`) of the points both
    ways, or to ``max_triangles``. ``areas``: the points' disc areas
    (`is_closed_sample`), ``neighbors``: their k-NN table (`query_knn`, for
    `PointDistances.floor_at`), ``radius``: their discs' radii (`PointSurface`,
    `disc_radii`); found when None; ``off``: as `reconstruct_surface`'s; ``first``:
    ``(tree, surface, reconstruction)`` of these points found already, or None.

    Returns ``(result, reconstruction, point_labels)``: the `SurfaceSimplification`
    in input coordinates (``distances`` are those of the points), the surface and
    the face of every point (its nearest triangle's region).
    """
    from ._decimate_mesh import MAX_ERROR
    from ._distance import PointSurface
    from ._level_search import default_steps, start_collapses
    from ._point_distances import PointDistances
    from ._polygons import PLANAR_RTOL
    from ._snap import FIT_STEPS, PointsDecimation, fit_to_points
    from ._surface_regions import region_layers, region_planes, transfer_labels
    from ._triangles import _face_graph, _surface

    diag = float(np.linalg.norm(q.max(axis=0) - q.min(axis=0)))
    bound = MAX_ERROR * diag if max_error is None else max_error / frame.scale
    # the regions' planes refitted, and split into their parallel layers (a gap of a
    # quarter of the bound: their vertices go onto the planes within it, below)
    labels, proxy_normals = region_layers(q, normals, labels, proxy_normals, 0.25 * bound)
    if first is None:
        tree = cKDTree(q)
        surface = PointSurface(q, normals, tree, radius)
        rec = reconstruct_surface(q, normals, areas, tree, surface, off)
    else:
        tree, surface, rec = first
    # the vertices' fit on a thread while the triangles take the points' regions
    fitted = on_thread(
        fit_to_points, rec.vertices, rec.triangles, q, normals, surface.grid, FIT_STEPS * rec.step
    )
    s = _surface(rec.vertices, rec.triangles)
    nearest = surface.grid.query(s.centroids, 1)[1][:, 0]
    lab, source = transfer_labels(s, _face_graph(s), labels, nearest)
    pn, offsets, deviation, width, steady = region_planes(q, labels, proxy_normals, source, normals)
    # a region whose points lie within a quarter of the bound of its plane, and wider
    # than a grid step, is flat: its vertices go onto the plane (at most two grid
    # steps: the voxel surface's rounded edges and corners come back). A narrow band
    # (estimated normals turning over an edge) carries no plane.
    planes = (pn, offsets, (deviation <= 0.25 * bound) & ((width >= rec.step) | steady))
    measure = PointDistances(q, surface)
    verts = fitted.result()
    box = measure.box  # never a vertex outside
    # a vertex placed on its planes stays there only within a quarter of the bound of
    # the points' surface (or no farther than it was): a wrong plane is not followed
    level = PointsDecimation(
        verts,
        rec.triangles,
        lab,
        planes,
        2.0 * rec.step,
        0.0,
        measure,
        box,
        0.25 * bound,
        FIT_STEPS * rec.step,
        bound,
    )
    if max_triangles is None:
        start_collapses(level, measure, verts, rec.triangles, bound, max_error, neighbors)
    if max_error is None:
        # the default bound, or what the points' surface reaches there (before or
        # after its placement on the planes, the more), if more
        steps = default_steps(
            level, measure, (verts, rec.triangles), bound, neighbors, max_triangles
        )
    else:
        steps = level.steps_for(max_triangles, bound)
    if max_triangles is not None and not level.within(steps, SPIKE_FACTOR * bound):
        # a budget is met only while the output stays near the points (the last
        # collapses of a sequence can fold the surface): else the closest level
        steps = level.steps_within(SPIKE_FACTOR * bound)
    res = _in_input(level.result(steps, PLANAR_RTOL * diag), frame)  # to the points
    near_tri = GridKnn(s.centroids, 2.0 * rec.step).query(q, 1)[1][:, 0]
    return res, rec, lab[near_tri]


def _in_input(res, frame):
    """The `SurfaceSimplification` ``res`` of the frame's coordinates in the input's:
    its vertices mapped back, its distances and planarity errors scaled."""
    scale = frame.scale
    return replace(
        res,
        vertices=frame.to_input(res.vertices),
        distances=res.distances * scale,
        distance_mean=res.distance_mean * scale,
        distance_max=res.distance_max * scale,
        back_distance_mean=res.back_distance_mean * scale,
        back_distance_max=res.back_distance_max * scale,
        planarity_error=res.planarity_error * scale,
        polygon_planarity=res.polygon_planarity * scale,
    )
