"""The halo a denoise run needs for tiles to give the untiled result (decisions: denoise)."""

from __future__ import annotations

from typing import NamedTuple

from .._core import as_int
from .._core.tolerances import DENOISE_K_MAX, DENOISE_K_WIDTH
from ._defaults import LONELY_PASSES, MAX_ROUNDS, MAX_UPDATES, default_filter_iter
from ._flatness import FLATNESS_SCHEDULES

__all__ = ["DenoiseHalo", "denoise_halo"]

_METHODS = ("normal-voting", "normal-voting-adaptive", "flatness")


class DenoiseHalo(NamedTuple):
    """Reach of a denoise run in neighbour rings of a k-NN table (`denoise_halo`).

    Attributes
    ----------
    rings : int
        Hops in the k-NN graph of ``columns`` columns (the point itself counted)
        from an owned point to the farthest point its result depends on.
    columns : int
        Width of that k-NN table.
    exact : bool
        True when a tile holding every point within ``rings`` hops of its owned
        points gives them the untiled result bit for bit (fixed iteration counts,
        the untiled l passed as ``spacing``, the same neighbour table); False when
        the run has global stopping tests or re-queries neighbours of moved points
        (then ``rings`` is the reach of the worst case or of the input's table).
    """

    rings: int
    columns: int
    exact: bool

    def length(self, reach: float) -> float:
        """Halo in length units: ``rings * reach``.

        Parameters
        ----------
        reach : float
            The largest distance from a point of the tile region to its
            ``columns``-th nearest neighbour (the point itself counted).

        Returns
        -------
        halo : float
            Each hop spans at most ``reach``, so ``rings * reach`` covers them all.
        """
        return float(self.rings) * float(reach)


def denoise_halo(
    method: str = "normal-voting",
    *,
    n_iter: int | None,
    n_filter_iter: int | None = None,
    n_update: int | None = None,
    estimate: bool = False,
    normal_k: int = 20,
    k: int = 28,
    k_start: int | None = None,
    schedule: str = "constant",
) -> DenoiseHalo:
    """The halo, in neighbour rings, that a tiled denoise run needs to equal the untiled one.

    Parameters
    ----------
    method : {"normal-voting", "normal-voting-adaptive", "flatness"}
        The denoiser (resolve ``"auto"`` with `choose_method` first).
    n_iter : int or None
        Normal voting: rounds (None: automatic, up to 4). Flatness: iterations.
    n_filter_iter : int or None
        Normal voting: filter steps per round and after the last one. None: as
        `normal_voting_denoise` (`default_filter_iter`: 1 with ``estimate``, else 5).
    n_update : int or None
        Normal voting: point updates per round (None: automatic, up to 12).
    estimate : bool
        Normal voting: normals estimated from the points (PCA over ``normal_k``
        neighbours and MST orientation; the orientation is global, never exact),
        so the returned ones are refitted instead of filtered further.
    normal_k : int
        Normal voting: neighbours of the PCA normals (more than the table's
        columns: a second query, not exact).
    k, k_start, schedule
        Flatness: the neighbourhood size, the first k of the "decreasing"
        schedule (default 4 k) and the schedule (`flatness_denoise`).

    Returns
    -------
    halo : DenoiseHalo
        ``rings`` and ``columns`` of the k-NN graph, and whether the tiled result
        is exact; ``halo.length(reach)`` converts to length units.

    Raises
    ------
    ValueError
        Unknown method or schedule, counts below 0, k below 3.
    TypeError
        Non-integer counts.

    Notes
    -----
    Normal voting (docs/decisions/denoise.md, "Tiles") reads only the input's
    neighbour table of min(48, N) columns (+10 for the adaptive k): each PCA
    estimate, filter step, lonely-normal pass, point update and the final feature
    classes read the table's rows, so an owned point's result depends on points
    R (F + P) + (R - 1) + R U + F + 1 hops away (R rounds, F filter steps, P = 1
    lonely-normal pass per round, U updates; estimated normals:
    R (F + P) + (R - 1) + R U + 2). Only the rows of points less than that
    far are read, and their neighbours lie within the halo, so a tile's own
    exact k-NN rows serve. With ``n_iter`` or ``n_update`` None the counts are the worst
    case (4 rounds, 12 updates, and one more ring for the polish step that may end
    an automatic run) and the stops are RMS tests over all points, so ``exact`` is
    False. Exact tiles also need ``spacing=`` (the untiled l) and
    the same neighbour table (``neighbors=``) in `normal_voting_denoise`.

    Flatness (thesis Eq. 6.3) re-queries the k nearest neighbours of the moved
    points every iteration: ``n_iter`` rings of the input's table of
    max(k, k_start) columns, not exact (the points move by up to about
    2 eps times the k-th neighbour distance per iteration; add a margin).

    Examples
    --------
    >>> denoise_halo("normal-voting", n_iter=1, n_update=4)
    DenoiseHalo(rings=16, columns=48, exact=True)
    >>> denoise_halo("normal-voting", n_iter=1, n_update=4).length(0.5)
    8.0
    """
    if method not in _METHODS:
        raise ValueError(f"method must be one of {', '.join(_METHODS)}; got {method!r}")
    if method == "flatness":
        n_iter = as_int(60 if n_iter is None else n_iter, "n_iter", lo=0)
        k = as_int(k, "k", lo=3)
        if schedule not in FLATNESS_SCHEDULES:
            raise ValueError(
                f"schedule must be one of {', '.join(FLATNESS_SCHEDULES)}; got {schedule!r}"
            )
        width = k
        if schedule == "decreasing" or k_start is not None:
            width = max(k, 4 * k if k_start is None else as_int(k_start, "k_start", lo=k))
        return DenoiseHalo(rings=n_iter, columns=width, exact=False)
    columns = DENOISE_K_MAX + (DENOISE_K_WIDTH if method == "normal-voting-adaptive" else 0)
    normal_k = as_int(normal_k, "normal_k", lo=3)
    # a wider PCA table than the input's is a second, global query
    exact = n_iter is not None and n_update is not None and not estimate and normal_k <= columns
    rounds = MAX_ROUNDS if n_iter is None else as_int(n_iter, "n_iter", lo=0)
    updates = MAX_UPDATES if n_update is None else as_int(n_update, "n_update", lo=0)
    if n_filter_iter is None:
        n_filter_iter = default_filter_iter(estimate)
    steps = as_int(n_filter_iter, "n_filter_iter", lo=0)
    hops = 0
    if rounds:  # estimated normals: refitted (one hop, beside the classes) instead of F steps
        final = 0 if estimate else steps
        hops = rounds * (steps + LONELY_PASSES) + (rounds - 1) + rounds * updates + final + 1
    hops += int(bool(estimate))
    if n_iter is None and rounds:  # the polish after an automatic run: one more ring
        hops += 1
    return DenoiseHalo(rings=hops, columns=columns, exact=exact)
