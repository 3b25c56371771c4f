"""Z-buffer rasteriser for triangles (the mesh renderer's back end): numpy scanline
spans, their pixels z-buffered by a numba kernel (`_zbuffer.spans_kernel`)."""

from __future__ import annotations

import numpy as np

from ._zbuffer import spans_kernel

__all__ = ["triangulate_faces", "rasterize_triangles"]

#: Slack (pixels) added to both ends of a scanline span (see `_spans`).
SPAN_SLACK = 1e-7


def _polygon_frame(verts: np.ndarray, normal: np.ndarray) -> tuple[int, int]:
    """The two coordinate axes to keep when projecting a polygon to 2-D."""
    drop = int(np.argmax(np.abs(normal)))
    keep = [a for a in range(3) if a != drop]
    return keep[0], keep[1]


def triangulate_faces(vertices, indptr, flat, normals) -> tuple[np.ndarray, np.ndarray]:
    """Triangles (T, 3) and their face ids (T,) for polygon faces (private).

    Triangles pass through; convex polygons are fanned (vectorised per face
    size); non-convex polygons are ear-clipped (mapbox-earcut) in the plane that
    drops their normal's largest axis, so an L-shaped face is filled correctly.
    Inputs are validated; ``normals`` are the faces' Newell normals.
    """
    sizes = np.diff(indptr)
    tris = []
    owners = []
    for m in np.unique(sizes):
        faces_m = np.flatnonzero(sizes == m)
        corners = flat[indptr[faces_m][:, None] + np.arange(m)]  # (F_m, m)
        if m == 3:
            tris.append(corners)
            owners.append(faces_m)
            continue
        p = vertices[corners]  # (F_m, m, 3)
        e = np.roll(p, -1, axis=1) - p
        turn = np.cross(e, np.roll(e, -1, axis=1))  # (F_m, m, 3)
        sign = np.einsum("fmk,fk->fm", turn, normals[faces_m])
        convex = (sign >= -1e-12 * np.abs(sign).max(initial=1.0)).all(axis=1)
        # fan: (0, j, j + 1) for j = 1 .. m - 2
        j = np.arange(1, m - 1)
        fan = np.stack(
            [
                np.repeat(corners[convex, :1], m - 2, axis=1),
                corners[convex][:, j],
                corners[convex][:, j + 1],
            ],
            axis=2,
        ).reshape(-1, 3)
        tris.append(fan)
        owners.append(np.repeat(faces_m[convex], m - 2))
        if (~convex).any():
            import mapbox_earcut

            for f, c in zip(faces_m[~convex], corners[~convex], strict=True):
                a, b = _polygon_frame(vertices[c], normals[f])
                xy = vertices[c][:, [a, b]]
                idx = mapbox_earcut.triangulate_float64(xy, np.array([m], dtype=np.uint32))
                if idx.size:
                    tris.append(c[idx.reshape(-1, 3)])
                    owners.append(np.full(idx.size // 3, f, dtype=np.int64))
    return np.concatenate(tris).astype(np.int64), np.concatenate(owners).astype(np.int64)


def _spans(x, y, z, tris, width, height):
    """Scanline spans of every triangle: one row of covered pixel centres each.

    Returns per span: row, first column, pixel count, depth at column 0 of the
    row and depth step per column, and the triangle index. A pixel centre is
    covered when it lies inside or on the triangle (half-planes, edges included).
    """
    tx, ty, tz = x[tris], y[tris], z[tris]  # (T, 3)
    # edge k is opposite vertex k: from vertex k+1 to vertex k+2
    x1, y1 = np.roll(tx, -1, axis=1), np.roll(ty, -1, axis=1)
    x2, y2 = np.roll(tx, -2, axis=1), np.roll(ty, -2, axis=1)
    area = (tx[:, 1] - tx[:, 0]) * (ty[:, 2] - ty[:, 0]) - (ty[:, 1] - ty[:, 0]) * (
        tx[:, 2] - tx[:, 0]
    )
    ok = np.isfinite(area) & (area != 0)
    sign = np.where(area < 0, -1.0, 1.0)[:, None]
    # w_k(p) = A_k px + B_k py + C_k >= 0 inside (oriented by the area's sign)
    a = -sign * (y2 - y1)
    b = sign * (x2 - x1)
    c = sign * ((y2 - y1) * x1 - (x2 - x1) * y1)
    # depth plane z = dzx x + dzy y + dz0 from barycentrics w_k / |area|
    inv = np.divide(1.0, np.abs(area), out=np.zeros_like(area), where=ok)
    dzx = (a * tz).sum(axis=1) * inv
    dzy = (b * tz).sum(axis=1) * inv
    dz0 = (c * tz).sum(axis=1) * inv
    r0 = np.clip(np.ceil(ty.min(axis=1) - 0.5), 0, height).astype(np.int64)
    r1 = np.clip(np.floor(ty.max(axis=1) - 0.5), -1, height - 1).astype(np.int64)
    n_rows = np.where(ok, np.maximum(r1 - r0 + 1, 0), 0)
    t = np.repeat(np.arange(tris.shape[0]), n_rows)
    row = r0[t] + np.arange(t.shape[0]) - np.repeat(np.cumsum(n_rows) - n_rows, n_rows)
    cy = row + 0.5
    lo = np.full(t.shape[0], -np.inf)
    hi = np.full(t.shape[0], np.inf)
    empty = np.zeros(t.shape[0], dtype=bool)
    for k in range(3):
        ak, rest = a[t, k], b[t, k] * cy + c[t, k]
        with np.errstate(divide="ignore", invalid="ignore"):
            bound = -rest / ak
        lo = np.where(ak > 0, np.maximum(lo, bound), lo)
        hi = np.where(ak < 0, np.minimum(hi, bound), hi)
        empty |= (ak == 0) & (rest < 0)
    # a hair of slack: centres on an edge shared by two triangles must not be
    # lost to round-off in both (cracks along triangulation diagonals)
    col0 = np.clip(np.ceil(lo - 0.5 - SPAN_SLACK), 0, width).astype(np.int64)
    col1 = np.clip(np.floor(hi - 0.5 + SPAN_SLACK), -1, width - 1).astype(np.int64)
    count = np.where(empty, 0, np.maximum(col1 - col0 + 1, 0))
    keep = count > 0
    t, row, col0, count = t[keep], row[keep], col0[keep], count[keep]
    z_row = dzy[t] * (row + 0.5) + dz0[t] + dzx[t] * 0.5  # depth at column 0 centre
    return row, col0, count, z_row, dzx[t], t


def rasterize_triangles(x, y, z, tris, owner_of_tri, width, height):
    """Z-buffer triangles; returns (owner (H*W,) int64 with -1, zbuf (H*W,)).

    ``x, y`` are pixel coordinates (pixel (i, j) has its centre at (i + 0.5,
    j + 0.5)), ``z`` depth (larger = nearer). A pixel centre inside a triangle
    (edges included) takes its interpolated depth; per pixel the largest depth
    wins, ties to the smaller owner id. Scanline spans, so the work is
    proportional to the covered pixels (no bounding-box waste); their pixels are
    z-buffered in one pass (`_zbuffer.spans_kernel`). Inputs are validated (private).
    """
    npix = width * height
    zbuf = np.full(npix, -np.inf)
    owner = np.full(npix, -1, dtype=np.int64)
    row, col0, count, z_row, step, t = _spans(x, y, z, tris, width, height)
    ids = np.ascontiguousarray(owner_of_tri[t], dtype=np.int64)
    spans_kernel(row, col0, count, z_row, step, ids, int(width), owner, zbuf)
    return owner, zbuf
