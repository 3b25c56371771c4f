"""STL reading (binary and ASCII, corners merged) and binary writing (private)."""

from __future__ import annotations

import re

import numpy as np

from ._errors import fail
from ._raw import RawData

__all__ = ["read_stl", "write_stl"]

_STL_RECORD = np.dtype([("normal", "<f4", (3,)), ("corners", "<f4", (3, 3)), ("attribute", "<u2")])
_VERTEX_RE = re.compile(rb"vertex\s+(\S+)\s+(\S+)\s+(\S+)")
#: Control bytes that never occur in ASCII STL text (NUL, DEL, C0 except tab/CR/LF/FF/VT).
_BINARY_BYTES = re.compile(rb"[\x00-\x08\x0e-\x1f\x7f]")


def read_stl(path) -> RawData:
    """Read an STL triangle soup and merge bit-identical corners into vertices (private).

    Binary or ASCII is decided by size, as trimesh and numpy-stl do: a file of
    exactly 84 + 50 n bytes, n being the count at byte 80, is binary even when its
    80-byte header starts with ``solid`` (common in CAD exports). Any other file
    must be ASCII text (``solid`` ... ``endsolid``); a file that is neither is an
    error naming the expected and the actual size. Vertices are numbered in order
    of first appearance; the stored facet normals are ignored (normals are
    recomputed from the triangles).
    """
    with open(path, "rb") as fh:
        data = fh.read()
    n_tri = None
    if len(data) >= 84:
        n_tri = int(np.frombuffer(data, dtype="<u4", count=1, offset=80)[0])
        if len(data) == 84 + 50 * n_tri:
            recs = np.frombuffer(data, dtype=_STL_RECORD, count=n_tri, offset=84)
            with np.errstate(invalid="ignore", over="ignore"):  # NaN/Inf: refused by the caller
                corners = recs["corners"].reshape(-1, 3).astype(np.float64)
            return _merge(corners)
    if data.lstrip()[:5].lower() != b"solid" or _BINARY_BYTES.search(data):
        if n_tri is not None:
            need = 84 + 50 * n_tri
            if len(data) > need:
                what = "binary STL longer than its header declares"
            else:
                what = "truncated binary STL"
            raise fail(
                path,
                f"{what} (or not an STL file): the binary header declares "
                f"{n_tri} triangles, so {need} bytes are expected, but the file has "
                f"{len(data)} bytes (and it is not ASCII STL text)",
            )
        raise fail(path, "not an STL file (too short for binary, no 'solid' keyword)")
    if not re.search(rb"\bendsolid\b", data):
        raise fail(path, "ASCII STL ends without 'endsolid' (truncated?)")
    found = _VERTEX_RE.findall(data)
    n_facets = len(re.findall(rb"\bfacet\b", data))
    if len(found) % 3 or len(found) != 3 * n_facets:
        raise fail(
            path, f"ASCII STL has {len(found)} vertex lines for {n_facets} facets (need 3 each)"
        )
    try:
        corners = np.array(found, dtype=np.float64)
    except ValueError:
        raise fail(path, "non-numeric vertex coordinates in ASCII STL") from None
    return _merge(corners.reshape(-1, 3))


def _merge(corners: np.ndarray) -> RawData:
    if corners.shape[0] == 0:
        return RawData(
            points=np.zeros((0, 3)),
            faces=np.zeros(0, dtype=np.int64),
            face_offsets=np.zeros(1, dtype=np.int64),
        )
    keys = np.ascontiguousarray(corners).view(np.dtype((np.void, 24))).ravel()
    _, first, inverse = np.unique(keys, return_index=True, return_inverse=True)
    order = np.argsort(first, kind="stable")
    rank = np.empty_like(order)
    rank[order] = np.arange(order.size)
    faces = rank[inverse.ravel()].astype(np.int64)
    points = corners[first[order]]
    offsets = np.arange(faces.size // 3 + 1, dtype=np.int64) * 3
    return RawData(points=points, faces=faces, face_offsets=offsets)


def write_stl(fh, vertices: np.ndarray, triangles: np.ndarray) -> None:
    """Write a binary STL (private): triangles (T, 3) into ``vertices`` (V, 3)."""
    recs = np.zeros(triangles.shape[0], dtype=_STL_RECORD)
    corners = vertices[triangles]
    normal = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    length = np.linalg.norm(normal, axis=1)
    normal = np.divide(
        normal, length[:, None], out=np.zeros_like(normal), where=length[:, None] > 0
    )
    recs["normal"] = normal
    recs["corners"] = corners
    header = b"binary STL written by pointatlas".ljust(80, b" ")
    fh.write(header)
    fh.write(np.array([triangles.shape[0]], dtype="<u4").tobytes())
    fh.write(recs.tobytes())
