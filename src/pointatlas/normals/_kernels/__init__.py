"""numba kernels of the normals room, one module per stage (validated input assumed).

* `eig3`: the symmetric 3 x 3 eigensolvers, shared with the features room;
* `pca`: PCA normals of k-neighbourhoods;
* `graph`: the Riemannian graph of the orientation step;
* `forest`: its minimum spanning forest with sign parities.

Plain-numpy references: ``tests/normals/reference.py``.
"""

from .eig3 import sym3_eigen
from .forest import spanning_forest_kernel
from .graph import component_tops_kernel, offsets_kernel, riemannian_graph_kernel
from .pca import pca_normals_kernel

__all__ = [
    "component_tops_kernel",
    "offsets_kernel",
    "pca_normals_kernel",
    "riemannian_graph_kernel",
    "spanning_forest_kernel",
    "sym3_eigen",
]
