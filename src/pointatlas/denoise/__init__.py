"""Denoising: normal voting filtering with adaptive k, point updates, flatness denoising.

Thesis 5.4 (application scenario, Table 5.3) and 6.2 (Eq. 6.3, Figs 6.7-6.9):
the normal voting tensor stage of [YRS+18] (reconstructed), the thesis'
variant choosing every point's k by least E_dim, a point update driven by the
filtered normals (the halo a tiled run needs: `denoise_halo`), the flatness
update of Eq. 6.3 (with the large-k-first schedule of 6.2's outlook), noise
models and the measures of the denoising literature (normal MSE, Chamfer,
point-to-mesh, tangential drift).
"""

from .._core._deprecation import deprecated_alias
from ._api import (
    DENOISE_METHODS,
    choose_method,
    denoise,
    flatness_with_sides,
    snap_planar_pieces,
    voting_with_pieces,
)
from ._defaults import default_filter_iter
from ._filter import THESIS_FILTER_PARAMETERS, default_neighborhoods, filter_normals
from ._flatness import FLATNESS_SCHEDULES, flatness_denoise, flatness_schedule
from ._halo import DenoiseHalo, denoise_halo
from ._measures import (
    DenoiseMeasures,
    chamfer_distance,
    denoise_measures,
    normal_mse,
    unit_sphere_transform,
)
from ._noise import NOISE_KINDS, add_impulsive_noise, add_noise
from ._result import DenoiseResult, NormalFilterResult
from ._voting import normal_voting_denoise

__all__ = [
    "DENOISE_METHODS",
    "FLATNESS_SCHEDULES",
    "NOISE_KINDS",
    "THESIS_FILTER_PARAMETERS",
    "DenoiseHalo",
    "DenoiseMeasures",
    "DenoiseResult",
    "NormalFilterResult",
    "add_impulsive_noise",
    "add_noise",
    "chamfer_distance",
    "choose_method",
    "default_filter_iter",
    "default_neighborhoods",
    "denoise",
    "denoise_halo",
    "denoise_measures",
    "filter_normals",
    "flatness_denoise",
    "flatness_schedule",
    "flatness_with_sides",
    "normal_mse",
    "normal_voting_denoise",
    "snap_planar_pieces",
    "unit_sphere_transform",
    "voting_with_pieces",
]

# Former (British) names: they still work and warn, naming the new name (not in __all__).
default_neighbourhoods = deprecated_alias(default_neighborhoods, "default_neighbourhoods")
