"""Mesh renderer: flat-shaded polygons, z-buffer, polygon outlines."""

from __future__ import annotations

import numpy as np

from .._core import as_labels, as_points
from ._camera import Camera, resolve_camera
from ._colors import BACKGROUND, NEUTRAL, label_colors
from ._points import AMBIENT, check_size
from ._raster import rasterize_triangles, triangulate_faces

__all__ = ["as_faces", "prepare_mesh", "render_mesh_array", "render_mesh_rgb"]

#: Colour of polygon outlines (dark grey) and its opacity.
EDGE_COLOR = np.array([0.12, 0.12, 0.14])
EDGE_ALPHA = 0.85
#: Up to this many faces outlines are ~1 px wide; above, ~0.5 px.
EDGE_BOTH_SIDES_MAX = 2_000
#: Above this many faces outlines are drawn at half opacity (dense meshes).
EDGE_FULL_MAX = 30_000
#: Rasterise at this multiple of the resolution, then box-filter (anti-aliasing)...
SUPERSAMPLE = 2
#: ... for images up to this many pixels (2048 x 2048); larger ones are big
#: enough without it and would need 4x the z-buffer memory.
SUPERSAMPLE_MAX_PIXELS = 2048 * 2048


def _csr_faces(faces, face_offsets) -> tuple[np.ndarray, np.ndarray]:
    """Flat indices + offsets (the `pointatlas.io.Mesh` layout) -> (indptr, flat)."""
    flat = np.asarray(faces)
    indptr = np.asarray(face_offsets)
    if (
        flat.ndim != 1
        or indptr.ndim != 1
        or flat.dtype.kind not in "iu"
        or (indptr.dtype.kind not in "iu")
    ):
        raise ValueError(
            "with face_offsets, faces must be a flat (M,) int array and face_offsets "
            f"(F + 1,) ints; got shapes {flat.shape} and {indptr.shape}"
        )
    indptr = indptr.astype(np.int64)
    if indptr.size < 1 or indptr[0] != 0 or indptr[-1] != flat.size:
        raise ValueError(
            f"face_offsets must start at 0 and end at len(faces) = {flat.size}; "
            f"got {indptr[:1].tolist()} ... {indptr[-1:].tolist()}"
        )
    sizes = np.diff(indptr)
    if (sizes < 3).any():
        first = int(np.flatnonzero(sizes < 3)[0])
        raise ValueError(
            f"faces must list at least 3 vertex indices each; face {first} has {sizes[first]}"
        )
    return indptr, flat.astype(np.int64)


def as_faces(faces, n_vertices: int, face_offsets=None) -> tuple[np.ndarray, np.ndarray]:
    """Validate faces as CSR ``(indptr (F+1,), indices)``, both int64 (private).

    ``faces`` is an (F, k) integer array (k >= 3), a sequence of index sequences
    of any lengths >= 3 (polygons), or with ``face_offsets`` the flat index array.
    """
    if face_offsets is not None:
        indptr, flat = _csr_faces(faces, face_offsets)
    elif isinstance(faces, np.ndarray) and faces.dtype != object and faces.ndim == 2:
        arr = faces
        if arr.dtype.kind not in "iu":
            if arr.dtype.kind != "f" or not np.array_equal(arr, np.round(arr)):
                raise ValueError(f"faces must hold integer vertex indices; got dtype {arr.dtype}")
        if arr.shape[1] < 3:
            raise ValueError(f"faces must have at least 3 vertices each; got shape {arr.shape}")
        flat = arr.astype(np.int64).ravel()
        indptr = np.arange(arr.shape[0] + 1, dtype=np.int64) * arr.shape[1]
    else:
        try:
            rows = [np.asarray(f) for f in faces]
        except TypeError:
            raise TypeError(
                "faces must be an (F, k) int array or a sequence of index lists; "
                f"got {type(faces).__name__}"
            ) from None
        lengths = np.array([r.size for r in rows], dtype=np.int64)
        bad = [i for i, r in enumerate(rows) if r.ndim != 1 or r.size < 3]
        if bad:
            raise ValueError(
                f"faces must list at least 3 vertex indices each; face {bad[0]} has "
                f"{rows[bad[0]].size}"
            )
        flat = np.concatenate(rows) if rows else np.zeros(0)
        if flat.size and flat.dtype.kind not in "iu":
            if flat.dtype.kind != "f" or not np.array_equal(flat, np.round(flat)):
                raise ValueError(f"faces must hold integer vertex indices; got dtype {flat.dtype}")
        flat = flat.astype(np.int64)
        indptr = np.zeros(len(rows) + 1, dtype=np.int64)
        np.cumsum(lengths, out=indptr[1:])
    if indptr.shape[0] < 2:
        raise ValueError("faces must hold at least 1 face; got 0")
    out = (flat < 0) | (flat >= n_vertices)
    if out.any():
        first = int(flat[np.flatnonzero(out)[0]])
        raise ValueError(
            f"faces index vertices 0..{n_vertices - 1}; got {int(out.sum())} out-of-range "
            f"entries (first {first})"
        )
    return indptr, flat


def _face_normals(vertices, indptr, flat) -> np.ndarray:
    """Unit Newell normals of polygons (zero for degenerate faces)."""
    nxt = np.arange(1, flat.shape[0] + 1, dtype=np.int64)
    nxt[indptr[1:] - 1] = indptr[:-1]  # last corner of each face wraps to its first
    cross = np.cross(vertices[flat], vertices[flat[nxt]])
    normal = np.add.reduceat(cross, indptr[:-1], axis=0)
    length = np.linalg.norm(normal, axis=1)
    good = length > 0
    normal[good] /= length[good, None]
    normal[~good] = 0.0
    return normal


def prepare_mesh(vertices, faces, face_labels, face_colors, face_offsets=None):
    """Validate; return (verts, indptr, flat, base colours (F, 3), note) (private)."""
    verts = as_points(vertices, name="vertices", min_points=1)
    indptr, flat = as_faces(faces, verts.shape[0], face_offsets)
    n_faces = indptr.shape[0] - 1
    note = None
    if face_labels is not None and face_colors is not None:
        raise ValueError("give face_labels or face_colors, not both")
    if face_labels is not None:
        lab = as_labels(face_labels, n_faces, name="face_labels")
        base = label_colors(lab)
        n_labels = np.unique(lab[lab >= 0]).size
        note = f"{n_labels} label{'s' if n_labels != 1 else ''}"
    elif face_colors is not None:
        col = np.asarray(face_colors)
        if col.ndim != 2 or col.shape[0] != n_faces or col.shape[1] not in (3, 4):
            raise ValueError(
                f"face_colors must have shape ({n_faces}, 3) or ({n_faces}, 4); got {col.shape}"
            )
        if col.dtype == np.uint8:
            base = col[:, :3].astype(np.float64) / 255.0
        else:
            base = np.asarray(col[:, :3], dtype=np.float64)
            if not np.isfinite(base).all() or base.min() < 0 or base.max() > 1:
                raise ValueError("face_colors must be floats in [0, 1] or uint8")
    else:
        base = np.broadcast_to(NEUTRAL, (n_faces, 3))
    return verts, indptr, flat, base, note


def _edge_mask(owner: np.ndarray, both_sides: bool) -> np.ndarray:
    """Face pixels next to a pixel of another face or the background (private).

    ``both_sides``: mark both pixels of a face/face boundary and two face pixels
    at the silhouette (lines 2 pixels wide at the supersampled resolution).
    """
    o = owner
    mask = np.zeros(o.shape, dtype=bool)
    diff_x = o[:, 1:] != o[:, :-1]
    diff_y = o[1:, :] != o[:-1, :]
    mask[:, :-1] |= diff_x
    mask[:-1, :] |= diff_y
    if both_sides:
        mask[:, 1:] |= diff_x
        mask[1:, :] |= diff_y
        # against the background only the face side is drawn: two pixels deep
        bg = o < 0
        near = np.zeros_like(bg)
        for step in (1, 2):
            near[:, :-step] |= bg[:, step:]
            near[:, step:] |= bg[:, :-step]
            near[:-step, :] |= bg[step:, :]
            near[step:, :] |= bg[:-step, :]
        mask |= near
    return mask & (o >= 0)


def render_mesh_rgb(
    verts, indptr, flat, base, *, camera: Camera, width, height, edges, lighting
) -> np.ndarray:
    """Draw validated mesh data into an RGB array (private).

    Z-buffer at ``SUPERSAMPLE`` x the resolution, flat colour per face, polygon
    outlines where the visible face changes, then a box filter down to the
    requested size (anti-aliasing).
    """
    n_faces = indptr.shape[0] - 1
    normal = _face_normals(verts, indptr, flat)
    tris, tri_face = triangulate_faces(verts, indptr, flat, normal)
    ss = SUPERSAMPLE if width * height <= SUPERSAMPLE_MAX_PIXELS else 1
    x, y, depth = camera.project(verts, width, height)
    owner, _ = rasterize_triangles(x * ss, y * ss, depth, tris, tri_face, width * ss, height * ss)
    if lighting:
        shade = AMBIENT + (1.0 - AMBIENT) * np.abs(normal @ camera.light())
    else:
        shade = np.ones(n_faces)
    colors = np.clip(base * shade[:, None], 0.0, 1.0)
    image = np.empty((owner.shape[0], 3), dtype=np.float32)
    image[:] = BACKGROUND
    covered = owner >= 0
    image[covered] = colors[owner[covered]]
    image = image.reshape(height * ss, width * ss, 3)
    if edges:
        own = owner.reshape(height * ss, width * ss)
        both = n_faces <= EDGE_BOTH_SIDES_MAX
        alpha = EDGE_ALPHA if n_faces <= EDGE_FULL_MAX else 0.5 * EDGE_ALPHA
        mask = _edge_mask(own, both)
        image[mask] = (1 - alpha) * image[mask] + alpha * EDGE_COLOR
    small = image.reshape(height, ss, width, ss, 3).mean(axis=(1, 3))
    return np.round(np.clip(small, 0.0, 1.0) * 255.0).astype(np.uint8)


def render_mesh_array(
    vertices,
    faces,
    *,
    face_labels=None,
    face_colors=None,
    edges: bool = True,
    view=None,
    size=(1024, 1024),
    lighting: bool = True,
    face_offsets=None,
) -> np.ndarray:
    """Render a triangle or polygon mesh to an RGB image (no axes, no legend).

    Parameters
    ----------
    vertices : array_like of shape (V, 3), float64
        Vertex positions.
    faces : array_like of shape (F, k), int, or sequence of index sequences
        Faces with k >= 3 corners each; polygon meshes may mix face sizes. With
        ``face_offsets``: the flat (M,) index array (`pointatlas.io.Mesh` layout).
    face_labels : array_like of shape (F,), int, optional
        Region id per face, coloured like point labels (negative = grey).
    face_colors : array_like of shape (F, 3) or (F, 4), optional
        Explicit RGB(A) per face, floats in [0, 1] or uint8 (alpha ignored).
    edges : bool
        Draw each polygon's boundary (not the diagonals of a triangulation).
    view : None, Camera or (float, float)
        Camera as in :func:`render_points_array`.
    size : (int, int)
        Image (width, height) in pixels.
    lighting : bool
        Flat Lambert shading per face (two-sided); False draws base colours.
    face_offsets : array_like of shape (F + 1,), int, optional
        Start of each face in a flat ``faces`` array (compressed rows).

    Returns
    -------
    rgb : ndarray of shape (height, width, 3), uint8

    Raises
    ------
    ValueError
        Bad vertices, no faces, faces with fewer than 3 corners or indices out of
        range, mismatched labels/colours.

    Notes
    -----
    A numpy z-buffer rasteriser (per-pixel depth, exact occlusion also for large
    overlapping polygons, where a painter's algorithm fails) at 2x resolution,
    box-filtered down (anti-aliasing). Polygons are fanned when convex and
    ear-clipped otherwise; outlines are drawn where the visible *polygon* changes,
    so triangulation diagonals and hidden edges never show. Flat shading from
    Newell normals, valid for non-planar polygons.

    Examples
    --------
    >>> quad = [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]]
    >>> render_mesh_array(quad, [[0, 1, 2, 3]], size=(40, 30)).shape
    (30, 40, 3)
    """
    width, height = check_size(size)
    verts, indptr, flat, base, _ = prepare_mesh(
        vertices, faces, face_labels, face_colors, face_offsets
    )
    camera = resolve_camera(view, verts)
    return render_mesh_rgb(
        verts,
        indptr,
        flat,
        base,
        camera=camera,
        width=width,
        height=height,
        edges=edges,
        lighting=lighting,
    )
