"""numba kernels of the neighbour queries, one module per stage (validated input assumed).

* `grid`: the compact sorted-cell grid's look-ups (cells of a column, occupancy levels,
  queries grouped by cell; the grid itself is built by numpy in ``_grid``);
* `knn`: k nearest neighbours on the grid from each cell's 3 x 3 x 3 block, the k-d
  tree path's selection, the scan of all points for far queries;
* `knn_rings`: the grid rows the block leaves (a per-query block scan, further rings);
* `radius`: closed-ball queries and row sorting;
* `graph`: CSR structure and edge lengths of the k-NN graph;
* `mesh_distance`: the bounding-volume hierarchy of the exact point-to-mesh distance
  (imported from its module by ``_mesh_distance``).

The decisions behind them (column 0 is the point itself, ties by index, the grid
layout) are in docs/decisions/neighbors.md; their plain-numpy references in
``tests/neighbors/reference.py``.

All kernels assume validated input: finite float64 coordinates that are already
centred (``_knn.NeighborIndex``), int64 indices, and the grid built by
``_grid.build_grid``.
"""

from .graph import edge_lengths, graph_structure
from .grid import (
    bounds,
    group_by_cell,
    occupancy_levels,
)
from .knn import knn_brute, knn_grid, select_candidates, sqrt_inplace
from .knn_rings import knn_grid_rings
from .radius import radius_grid, sort_rows

__all__ = [
    "bounds",
    "edge_lengths",
    "graph_structure",
    "group_by_cell",
    "knn_brute",
    "knn_grid",
    "knn_grid_rings",
    "occupancy_levels",
    "radius_grid",
    "select_candidates",
    "sort_rows",
    "sqrt_inplace",
]
