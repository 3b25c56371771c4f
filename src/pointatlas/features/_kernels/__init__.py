"""numba kernels of the features room, one module per stage (validated input assumed).

* `layout`: reason codes, named output columns, blocking and prefetch;
* `math_helpers`: the cosine ramp, atan2, the angle between normals, -t ln t and
  its chord bounds;
* `formulas`: the 11 eigenvalue features, written once;
* `edim_table`: the table of certified E_dim lower bounds (plain numpy);
* `covariance`: weighted covariances of neighbourhoods (Eq. 5.4);
* `fixed_k`: one (a, b, k) choice per point, and the batch helpers;
* `optimal`: the optimal (a, b, k) search (Eq. 5.9), stage by stage.

The 3 x 3 eigensolvers are shared with the normals room
(`pointatlas.normals._kernels.eig3`). Plain-numpy references:
``tests/features/reference.py``.
"""

from .covariance import covariance_kernel
from .edim_table import EDIM_TABLE_SHAPE, edim_table
from .fixed_k import (
    angles_kernel,
    eigvals_batch_kernel,
    features_kernel,
    fused_kernel,
    unit_normals_kernel,
)
from .layout import (
    N_FEATURES,
    N_OUT,
    OUT_EIGENVALUES,
    OUT_FEATURES,
    OUT_VECTOR_1,
    OUT_VECTOR_3,
    REASON_BAD_INDEX,
    REASON_FEW_DISTINCT,
    REASON_NONFINITE,
    REASON_OK,
    REASON_ZERO_EIGENSUM,
    REASON_ZERO_WEIGHTS,
)
from .optimal import optimal_kernel

__all__ = [
    "EDIM_TABLE_SHAPE",
    "N_FEATURES",
    "N_OUT",
    "OUT_EIGENVALUES",
    "OUT_FEATURES",
    "OUT_VECTOR_1",
    "OUT_VECTOR_3",
    "REASON_BAD_INDEX",
    "REASON_FEW_DISTINCT",
    "REASON_NONFINITE",
    "REASON_OK",
    "REASON_ZERO_EIGENSUM",
    "REASON_ZERO_WEIGHTS",
    "angles_kernel",
    "covariance_kernel",
    "edim_table",
    "eigvals_batch_kernel",
    "features_kernel",
    "fused_kernel",
    "optimal_kernel",
    "unit_normals_kernel",
]
