"""Simplified polygon meshes from segmented point sets (thesis 4.4)."""

from ._crossings import self_intersections
from ._decimate_mesh import decimate_mesh
from ._estimated import RETRY_FACTOR, RETRY_K, EstimatedSimplification, simplify_estimated
from ._mesh import SimplifiedMesh, mesh_checks, point_mesh_distance
from ._mesh_path import simplify_mesh, surface_diagonal
from ._normals import NORMAL_K_RANGE, surface_normals
from ._pipeline import PointSimplification, simplify_points
from ._proxies import RegionProxies, region_proxies
from ._segmentation import simplify_segmentation
from ._sharp import sharpen_normals
from ._signs import outward_normals
from ._surface import SurfaceSimplification
from ._vertices import MeshVertices, SimplifyWarning

__all__ = [
    "NORMAL_K_RANGE",
    "RETRY_FACTOR",
    "RETRY_K",
    "EstimatedSimplification",
    "MeshVertices",
    "PointSimplification",
    "RegionProxies",
    "SimplifiedMesh",
    "SimplifyWarning",
    "SurfaceSimplification",
    "decimate_mesh",
    "mesh_checks",
    "outward_normals",
    "point_mesh_distance",
    "region_proxies",
    "self_intersections",
    "sharpen_normals",
    "simplify_estimated",
    "simplify_mesh",
    "simplify_points",
    "simplify_segmentation",
    "surface_diagonal",
    "surface_normals",
]
