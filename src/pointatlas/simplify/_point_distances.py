"""The points path's measure of a level: within a bound of the points both ways
(private; `_reconstruct.robust_mesh`, `_snap.PointsDecimation`).

Decisions in docs/decisions/simplify.md ("The points path's robust path").
"""

from __future__ import annotations

import copy

import numpy as np

from ._grid_knn import GridKnn

__all__ = [
    "FLOOR_FACTOR",
    "FLOOR_NEIGHBORS",
    "FLOOR_SLACK",
    "LOOSE_SHARE",
    "LOOSE_SLACK",
    "FIRST_SAMPLES",
    "BackFloors",
    "SEARCH_POINTS",
    "SPARE",
    "SPARE_FACTOR",
    "WITNESSES",
    "PointDistances",
]

#: Without ``max_error``, where the points' surface itself is farther from the points
#: than the default bound, an output may reach there what the surface reaches plus
#: this many times the bound (at 2, a surface 0.9 % of the diagonal off anywhere
#: gave the floor of 1 %, twice the default bound, at every point; with the floors
#: of level 0 before and after its placement and the placement kept from taking a
#: point past its floor, 1 leaves the search failing at the coarse end on few
#: models: `LOOSE_SLACK` there) ...
FLOOR_SLACK = 1.0
#: ... and where the level found at 1 keeps more than `LOOSE_SHARE` of level 0's
#: triangles, the search runs again at this slack (`_reconstruct.robust_mesh`) ...
LOOSE_SLACK = 2.0
LOOSE_SHARE = 0.05
#: ... what it reaches at a point or a sample being the most at its this many
#: nearest (a level's sample between two of the surface's meets the surface's own
#: sampling noise) ...
FLOOR_NEIGHBORS = 8
#: ... and never more than this many times the most it reaches anywhere.
FLOOR_FACTOR = 1.1
#: The level search's floors (`floor_at`'s ``cap``): where the surface is nearer than
#: this many bounds, no more than that (0.9 % of the diagonal at the default bound:
#: with `SPARE` points up to `SPARE_FACTOR` over, within the 1 % the report's
#: two-sided distance is held to); where it is farther, no more than it reaches there.
FLOOR_CAP = 1.8
#: Without ``max_error``, a level may leave this many points, and this many of its
#: samples, over the bound (or the floor there), by at most this factor: the level
#: search was decided by a point a hair over (a sampled fan mount's levels from
#: 69,324 triangles down to 3,532 all left one point 1.03 times the bound off, and it
#: kept 72,434 triangles).
SPARE = 4
SPARE_FACTOR = 1.1
#: The level search first measures at most about this many of the points (evenly
#: strided, `PointDistances.subset`): a level over the bound on them is over it on all.
SEARCH_POINTS = 4000
#: `PointDistances.within` measures this many of a level's samples back first (its
#: edge midpoints, vertices, then area samples), the rest only when none of them is
#: over the bound.
FIRST_SAMPLES = 4000
#: A level found over the bound at its points keeps this many of them, the farthest
#: past their floors; the next measure asks them first (a level over the bound on
#: them is over it on all: the same answer, without the distances of every point).
#: The level search's neighbours and a level's planar retries are mostly over at the
#: same points (a 10^6-point scan: 4 measures of all points per level over the bound).
WITNESSES = 64


class PointDistances:
    """Whether an output is within a bound of the points both ways: every point to
    the output's triangles, the output's vertices and samples (`back_distances`) to
    the points' surface (`PointSurface`); and no vertex outside the points' box
    grown by 1 % of its diagonal (a spike)."""

    def __init__(self, q, surface):
        self.q, self.surface = q, surface
        lo, hi = q.min(axis=0), q.max(axis=0)
        grow = 0.01 * float(np.linalg.norm(hi - lo))
        self.lo, self.hi = lo - grow, hi + grow
        # vertices are clipped a little inside, so that mapping back to the input's
        # coordinates cannot round them out
        self.box = (lo - 0.99 * grow, hi + 0.99 * grow)
        self.there_floor = None
        self.back_floor = None  # `BackFloors`, set by `floor_at`
        # (out_v, out_t, `_first_measure`'s) of the last two surfaces measured: level
        # 0's before and after its placement, measured once
        self._first = []
        self.spare = 0  # points and samples a level may leave over (`floor_at`)
        self._witness = np.zeros(0, dtype=np.int64)  # rows of ``q`` last found over

    def floor_at(
        self,
        out_v,
        out_t,
        bound: float,
        *,
        slack=None,
        factor=FLOOR_FACTOR,
        neighbors=None,
        raise_only=False,
        cap=np.inf,
    ):
        """From now on (`within`), at each point and near each sample of the surface
        ``out_v``, ``out_t`` a level may reach what that surface reaches there (the
        most at the `FLOOR_NEIGHBORS` nearest) plus ``slack`` times ``bound``, but
        never more than ``factor`` times the most it reaches anywhere, nor less than
        the bound given to `within`: where the points' surface lost a thin wall or
        bridged a gap, the bound rises there only, not everywhere (raised
        everywhere, it let a level of 168 triangles 3.6 % of the diagonal off the
        truth pass). ``neighbors``: the points' k-NN table (`query_knn`: the point
        itself first, at least `FLOOR_NEIGHBORS` columns), searched when None;
        ``slack``: `FLOOR_SLACK` when None; ``cap`` (in bounds): where the surface is
        nearer, no floor above it, and no more than the surface reaches elsewhere
        (`FLOOR_CAP`; none by default). With ``raise_only``, the floors already
        set are only raised (a second surface's: each point's the higher of the two,
        near each sample the nearest sample's of either). Returns the largest
        distance both ways."""
        slack = FLOOR_SLACK if slack is None else slack
        there, most, samples, back = self._first_measure(out_v, out_t, neighbors)[:4]
        most = float(max(most, back.max()))
        there_floor = _capped(there, slack * bound, factor * most, cap * bound)
        edges = np.linalg.norm(out_v[out_t[:, 1]] - out_v[out_t[:, 0]], axis=1)
        cell = 1.5 * float(np.median(edges)) if edges.size else 0.0  # ~3 samples apart
        back_floor = BackFloors([(samples, back, cell, slack * bound, factor * most, cap * bound)])
        if raise_only and self.there_floor is not None:
            # the floors of both surfaces: each point the higher, near each sample
            # the nearest sample's of either
            there_floor = np.maximum(there_floor, self.there_floor)
            back_floor = self.back_floor.then(back_floor.layers[0])
        self.there_floor, self.back_floor = there_floor, back_floor
        self.spare = SPARE
        return most

    def there_floor_of(self, out_v, out_t, bound: float, neighbors=None) -> np.ndarray:
        """How far each point may be from a level by `floor_at` (``out_v``, ``out_t``)
        counted from the points' side alone: at least ``bound``."""
        there, most = self._first_measure(out_v, out_t, neighbors)[:2]
        return np.maximum(bound, np.minimum(there + FLOOR_SLACK * bound, FLOOR_FACTOR * most))

    def back_near_points(self, out_v, out_t, neighbors=None) -> np.ndarray:
        """How far the surface ``out_v``, ``out_t`` is from the points' discs near each
        point: the most of its back samples' distances (`floor_at`'s: edge midpoints,
        vertices, area samples) among those nearest to the point or to one of its
        `FLOOR_NEIGHBORS` nearest."""
        _, _, _, back, nearest, sample_point = self._first_measure(out_v, out_t, neighbors)
        most = np.zeros(self.q.shape[0])
        np.maximum.at(most, sample_point, back)
        return most[nearest].max(axis=1)

    def _first_measure(self, out_v, out_t, neighbors):
        """``(there, most, samples, back, nearest, sample_point)`` of the surface
        ``out_v``, ``out_t`` (measured once, kept for the same arrays): each point's
        distance to it, the most at its `FLOOR_NEIGHBORS` nearest (``nearest``: their
        rows; ``neighbors``: `floor_at`'s), the largest, and its edge midpoints,
        vertices and area samples (`point_back_samples`) with their distances to the
        points' discs and their nearest points (the discs' search: no second one)."""
        from ._distance import point_back_samples
        from ._mesh import point_mesh_distance

        for v, t, found in self._first:
            if v is out_v and t is out_t:
                return found
        there = point_mesh_distance(self.q, out_v, out_t)
        k = min(FLOOR_NEIGHBORS, self.q.shape[0])
        if neighbors is None or neighbors.shape[1] < k:
            neighbors = self.surface.tree.query(self.q, k=k, workers=-1)[1]
        nearest = neighbors[:, :k]
        samples = point_back_samples(out_v, out_t)
        found = (there[nearest].max(axis=1), float(there.max()), samples)
        back, sample_point = self.surface.distance(samples, nearest=True)
        found += (back, nearest, sample_point)
        self._first = self._first[-1:] + [(out_v, out_t, found)]
        return found

    def subset(self, n: int = SEARCH_POINTS):
        """This measure on every s-th point only, s the smallest stride that leaves at
        most ``n`` of them (their floors kept, the box and the back samples as they
        are): whatever it finds over a bound is over it on all the points. None when
        that is every point."""
        stride = -(-self.q.shape[0] // max(int(n), 1))
        if stride <= 1:
            return None
        few = copy.copy(self)
        few.q = self.q[::stride]
        few._witness = np.zeros(0, dtype=np.int64)  # rows of its own points
        if self.there_floor is not None:
            few.there_floor = self.there_floor[::stride]
        return few

    def within(self, out_v, out_t, bound: float) -> bool:
        from ._distance import point_back_samples
        from ._mesh import point_mesh_distance

        if (out_v < self.lo).any() or (out_v > self.hi).any():
            return False
        floor = self._points_floor(bound)
        if self._witness.size and self._over_at_witnesses(out_v, out_t, bound, floor):
            return False
        there = point_mesh_distance(self.q, out_v, out_t, within=bound)
        left = self.spare - _over(there, floor, self.spare)
        if left < 0:
            excess = there - floor
            over = np.flatnonzero(excess > 0.0)
            if over.size > WITNESSES:  # the farthest past their floors (ties: lower row)
                order = np.argsort(-excess[over], kind="stable")
                over = np.sort(over[order[:WITNESSES]])
            self._witness = over
            return False
        samples = point_back_samples(out_v, out_t)
        # the edges' midpoints, the vertices and the first area samples first: a
        # level over the bound is mostly found there (the answer is the same, and so
        # is every distance)
        cut = min(samples.shape[0], FIRST_SAMPLES)
        left -= self._back_over(samples[:cut], bound)
        return left >= 0 and self._back_over(samples[cut:], bound) <= left

    def _over_at_witnesses(self, out_v, out_t, bound: float, floor) -> bool:
        """Whether the points a level was last found over at (``_witness``) alone put
        this one over ``bound`` (then so do all the points: `within`'s answer)."""
        from ._mesh import point_mesh_distance

        rows = self._witness
        there = point_mesh_distance(self.q[rows], out_v, out_t, within=bound)
        return _over(there, floor if np.ndim(floor) == 0 else floor[rows], self.spare) > self.spare

    def _points_floor(self, bound: float):
        """What each point may be from a level: ``bound``, or its floor where higher."""
        return bound if self.there_floor is None else np.maximum(bound, self.there_floor)

    def _samples_floor(self, samples, bound: float) -> np.ndarray:
        """What each of a level's ``samples`` may be from the points' surface: ``bound``,
        or the floor near it where higher (`BackFloors`; set)."""
        return np.maximum(bound, self.back_floor.near(samples))

    def over_at(self, out_v, out_t, bound: float) -> np.ndarray:
        """(k, 3): where the surface ``out_v``, ``out_t`` is over ``bound`` as `within`
        measures it: its vertices outside the box, the points farther than their floor
        from it, and its back samples farther than the bound (or the floor near them)
        from the points' surface (the spare ones included)."""
        from ._distance import point_back_samples
        from ._mesh import point_mesh_distance

        outside = out_v[((out_v < self.lo) | (out_v > self.hi)).any(axis=1)]
        there = point_mesh_distance(self.q, out_v, out_t, within=bound)
        floor = self._points_floor(bound)
        samples = point_back_samples(out_v, out_t)
        back = self.surface.distance_over(samples, bound)
        over = np.flatnonzero(back > bound)
        if over.size and self.back_floor is not None:
            over = over[back[over] > self._samples_floor(samples[over], bound)]
        return np.vstack([outside, self.q[there > floor], samples[over]])

    def _back_over(self, samples, bound: float) -> float:
        """How many ``samples`` of an output are farther than ``bound`` from the points'
        surface (or than the floor `floor_at` set near them): inf when one is farther
        than `SPARE_FACTOR` times that, or more than the spare."""
        back = self.surface.distance_over(samples, bound)  # exact where over
        over = back > bound
        if not over.any():
            return 0
        if self.back_floor is None:
            return np.inf
        return _over(back[over], self._samples_floor(samples[over], bound), self.spare)

    def error(self, out_v, out_t) -> float:
        """The largest distance both ways."""
        there, back = self.report(out_v, out_t)
        return float(max(there.max(), back.max()))

    def report(self, out_v, out_t):
        """Every point to the output, and the output's samples to the points' surface."""
        from ._distance import back_distances
        from ._mesh import point_mesh_distance

        there = point_mesh_distance(self.q, out_v, out_t)
        return there, back_distances(out_v, out_t, self.surface)


class BackFloors:
    """`PointDistances.floor_at`'s floors near a level's samples: at a position, that
    of the nearest sample of the surfaces ``layers`` (each ``(samples, back, cell,
    add, cap, low)``: a surface's samples, their distances to the points' discs, the
    cells of their `GridKnn`, the bound's slack and the caps), which is the most
    ``back`` at that sample's `FLOOR_NEIGHBORS` nearest of its own surface plus
    ``add``, at most ``cap``, and at most ``low`` where that most is nearer; where
    samples of two surfaces are as near (a vertex the placement left where it was),
    the higher. Found only for the samples asked about (a level's samples over the
    bound: a handful a call), on grids of each surface's samples built at the first
    call: none where none is asked about (2 of 5 models measured; k-d trees of level
    0's 419,500 samples before and after its placement, and of both, took 0.6 s of a
    9 s run, built whether asked or not)."""

    def __init__(self, layers, grids=()):
        self.layers = list(layers)
        self.grids = list(grids) + [None] * (len(self.layers) - len(grids))

    def then(self, layer) -> BackFloors:
        """These floors and one more surface's ``layer`` (their grids kept)."""
        return BackFloors([*self.layers, layer], self.grids)

    def near(self, x) -> np.ndarray:
        """The floor at each row of ``x``."""
        x = np.asarray(x, dtype=np.float64).reshape(-1, 3)
        best = np.full(x.shape[0], np.inf)
        out = np.full(x.shape[0], -np.inf)
        for at, (samples, back, cell, add, cap, low) in enumerate(self.layers):
            if self.grids[at] is None:
                self.grids[at] = GridKnn(samples, cell)
            d, i = self.grids[at].query(x, 1)
            k = min(FLOOR_NEIGHBORS, samples.shape[0])
            j = self.grids[at].query(samples[i[:, 0]], k)[1]
            local = back[j].max(axis=1)
            floor = _capped(local, add, cap, low)
            d = d[:, 0]
            out = np.where(d < best, floor, np.where(d == best, np.maximum(out, floor), out))
            best = np.minimum(best, d)
        return out


def _capped(local, add, cap, low):
    """The floors over distances ``local``: ``local`` plus ``add``, at most ``cap``,
    and at most ``low`` where ``local`` is nearer."""
    return np.minimum(np.minimum(local + add, cap), np.maximum(low, local))


def _over(d, floor, spare: int) -> float:
    """How many of distances ``d`` exceed ``floor`` (a number or one per distance):
    inf when one exceeds `SPARE_FACTOR` times it, or more than ``spare`` do."""
    over = d > floor
    n = int(np.count_nonzero(over))
    if n == 0:
        return 0
    lim = floor if np.ndim(floor) == 0 else floor[over]
    if n > spare or (d[over] > SPARE_FACTOR * lim).any():
        return np.inf
    return n
