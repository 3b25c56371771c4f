"""Neighbourhoods: k nearest (itself first, ties by index), radius balls, k-NN graph."""

from ._graph import knn_components, knn_graph, mean_spacing
from ._knn import NeighborIndex, RadiusNeighbors, query_knn, query_radius

__all__ = [
    "NeighborIndex",
    "RadiusNeighbors",
    "knn_components",
    "knn_graph",
    "mean_spacing",
    "query_knn",
    "query_radius",
]
