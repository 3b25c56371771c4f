"""Neighbourhoods: k nearest (itself first, ties by index), radius balls, k-NN graph,
exact point-to-mesh distance."""

from ._graph import knn_components, knn_graph, mean_spacing
from ._info import knn_component_sizes, point_set_info
from ._knn import NeighborIndex, RadiusNeighbors, query_knn, query_radius
from ._mesh_distance import MeshDistanceIndex, point_mesh_distance

__all__ = [
    "MeshDistanceIndex",
    "NeighborIndex",
    "RadiusNeighbors",
    "knn_component_sizes",
    "knn_components",
    "knn_graph",
    "mean_spacing",
    "point_mesh_distance",
    "point_set_info",
    "query_knn",
    "query_radius",
]
