"""Defaults of `normal_voting_denoise` shared with `denoise_halo` (no kernels here).

docs/decisions/denoise.md, "Point update" and "Filter steps per round and ball".
"""

from __future__ import annotations

__all__ = [
    "FILTER_ITER_ESTIMATED",
    "FILTER_ITER_GIVEN",
    "LONELY_PASSES",
    "LONELY_PLANES",
    "LONELY_SIGMA",
    "MAX_ROUNDS",
    "MAX_UPDATES",
    "POLISH_K",
    "POLISH_LAMBDA",
    "POLISH_MOVE",
    "POLISH_NORMAL_K",
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
