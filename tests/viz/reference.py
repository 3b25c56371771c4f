"""Plain-numpy references of the viz room's numba kernels."""

from __future__ import annotations

import numpy as np

from pointatlas.viz._raster import _spans

#: Pixels generated per batch of triangle bounding boxes (bounds memory).
RASTER_BATCH = 4_000_000


def zbuffer_reference(ix, iy, depth, width, height, radii, offsets, slopes=None):
    """`pointatlas.viz._zbuffer.zbuffer` in numpy, over the disc ``offsets`` (the
    renderer's code before its kernel). Nearest point per pixel: (owner (H*W,) int64
    with -1, zbuf (H*W,)).

    Without ``slopes`` every point is a disc of ``radii[i]`` pixels facing the
    viewer at its depth. With ``slopes = (ax, ay)`` (depth change per pixel step
    right/down along the point's tangent plane) it is a disc *in the tangent
    plane*: an ellipse on screen whose samples carry their own depth, so
    silhouettes stay thin and slanted surfaces z-buffer correctly (surface
    splatting). Per pixel the largest depth wins, ties go to the smaller index.
    The splat samples are generated twice (max depth, then owner) instead of
    being stored, so memory stays O(N + pixels).
    """
    n = depth.shape[0]
    npix = width * height
    zbuf = np.full(npix, -np.inf)
    ids = np.arange(n, dtype=np.int64)
    reach2 = radii * radii + 0.5
    uniform = slopes is None and bool(np.all(radii == radii[0]))
    offsets = list(zip(*offsets, strict=True))

    def samples(dx, dy):
        px = ix + dx
        py = iy + dy
        ok = (px >= 0) & (px < width) & (py >= 0) & (py < height)
        if slopes is None:
            if not uniform:
                ok &= reach2 >= dx * dx + dy * dy
            d = depth[ok]
        else:
            dz = slopes[0] * dx + slopes[1] * dy  # depth offset, input units
            lift = dz * slopes[2]  # the same offset in pixels
            ok &= reach2 >= dx * dx + dy * dy + lift * lift
            d = depth[ok] + dz[ok]
        return py[ok] * width + px[ok], d, ok

    for dx, dy in offsets:
        pix, d, _ = samples(dx, dy)
        np.maximum.at(zbuf, pix, d)
    owner = np.full(npix, n, dtype=np.int64)
    for dx, dy in offsets:
        pix, d, ok = samples(dx, dy)
        win = d == zbuf[pix]
        np.minimum.at(owner, pix[win], ids[ok][win])
    owner[owner == n] = -1
    return owner, zbuf


def fill_pinholes_reference(owner, zbuf, width: int, height: int, jump: float) -> None:
    """`pointatlas.viz._zbuffer.fill_pinholes` in numpy (the renderer's code before
    its kernel). In place: close one-pixel holes of the front surface.

    A pixel is a hole when at least 3 of its 4 neighbours are nearer by more than
    ``jump`` (background counts as infinitely far); it takes the nearest
    neighbour's point. Random samples leave such holes where the splats just miss.
    """
    own = owner.reshape(height, width)
    z = zbuf.reshape(height, width)
    pad_o = np.pad(own, 1, constant_values=-1)
    pad_z = np.pad(z, 1, constant_values=-np.inf)
    shifts = ((0, 1), (2, 1), (1, 0), (1, 2))
    nb_o = np.stack([pad_o[sy : sy + height, sx : sx + width] for sy, sx in shifts])
    nb_z = np.stack([pad_z[sy : sy + height, sx : sx + width] for sy, sx in shifts])
    with np.errstate(invalid="ignore"):  # -inf - -inf between background pixels
        nearer = (nb_z - z[None]) > jump
    hole = nearer.sum(axis=0) >= 3
    if not hole.any():
        return
    best = np.argmax(nb_z, axis=0)
    rows, cols = np.nonzero(hole)
    own[rows, cols] = nb_o[best[rows, cols], rows, cols]
    z[rows, cols] = nb_z[best[rows, cols], rows, cols]


def rasterize_triangles_reference(x, y, z, tris, owner_of_tri, width, height):
    """`pointatlas.viz._raster.rasterize_triangles` in numpy (the renderer's code before
    its kernel). Z-buffer triangles; returns (owner (H*W,) int64 with -1, zbuf (H*W,)).

    ``x, y`` are pixel coordinates (pixel (i, j) has its centre at (i + 0.5,
    j + 0.5)), ``z`` depth (larger = nearer). A pixel centre inside a triangle
    (edges included) takes its interpolated depth; per pixel the largest depth
    wins, ties to the smaller owner id. Scanline spans, so the work is
    proportional to the covered pixels (no bounding-box waste); fragments are
    generated twice (depth pass, owner pass) in batches to bound memory.
    Inputs are validated (private).
    """
    npix = width * height
    zbuf = np.full(npix, -np.inf)
    row, col0, count, z_row, step, t = _spans(x, y, z, tris, width, height)
    ids = owner_of_tri[t]

    def fragments(lo, hi):
        c = count[lo:hi]
        # column = position within the batch minus the span's start, plus col0
        col = np.arange(int(c.sum()), dtype=np.int64) + np.repeat(
            col0[lo:hi] - (np.cumsum(c) - c), c
        )
        pix = np.repeat(row[lo:hi] * width, c) + col
        depth = np.repeat(z_row[lo:hi], c) + np.repeat(step[lo:hi], c) * col
        return pix, depth, c

    for lo, hi in _batches(count):
        pix, depth, _ = fragments(lo, hi)
        np.maximum.at(zbuf, pix, depth)
    sentinel = np.iinfo(np.int64).max
    owner = np.full(npix, sentinel, dtype=np.int64)
    for lo, hi in _batches(count):
        pix, depth, c = fragments(lo, hi)
        win = depth == zbuf[pix]
        np.minimum.at(owner, pix[win], np.repeat(ids[lo:hi], c)[win])
    owner[owner == sentinel] = -1
    return owner, zbuf


def _batches(counts: np.ndarray):
    """Split consecutive items so each batch holds about RASTER_BATCH fragments."""
    ends = np.cumsum(counts)
    start = 0
    while start < counts.shape[0]:
        base = ends[start - 1] if start else 0
        stop = int(np.searchsorted(ends, base + RASTER_BATCH, side="right"))
        stop = max(stop, start + 1)
        yield start, stop
        start = stop
