"""Reading and writing point sets and meshes (PLY, OBJ, OFF, STL, XYZ, LAS/LAZ).

Every read error is a :class:`PointAtlasIOError` naming the file; every write is
atomic (:func:`atomic_write`).
"""

from ._atomic import (
    atomic_write,
    name_problem,
    output_problem,
    output_target,
    remove_stale_temp_files,
    temp_prefix,
)
from ._attrs import merge_attributes
from ._errors import PointAtlasIOError
from ._json import json_text, to_json_safe, write_json
from ._las import check_las_complete
from ._mesh import Mesh, fan_triangulate, vertex_normals
from ._plan import POINT_WRITE_EXTENSIONS, check_point_set_writable
from ._read import MESH_EXTENSIONS, POINT_EXTENSIONS, as_point_set, read_mesh, read_point_set
from ._text import file_record, write_summary_json, write_text
from ._write import write_mesh, write_point_set

__all__ = [
    "MESH_EXTENSIONS",
    "POINT_EXTENSIONS",
    "POINT_WRITE_EXTENSIONS",
    "Mesh",
    "PointAtlasIOError",
    "as_point_set",
    "atomic_write",
    "check_las_complete",
    "check_point_set_writable",
    "fan_triangulate",
    "file_record",
    "json_text",
    "merge_attributes",
    "name_problem",
    "output_problem",
    "output_target",
    "read_mesh",
    "read_point_set",
    "remove_stale_temp_files",
    "temp_prefix",
    "to_json_safe",
    "vertex_normals",
    "write_json",
    "write_mesh",
    "write_point_set",
    "write_summary_json",
    "write_text",
]
