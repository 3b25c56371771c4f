"""Writing point sets and meshes (atomically, the format from the extension)."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from .._core import PointAtlasError
from ._atomic import atomic_write
from ._errors import describe_exception, fail
from ._las import write_las
from ._mesh import Mesh
from ._obj import write_obj, write_off
from ._plan import POINT_WRITE_EXTENSIONS, plan_write
from ._ply import write_ply
from ._raw import colors_to_uint8
from ._read import MESH_EXTENSIONS
from ._stl import write_stl
from ._xyz import write_xyz

__all__ = ["POINT_WRITE_EXTENSIONS", "write_mesh", "write_point_set"]


def write_point_set(
    path, data, *, normals=None, attributes=None, colors=None, binary: bool = True
) -> Path:
    """Write a point set atomically to PLY, XYZ/TXT, LAS or LAZ.

    Parameters
    ----------
    path : str or os.PathLike
        Destination; the format is chosen by the extension.
    data : PointSet or array_like of shape (N, 3)
        The points (with a PointSet its normals and attributes are written too).
    normals : array_like of shape (N, 3), optional
        Normals (replacing those of ``data``); rescaled to unit length.
    attributes : mapping of str to array_like of shape (N,) or (N, k), optional
        Extra per-point fields (added to, or replacing, those of ``data``).
    colors : array_like of shape (N, 3) or (N, 4), optional
        RGB(A) as uint8 0..255, uint16 0..65535 or floats in [0, 1]; also taken
        from the attribute ``colors`` (see Notes).
    binary : bool
        PLY only: binary little-endian (default) or ASCII.

    Returns
    -------
    path : pathlib.Path
        The written file.

    Raises
    ------
    PointAtlasIOError
        Unsupported extension, an attribute name or dtype the format cannot store,
        two fields with the same name in the file, values that do not fit a LAS
        dimension, or the write failed (the previous file, if any, is left
        untouched). :func:`check_point_set_writable` raises the same errors
        without writing.
    PointAtlasError
        Invalid points, normals, attributes or colours.

    Notes
    -----
    Colours: the ``colors=`` argument is converted (uint8 and uint16 kept, other
    integers 0..255 -> uint8, floats in [0, 1] -> uint8); a
    ``colors`` attribute (of ``data`` or in ``attributes``, e.g. as read) is written
    as stored when uint8, uint16, float32 or float64.

    PLY: x, y, z and nx, ny, nz as double; colours as red/green/blue(/alpha) of
    their dtype (uchar, ushort, float, double); 1-D attributes as vertex properties
    of their own name and type (bool -> uchar, float16 -> float, int64/uint64 ->
    int/uint when the values fit, else double when exact); an (N, k) attribute
    becomes ``name_0`` ... ``name_{k-1}``. Any name PLY allows (ASCII, no
    whitespace, e.g. ``scalar_Intensity(1)``) is written unchanged; a name may not
    repeat x/y/z, the normals' nx/ny/nz (when normals are written), the colour
    channels (when colours are written) or another column. XYZ/TXT stores only
    coordinates and normals.

    LAS/LAZ from a point set read from LAS/LAZ (``meta["las_header"]``): the
    input's header is kept (version, point format, scales, offsets, VLRs, EVLRs,
    extra-bytes dimensions); every attribute named like one of its dimensions fills
    it (values must fit the dimension's type; colours go back to RGB as uint16), so
    an untouched point set is written back bit for bit, X/Y/Z included. Moved
    coordinates are re-quantised with the input's scale and offset; an axis that no
    longer fits int32 gets a new offset (its minimum) and, if still needed, the
    finest power-of-ten scale that fits (the only header change). New fields, the
    normals (unless the file had nx/ny/nz) and colours for a format without RGB
    become extra bytes (a fourth colour channel becomes extra bytes ``alpha``).
    Other point sets: LAS 1.4 point format 6 (7 with colours), coordinates scaled
    to the finest power of ten that fits int32 (round-trip error at most 2.5e-9 of
    the extent), colours as 16 bits (uint8 x 257, floats in [0, 1] x 65535),
    attributes that are not standard dimensions and the normals as extra
    bytes. Writes go through :func:`atomic_write`.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> from pointatlas.io import read_point_set
    >>> f = pathlib.Path(tempfile.mkdtemp()) / "pts.ply"
    >>> _ = write_point_set(f, [[0, 0, 0], [1, 2, 3]], attributes={"label": [4, 5]})
    >>> ps = read_point_set(f)
    >>> ps.points[1].tolist(), ps.attributes["label"].tolist()
    ([1.0, 2.0, 3.0], [4, 5])
    """
    plan = plan_write(path, data, normals, attributes, colors)
    p, ext = plan.path, plan.ext
    if ext == ".ply":
        columns = plan.ply_columns
        _write_guarded(
            p,
            "wb",
            lambda fh: write_ply(fh, columns, binary=binary, comments=("written by pointatlas",)),
        )
    elif ext in (".xyz", ".txt"):
        _write_guarded(p, "w", lambda fh: write_xyz(fh, plan.points, plan.normals))
    else:
        _write_guarded(p, "wb", lambda fh: write_las(fh, plan.las, laz=ext == ".laz"))
    return p


def _write_guarded(p: Path, mode: str, writer) -> None:
    try:
        with atomic_write(p, mode, newline="\n" if mode == "w" else None) as fh:
            writer(fh)
    except (PointAtlasError, KeyboardInterrupt):
        raise
    except OSError as exc:
        raise fail(p, f"cannot write ({exc.strerror or describe_exception(exc)})") from None
    except Exception as exc:  # laspy and friends
        raise fail(p, f"cannot write ({describe_exception(exc)})") from None


def write_mesh(
    path, mesh_or_vertices, faces=None, *, face_offsets=None, face_colors=None, binary: bool = True
) -> Path:
    """Write a triangle or polygon mesh atomically to PLY, OBJ, OFF or STL.

    Parameters
    ----------
    path : str or os.PathLike
        Destination; the format is chosen by the extension.
    mesh_or_vertices : Mesh or array_like of shape (V, 3)
        A mesh, or its vertices (then ``faces`` is required).
    faces : array_like, optional
        (F, k) indices, a sequence of polygons, or flat indices with ``face_offsets``.
    face_offsets : array_like of shape (F + 1,), optional
        Compressed-row offsets for flat ``faces``.
    face_colors : array_like of shape (F, 3) or (F, 4), uint8, optional
        Per-face colours (PLY and OFF; replaces the mesh's own).
    binary : bool
        PLY only: binary little-endian (default) or ASCII.

    Returns
    -------
    path : pathlib.Path
        The written file.

    Raises
    ------
    PointAtlasIOError
        Unsupported extension, face colours for OBJ/STL, or the write failed.
    PointAtlasError
        Invalid mesh.

    Notes
    -----
    Polygon faces are written as polygons (PLY, OBJ, OFF) or fan-triangulated (STL,
    float32 coordinates by the format). PLY vertices are doubles; the face list is
    ``property list uchar int vertex_indices`` (``uint`` counts for faces over 255
    vertices) plus uchar ``red green blue (alpha)``.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> f = pathlib.Path(tempfile.mkdtemp()) / "quad.obj"
    >>> _ = write_mesh(f, [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], [[0, 1, 2, 3]])
    >>> f.read_text().splitlines()[-1]
    'f 1 2 3 4'
    """
    p = Path(os.fspath(path))
    ext = p.suffix.lower()
    if ext not in MESH_EXTENSIONS:
        raise fail(p, f"cannot write meshes as {ext or '(none)'!r}; use {MESH_EXTENSIONS}")
    if isinstance(mesh_or_vertices, Mesh):
        if faces is not None or face_offsets is not None:
            raise PointAtlasError("faces must not be given together with a Mesh")
        mesh = mesh_or_vertices
        if face_colors is not None:
            mesh = Mesh(
                mesh.vertices,
                mesh.faces,
                mesh.face_offsets,
                face_colors=_face_colors(face_colors),
                name=mesh.name,
            )
    else:
        if faces is None:
            raise PointAtlasError("faces are required when vertices are given")
        fc = None if face_colors is None else _face_colors(face_colors)
        mesh = Mesh(mesh_or_vertices, faces, face_offsets, face_colors=fc)
    if mesh.face_colors is not None and ext in (".obj", ".stl"):
        raise fail(p, f"{ext} cannot store face colours; use .ply or .off")
    v, f, o = mesh.vertices, mesh.faces, mesh.face_offsets
    if ext == ".ply":
        columns = [(k, v[:, c]) for c, k in enumerate("xyz")]
        _write_guarded(
            p,
            "wb",
            lambda fh: write_ply(
                fh,
                columns,
                faces=f,
                face_offsets=o,
                face_colors=mesh.face_colors,
                binary=binary,
                comments=("written by pointatlas",),
            ),
        )
    elif ext == ".obj":
        _write_guarded(p, "w", lambda fh: write_obj(fh, v, f, o))
    elif ext == ".off":
        _write_guarded(p, "w", lambda fh: write_off(fh, v, f, o, mesh.face_colors))
    else:
        _write_guarded(p, "wb", lambda fh: write_stl(fh, v, mesh.triangles))
    return p


def _face_colors(values) -> np.ndarray:
    arr = np.asarray(values)
    converted = colors_to_uint8(arr) if arr.ndim == 2 else None
    if converted is None:
        raise PointAtlasError(
            "face_colors must have shape (F, 3) or (F, 4), uint8 0..255 or floats in [0, 1]; "
            f"got shape {arr.shape}, dtype {arr.dtype}"
        )
    return converted
