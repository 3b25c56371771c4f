"""The z-buffers (private): the points' (`_points.render_points_rgb`: every point a
splat of disc offsets, the nearest per pixel, then one-pixel holes closed) and the
triangles' (`_raster.rasterize_triangles`: their scanline spans' pixels). Serial numba kernels
(over the points in order; over the pixels); their plain-numpy references are in
tests/viz/reference.py (`zbuffer_reference`: max depth, then the smallest index at it;
`fill_pinholes_reference`; `rasterize_triangles_reference`), equal bit for bit.
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["fill_pinholes", "pinholes_kernel", "spans_kernel", "zbuffer", "zbuffer_kernel"]


@njit(cache=True)
def zbuffer_kernel(ix, iy, depth, width, height, reach2, dx, dy, check, ax, ay, lift, owner, zbuf):
    """Point ``i`` covers pixel ``(ix[i] + dx[k], iy[i] + dy[k])`` for every offset ``k``
    inside the image and, where ``check``, inside its disc (``reach2[i]`` against
    ``dx^2 + dy^2``, plus ``(dz * lift)^2`` where ``ax`` is not empty) at depth
    ``depth[i] + dz``, ``dz = ax[i] dx + ay[i] dy`` (0 without ``ax``). Per pixel the
    largest depth wins, ties go to the smaller index: ``owner`` (-1 where none, filled
    in place) and ``zbuf`` (-inf where none)."""
    tilted = ax.shape[0] > 0
    for i in range(depth.shape[0]):
        for k in range(dx.shape[0]):
            px = ix[i] + dx[k]
            py = iy[i] + dy[k]
            if px < 0 or px >= width or py < 0 or py >= height:
                continue
            r2 = dx[k] * dx[k] + dy[k] * dy[k]
            d = depth[i]
            if tilted:
                dz = ax[i] * dx[k] + ay[i] * dy[k]
                up = dz * lift
                if reach2[i] < r2 + up * up:
                    continue
                d = depth[i] + dz
            elif check and reach2[i] < r2:
                continue
            pix = py * width + px
            if d > zbuf[pix]:
                zbuf[pix] = d
                owner[pix] = i
    return owner, zbuf


def zbuffer(ix, iy, depth, width, height, radii, offsets, slopes=None):
    """``(owner, zbuf)`` of `zbuffer_kernel` for ``offsets`` ``(dx, dy)`` and
    ``slopes`` ``(ax, ay, lift)`` or None (discs facing the viewer)."""
    npix = width * height
    owner = np.full(npix, -1, dtype=np.int64)
    zbuf = np.full(npix, -np.inf)
    reach2 = radii * radii + 0.5
    check = slopes is not None or not bool(np.all(radii == radii[0]))
    if slopes is None:
        ax = ay = np.zeros(0)
        lift = 0.0
    else:
        ax, ay = np.ascontiguousarray(slopes[0], float), np.ascontiguousarray(slopes[1], float)
        lift = float(slopes[2])
    dx, dy = (np.ascontiguousarray(o, dtype=np.int64) for o in offsets)
    args = (np.ascontiguousarray(ix, dtype=np.int64), np.ascontiguousarray(iy, dtype=np.int64))
    args += (np.ascontiguousarray(depth, dtype=np.float64), int(width), int(height))
    zbuffer_kernel(*args, reach2, dx, dy, check, ax, ay, lift, owner, zbuf)
    return owner, zbuf


@njit(cache=True)
def pinholes_kernel(own, z, width, height, jump, owner, zbuf):
    """One pass of `fill_pinholes`: read ``own``, ``z`` (a copy), write ``owner``,
    ``zbuf``. A pixel whose 4-neighbours (up, down, left, right) are nearer by more
    than ``jump`` at 3 or 4 of them takes the nearest one's (the first on ties)."""
    for y in range(height):
        for x in range(width):
            here = z[y * width + x]
            count, best, best_z = 0, -1, -np.inf
            for k in range(4):
                ny, nx = y, x
                if k == 0:
                    ny = y - 1
                elif k == 1:
                    ny = y + 1
                elif k == 2:
                    nx = x - 1
                else:
                    nx = x + 1
                nz, no = -np.inf, -1
                if 0 <= ny < height and 0 <= nx < width:
                    nz, no = z[ny * width + nx], own[ny * width + nx]
                # nz - here > jump, without -inf - -inf (background beside background)
                if nz > -np.inf and (here == -np.inf or nz - here > jump):
                    count += 1
                if best < 0 or nz > best_z:
                    best, best_z, best_own = k, nz, no
            if count >= 3:
                owner[y * width + x] = best_own
                zbuf[y * width + x] = best_z


def fill_pinholes(owner, zbuf, width: int, height: int, jump: float) -> None:
    """In place, one pass: every pixel with at least 3 of its 4 neighbours nearer by
    more than ``jump`` (background infinitely far) takes its nearest neighbour's
    point (`pinholes_kernel`, on a copy: the pixels change together): the one-pixel
    holes random samples leave where their splats just miss."""
    pinholes_kernel(owner.copy(), zbuf.copy(), int(width), int(height), float(jump), owner, zbuf)


@njit(cache=True)
def spans_kernel(row, col0, count, z_row, step, ids, width, owner, zbuf):
    """Span ``s`` covers the ``count[s]`` pixels from column ``col0[s]`` of ``row[s]``
    at depth ``z_row[s] + step[s] * column``; per pixel the largest depth wins, ties
    to the smaller ``ids`` (``owner`` -1 and ``zbuf`` -inf where none, in place)."""
    for s in range(row.shape[0]):
        for col in range(col0[s], col0[s] + count[s]):
            pix = row[s] * width + col
            d = z_row[s] + step[s] * col
            if d > zbuf[pix] or (d == zbuf[pix] and ids[s] < owner[pix]):
                zbuf[pix] = d
                owner[pix] = ids[s]
    return owner, zbuf
