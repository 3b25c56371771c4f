"""`VSAOptions`: the settings of a VSA run, one value shared by `vsa_segment`,
`pointatlas.simplify.simplify_points` and the CLI commands ``segment`` and
``simplify``."""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from .._core import as_float, as_int, readonly
from .._core.tolerances import VSA_DEFAULT_MAX_ANGLE

__all__ = ["VSAOptions"]

SWITCH_MODES = ("batch", "single", "none")
WEIGHT_MODES = ("uniform", "area")


def _check_bool(value, name):
    if not isinstance(value, bool | np.bool_):
        raise TypeError(f"{name} must be True or False; got {value!r}")
    return bool(value)


def _check_weights(weights):
    """Weights as "uniform", "area" or a read-only float64 copy of a 1-D array of finite
    weights >= 0 (its length is checked against the points by `vsa_segment`)."""
    if isinstance(weights, str):
        if weights not in WEIGHT_MODES:
            raise ValueError(f"weights must be 'uniform', 'area' or an (N,) array; got {weights!r}")
        return weights
    w = np.asarray(weights, dtype=np.float64)
    if w.ndim != 1:
        raise ValueError(f"weights must have shape (N,); got {w.shape}")
    if not np.isfinite(w).all() or (w < 0).any():
        raise ValueError("weights must be finite and >= 0")
    return readonly(w.copy())


def _check_seeds(seeds):
    """Seeds as "all", a count >= 1 (at most N, checked by `vsa_segment`) or a read-only
    int64 copy of a non-empty 1-D array of distinct indices >= 0."""
    if isinstance(seeds, str):
        if seeds != "all":
            raise ValueError(f"seeds must be an int, an index array or 'all'; got {seeds!r}")
        return seeds
    if isinstance(seeds, int | np.integer) and not isinstance(seeds, bool | np.bool_):
        return as_int(seeds, "seeds", lo=1)
    chosen = np.asarray(seeds)
    if chosen.ndim != 1 or chosen.size == 0 or not np.issubdtype(chosen.dtype, np.integer):
        raise ValueError(
            f"seeds must be an int, a non-empty 1-D integer index array or 'all'; "
            f"got {type(seeds).__name__} of shape {np.shape(seeds)}"
        )
    chosen = chosen.astype(np.int64)
    if chosen.min() < 0:
        raise ValueError(f"seeds must be point indices >= 0; got {chosen.tolist()[:5]}")
    if np.unique(chosen).size != chosen.size:
        raise ValueError("seeds must not repeat a point index")
    return readonly(chosen)


@dataclass(frozen=True, slots=True)
class VSAOptions:
    """Settings of variational shape approximation (`vsa_segment`).

    One value for every place that runs VSA: `vsa_segment` takes it as
    ``options=`` (or its fields as keywords), `pointatlas.simplify.simplify_points`
    passes it on, and the CLI commands ``segment`` and ``simplify`` build it from
    the same flags. The per-run data stay arguments of `vsa_segment`: ``rng`` and
    ``neighbors``.

    Parameters
    ----------
    k : int
        Neighbourhood size (the point itself included) of the k-NN graph used by
        flood, switch and region adjacency: >= 1, and at most the number of points
        when no ``neighbors`` are given to `vsa_segment`.
    weights : {"uniform", "area"} or array_like of shape (N,), float64
        Point weights w_j of Eq. 4.4: 1, the area proxy of Eq. 4.6
        (`area_weights`), or given (finite, >= 0).
    seeds : int, array_like of shape (m,), int, or "all"
        Number of random seeds in [1, N] (drawn with `vsa_segment`'s ``rng``),
        distinct seed point indices, or every point a seed. Every connected
        component of the graph without a seed gets its smallest-index point as an
        extra seed, so no point stays unassigned.
    eta : float, optional
        Split regions with L21 > eta, merge neighbours whose union has L21 < eta
        (4.3.3); finite, >= 0. Depends on the number of points per region; see
        `estimate_eta`.
    max_angle : float, optional
        Alternative threshold independent of the number of points (radians in
        [0, pi]): a region's mean normal deviation arccos(|S|/W) must not exceed
        it. With neither threshold, ``max_angle`` = 10 degrees is used.
    split, merge : bool
        Enable the split and merge steps.
    switch : {"batch", "single", "none"}
        "batch" moves every boundary point that lowers the energy at once,
        "single" the thesis' one best move per iteration, "none" stops after the
        initial flood (plus splits and merges).
    classic : bool
        Run the classic loop of 4.2.2 instead (flood, proxy update, re-seed,
        stopping when nothing changes or a labelling repeats); split, merge and
        switch do not apply and eta/max_angle must not be given.
    max_iter : int
        Maximum number of iterations (>= 0).
    local : bool
        Local mode (default False): the switch never moves a point when that
        puts its source or destination region over the threshold, merges accept
        a union only within ``VSA_LOCAL_MERGE_FACTOR`` (0.7) of the threshold
        (0.7 x max_angle, or 0.7 eta), and merges run in every iteration instead
        of stopping on the whole input's region count. Leaving out a few points
        then changes the regions only near them, so tiled runs
        (`pointatlas.batch`) agree with an untiled run of the same mode; the
        result differs from the default (on the 1M-point lidar scan about 4-8 %
        fewer regions and 35-47 % more energy). See docs/decisions/segment.md
        "Local mode".
    min_region_size : int
        Regions with fewer points join, at the end of the run, the neighbouring
        region whose union with them adds the least L21 energy among those on
        whose surface they lie (within the neighbourhood reach of its plane)
        (>= 0; 0 or 1: off, the default, so Table 4.1 and `pointatlas.simplify`
        keep VSA's own regions; ``pointatlas segment`` uses k). A region with no
        such neighbour (off every surface, or a small connected component of the
        graph) stays; in local mode the step runs before the off-surface step,
        whose regions of their own stay too. See docs/decisions/segment.md
        "Small regions".

    Raises
    ------
    ValueError
        An option out of range (the message names it), both ``eta`` and
        ``max_angle``, or ``classic`` with a threshold.
    TypeError
        Non-integer k, seeds, max_iter or min_region_size; non-numeric eta or max_angle; a
        non-boolean switch flag.

    See Also
    --------
    vsa_segment : Runs VSA with these settings.

    Notes
    -----
    Arrays (given weights or seed indices) are kept as read-only copies; two
    options are equal when every field is (arrays element-wise). An options
    value holding an array cannot be hashed.

    Examples
    --------
    >>> opts = VSAOptions(eta=25.0)
    >>> opts.replace(k=12).k, opts.k
    (12, 8)
    >>> VSAOptions(eta=1.0, max_angle=0.2)
    Traceback (most recent call last):
    ...
    ValueError: give eta or max_angle, not both
    """

    k: int = 8
    weights: str | np.ndarray = "uniform"
    seeds: str | int | np.ndarray = "all"
    eta: float | None = None
    max_angle: float | None = None
    split: bool = True
    merge: bool = True
    switch: str = "batch"
    classic: bool = False
    max_iter: int = 1000
    local: bool = False
    min_region_size: int = 0

    def __post_init__(self):
        def put(name, value):
            object.__setattr__(self, name, value)

        put("k", as_int(self.k, "k", lo=1))
        put("max_iter", as_int(self.max_iter, "max_iter", lo=0))
        put("min_region_size", as_int(self.min_region_size, "min_region_size", lo=0))
        if self.switch not in SWITCH_MODES:
            raise ValueError(f"switch must be one of {SWITCH_MODES}; got {self.switch!r}")
        if self.eta is not None and self.max_angle is not None:
            raise ValueError("give eta or max_angle, not both")
        if self.eta is not None:
            put("eta", as_float(self.eta, "eta", lo=0.0))
        if self.max_angle is not None:
            put(
                "max_angle",
                as_float(
                    self.max_angle, "max_angle", lo=0.0, hi=math.pi, what="angle", unit="radians"
                ),
            )
        for name in ("split", "merge", "classic", "local"):
            put(name, _check_bool(getattr(self, name), name))
        if self.classic and (self.eta is not None or self.max_angle is not None):
            raise ValueError("classic=True runs without split/merge; do not give eta or max_angle")
        put("weights", _check_weights(self.weights))
        put("seeds", _check_seeds(self.seeds))

    def __eq__(self, other):
        if not isinstance(other, VSAOptions):
            return NotImplemented
        for f in dataclasses.fields(self):
            a, b = getattr(self, f.name), getattr(other, f.name)
            if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
                if not (
                    isinstance(a, np.ndarray) and isinstance(b, np.ndarray) and np.array_equal(a, b)
                ):
                    return False
            elif a != b:
                return False
        return True

    def replace(self, **changes) -> VSAOptions:
        """A copy with some fields changed (validated again).

        Parameters
        ----------
        **changes
            New values of fields (``k``, ``weights``, ``seeds``, ``eta``,
            ``max_angle``, ``split``, ``merge``, ``switch``, ``classic``,
            ``max_iter``, ``local``, ``min_region_size``).

        Returns
        -------
        options : VSAOptions
            The changed copy (``self`` when nothing changes).

        Raises
        ------
        TypeError
            A name that is not a field.
        ValueError
            A changed value out of range (as the constructor).

        Examples
        --------
        >>> VSAOptions().replace(max_angle=0.2).max_angle
        0.2
        """
        if not changes:
            return self
        names = [f.name for f in dataclasses.fields(self)]
        unknown = [key for key in changes if key not in names]
        if unknown:
            raise TypeError(
                f"unknown VSA option {unknown[0]!r}; the options are {', '.join(names)}"
            )
        return dataclasses.replace(self, **changes)

    @property
    def min_cos(self) -> float | None:
        """Cosine of the mean-deviation bound (None in eta mode).

        Returns
        -------
        min_cos : float or None
            cos(max_angle), cos(10 degrees) when neither threshold is given.
        """
        if self.eta is not None:
            return None
        return math.cos(VSA_DEFAULT_MAX_ANGLE if self.max_angle is None else self.max_angle)
