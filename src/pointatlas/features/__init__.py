"""Inside a cloud: normal-weighted covariance features and optimal neighbourhoods.

Thesis sections 5.2-5.4 and 6.1-6.2: the cosine sigmoid weights of
Def. 15, the covariance of Eq. 5.4, eigenvalue features (linearity, planarity,
scattering, E_dim, omnivariance, anisotropy, change of curvature, eigenentropy,
sum, verticality, flatness), the optimal (a, b, k) search of Eq. 5.9, Weinmann's
optimal-k mode and a fixed-k mode. Degenerate neighbourhoods give NaN plus a
reason code (`REASON_CODES`), never a crash.
"""

from .._core._deprecation import deprecated_alias
from ._dimension import DIMENSION_CLASSES, classify_dimension
from ._features import (
    FEATURE_NAMES,
    REASON_CODES,
    FeatureResult,
    covariance_features,
    eigen_features,
    symmetric_eigenvalues,
    weighted_covariances,
)
from ._optimal import (
    THESIS_ANGLE_GRID,
    THESIS_K_RANGE,
    angle_pairs,
    decrease_cases,
    optimal_k_features,
    optimal_neighborhood,
)
from ._weights import cosine_sigmoid, normal_angles, normal_weights

__all__ = [
    "DIMENSION_CLASSES",
    "FEATURE_NAMES",
    "REASON_CODES",
    "THESIS_ANGLE_GRID",
    "THESIS_K_RANGE",
    "FeatureResult",
    "angle_pairs",
    "classify_dimension",
    "cosine_sigmoid",
    "covariance_features",
    "decrease_cases",
    "eigen_features",
    "normal_angles",
    "normal_weights",
    "optimal_k_features",
    "optimal_neighborhood",
    "symmetric_eigenvalues",
    "weighted_covariances",
]

# Former (British) names: they still work and warn, naming the new name (not in __all__).
optimal_neighbourhood = deprecated_alias(optimal_neighborhood, "optimal_neighbourhood")
