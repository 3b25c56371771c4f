"""`decimate_mesh`: the mesh path's default (public entry, private module).

VSA on the input's triangles (as `simplify_mesh`), then structure-aware quadric edge
collapse (`_decimate.py`) to a level of detail: a triangle budget, or the most
collapses whose output stays within a distance of the input both ways (the default,
`MAX_ERROR` of the diagonal); vertices placed on their flat regions' planes; each
region's triangles written as simple planar polygons. Decisions in
docs/decisions/simplify.md, section "Decimation".
"""

from __future__ import annotations

import dataclasses

import numpy as np

from .._core import as_float, as_int, as_points
from .._core._threads import machine_busy, on_thread, one_thread_if
from ..neighbors import MeshDistanceIndex
from ._caps import flip_caps
from ._decimate import Collapses, collapse_all, no_collapses
from ._distance import _samples_in_order, back_distances
from ._mesh import _as_triangles, point_mesh_distance, used_vertices
from ._mesh_path import (
    FLAT_MERGE_ANGLE,
    MAX_ANGLE,
    _diagonal,
    _merge_flat,
    _segment_faces,
    _unreferenced_apart,
    repaired_input,
)
from ._place import FLAT_RTOL, flat_planes, place_on_planes, settle_planes
from ._polygons import PLANAR_RTOL
from ._surface import SurfaceSimplification, surface_result
from ._triangles import _face_graph, _surface

__all__ = ["MAX_ERROR", "Decimation", "MeshDistances", "decimate_mesh"]

#: Default largest distance between input and output, both ways, relative to the
#: bounding-box diagonal of the vertices on triangles.
MAX_ERROR = 0.005
#: A placed vertex moves at most this far (relative to the diagonal).
_PLACE_STEP = 1e-3
#: Faces of flat regions left bent by the placement are made planar within this
#: fraction of its step (1e-7 of the diagonal; `settle_planes`).
_SETTLE = 1e-4
#: Area samples of the output measured back in the level search (of the report's
#: `BACK_SAMPLES`, the same points; the level found is measured on all of them).
SEARCH_SAMPLES = 500
#: Area samples of each output measured back when a budget chooses between the
#: structured and the plain decimation (the first of the report's; the one kept is
#: then measured on all of them).
CHOICE_SAMPLES = 2_000
#: Below this many input triangles, on a busy machine (1-minute load average at least
#: the number of CPUs, `machine_busy`), the numba kernels of a run (the distance
#: queries, VSA's) run in one thread (`_threads_for`): dozens of small parallel
#: regions per run, each waiting for a busy core, cost more than the second thread
#: gains (load ~3 on 2 cores, wall time, 2 threads / 1: cad_a_a27 1.8x, bunny_3301
#: 1.7x, armadillo_14587 1.4x, dragon_50002 1.0x). Outputs are the same.
PARALLEL_MIN_TRIANGLES = 200_000


def decimate_mesh(
    vertices,
    triangles,
    max_triangles: int | None = None,
    *,
    max_error: float | None = None,
    max_angle: float | None = None,
    rng=None,
) -> SurfaceSimplification:
    """Structure-aware decimation of a triangle mesh into planar polygons.

    Parameters
    ----------
    vertices : array_like of shape (V, 3), float64
    triangles : array_like of shape (F, 3), int
        An open or closed surface; repaired first as in `simplify_mesh` (welded,
        degenerate and repeated triangles dropped, non-manifold edges and vertices
        cut apart, orientation made consistent).
    max_triangles : int, optional
        Triangle budget: the decimation stops at the first level with at most this
        many triangles (or at the last valid collapse).
    max_error : float, optional
        Largest distance between input and output, both ways (every input vertex to
        the output; the output's vertices and 20,000 seeded area samples to the
        input's triangles), input units. Default: `MAX_ERROR` (0.5 %) of the
        bounding-box diagonal when ``max_triangles`` is not given.
    max_angle : float, optional
        Segmentation level (radians; default 10 degrees): VSA's regions carry the
        structure term (flat regions' planes) and become the polygons.
    rng : None, int or numpy.random.Generator
        Passed to VSA.

    Returns
    -------
    result : SurfaceSimplification
        Polygons (simple, planar), triangles, checks, distances both ways.

    Notes
    -----
    Every collapse is computed once, cheapest first (Garland-Heckbert quadrics with
    each flat region's plane, Salinas, Lafarge and Alliez 2015); a level of detail
    is a prefix of that sequence, so the error bound is met by bisection over the
    number of collapses, each level measured both ways exactly as reported. Closed,
    manifold inputs stay closed and manifold (link condition, no triangle turned
    over).

    Examples
    --------
    >>> from pointatlas.synth import cube
    >>> m = cube(6)
    >>> r = decimate_mesh(m.vertices, m.faces)
    >>> len(r.polygons), len(r.triangles), r.is_closed, r.distance_max < 1e-12
    (6, 12, True, True)
    """
    verts = as_points(vertices, name="vertices")
    tri = _as_triangles(triangles, verts.shape[0])
    if max_triangles is not None and max_error is not None:
        raise ValueError("give at most one of max_triangles and max_error")
    with _threads_for(tri.shape[0]):
        return _decimate_mesh(verts, tri, max_triangles, max_error, max_angle, rng)


def _threads_for(n_triangles: int):
    """One numba thread (numba's setting of the calling thread, restored on exit)
    below `PARALLEL_MIN_TRIANGLES` input triangles on a busy machine; else nothing."""
    return one_thread_if(n_triangles < PARALLEL_MIN_TRIANGLES and machine_busy())


def _decimate_mesh(verts, tri, max_triangles, max_error, max_angle, rng):
    """`decimate_mesh` on validated vertices and triangles."""
    used = used_vertices(verts.shape[0], tri)
    diag = _diagonal(verts[used])
    if max_triangles is not None:
        max_triangles = as_int(max_triangles, "max_triangles", lo=1)
    elif max_error is not None:
        max_error = as_float(max_error, "max_error", lo=0.0, lo_open=True)
    else:
        max_error = MAX_ERROR * diag
    angle = MAX_ANGLE if max_angle is None else as_float(max_angle, "max_angle", lo=0.0)
    verts, tri, run_used, repair = repaired_input(verts, tri, used)
    s = _surface(verts, tri)
    graph = _face_graph(s)
    labels, _ = _segment_faces(s, graph, max_angle=angle, eta=None, rng=rng)
    labels = _merge_flat(s, graph, labels, min(angle, FLAT_MERGE_ANGLE))
    planes = flat_planes(verts, tri, labels, int(labels.max()) + 1, FLAT_RTOL * diag)
    on = verts if run_used is None else verts[run_used]  # the vertices on a triangle
    measure = MeshDistances(on, verts, tri, run_used)
    args = (verts, tri, labels, planes, _PLACE_STEP * diag, 1e-9 * diag, measure)
    if max_triangles is not None and planes[2].any():
        # three sequences (`_nearest_within`), the other two on threads meanwhile
        soft = Decimation(*args, target=max_triangles, hold=False, start=False)
        plain = Decimation(*args, structure=0.0, target=max_triangles, hold=False, start=False)
        soft.start(background=True)
        plain.start(background=True)
        level = Decimation(*args, target=max_triangles)
        level, m, distances = _nearest_within([level, soft, plain], max_triangles)
    else:
        level = Decimation(*args, target=max_triangles)
        m, distances = level.steps_for(max_triangles, max_error), None
    res = level.result(m, PLANAR_RTOL * diag, distances)
    if run_used is not None:
        res = _unreferenced_apart(res, run_used)
    return res if repair is None else repair.back(res)


def _nearest_within(levels: list, budget: int):
    """``(decimation, collapses, distances)``: of the ``levels`` (the planes held, the
    structure term alone, plain quadrics), each at its first level within the
    triangle ``budget``, those that meet it (none: all), the one with the least
    product of its two-sided mean and largest distance, ties to the first: every
    input vertex to the output and the output's vertices and first `CHOICE_SAMPLES`
    area samples back (of the report's; the one kept is measured on all of them by
    `result`). At small budgets the flat regions can no longer all be kept: their
    planes held, or their quadrics, then steer the last collapses away from the
    shape, and a spike shows only in the largest distance (docs/decisions/
    simplify.md, "Decimation")."""
    steps = [level.steps_for(budget, None) for level in levels]
    meet = [
        k
        for k, (lv, m) in enumerate(zip(levels, steps, strict=True))
        if lv.seq.n_triangles(m) <= budget
    ]
    pick = meet or list(range(len(levels)))
    if len(pick) == 1:  # its distances are measured by `result`
        return levels[pick[0]], steps[pick[0]], None
    near = {k: levels[k].near(steps[k], CHOICE_SAMPLES) for k in pick}
    k = min(pick, key=lambda j: (near[j][0] * near[j][1], j))
    return levels[k], steps[k], None


class MeshDistances:
    """Whether an output is within a bound of a mesh both ways, as `surface_result`
    measures it: ``on`` (the input vertices on a triangle; ``on_ids`` their rows of
    ``verts``, None: all) to the output, and the output's vertices and samples
    (`back_distances`) to the input's triangles (their hierarchy built once).

    The decimation's lineage makes the searches short without changing a value:
    every output triangle is an input triangle (``kept``), measured first from the
    samples on it, and every input vertex went to an output vertex (``went``), whose
    first triangle is measured first from it (`MeshDistanceIndex`'s ``hint``)."""

    def __init__(self, on, verts, tri, on_ids=None):
        self.on, self.verts, self.tri, self.on_ids = on, verts, tri, on_ids
        self.index = MeshDistanceIndex(verts, tri)
        # (out_v, out_t, its index, {count: (samples, triangles, order), "back": distances})
        self._last = None
        self._orders = {}  # the order to measure ``on`` and ``verts`` in, made once

    def within(
        self, out_v, out_t, bound: float, lineage=None, first=None, there_known=False
    ) -> bool:
        """``lineage``: ``(kept, went)`` of `Collapses.mesh_and_map`, optional;
        ``first``: measure only the output's vertices and the first this many of its
        area samples back (None: all), a subset of the report's; ``there_known``:
        the input's vertices are known to be within ``bound`` of this output."""
        there, back = self._hints(out_v, out_t, lineage)
        index = self._output_index(out_v, out_t)
        order = self._order("on", there)
        if not there_known and not index.all_within(self.on, bound, hint=there, order=order):
            return False
        samples, on, order = self._samples(out_v, out_t, first)
        hint = None if back is None else back[on]
        return self.index.all_within(samples, bound, hint=hint, order=order)

    def error(self, out_v, out_t) -> float:
        """The largest distance both ways."""
        there = point_mesh_distance(self.on, out_v, out_t).max()
        return float(max(there, back_distances(out_v, out_t, self.index).max()))

    def report(self, out_v, out_t, lineage=None):
        """The distances `surface_result` reports: every vertex to the output, and the
        output's samples back to the input."""
        return self.there(out_v, out_t, lineage), self.back(out_v, out_t, lineage)

    def near(self, out_v, out_t, lineage=None, first=None) -> tuple[np.ndarray, float, float]:
        """``(there, back_mean, back_max)``: `report`'s first part, and the mean and
        largest distance back of the output's vertices and its first ``first`` area
        samples (None: all, as `back`)."""
        there = self.there(out_v, out_t, lineage)
        back = self._back(out_v, out_t, lineage, first)
        if not back.size:
            return there, 0.0, 0.0
        return there, float(back.mean()), float(back.max())

    def there(self, out_v, out_t, lineage=None) -> np.ndarray:
        """Every input vertex to the output, exactly (`report`'s first part)."""
        hint, _ = self._hints(out_v, out_t, lineage, every=True)
        index = self._output_index(out_v, out_t)
        return index.distance(self.verts, hint=hint, order=self._order("verts", hint))

    def back(self, out_v, out_t, lineage=None) -> np.ndarray:
        """The output's vertices and samples back to the input, exactly (`report`'s
        second part; kept with the output's index)."""
        self._output_index(out_v, out_t)
        made = self._last[3]
        if "back" not in made:
            made["back"] = self._back(out_v, out_t, lineage)
        return made["back"]

    def _back(self, out_v, out_t, lineage, first=None) -> np.ndarray:
        """The output's vertices and its first ``first`` area samples (None: all) back
        to the input, exactly."""
        kept = None if lineage is None else lineage[0]
        samples, on, order = self._samples(out_v, out_t, first)
        hint = None if kept is None else kept[on]
        return self.index.distance(samples, hint=hint, order=order)

    def _order(self, name: str, hint):
        """The order to measure ``on`` or ``verts`` in (`MeshDistanceIndex.point_order`,
        the same at every level: made once); None without a hint."""
        if hint is None:
            return None
        if name not in self._orders:
            self._orders[name] = MeshDistanceIndex.point_order(getattr(self, name))
        return self._orders[name]

    def _output_index(self, out_v, out_t) -> MeshDistanceIndex:
        """The output's `MeshDistanceIndex`; the last output's is kept (the level
        search ends on the level `report` measures: the same arrays)."""
        last = self._last
        if last is not None and last[0] is out_v and last[1] is out_t:
            return last[2]
        self._last = (out_v, out_t, MeshDistanceIndex(out_v, out_t), {})
        return self._last[2]

    def _samples(self, out_v, out_t, first=None):
        """`output_samples_on` of the output (its vertices and the ``first`` area
        samples; None: all) and an order to measure them in (by triangle: near
        samples one after the other), kept with its index."""
        self._output_index(out_v, out_t)
        made = self._last[3]
        if first not in made:
            made[first] = _samples_in_order(out_v, out_t, first=first)
        return made[first]

    def _hints(self, out_v, out_t, lineage, every=False):
        """The output triangle to measure first from every input vertex (of ``on``,
        or of ``verts`` when ``every``), and the input triangle of every output one."""
        if lineage is None:
            return None, None
        kept, went = lineage
        first = np.full(out_v.shape[0] + 1, -1, dtype=np.int64)  # the last: none
        first[out_t[::-1].reshape(-1)] = np.repeat(np.arange(out_t.shape[0] - 1, -1, -1), 3)
        if not every and self.on_ids is not None:
            went = went[self.on_ids]
        return first[went], kept


class Decimation:
    """The collapse sequence of a labelled triangle mesh and its levels of detail.

    ``planes``: (normals, offsets, flat) of the regions (`flat_planes`), in the
    quadrics (weighted by ``structure``; 0: plain quadrics) and for the placement
    (vertices move at most ``step``; those within ``still`` of their planes stay);
    ``measure.within(out_v, out_t, bound)`` decides the error bound
    (`MeshDistances`, or the points' on the points path); ``box`` (lo, hi): vertices
    are clipped into it; ``target``: the collapses stop at the first level with at
    most this many triangles (`collapse_all`; for a budget: `steps_within` then sees
    only those); ``start``: False to begin the collapses later (`start`); ``hold``:
    the collapses put their vertices on their flat regions' planes, ``uncross``:
    refuse those that make the surface pass through itself more (`collapse_all`).
    """

    def __init__(
        self,
        verts,
        tri,
        labels,
        planes,
        step,
        still,
        measure,
        box=None,
        *,
        structure=1.0,
        target=None,
        start=True,
        hold=True,
        uncross=True,
    ):
        self.verts, self.tri, self.labels, self.planes = verts, tri, labels, planes
        self.step, self.still, self.measure, self.box = step, still, measure, box
        self.n_regions = int(labels.max()) + 1
        self._args = {
            "labels": labels,
            "planes": planes,
            "structure": structure,
            "target": target,
            "hold": hold,
            "uncross": uncross,
        }
        self._seq, self._pending = None, None
        if start:
            self.start()
        self._kept_level = None
        self._report = None  # (m, the distances of `distances`)
        self._there = None  # (m, the input's vertices to that level, of `near`)
        self._over = set()  # (m, bound): levels found over a bound
        self._near = {}  # (m, bound): levels within it on a subset of the samples

    def start(self, background: bool = False, **carried) -> None:
        """Makes the collapse sequence (`collapse_all`; ``carried``: its ``surface``,
        ``tolerance`` and ``back``), on a thread with ``background`` (`seq` waits)."""
        if background:
            self._pending = on_thread(collapse_all, self.verts, self.tri, **self._args, **carried)
        else:
            self._seq = collapse_all(self.verts, self.tri, **self._args, **carried)

    @property
    def seq(self) -> Collapses:
        """The collapse sequence (`collapse_all`; waited for when made on a thread,
        made now when not begun)."""
        if self._seq is None and self._pending is None:
            self.start()
        if self._seq is None:
            self._seq, self._pending = self._pending.result(), None
        return self._seq

    def mesh_and_map(self, m: int):
        """`Collapses.mesh_and_map` after ``m`` collapses; level 0 without waiting for
        the sequence (the same arrays: no collapse applied)."""
        if m == 0 and self._seq is None:
            return no_collapses(self.verts, self.tri).mesh_and_map(0)
        return self.seq.mesh_and_map(m)

    def placed(self, m: int):
        """The mesh after ``m`` collapses with its vertices on their flat planes."""
        return self._placed(m)[:4]

    def forget_levels(self) -> None:
        """Forgets which levels were found over or within a bound (``measure`` was
        changed: the next search measures again)."""
        self._over.clear()
        self._near.clear()

    def _placed(self, m: int):
        """`placed` and the lineage ``(kept, went)`` (`MeshDistances`); the level last
        found within the bound is kept (`result` asks for it again)."""
        if self._kept_level is not None and self._kept_level[0] == m:
            return self._kept_level[1]
        out_v, out_t, kept, source, went = self.mesh_and_map(m)
        face = self.labels[kept]
        normals, offsets, flat = self.planes
        if self._args["hold"]:  # a face of one triangle is planar where it is
            flat = flat & (np.bincount(face, minlength=flat.size) >= 2)
        out_v = place_on_planes(out_v, out_t, face, normals, offsets, flat, self.step, self.still)
        if self._args["hold"]:  # faces on planes that do not quite meet
            out_v = settle_planes(
                out_v, out_t, face, normals, offsets, flat, _SETTLE * self.step, self.step
            )
        if self.box is not None:  # no vertex beyond the box (lo, hi)
            out_v = np.clip(out_v, *self.box)
        # vertices placed in a row on the line of two planes: no zero-area triangle
        out_t = flip_caps(out_v, out_t, face)
        return out_v, out_t, face, source, (kept, went)

    def within(self, m: int, bound: float, first=None) -> bool:
        """Whether the output after ``m`` collapses is within ``bound`` (``measure``;
        ``first``: `MeshDistances.within`'s; a level over the bound on a subset of
        the samples is over it on all of them)."""
        if (m, bound) in self._over:
            return False
        near = self._near.get((m, bound))  # within on a subset: placed, vertices within
        placed = self._placed(m) if near is None else near
        out_v, out_t, _, _, lineage = placed
        if isinstance(self.measure, MeshDistances):
            ok = self.measure.within(out_v, out_t, bound, lineage, first, near is not None)
        else:
            ok = self.measure.within(out_v, out_t, bound)
        if ok:
            self._kept_level = (m, placed)
            if first is not None:
                self._near[(m, bound)] = placed
        else:
            self._over.add((m, bound))
        return ok

    def error(self, m: int) -> float:
        """The largest distance both ways after ``m`` collapses (``measure``)."""
        out_v, out_t, _, _ = self.placed(m)
        return self.measure.error(out_v, out_t)

    def steps_for(self, max_triangles: int | None, max_error: float | None) -> int:
        """Collapses for a triangle budget, else the most within ``max_error``."""
        if max_triangles is not None:
            return self.seq.steps_for(max_triangles)
        return self.steps_within(max_error)

    def steps_within(self, bound: float, lowest: int = 0) -> int | None:
        """The most collapses whose output is within ``bound`` both ways: from the
        last collapse down, n - 1, n - 2, n - 4, ... (`_next_gap`) until a level meets
        the bound, then bisection up to the next that did not; None where no level of
        at least ``lowest`` collapses meets it (level 0 is taken to meet it). The
        error does not grow strictly with the collapses (a collapse can undo an
        earlier one's deviation), so a plain bisection from the middle stops early
        (measured: half the collapses on a sampled CAD cover, where 99 % meet the
        bound).

        Against a mesh (`MeshDistances`) the search first measures the output's
        vertices and `SEARCH_SAMPLES` of its area samples back (a subset of the
        report's: a level over the bound on it is over it on all), then the level
        found on all of them; where that fails, the search runs again on all of
        them (levels found over the bound are not measured again, nor the input's
        vertices of those found within it), which is the plain search's answer. The
        answer always meets the bound on all samples, as reported; it differs from
        the plain search's only where a level the first search passed fails on all
        samples while the level it ends on does not: 1 of the 178 meshes of the
        collection and models (hand_closed_1502: 588 triangles instead of 612, both
        within the bound).
        """
        n = int(self.seq.kept.size)
        if not isinstance(self.measure, MeshDistances):
            return self._search(n, bound, None, lowest)
        m = self._search(n, bound, SEARCH_SAMPLES, lowest)
        if m is None or m == 0 or self._meets(m, bound):
            return m
        return self._search(n, bound, None, lowest)

    def _meets(self, m: int, bound: float) -> bool:
        """Whether a level found within ``bound`` on a subset of the samples is within
        it on all of them: their exact distances, as reported (kept for `result`)."""
        placed = self._placed(m)
        out_v, out_t, _, _, lineage = placed
        back = self.measure.back(out_v, out_t, lineage)
        if back.size and back.max() > bound:
            self._over.add((m, bound))
            return False
        self._kept_level = (m, placed)
        return True

    def _search(self, n: int, bound: float, first, lowest: int = 0) -> int | None:
        """`steps_within` from ``n`` collapses down to ``lowest``, ``first`` as in
        `within`."""
        if n == 0 or self.within(n, bound, first):
            return n
        hi, gap = n, self._first_gap(n)  # hi does not meet the bound
        while True:
            lo = max(n - gap, lowest)
            if lo == 0 or self.within(lo, bound, first):
                break
            if lo == lowest:
                return None
            hi, gap = lo, self._next_gap(gap)
        while not self._settled(lo, hi):  # lo meets the bound (or is 0), hi does not
            mid = (lo + hi) // 2
            if self.within(mid, bound, first):
                lo = mid
            else:
                hi = mid
        return lo

    def _first_gap(self, n: int) -> int:
        """The level search's first step down from the last collapse ``n``: 1."""
        return 1

    @staticmethod
    def _next_gap(gap: int) -> int:
        """The level search's next step down from the last collapse: 1, 2, 4, 8, ..."""
        return 2 * gap

    def _settled(self, lo: int, hi: int) -> bool:
        """Whether the bisection between ``lo`` (within the bound) and ``hi`` (over
        it) is done: here when they are next to each other."""
        return hi - lo <= 1

    def near(self, m: int, first: int) -> tuple[float, float]:
        """``(mean, largest)``: the two-sided mean and largest distance after ``m``
        collapses: every input vertex to the output (as reported; kept for
        `distances`) and the output's vertices and first ``first`` area samples back
        (`MeshDistances.near`)."""
        placed = self._placed(m)
        out_v, out_t, _, _, lineage = placed
        self._kept_level = (m, placed)
        there, back_mean, back_max = self.measure.near(out_v, out_t, lineage, first)
        self._there = (m, there)
        there_mean = float(there.mean()) if there.size else 0.0
        return there_mean + back_mean, max(float(there.max(initial=0.0)), back_max)

    def distances(self, m: int):
        """``(there, back)``: the distances the report gives after ``m`` collapses
        (``measure.report``); the level and its distances are kept for `result`."""
        if self._report is not None and self._report[0] == m:
            return self._report[1]
        placed = self._placed(m)
        out_v, out_t, _, _, lineage = placed
        self._kept_level = (m, placed)
        if isinstance(self.measure, MeshDistances) and self._there and self._there[0] == m:
            found = (self._there[1], self.measure.back(out_v, out_t, lineage))
        elif isinstance(self.measure, MeshDistances):
            found = self.measure.report(out_v, out_t, lineage)
        else:
            found = self.measure.report(out_v, out_t)
        self._report = (m, found)
        return found

    def result(self, m: int, planar_tol: float, distances=None) -> SurfaceSimplification:
        """The `SurfaceSimplification` after ``m`` collapses: one face per region
        that kept a triangle (a small region can be collapsed away whole), and one
        more, not flat, for a label R + r (R regions: region r's companion,
        `_planar.bent_apart`); ``distances``: those of `distances` (``m``), when
        already measured."""
        if distances is None:
            distances = self.distances(m)
        out_v, out_t, region, source, _ = self._placed(m)
        present, face = np.unique(region, return_inverse=True)
        n = self.planes[2].size
        flat = np.zeros(present.size, dtype=bool)
        flat[present < n] = self.planes[2][present[present < n]]
        res = surface_result(
            self.verts,
            self.tri,
            out_v,
            out_t,
            face.astype(np.int64),
            source,
            [()] * present.size,
            labels=self.labels,
            kept_input=np.zeros(present.size, dtype=bool),
            flat=flat,
            planar_tol=planar_tol,
            chord_tolerance=float("nan"),
            n_refined=0,
            distances=distances,
        )
        return dataclasses.replace(res, face_region=(present % n).astype(np.int64))
