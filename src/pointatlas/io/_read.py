"""Reading point sets and meshes, and converting arrays and foreign objects to a PointSet."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from .._core import PointAtlasError, PointSet, as_points, describe_indices
from .._core.tolerances import NORMAL_ZERO_LENGTH
from ._errors import PointAtlasIOError, describe_exception, fail
from ._las import read_las
from ._mesh import Mesh, _check_faces, _vertex_normals
from ._obj import read_obj, read_off
from ._ply import read_ply
from ._raw import RawData, colors_to_uint8
from ._stl import read_stl
from ._xyz import read_xyz

__all__ = ["MESH_EXTENSIONS", "POINT_EXTENSIONS", "as_point_set", "read_mesh", "read_point_set"]

_READERS = {
    ".ply": read_ply,
    ".obj": read_obj,
    ".off": read_off,
    ".stl": read_stl,
    ".xyz": read_xyz,
    ".txt": read_xyz,
    ".las": read_las,
    ".laz": read_las,
}
#: Extensions read_point_set understands (lower case).
POINT_EXTENSIONS = tuple(sorted(_READERS))
#: Extensions read_mesh and write_mesh understand.
MESH_EXTENSIONS = (".obj", ".off", ".ply", ".stl")
_ZERO_POLICIES = ("raise", "drop")


def _load(path) -> tuple[Path, RawData]:
    """Read any supported file into validated raw arrays (errors: PointAtlasIOError)."""
    try:
        p = Path(os.fspath(path))
    except TypeError:
        raise PointAtlasError(
            f"path must be a str or os.PathLike; got {type(path).__name__}"
        ) from None
    ext = p.suffix.lower()
    if ext not in _READERS:
        raise fail(p, f"unknown file extension {ext or '(none)'!r}; supported: {POINT_EXTENSIONS}")
    try:
        st = p.stat()
    except FileNotFoundError:
        raise fail(p, "no such file") from None
    except OSError as exc:
        raise fail(p, f"cannot access ({exc.strerror})") from None
    if not p.is_file():
        raise fail(p, "not a regular file")
    if st.st_size == 0:
        raise fail(p, "empty file (0 bytes)")
    try:
        raw = _READERS[ext](p)
    except PointAtlasIOError:
        raise
    except OSError as exc:
        raise fail(p, f"cannot read ({exc.strerror or describe_exception(exc)})") from None
    except Exception as exc:  # any parser failure on corrupt input becomes an I/O error
        raise fail(p, f"cannot parse {ext} file ({describe_exception(exc)})") from None
    if not np.isfinite(raw.points).all():
        bad = ~np.isfinite(raw.points).all(axis=1)
        raise fail(p, f"non-finite (NaN/Inf) coordinates at {describe_indices(bad)} vertices")
    if raw.face_offsets is not None:
        try:
            _check_faces(raw.faces, raw.face_offsets, raw.points.shape[0])
        except PointAtlasError as exc:
            raise fail(p, str(exc)) from None
    return p, raw


def read_point_set(path, *, with_normals: bool = True, zero_normals: str = "raise") -> PointSet:
    """Read a point set from PLY, OBJ, OFF, STL, XYZ/TXT, LAS or LAZ.

    Parameters
    ----------
    path : str or os.PathLike
        The file; the format is chosen by the extension (case-insensitive).
    with_normals : bool
        Attach normals when the file provides them (PLY ``nx ny nz``, XYZ columns
        4-6, LAS extra bytes ``nx ny nz``) or when it is a mesh (area-weighted
        vertex normals). False skips them.
    zero_normals : {"raise", "drop"}
        What to do with points that have no usable normal: a mesh vertex that is
        unreferenced, lies only on zero-area faces or whose faces cancel, or a
        zero/non-finite normal stored in the file. ``"raise"`` (default) raises
        PointAtlasIOError naming their count and first indices; ``"drop"`` leaves
        those points out and records the kept points' original indices in the
        attribute ``source_index`` (int64).

    Returns
    -------
    point_set : PointSet
        Points (N, 3) float64, unit normals or None, attributes (other PLY vertex
        properties with their names and dtypes; ``colors`` (N, 3|4) from PLY
        red/green/blue(/alpha) of one dtype, kept as uint8, uint16, float32 or
        float64 (other integer types 0..255 become uint8); LAS dimensions with their
        dtypes and ``colors`` (N, 3) uint16 as stored; XYZ colour columns
        (integers 0..255 / 0..65535) as ``colors``, other columns ``column_<j>``
        or their header name; ``meta["columns"]`` says how XYZ columns were read),
        name = the file stem, and for LAS/LAZ
        ``meta["las_header"]`` (the ``laspy.LasHeader``), which
        :func:`write_point_set` keeps when writing LAS/LAZ again.

    Raises
    ------
    PointAtlasIOError
        Missing, empty, truncated or malformed file, unknown extension, non-numeric
        values, NaN/Inf coordinates, faces with out-of-range indices, points
        without normals (``zero_normals="raise"``), a binary PLY with bytes after
        its declared elements, a binary STL whose size does not match its
        triangle count, an XYZ row that is ambiguous (commas and spaces both
        separating) or has another column count than the first row. The message
        names the file (and the line for text formats).

    Warns
    -----
    UserWarning
        An ASCII PLY with more records than its header declares (the extra lines
        are ignored; the warning names the declared counts and the extra lines).
    PointAtlasError
        Invalid ``zero_normals``.

    Notes
    -----
    A mesh read as a point set is its vertex set with area-weighted vertex normals
    (the thesis' convention, e.g. section 4.4); see :func:`vertex_normals`. OBJ
    ``vn`` records are ignored; PLY vertex normals, when present, win over the faces.
    STL corners are merged into vertices when bit-identical.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> f = pathlib.Path(tempfile.mkdtemp()) / "tri.obj"
    >>> _ = f.write_text("v 0 0 0\\nv 1 0 0\\nv 0 1 0\\nf 1 2 3\\n")
    >>> ps = read_point_set(f)
    >>> ps.n_points, ps.normals[0].tolist(), ps.name
    (3, [0.0, 0.0, 1.0], 'tri')
    """
    if zero_normals not in _ZERO_POLICIES:
        raise PointAtlasError(f"zero_normals must be 'raise' or 'drop'; got {zero_normals!r}")
    p, raw = _load(path)
    normals = None
    if with_normals:
        if raw.normals is not None:
            normals, what = raw.normals, "zero-length or non-finite normals in the file"
        elif raw.has_faces:
            normals = _vertex_normals(raw.points, raw.faces, raw.face_offsets)
            what = (
                "vertices without an area-weighted normal (unreferenced, only on "
                "zero-area faces, or faces cancelling)"
            )
    return _finish(
        p,
        raw.points,
        normals,
        raw.attributes,
        p.stem,
        zero_normals,
        what="" if normals is None else what,
        trusted=True,
        meta=raw.meta,
    )


def _finish(
    source,
    points,
    normals,
    attributes,
    name,
    zero_normals,
    *,
    what: str,
    trusted: bool = False,
    meta=None,
) -> PointSet:
    """Apply the zero-normal policy and build the PointSet (errors name ``source``).

    ``trusted``: the arrays are fresh, owned by the caller and ``points`` are known
    finite, so the PointSet wraps them without a second validation pass.
    """
    attributes = dict(attributes)
    if normals is not None:
        lengths = _row_lengths(normals)
        bad = ~(lengths > NORMAL_ZERO_LENGTH)
        if np.isinf(lengths).any():
            bad |= np.isinf(lengths)
        if bad.any():
            if zero_normals == "raise":
                raise fail(
                    source,
                    f"{what}: {describe_indices(bad)}; pass zero_normals='drop' to leave "
                    f"them out or with_normals=False",
                )
            keep = ~bad
            points, normals, lengths = points[keep], normals[keep], lengths[keep]
            attributes = {k: v[keep] for k, v in attributes.items()}
            attributes["source_index"] = np.flatnonzero(keep).astype(np.int64)
        if trusted:  # fresh array owned by the reader: scale in place, column-wise
            inv = np.divide(1.0, lengths, out=lengths)
            for c in range(3):
                normals[:, c] *= inv
        else:
            normals = normals / lengths[:, None]
    if trusted:
        attrs = {k: v if v.flags.owndata else v.copy() for k, v in attributes.items()}
        points = np.ascontiguousarray(points, dtype=np.float64)
        return PointSet._from_validated(points, normals, attrs, name=name, meta=meta)
    try:
        return PointSet(points, normals, attributes, name=name, meta=meta or {})
    except ValueError as exc:
        raise fail(source, str(exc)) from None


def _row_lengths(vectors: np.ndarray) -> np.ndarray:
    """Euclidean length of each row of an (N, 3) array (NaN rows give NaN; a row whose
    squares overflow gives inf, without a warning: the caller treats it as bad)."""
    with np.errstate(over="ignore"):
        sq = vectors[:, 0] * vectors[:, 0]
        sq += vectors[:, 1] * vectors[:, 1]
        sq += vectors[:, 2] * vectors[:, 2]
    return np.sqrt(sq, out=sq)


def read_mesh(path) -> Mesh:
    """Read a triangle or polygon mesh from PLY, OBJ, OFF or STL.

    Parameters
    ----------
    path : str or os.PathLike
        The file; ``.ply``, ``.obj``, ``.off`` or ``.stl`` (case-insensitive).

    Returns
    -------
    mesh : Mesh
        Vertices in file order (STL: distinct corners in order of first
        appearance), polygon faces as stored, per-face colours from PLY/OFF when
        present, name = the file stem. A PLY without a face element gives a mesh
        with no faces.

    Raises
    ------
    PointAtlasIOError
        As :func:`read_point_set`, and for point-only formats (XYZ, LAS).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> f = pathlib.Path(tempfile.mkdtemp()) / "quad.off"
    >>> _ = f.write_text("OFF\\n4 1 0\\n0 0 0\\n1 0 0\\n1 1 0\\n0 1 0\\n4 0 1 2 3\\n")
    >>> m = read_mesh(f)
    >>> m.n_vertices, m.n_faces, m.face_sizes.tolist()
    (4, 1, [4])
    """
    p = Path(os.fspath(path))
    if p.suffix.lower() not in MESH_EXTENSIONS:
        raise fail(p, f"not a mesh format {p.suffix!r}; mesh formats: {MESH_EXTENSIONS}")
    p, raw = _load(p)
    faces = raw.faces if raw.faces is not None else np.zeros(0, dtype=np.int64)
    offsets = raw.face_offsets if raw.face_offsets is not None else np.zeros(1, dtype=np.int64)
    try:
        return Mesh(raw.points, faces, offsets, face_colors=raw.face_colors, name=p.stem)
    except PointAtlasError as exc:
        raise fail(p, str(exc)) from None


def as_point_set(obj, *, name: str | None = None, zero_normals: str = "raise") -> PointSet:
    """Convert arrays, files, meshes and Open3D/trimesh objects into a PointSet.

    Parameters
    ----------
    obj : PointSet, Mesh, str, os.PathLike, array_like, trimesh or Open3D object
        - PointSet: returned as is (renamed when ``name`` is given);
        - str / os.PathLike: read with :func:`read_point_set`;
        - (N, 3) array: points; (N, 6) array: points and normals;
        - :class:`Mesh`, ``trimesh.Trimesh``, ``open3d.geometry.TriangleMesh``:
          vertices with area-weighted vertex normals;
        - ``trimesh.PointCloud``, ``open3d.geometry.PointCloud``: points, their
          normals (Open3D) and colours when present.
    name : str, optional
        Name of the result.
    zero_normals : {"raise", "drop"}
        Policy for mesh vertices without a normal, as in :func:`read_point_set`.

    Returns
    -------
    point_set : PointSet

    Raises
    ------
    PointAtlasError
        Unsupported object or invalid arrays; PointAtlasIOError for files.

    Notes
    -----
    Open3D and trimesh are recognised by duck typing (their attributes), so neither
    is imported here. Arrays are copied once into the (read-only) PointSet.

    Examples
    --------
    >>> as_point_set([[0, 0, 0, 0, 0, 2]]).normals.tolist()
    [[0.0, 0.0, 1.0]]
    """
    if zero_normals not in _ZERO_POLICIES:
        raise PointAtlasError(f"zero_normals must be 'raise' or 'drop'; got {zero_normals!r}")
    if isinstance(obj, PointSet):
        return obj if name is None else obj.replace(name=name)
    if isinstance(obj, (str, os.PathLike)):
        ps = read_point_set(obj, zero_normals=zero_normals)
        return ps if name is None else ps.replace(name=name)
    label = type(obj).__name__
    what = "vertices without an area-weighted normal"
    if isinstance(obj, Mesh):
        return _mesh_point_set(
            label, obj.vertices, obj.faces, obj.face_offsets, {}, name or obj.name, zero_normals
        )
    if callable(getattr(obj, "has_triangles", None)) and hasattr(obj, "vertices"):
        verts = np.asarray(obj.vertices, dtype=np.float64)
        tris = np.asarray(obj.triangles, dtype=np.int64).reshape(-1, 3)
        return _mesh_point_set(
            label,
            verts,
            tris.reshape(-1),
            np.arange(tris.shape[0] + 1) * 3,
            {},
            name or "",
            zero_normals,
        )
    if callable(getattr(obj, "has_normals", None)) and hasattr(obj, "points"):
        pts = np.asarray(obj.points, dtype=np.float64)
        nrm = np.asarray(obj.normals, dtype=np.float64) if obj.has_normals() else None
        attrs = {}
        if callable(getattr(obj, "has_colors", None)) and obj.has_colors():
            converted = colors_to_uint8(np.clip(np.asarray(obj.colors, dtype=np.float64), 0.0, 1.0))
            attrs["colors"] = converted
        return _from_arrays(label, pts, nrm, attrs, name or "", zero_normals, "zero-length normals")
    if hasattr(obj, "vertices") and hasattr(obj, "faces"):
        verts = np.asarray(obj.vertices, dtype=np.float64)
        tris = np.asarray(obj.faces, dtype=np.int64)
        if tris.ndim != 2:
            raise PointAtlasError(f"{label}.faces must have shape (F, k); got {tris.shape}")
        offsets = np.arange(tris.shape[0] + 1, dtype=np.int64) * tris.shape[1]
        return _mesh_point_set(
            label, verts, tris.reshape(-1), offsets, {}, name or "", zero_normals
        )
    if hasattr(obj, "vertices") and not isinstance(obj, np.ndarray):
        pts = np.asarray(obj.vertices, dtype=np.float64)
        attrs = {}
        colors = getattr(obj, "colors", None)
        if colors is not None and np.asarray(colors).shape[:1] == pts.shape[:1] and len(pts):
            converted = colors_to_uint8(np.asarray(colors))
            if converted is not None:
                attrs["colors"] = converted
        return _from_arrays(label, pts, None, attrs, name or "", zero_normals, what)
    try:
        arr = np.asarray(obj, dtype=np.float64)
    except (TypeError, ValueError):
        raise PointAtlasError(f"cannot convert {label} to a PointSet") from None
    if arr.ndim != 2 or arr.shape[1] not in (3, 6):
        raise PointAtlasError(f"array must have shape (N, 3) or (N, 6); got {arr.shape}")
    nrm = arr[:, 3:] if arr.shape[1] == 6 else None
    return _from_arrays(label, arr[:, :3], nrm, {}, name or "", zero_normals, "zero-length normals")


def _mesh_point_set(label, verts, flat, offsets, attrs, name, zero_normals) -> PointSet:
    try:
        verts = as_points(verts, name=f"{label} vertices", min_points=0)
        _check_faces(flat, offsets, verts.shape[0])
    except ValueError as exc:
        raise PointAtlasError(str(exc)) from None
    nrm = _vertex_normals(verts, flat, offsets)
    return _from_arrays(
        label, verts, nrm, attrs, name, zero_normals, "vertices without an area-weighted normal"
    )


def _from_arrays(label, pts, nrm, attrs, name, zero_normals, what) -> PointSet:
    try:
        pts = as_points(pts, name=f"{label} points", min_points=0)
    except ValueError as exc:
        raise PointAtlasError(str(exc)) from None
    if nrm is not None and nrm.shape != pts.shape:
        raise PointAtlasError(f"{label} normals must have shape {pts.shape}; got {nrm.shape}")
    try:
        return _finish(label, pts, nrm, attrs, name, zero_normals, what=what)
    except PointAtlasIOError as exc:
        raise PointAtlasError(str(exc)) from None
