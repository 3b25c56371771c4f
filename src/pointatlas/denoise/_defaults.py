"""Defaults of `normal_voting_denoise` shared with `denoise_halo` (no kernels here).

docs/decisions/denoise.md, "Point update" and "Filter steps per round and ball".
"""

from __future__ import annotations

__all__ = [
    "FILTER_ITER_ESTIMATED",
    "FILTER_ITER_GIVEN",
    "FLATNESS_MAX_ITER",
    "FLATNESS_MAX_MOVE",
    "FLATNESS_STOP",
    "LONELY_PASSES",
    "LONELY_PLANES",
    "LONELY_SIGMA",
    "MAX_ROUNDS",
    "MAX_UPDATES",
    "NOISE_K",
    "NOISE_PLANE_BIAS",
    "POLISH_K",
    "POLISH_LAMBDA",
    "POLISH_MOVE",
    "POLISH_NORMAL_K",
    "SIDES_MIN_HEIGHT",
    "SIDES_MIN_SHARE",
    "SIDES_Z",
    "default_filter_iter",
]

#: ``n_update=None``: at most this many point updates per round
MAX_UPDATES = 12
#: ``n_iter=None``: at most this many rounds
MAX_ROUNDS = 4
#: lonely points (docs/decisions/denoise.md, "Lonely points"): a point whose filtered
#: normal is within the cut-off of fewer than LONELY_PLANES of its neighbours (itself
#: counted) takes their normals (Gaussian weights of LONELY_SIGMA l), LONELY_PASSES
#: times per round (each pass adds a neighbour ring to `denoise_halo`; a second pass
#: measured a little better on fertility 3 %, 1.027x vs 1.036x, for wider tile halos)
LONELY_PLANES = 5
LONELY_SIGMA = 1.5
LONELY_PASSES = 1
#: polish (docs/decisions/denoise.md, "Polish"): after an automatic run of two or more
#: rounds whose last one still moved the points by an RMS above POLISH_MOVE l (about
#: 1 l of noise), each point moves POLISH_LAMBDA of the way to the mean of its
#: POLISH_K nearest moved points (itself included) along the PCA normal of its
#: POLISH_NORMAL_K nearest (both among its row of the input's neighbour table)
POLISH_MOVE = 0.28
POLISH_LAMBDA = 0.85
POLISH_K = 12
POLISH_NORMAL_K = 24
#: filter steps per round when the returned normals are refitted (estimated normals)
#: and when they are filtered (given normals; also their final steps)
FILTER_ITER_ESTIMATED = 1
FILTER_ITER_GIVEN = 5


def default_filter_iter(refit: bool) -> int:
    """Filter steps per round of `normal_voting_denoise` when ``n_filter_iter`` is None.

    Parameters
    ----------
    refit : bool
        Whether the returned normals are refitted to their faces (``refit_normals``;
        by default when the normals are estimated).

    Returns
    -------
    steps : int
        1 when refitted (one step facets curved parts less; the refit gives the
        sharp normals), 5 otherwise (the returned normals take as many steps
        more and keep edges sharp); docs/decisions/denoise.md.

    Examples
    --------
    >>> default_filter_iter(True), default_filter_iter(False)
    (1, 5)
    """
    return FILTER_ITER_ESTIMATED if refit else FILTER_ITER_GIVEN


#: flatness_denoise with ``n_iter=None`` (docs/decisions/denoise.md, "Flatness
#: defaults"): at most FLATNESS_MAX_ITER Jacobi steps of Eq. 6.3, stopped once the
#: RMS displacement from the input reaches FLATNESS_STOP noise sigmas (Eq. 6.3 at
#: eta = 1 is a curvature flow: past about the noise it shrinks the shape; on the
#: bench's CAD inputs the best step count moved the points by 0.7 sigma); no point
#: moves farther than FLATNESS_MAX_MOVE sigmas from its input (edges and corners
#: move fastest under the flow)
FLATNESS_MAX_ITER = 60
FLATNESS_STOP = 0.5
FLATNESS_MAX_MOVE = 2.5
#: the noise sigma flatness estimates: the median absolute height of each point over
#: the PCA plane of its NOISE_K nearest (itself included), x 1.4826 (a Gaussian's
#: MAD), / NOISE_PLANE_BIAS (the fitted plane takes part of the noise: 0.89 measured
#: on a noisy plane, 4,000 points; a smaller k follows curvature, a larger one
#: tilts less)
NOISE_K = 12
NOISE_PLANE_BIAS = 0.89
#: two sides (`_sides.py`, docs/decisions/denoise.md, "Thin plates"): the centred
#: heights of the input over the first denoise are split by sign when their
#: kurtosis is below 3 by SIDES_Z standard errors (a Gaussian's one-sided 0.1 %)
#: and the two-sheet fit's offset^2 is at least SIDES_MIN_SHARE of their variance
#: (a plate 1 sigma thick gives 0.2 and loses nothing by merging; 1.6 sigma 0.39);
#: heights with an RMS below SIDES_MIN_HEIGHT l (a clean input) are never split
SIDES_Z = 3.0
SIDES_MIN_SHARE = 0.25
SIDES_MIN_HEIGHT = 0.02
