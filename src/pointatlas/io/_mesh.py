"""The Mesh container (polygon faces in CSR form) and area-weighted vertex normals."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._core import PointAtlasError, as_points, describe_indices, readonly
from .._core.tolerances import MESH_NORMAL_CANCEL_RTOL

__all__ = ["Mesh", "fan_triangulate", "vertex_normals"]


def _flatten_faces(faces, face_offsets) -> tuple[np.ndarray, np.ndarray]:
    """Return (flat int64 indices, offsets int64) from any accepted face layout."""
    if face_offsets is not None:
        flat = _as_index_array(faces, "faces")
        if flat.ndim != 1:
            raise PointAtlasError(
                f"faces must be a flat index array when face_offsets is given; got shape "
                f"{flat.shape}"
            )
        offsets = _as_index_array(face_offsets, "face_offsets")
        if offsets.ndim != 1 or offsets.size == 0:
            raise PointAtlasError(
                f"face_offsets must have shape (F + 1,) and start at 0; got shape {offsets.shape}"
            )
        if offsets[0] != 0 or offsets[-1] != flat.size:
            raise PointAtlasError(
                f"face_offsets must start at 0 and end at len(faces) = {flat.size}; got "
                f"{int(offsets[0])} ... {int(offsets[-1])}"
            )
        return flat, offsets
    if isinstance(faces, np.ndarray) or _is_rectangular(faces):
        arr = _as_index_array(faces, "faces")
        if arr.ndim == 1 and arr.size == 0:
            arr = arr.reshape(0, 3)
        if arr.ndim != 2:
            raise PointAtlasError(f"faces must have shape (F, k); got {arr.shape}")
        flat = arr.reshape(-1).copy()
        offsets = np.arange(arr.shape[0] + 1, dtype=np.int64) * arr.shape[1]
        return flat, offsets
    rows = [_as_index_array(f, "faces") for f in faces]
    for i, row in enumerate(rows):
        if row.ndim != 1:
            raise PointAtlasError(f"faces[{i}] must be a sequence of vertex indices")
    sizes = np.array([r.size for r in rows], dtype=np.int64)
    offsets = np.zeros(len(rows) + 1, dtype=np.int64)
    np.cumsum(sizes, out=offsets[1:])
    flat = np.concatenate(rows) if rows else np.zeros(0, dtype=np.int64)
    return flat.astype(np.int64, copy=False), offsets


def _is_rectangular(faces) -> bool:
    try:
        lengths = {len(f) for f in faces}
    except TypeError:
        return False
    return len(lengths) <= 1


def _as_index_array(values, name: str) -> np.ndarray:
    arr = np.asarray(values)
    if arr.size == 0:
        return arr.astype(np.int64)
    if arr.dtype.kind == "f":
        if not np.isfinite(arr).all() or (arr != np.round(arr)).any():
            raise PointAtlasError(f"{name} must hold integer vertex indices")
    elif arr.dtype.kind not in "iub":
        raise PointAtlasError(f"{name} must hold integer vertex indices; got dtype {arr.dtype}")
    return arr.astype(np.int64)


def _check_faces(flat: np.ndarray, offsets: np.ndarray, n_vertices: int) -> None:
    sizes = np.diff(offsets)
    small = sizes < 3
    if small.any():
        raise PointAtlasError(
            f"every face needs at least 3 vertices; faces with fewer: {describe_indices(small)}"
        )
    bad = (flat < 0) | (flat >= n_vertices)
    if bad.any():
        face_of = np.repeat(np.arange(sizes.size), sizes)
        bad_faces = np.zeros(sizes.size, dtype=bool)
        bad_faces[face_of[bad]] = True
        raise PointAtlasError(
            f"faces reference vertex indices outside [0, {n_vertices}): "
            f"faces {describe_indices(bad_faces)}"
        )


@dataclass(frozen=True, slots=True, eq=False)
class Mesh:
    """A polygon mesh: vertices and faces of any size in compressed-row form.

    Face ``f`` is ``faces[face_offsets[f]:face_offsets[f + 1]]`` (vertex indices in
    order around the face). Triangle meshes have ``face_offsets = 3 * arange(F + 1)``.

    Parameters
    ----------
    vertices : array_like of shape (V, 3), float64
        Vertex positions.
    faces : array_like
        Either an (F, k) integer array (all faces with k vertices), a sequence of
        index sequences of any lengths (polygons), or, with ``face_offsets``, the flat
        (M,) index array.
    face_offsets : array_like of shape (F + 1,), int64, optional
        Start of each face in the flat ``faces``; ``face_offsets[-1] == len(faces)``.
    face_colors : array_like of shape (F, 3) or (F, 4), uint8, optional
        Per-face RGB(A) colours.
    name : str
        Name for reports and file names.

    Raises
    ------
    PointAtlasError
        Non-finite vertices, faces with fewer than 3 vertices, indices out of range,
        inconsistent offsets or colours.

    Notes
    -----
    The compressed-row layout stores mixed polygon meshes (the simplified meshes of
    thesis section 4.4) without padding; :attr:`triangles` fan-triangulates them.

    Examples
    --------
    >>> m = Mesh([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], [[0, 1, 2, 3]])
    >>> m.n_faces, m.face_sizes.tolist(), m.triangles.tolist()
    (1, [4], [[0, 1, 2], [0, 2, 3]])
    """

    vertices: np.ndarray
    faces: np.ndarray
    face_offsets: np.ndarray | None = None
    face_colors: np.ndarray | None = None
    name: str = ""

    def __post_init__(self):
        try:
            verts = np.array(as_points(self.vertices, name="vertices", min_points=0), copy=True)
        except PointAtlasError:
            raise
        except (TypeError, ValueError) as exc:
            raise PointAtlasError(str(exc)) from None
        flat, offsets = _flatten_faces(self.faces, self.face_offsets)
        flat = np.array(flat, dtype=np.int64, copy=True)
        offsets = np.array(offsets, dtype=np.int64, copy=True)
        _check_faces(flat, offsets, verts.shape[0])
        object.__setattr__(self, "vertices", readonly(verts))
        object.__setattr__(self, "faces", readonly(flat))
        object.__setattr__(self, "face_offsets", readonly(offsets))
        if self.face_colors is not None:
            colors = np.asarray(self.face_colors)
            n_faces = offsets.size - 1
            if colors.ndim != 2 or colors.shape[0] != n_faces or colors.shape[1] not in (3, 4):
                raise PointAtlasError(
                    f"face_colors must have shape (F, 3) or (F, 4) with F = {n_faces}; "
                    f"got {colors.shape}"
                )
            if colors.dtype != np.uint8:
                raise PointAtlasError(f"face_colors must be uint8; got dtype {colors.dtype}")
            object.__setattr__(self, "face_colors", readonly(colors.copy()))
        object.__setattr__(self, "name", str(self.name))

    @property
    def n_vertices(self) -> int:
        """Number of vertices V."""
        return int(self.vertices.shape[0])

    @property
    def n_faces(self) -> int:
        """Number of faces F."""
        return int(self.face_offsets.size - 1)

    @property
    def face_sizes(self) -> np.ndarray:
        """Number of vertices of each face, (F,) int64."""
        return np.diff(self.face_offsets)

    @property
    def is_triangular(self) -> bool:
        """Whether every face is a triangle."""
        return bool((self.face_sizes == 3).all())

    @property
    def triangles(self) -> np.ndarray:
        """Fan triangulation of the faces, (T, 3) int64 (the faces themselves if triangles)."""
        return fan_triangulate(self.faces, self.face_offsets)[0]

    def face(self, i: int) -> np.ndarray:
        """Vertex indices of face ``i``."""
        return self.faces[self.face_offsets[i] : self.face_offsets[i + 1]]

    def face_list(self) -> list[np.ndarray]:
        """The faces as a list of index arrays (one per face)."""
        return np.split(self.faces, self.face_offsets[1:-1])

    def vertex_normals(self) -> np.ndarray:
        """Area-weighted unit vertex normals; NaN rows where undefined (see `vertex_normals`)."""
        return vertex_normals(self.vertices, self.faces, self.face_offsets)

    def referenced(self) -> np.ndarray:
        """Boolean (V,) mask of the vertices used by at least one face."""
        used = np.zeros(self.n_vertices, dtype=bool)
        used[self.faces] = True
        return used


def fan_triangulate(faces, face_offsets) -> tuple[np.ndarray, np.ndarray]:
    """Fan-triangulate polygon faces given in compressed-row form.

    Parameters
    ----------
    faces : ndarray of shape (M,), int64
        Flat vertex indices of all faces.
    face_offsets : ndarray of shape (F + 1,), int64
        Start of each face in ``faces``; every face has at least 3 vertices.

    Returns
    -------
    triangles : ndarray of shape (T, 3), int64
        Face ``(v0, v1, ..., vk)`` becomes ``(v0, vj, vj+1)`` for j = 1..k-1.
    triangle_face : ndarray of shape (T,), int64
        The face each triangle comes from.

    Examples
    --------
    >>> tri, src = fan_triangulate([0, 1, 2, 3, 4, 5, 6], [0, 3, 7])
    >>> tri.tolist(), src.tolist()
    ([[0, 1, 2], [3, 4, 5], [3, 5, 6]], [0, 1, 1])
    """
    flat = np.asarray(faces, dtype=np.int64)
    offsets = np.asarray(face_offsets, dtype=np.int64)
    sizes = np.diff(offsets)
    n_tri = sizes - 2
    if (n_tri < 1).any():
        raise PointAtlasError("every face needs at least 3 vertices")
    if sizes.size and (sizes == 3).all():
        return flat.reshape(-1, 3).copy(), np.arange(sizes.size, dtype=np.int64)
    tri_face = np.repeat(np.arange(sizes.size, dtype=np.int64), n_tri)
    first_tri = np.zeros(sizes.size, dtype=np.int64)
    np.cumsum(n_tri[:-1], out=first_tri[1:])
    j = np.arange(tri_face.size, dtype=np.int64) - first_tri[tri_face]
    base = offsets[:-1][tri_face]
    tri = np.stack([flat[base], flat[base + j + 1], flat[base + j + 2]], axis=1)
    return tri, tri_face


def face_area_vectors(vertices: np.ndarray, flat: np.ndarray, offsets: np.ndarray) -> np.ndarray:
    """Twice the vector area of every face, (F, 3) (private; validated input).

    For a triangle this is the cross product of two edges, 2 * area * unit normal;
    for a polygon the sum of its fan triangles' cross products, which equals Newell's
    vector (independent of the fan's start vertex).
    """
    tri, tri_face = fan_triangulate(flat, offsets)
    p0 = vertices[tri[:, 0]]
    cross = np.cross(vertices[tri[:, 1]] - p0, vertices[tri[:, 2]] - p0)
    n_faces = offsets.size - 1
    if tri.shape[0] == n_faces:
        return cross
    out = np.empty((n_faces, 3), dtype=np.float64)
    for c in range(3):
        out[:, c] = np.bincount(tri_face, weights=cross[:, c], minlength=n_faces)
    return out


def vertex_normals(vertices, faces, face_offsets=None, *, normalize: bool = True) -> np.ndarray:
    """Area-weighted vertex normals of a triangle or polygon mesh.

    The normal of a vertex is the normalised sum, over the faces containing it, of
    the face's cross product (twice its area times its unit normal).

    Parameters
    ----------
    vertices : array_like of shape (V, 3), float64
        Vertex positions.
    faces : array_like
        (F, k) vertex indices, a sequence of polygons, or with ``face_offsets`` the
        flat (M,) indices (the :class:`Mesh` layout).
    face_offsets : array_like of shape (F + 1,), int64, optional
        Start of each face in a flat ``faces``.
    normalize : bool
        Return unit vectors (default); otherwise the raw sums (twice the summed
        area vectors).

    Returns
    -------
    normals : ndarray of shape (V, 3), float64
        Unit normals. A vertex with no defined normal -- unreferenced, only on
        zero-area faces, or whose face vectors cancel (sum shorter than
        ``MESH_NORMAL_CANCEL_RTOL`` times the summed lengths) -- gets a NaN row when
        ``normalize`` is True.

    Raises
    ------
    PointAtlasError
        Invalid vertices or faces (see :class:`Mesh`).

    Notes
    -----
    This is the convention of the thesis for turning a mesh into a point set with
    normals (sections 2.3 and 4.4, "area-weighted vertex normal"). Polygon faces
    contribute their Newell vector area to each of their vertices.

    Examples
    --------
    >>> vertex_normals([[0, 0, 0], [2, 0, 0], [0, 2, 0]], [[0, 1, 2]]).tolist()
    [[0.0, 0.0, 1.0], [0.0, 0.0, 1.0], [0.0, 0.0, 1.0]]
    """
    try:
        verts = as_points(vertices, name="vertices", min_points=0)
    except PointAtlasError:
        raise
    except (TypeError, ValueError) as exc:
        raise PointAtlasError(str(exc)) from None
    flat, offsets = _flatten_faces(faces, face_offsets)
    _check_faces(flat, offsets, verts.shape[0])
    return _vertex_normals(verts, flat, offsets, normalize=normalize)


def _vertex_normals(
    verts: np.ndarray, flat: np.ndarray, offsets: np.ndarray, *, normalize: bool = True
) -> np.ndarray:
    """`vertex_normals` on validated input (private)."""
    n_vert = verts.shape[0]
    out = np.zeros((n_vert, 3), dtype=np.float64)
    if offsets.size <= 1:
        return np.full((n_vert, 3), np.nan) if normalize else out
    area = face_area_vectors(verts, flat, offsets)
    sizes = np.diff(offsets)
    face_of = np.repeat(np.arange(sizes.size), sizes)
    for c in range(3):
        out[:, c] = np.bincount(flat, weights=area[face_of, c], minlength=n_vert)
    if not normalize:
        return out
    lengths = np.sqrt(np.einsum("ij,ij->i", out, out))
    face_len = np.sqrt(np.einsum("ij,ij->i", area, area))
    total = np.bincount(flat, weights=face_len[face_of], minlength=n_vert)
    undefined = ~(lengths > MESH_NORMAL_CANCEL_RTOL * total)
    safe = np.where(undefined, 1.0, lengths)
    out /= safe[:, None]
    out[undefined] = np.nan
    return out
