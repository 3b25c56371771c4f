"""Software point renderer: orthographic projection, z-buffered disc splats."""

from __future__ import annotations

import math

import numpy as np

from .._core import as_labels, as_normals, as_points
from ._camera import Camera, resolve_camera
from ._colors import BACKGROUND, NEUTRAL, ScalarLegend, label_colors, scalar_colors
from ._zbuffer import fill_pinholes, zbuffer

__all__ = ["render_points_array", "check_size", "render_points_rgb"]

#: Largest image side in pixels (the z-buffers are O(width x height) float64).
MAX_SIZE = 8192
#: Share of the light that reaches every surface (keeps back-lit parts legible).
AMBIENT = 0.3
#: Splat radius as a fraction of the local spacing (mean distance to the 12
#: nearest distinct neighbours, about 1.35 x the typical gap): 0.7 closes the
#: gaps of a surface sample without blurring detail.
SPLAT_FRACTION = 0.7
#: Largest splat radius: the smaller image side divided by this (a few hundred
#: points may need discs this big to close their surface).
MAX_SPLAT_FRACTION = 10.0
#: Points sampled (by stride) to estimate the spacing; keeps 1e6 points fast.
SPACING_SAMPLE = 4096
#: Up to this many points the splat size adapts to each point's own spacing.
PER_POINT_MAX = 200_000
#: Neighbours queried per sampled point (room for duplicates before 12 distinct).
SPACING_K = 32
#: Depth jump (in splat radii) to a neighbouring pixel that draws an outline.
OUTLINE_JUMP = 4.0
#: ... and at least this fraction of the camera radius (object half-size), so
#: tilted splats on one smooth surface do not draw spurious lines.
OUTLINE_RELATIVE = 0.04
#: Smallest |n . view| used to tilt a splat into its tangent plane: an edge-on
#: splat is still a 0.3 x radius wide ellipse, so grazing surfaces do not crack.
MIN_FACING = 0.3
#: Passes of one-pixel hole filling (each pass closes holes one pixel deeper).
PINHOLE_PASSES = 3
#: Brightness factor of outline pixels.
OUTLINE_DARKEN = 0.6


def check_size(size) -> tuple[int, int]:
    """Validate ``size = (width, height)`` in pixels (private)."""
    try:
        width, height = (int(v) for v in size)
        ok = all(float(v) == int(v) for v in size)
    except (TypeError, ValueError):
        raise TypeError(f"size must be a pair (width, height) of ints; got {size!r}") from None
    if not ok or width < 16 or height < 16 or width > MAX_SIZE or height > MAX_SIZE:
        raise ValueError(f"size must be two integers in [16, {MAX_SIZE}] (pixels); got {size!r}")
    return width, height


def _spacing(points: np.ndarray) -> np.ndarray:
    """Local point spacing: mean distance to the nearest distinct neighbours.

    Up to 12 distinct neighbour positions per point (exact duplicates, common in
    meshes split per texture coordinate, are skipped: per point they are merged
    first; on the sample up to 32 neighbours are searched for distinct ones). Per
    point when N <= ``PER_POINT_MAX``; beyond that the 90th percentile over a
    strided sample, broadcast.
    Returns shape (N,); zeros where unknown (a single point, all coincident).
    """
    n = points.shape[0]
    if n < 2:
        return np.zeros(n)
    from scipy.spatial import cKDTree

    per_point = n <= PER_POINT_MAX
    k = min(SPACING_K if not per_point else 13, n)
    stride = 1 if per_point else max(1, n // SPACING_SAMPLE)
    tree = cKDTree(points, balanced_tree=False, compact_nodes=False)
    dist, _ = tree.query(points[::stride], k=k)
    dist = dist[:, 1:]
    if per_point and (dist[:, 0] == 0).any():
        # exact duplicates: measure on the distinct positions, then map back
        distinct_pts, inverse = np.unique(points + 0.0, axis=0, return_inverse=True)
        return _spacing(distinct_pts)[inverse.reshape(-1)]
    prev = np.concatenate([np.zeros((dist.shape[0], 1)), dist[:, :-1]], axis=1)
    distinct = (dist > 0) & (dist != prev)
    keep = distinct & (np.cumsum(distinct, axis=1) <= 12)
    count = keep.sum(axis=1)
    total = np.where(keep, dist, 0.0).sum(axis=1)
    local = np.divide(total, count, out=np.zeros_like(total), where=count > 0)
    if not per_point:
        known = local[count > 0]
        # the 90th percentile, so sparser parts of a big cloud are still closed
        return np.full(n, float(np.quantile(known, 0.9)) if known.size else 0.0)
    return local


def _splat_radii(points: np.ndarray, scale: float, width: int, height: int) -> np.ndarray:
    """Disc radius in pixels per point: ``SPLAT_FRACTION`` x local spacing, bounded."""
    local = _spacing(points) * SPLAT_FRACTION * scale
    positive = local[local > 0]
    if positive.size == 0:  # one point or all coincident
        return np.full(points.shape[0], min(width, height) / 80.0)
    typical = float(np.median(positive))
    # sparse areas get larger discs (no holes), but never far from the typical
    # size, and outliers/duplicates never shrink below it by much
    radii = np.clip(np.where(local > 0, local, typical), 0.75 * typical, 4.0 * typical)
    return np.clip(radii, 1.0, max(1.0, min(width, height) / MAX_SPLAT_FRACTION))


def _disc_offsets(radius: float) -> tuple[np.ndarray, np.ndarray]:
    """Integer pixel offsets of a disc of ``radius`` pixels (always holds (0, 0))."""
    reach = int(math.ceil(radius))
    grid = np.arange(-reach, reach + 1)
    dx, dy = np.meshgrid(grid, grid, indexing="xy")
    inside = dx * dx + dy * dy <= radius * radius + 0.5
    return dx[inside].ravel(), dy[inside].ravel()


def _zbuffer(ix, iy, depth, width, height, radii, slopes=None):
    """Nearest point per pixel. Returns (owner (H*W,) int64 with -1, zbuf (H*W,)).

    Without ``slopes`` every point is a disc of ``radii[i]`` pixels facing the
    viewer at its depth. With ``slopes = (ax, ay, scale)`` (depth change per pixel
    step right/down along the point's tangent plane) it is a disc *in the tangent
    plane*: an ellipse on screen whose samples carry their own depth, so
    silhouettes stay thin and slanted surfaces z-buffer correctly (surface
    splatting). Per pixel the largest depth wins, ties go to the smaller index
    (`_zbuffer.zbuffer_kernel`: one pass over the points, memory O(N + pixels)).
    """
    offsets = _disc_offsets(float(radii.max()))
    return zbuffer(ix, iy, depth, width, height, radii, offsets, slopes)


def _tangent_slopes(normals: np.ndarray, camera: Camera, scale: float):
    """(ax, ay, scale): depth change per pixel step right / down in the tangent
    plane of each point; |n_z| is bounded below by ``MIN_FACING`` so edge-on
    splats stay at least that fraction of a disc wide (no cracks)."""
    right, screen_up, eye = camera.basis()
    nx, ny, nz = normals @ right, normals @ screen_up, normals @ eye
    nz = np.where(nz < 0, -1.0, 1.0) * np.maximum(np.abs(nz), MIN_FACING)
    # tangent plane: nx ox + ny oy + nz oz = 0 with (ox, oy) = (dx, -dy) / scale
    return -nx / (nz * scale), ny / (nz * scale), scale


def _outline(zbuf: np.ndarray, width: int, height: int, jump: float) -> np.ndarray:
    """Pixels whose 4-neighbour is background or farther by more than ``jump``."""
    z = zbuf.reshape(height, width)
    pad = np.pad(z, 1, constant_values=-np.inf)
    edge = np.zeros((height, width), dtype=bool)
    for sy, sx in ((0, 1), (2, 1), (1, 0), (1, 2)):
        nb = pad[sy : sy + height, sx : sx + width]
        with np.errstate(invalid="ignore"):  # -inf - -inf (background pairs) is NaN
            edge |= (z - nb) > jump
    edge &= np.isfinite(z)
    return edge.ravel()


def render_points_rgb(
    points: np.ndarray,
    *,
    normals: np.ndarray | None,
    base: np.ndarray,
    camera: Camera,
    width: int,
    height: int,
    point_size: float | None,
    lighting: bool,
) -> np.ndarray:
    """Rasterise validated inputs; ``base`` (N, 3) colours in [0, 1] (private)."""
    x, y, depth = camera.project(points, width, height)
    scale = camera.scale(width, height)
    if point_size is None:
        radii = _splat_radii(points, scale, width, height)
    else:
        radii = np.full(points.shape[0], 0.5 * float(point_size))
    ix = np.floor(x).astype(np.int64)
    iy = np.floor(y).astype(np.int64)
    slopes = None if normals is None else _tangent_slopes(normals, camera, scale)
    owner, zbuf = _zbuffer(ix, iy, depth, width, height, radii, slopes)
    typical = max(float(np.median(radii)), 1.0)
    jump = max(OUTLINE_JUMP * typical / scale, OUTLINE_RELATIVE * camera.radius)
    for _ in range(PINHOLE_PASSES):
        fill_pinholes(owner, zbuf, width, height, jump)
    covered = owner >= 0
    who = owner[covered]
    if lighting:
        if normals is not None:
            shade = AMBIENT + (1.0 - AMBIENT) * np.abs(normals[who] @ camera.light())
        else:  # depth cue: nearer is brighter
            lo, hi = float(depth.min()), float(depth.max())
            t = (depth[who] - lo) / (hi - lo) if hi > lo else np.ones(who.shape[0])
            shade = 0.45 + 0.55 * t
        edge = _outline(zbuf, width, height, jump)[covered]
        shade = np.where(edge, shade * OUTLINE_DARKEN, shade)
    else:
        shade = np.ones(who.shape[0])
    image = np.empty((width * height, 3), dtype=np.float32)
    image[:] = BACKGROUND
    image[covered] = base[who] * shade[:, None]
    rgb = np.round(np.clip(image, 0.0, 1.0) * 255.0).astype(np.uint8)
    return rgb.reshape(height, width, 3)


def _rgb_colors(colors, n: int) -> np.ndarray:
    """Explicit per-point colours -> (N, 3) floats in [0, 1] (private)."""
    col = np.asarray(colors)
    if col.ndim != 2 or col.shape[0] != n or col.shape[1] not in (3, 4):
        raise ValueError(f"colors must have shape ({n}, 3) or ({n}, 4); got {col.shape}")
    if col.dtype == np.uint8:
        return col[:, :3].astype(np.float64) / 255.0
    if col.dtype == np.uint16:  # LAS and 16-bit PLY colours, kept as read
        return col[:, :3].astype(np.float64) / 65535.0
    try:
        rgb = np.asarray(col[:, :3], dtype=np.float64)
    except (TypeError, ValueError):
        raise TypeError(f"colors must be numeric; got dtype {col.dtype}") from None
    if not np.isfinite(rgb).all() or rgb.min() < 0 or rgb.max() > 1:
        raise ValueError("colors must be uint8, uint16 or floats in [0, 1]")
    return rgb


def prepare_points(points, normals, labels, scalars, cmap, scalar_name, clim, colors=None):
    """Validate point inputs; return (pts, nrm, base colours, legend, note) (private)."""
    pts = as_points(points, min_points=1)
    n = pts.shape[0]
    nrm = None if normals is None else as_normals(normals, n)
    options = (("labels", labels), ("scalars", scalars), ("colors", colors))
    given = [name for name, value in options if value is not None]
    if len(given) > 1:
        raise ValueError(
            f"give one of labels, scalars or colors, not both (got {' and '.join(given)}; "
            "one colouring per picture)"
        )
    legend: ScalarLegend | None = None
    note = None
    if labels is not None:
        lab = as_labels(labels, n)
        base = label_colors(lab)
        n_labels = np.unique(lab[lab >= 0]).size
        note = f"{n_labels} label{'s' if n_labels != 1 else ''}"
        n_free = int((lab < 0).sum())
        if n_free:
            note += f", {n_free} unlabelled (grey)"
    elif scalars is not None:
        values = np.asarray(scalars)
        if values.ndim != 1 or values.shape[0] != n:
            raise ValueError(f"scalars must have shape ({n},) (one per point); got {values.shape}")
        base, legend = scalar_colors(values, cmap=cmap, name=scalar_name or "value", clim=clim)
    elif colors is not None:
        base = _rgb_colors(colors, n)
    else:
        base = np.broadcast_to(NEUTRAL, (n, 3))
    return pts, nrm, base, legend, note


def render_points_array(
    points,
    *,
    normals=None,
    labels=None,
    scalars=None,
    cmap: str = "viridis",
    view=None,
    size=(1024, 1024),
    point_size: float | None = None,
    lighting: bool = True,
    clim=None,
    colors=None,
) -> np.ndarray:
    """Render a point set to an RGB image (no axes, no legend).

    Parameters
    ----------
    points : array_like of shape (N, 3), float64
        Coordinates (N >= 1).
    normals : array_like of shape (N, 3), float64, optional
        Normals for Lambert shading (two-sided, so orientation does not matter).
        Without normals, nearer points are drawn brighter.
    labels : array_like of shape (N,), int, optional
        Region ids coloured with :func:`label_colors` (negative = grey).
    scalars : array_like of shape (N,), float, optional
        A field mapped through ``cmap`` (NaN = grey). Not together with ``labels``.
    cmap : str
        Matplotlib colormap name for ``scalars``.
    view : None, Camera or (float, float)
        Camera; ``None`` fits the default view, a pair is (azimuth, elevation) in
        radians. Pass the same :class:`Camera` to every picture of one model.
    size : (int, int)
        Image (width, height) in pixels.
    point_size : float, optional
        Splat diameter in pixels (default from the mean point spacing).
    lighting : bool
        Shade (Lambert / depth cue and outlines); False draws flat base colours.
    clim : (float, float), optional
        Value range of the colormap (default: finite min/max of ``scalars``).
    colors : array_like of shape (N, 3) or (N, 4), optional
        Explicit RGB(A) per point (uint8, or floats in [0, 1]; alpha ignored),
        e.g. scanner colours. Not together with ``labels``/``scalars``.

    Returns
    -------
    rgb : ndarray of shape (height, width, 3), uint8
        White background.

    Raises
    ------
    ValueError
        Empty or non-finite points, mismatched lengths, labels and scalars both
        given, bad size.

    Notes
    -----
    Orthographic projection; each point is a disc (radius 0.7 x its mean
    distance to its 12 nearest distinct neighbours, bounded by 0.75-4 x the
    median) lying in its tangent plane when normals are given (an ellipse on
    screen, surface splatting) or facing the viewer otherwise, kept per pixel
    when nearest to the viewer
    (``np.maximum.at`` z-buffer, ties to the smaller index), so the result is
    deterministic and costs O(N x disc area).

    Examples
    --------
    >>> rgb = render_points_array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], size=(32, 24))
    >>> rgb.shape, rgb.dtype
    ((24, 32, 3), dtype('uint8'))
    """
    width, height = check_size(size)
    pts, nrm, base, _, _ = prepare_points(
        points, normals, labels, scalars, cmap, None, clim, colors
    )
    if point_size is not None and not (np.isfinite(point_size) and point_size > 0):
        raise ValueError(f"point_size must be a positive number of pixels; got {point_size!r}")
    camera = resolve_camera(view, pts)
    return render_points_rgb(
        pts,
        normals=nrm,
        base=base,
        camera=camera,
        width=width,
        height=height,
        point_size=point_size,
        lighting=lighting,
    )
