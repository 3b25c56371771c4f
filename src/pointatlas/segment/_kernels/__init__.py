"""numba kernels of the segmentation room, one stage per module (inputs are
validated by the callers).

- `_csr`: the symmetric CSR graph, label numbering, connected pieces, region
  pairs and the boundary bookkeeping (foreign-neighbour counts);
- `_heap`: the room's one priority queue (a 4-ary heap of int64 rows);
- `_flood`: the flood from seeds and the re-seeding of the classic loop;
- `_switch`: the batch and single-best switch and the in-place move updates;
- `_merge`: merge candidate pairs and the greedy cheapest-first merge;
- `_grow`: the region-growing baseline.

Every kernel has a plain-numpy/Python reference in ``tests/segment/reference.py``.
"""

from ._csr import (
    boundary_points,
    canonical_labels,
    connected_label_components,
    edge_pairs,
    farthest_neighbor_distances,
    foreign_counts,
    recount_foreign,
    region_pairs,
    symmetric_csr,
    touched_points,
)
from ._flood import best_points, flood
from ._grow import region_growing
from ._merge import greedy_merge, merge_candidate_pairs
from ._switch import (
    apply_moves,
    batch_switch,
    batch_switch_bounded,
    best_single_move,
    forget_around,
    hold_under_threshold,
    renumber_memo,
)

__all__ = [
    "apply_moves",
    "batch_switch",
    "batch_switch_bounded",
    "best_points",
    "best_single_move",
    "boundary_points",
    "canonical_labels",
    "connected_label_components",
    "edge_pairs",
    "farthest_neighbor_distances",
    "flood",
    "foreign_counts",
    "forget_around",
    "greedy_merge",
    "hold_under_threshold",
    "merge_candidate_pairs",
    "recount_foreign",
    "region_growing",
    "region_pairs",
    "renumber_memo",
    "symmetric_csr",
    "touched_points",
]
