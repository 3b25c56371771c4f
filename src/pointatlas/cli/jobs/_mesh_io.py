"""Mesh input and the triangles output of ``pointatlas simplify``
(docs/decisions/simplify.md, "Output files")."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..._core import PointAtlasError
from ...io import write_mesh

__all__ = ["read_mesh_input", "write_simplified", "write_triangles"]


def read_mesh_input(infile):
    """The input as a triangle mesh when it has faces (a mesh file or a bundled model
    with a mesh), else None."""
    from ... import data
    from ...io import MESH_EXTENSIONS, read_mesh

    p = Path(infile)
    if p.is_file():
        if p.suffix.lower() not in MESH_EXTENSIONS:
            return None
        mesh = read_mesh(p)
    elif str(infile) in data.names():
        try:
            mesh = data.load_mesh(str(infile))
        except (PointAtlasError, ValueError, KeyError, AttributeError):
            return None
    else:
        return None
    return mesh if mesh.n_faces else None


def write_triangles(path, mesh) -> Path:
    """``--triangles``: the earcut triangles, coloured by their face where the format
    holds face colours (PLY, OFF), so every viewer shows the polygons."""
    colors = None
    if Path(path).suffix.lower() in (".ply", ".off"):
        from ...viz import label_colors

        colors = np.round(label_colors(mesh.triangle_face) * 255).astype(np.uint8)
    return write_mesh(path, mesh.vertices, mesh.triangles, face_colors=colors)


def write_simplified(path, mesh) -> Path:
    """OUT of ``simplify``: the polygon faces (OBJ, PLY, OFF); STL holds triangles only,
    so there the earcut triangles (`write_triangles`' triangles: a non-convex face is
    not fan-triangulated across its outside). A PLY whose faces have different numbers
    of corners is ASCII: trimesh's binary PLY reader refuses list rows of mixed
    lengths ("PLY is unexpected length!"), its ASCII one and Open3D's read both."""
    suffix = Path(path).suffix.lower()
    if suffix == ".stl":
        return write_mesh(path, mesh.vertices, mesh.triangles)
    faces = [p.tolist() for p in mesh.polygons]
    mixed = len({len(f) for f in faces}) > 1
    return write_mesh(path, mesh.vertices, faces, binary=not (suffix == ".ply" and mixed))
