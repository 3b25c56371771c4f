"""The points path's level search, set up (private): the collapses of a closed
surface on a thread, bounded by the points (`start_collapses`), and the level of the
default bound found with the floors of level 0 before and after its placement
(`default_steps`, the search itself `_snap.PointsDecimation.steps_within`).
Decisions in docs/decisions/simplify.md ("The points path's robust path").
"""

from __future__ import annotations

from concurrent.futures import Future

import numpy as np

from ._decimate import CarriedPoints

__all__ = ["CARRY_POINTS", "COLLAPSE_SHARE", "default_steps", "start_collapses"]

#: The collapses' bounds (`start_collapses`) carry every s-th point, s the smallest
#: stride that leaves at most this many: on the 10^6-point scan (its points with
#: oriented normals), 12.0 s of collapses with every point (the points of the
#: triangles around each collapse measured), 2.9 s with every 10th; 852 -> 626
#: triangles, mean distance 0.025 -> 0.027 % of the diagonal, largest 0.58 -> 0.57 %.
#: The level found is measured on all the points.
CARRY_POINTS = 100_000

#: Without a triangle budget, no collapse takes a point farther from the surface than
#: this share of what a level may reach there (the bound, or its floor: every level
#: of the sequence keeps every point within it, `_bound_kernels`); the placement onto
#: the planes and the distance back take the rest. Every 3rd collection model: 0.5
#: within 1 % of the truth 42 / 50, triangles median 660; 0.35: 41, 840; 0.65: 39,
#: 678; 1.0: the last levels' placement and distance back fail, 6,592 triangles on
#: the xyz cube (3,746 unbounded). No triangle goes farther from the points than the
#: bound (or as far as the surface was there at first). Only on a closed surface: an
#: open outline cut from the grid is a staircase whose collapses these bounds refuse
#: (a sampled 2 x 1 sheet: 79 triangles in 42 polygons, unbounded 23 in one).
COLLAPSE_SHARE = 0.5


def default_steps(level, measure, surface, bound, neighbors, budget):
    """The level of the default bound: the floors of `PointDistances.floor_at` from
    level 0 before (``surface``) and after its placement (each point the higher),
    then the level search (or the collapses for a ``budget`` of triangles), the
    floors capped (`FLOOR_CAP`). A search that would end above `LOOSE_SHARE` of level
    0's triangles (it failed at the coarse end) stops there, and runs again at the
    looser floors (`LOOSE_SLACK`); where that fails too, at the first floors without
    the cap, then at the looser ones without it, to the end."""
    # read when called (tests set them on `_point_distances`)
    from ._point_distances import FLOOR_CAP, FLOOR_SLACK, LOOSE_SHARE, LOOSE_SLACK

    measure.floor_at(*surface, bound, neighbors=neighbors, cap=FLOOR_CAP)
    placed = level.placed(0)[:2]  # placed within those floors
    measure.floor_at(*placed, bound, neighbors=neighbors, raise_only=True, cap=FLOOR_CAP)
    if budget is not None:
        return level.steps_for(budget, bound)
    lowest = level.seq.steps_for(int(LOOSE_SHARE * surface[1].shape[0]))
    steps = level.steps_within(bound, lowest)
    # looser, then uncapped (the first floors again), then both: the last to the end
    tries = (
        (LOOSE_SLACK, FLOOR_CAP, lowest),
        (FLOOR_SLACK, np.inf, lowest),
        (LOOSE_SLACK, np.inf, 0),
    )
    for slack, cap, least in tries:
        if steps is not None:
            break
        for first, raise_only in ((surface, False), (placed, True)):
            measure.floor_at(
                *first,
                bound,
                slack=slack,
                neighbors=neighbors,
                raise_only=raise_only,
                cap=cap,
            )
        level.forget_levels()
        steps = level.steps_within(bound, least)
    return steps


def start_collapses(level, measure, verts, tri, bound, max_error, neighbors):
    """The collapses of a closed surface on a thread (`Decimation.start`), while the
    floors of the level search are set from level 0's measure: none takes a point
    past `COLLAPSE_SHARE` of the bound (or of its floor, `there_floor_of`, by
    default), nor a triangle past the bound (or as far as level 0 was from the
    points). The thread finds the quadrics and the points' owners while those bounds
    are measured here. Of more than `CARRY_POINTS` points the collapses carry every
    s-th (`CarriedPoints`; the level found is measured on all, `steps_within`)."""
    bounds = Future()
    surface = measure.surface
    s = -(-surface.points.shape[0] // CARRY_POINTS)  # every s-th point carried
    if s > 1:
        # copies (C order: the kernels' one signature)
        rows = (surface.points, surface.normals, surface.radius)
        every = [None if a is None else a[::s].copy() for a in rows]
        surface = CarriedPoints(*every)
    level.start(True, surface=surface, tolerance=bounds)
    try:
        tol = bound
        if max_error is None:  # the floor of `floor_at`, from the points' side
            tol = measure.there_floor_of(verts, tri, bound, neighbors)
        # back: the tolerance, or as far as level 0 is near the point if more
        back = np.maximum(tol, measure.back_near_points(verts, tri, neighbors))
    except BaseException as exc:  # the thread waits for them: it stops too
        bounds.set_exception(exc)
        raise
    bounds.set_result((COLLAPSE_SHARE * (tol if np.ndim(tol) == 0 else tol[::s]), back[::s]))
